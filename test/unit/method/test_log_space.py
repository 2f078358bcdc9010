"""method.log_space: log-sum-exp and softmax against closed forms, far from 0 and with -inf entries."""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose

from grasp_intent_ros.method.log_space import log_sum_exp, softmax

EPS = np.finfo(np.float64).eps


def test_log_sum_exp_of_log_weights_is_the_log_of_their_sum() -> None:
    weights = np.array([1.0, 2.0, 3.0, 4.0])
    assert abs(float(log_sum_exp(np.log(weights))) - math.log(10.0)) <= 8 * EPS


def test_log_sum_exp_is_shifted_by_a_constant_without_overflow() -> None:
    # exp(1000) overflows a double: the shift by the largest value keeps every term at most 1
    a = np.array([1000.0, 1000.0, 1000.0 - math.log(2.0)])
    assert_allclose(log_sum_exp(a), 1000.0 + math.log(2.5), rtol=0.0, atol=8 * EPS * 1000.0)
    # and exp(-1000) underflows to 0: log(2 exp(-1000) + 2 exp(-1000)) = -1000 + log 4
    assert_allclose(log_sum_exp(-a), -1000.0 + math.log(4.0), rtol=0.0, atol=8 * EPS * 1000.0)


def test_log_sum_exp_reduces_the_last_axis_by_default_and_any_axis_asked() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(scale=4.0, size=(5, 7))
    rows = log_sum_exp(a)
    assert rows.shape == (5,)
    assert_allclose(rows, np.log(np.exp(a).sum(axis=1)), rtol=1e-14)
    assert_allclose(log_sum_exp(a, axis=0), np.log(np.exp(a).sum(axis=0)), rtol=1e-14)
    assert log_sum_exp(a[0]).shape == ()


def test_minus_infinity_adds_nothing_unless_all_are() -> None:
    assert float(log_sum_exp(np.array([-np.inf, math.log(3.0)]))) == math.log(3.0)
    with np.errstate(invalid='ignore'):  # -inf - (-inf): the nan the contract states
        assert math.isnan(float(log_sum_exp(np.array([-np.inf, -np.inf]))))


def test_softmax_normalises_the_exponentials_along_an_axis() -> None:
    weights = np.array([[1.0, 2.0, 5.0], [3.0, 3.0, 2.0]])
    p = softmax(np.log(weights) + 800.0)  # exp(800) overflows: shifted first
    # log w + 800 is rounded to a unit of 800's last place, which p carries as a relative error
    assert_allclose(p, weights / weights.sum(axis=1, keepdims=True), rtol=8 * EPS * 800.0, atol=0.0)
    assert_allclose(softmax(np.log(weights), axis=0), weights / weights.sum(axis=0), rtol=8 * EPS, atol=0.0)
    assert softmax(np.array([-np.inf, 0.0, 0.0])).tolist() == [0.0, 0.5, 0.5]
