"""shared_control.arbitration: how much the robot gets (the serving probability, the rules, the agreements)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from grasp_intent_ros.shared_control.arbitration import (
    ServingMemo,
    arbitration,
    grasp_task_set,
    operator_agreement,
    part_shares,
    robot_agreement,
    serving_probability,
)

from .assistance_case import ARGS, H, T, U
from .robot_alone import LABELS, TASKS


def test_serving_probability_of_a_grasp_that_is_no_demonstration_is_the_models_expectation() -> None:
    v = np.array([0.5, 0.1, 0.1, 0.1, 0.1, 0.05, 0.05])  # over LABELS: U, T, H, UT, UH, TH, UTH
    model = ('U', 'T', 'UT', 'UTH')  # a 4-zone model: its posterior names only these
    e = {'U': 0.5, 'T': 0.1, 'UT': 0.7, 'UTH': 1.0}
    p = np.array([0.1, 0.2, 0.3, 0.4])
    expected = sum(pk * e[k] for pk, k in zip(p, model))
    assert serving_probability(v, LABELS, TASKS, posterior=p, zone_labels=model) == pytest.approx(expected, abs=1e-15)
    assert serving_probability(v, LABELS, TASKS, task_set=U | T) == pytest.approx(0.7, abs=1e-15)
    assert serving_probability(v, LABELS, TASKS, posterior=[1.0, 0.0], zone_labels=('U', 'X')) == 0.0
    assert serving_probability(np.zeros(7), LABELS, TASKS, task_set=U) == 0.0
    assert serving_probability(v, LABELS, TASKS) == 0.0  # neither a task set nor a posterior


def test_the_serving_memo_answers_as_the_function_for_every_change_of_an_input() -> None:
    v = np.array([0.5, 0.1, 0.1, 0.1, 0.1, 0.05, 0.05])
    base = dict(v=v, v_labels=LABELS, task_names=TASKS, task_set=None, posterior=np.array([0.1, 0.2, 0.3, 0.4]),
                zone_labels=('U', 'T', 'UT', 'UTH'))
    changes = [dict(v=np.array([0.1, 0.5, 0.1, 0.1, 0.1, 0.05, 0.05])),  # each input changed alone
               dict(v=v.view(np.int64)),  # the same bytes and shape, another dtype
               dict(v_labels=('T', 'U', 'H', 'UT', 'UH', 'TH', 'UTH')),
               dict(task_names=('transfer', 'usage', 'handover')),
               dict(task_set=U | T),
               dict(posterior=np.array([0.4, 0.3, 0.2, 0.1])),
               dict(zone_labels=('T', 'U', 'UT', 'UTH'))]
    memo = ServingMemo()

    def call(inputs: dict) -> float:  # type: ignore[type-arg]
        args = {k: val for k, val in inputs.items() if k not in ('v', 'v_labels', 'task_names')}
        return memo(inputs['v'], inputs['v_labels'], inputs['task_names'], **args)

    def direct(inputs: dict) -> float:  # type: ignore[type-arg]
        args = {k: val for k, val in inputs.items() if k not in ('v', 'v_labels', 'task_names')}
        return serving_probability(inputs['v'], inputs['v_labels'], inputs['task_names'], **args)

    for change in changes:
        changed = {**base, **change}
        assert call(base) == direct(base)
        assert call(changed) == direct(changed)  # a memo that ignored this input would answer base's
        assert direct(changed) != direct(base), change  # the case can catch it
    v[0] = 0.6  # an array changed in place is a new input too
    assert call(base) == direct(base) != direct({**base, 'v': np.array([0.5, 0.1, 0.1, 0.1, 0.1, 0.05, 0.05])})


def test_the_grasp_task_set_is_the_demonstrations_label() -> None:
    demo_x = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 1.0]])
    sets = np.array([U, T | H, U], dtype=np.int64)
    scale = np.array([0.5, 2.0])
    assert grasp_task_set(np.array([1.0, 1.0 + 1e-7]), demo_x, sets, scale) == T | H  # the first of equal ones
    assert grasp_task_set(np.array([0.5, 1.0]), demo_x, sets, scale) is None  # moved: no label


def test_arbitration_rules() -> None:
    certain, uniform = np.eye(7)[0], np.full(7, 1 / 7)
    assert arbitration('confidence', certain, 1.0, **ARGS) == pytest.approx(0.9)
    assert arbitration('confidence', uniform, 1.0, **ARGS) == pytest.approx(0.9)  # v's spread vetoes nothing
    assert arbitration('confidence', certain, 0.5, **ARGS) == pytest.approx(0.45)
    assert arbitration('none', certain, 1.0, **ARGS) == 0.0
    assert arbitration('blend', [0.5, 0.35, 0.15], 0.0, **ARGS) == 0.0  # leads by 0.15 < 0.2
    assert arbitration('blend', [0.5, 0.25, 0.25], 0.0, **ARGS) == 0.9


def test_the_agreement_with_the_robots_twist_is_the_cosine_faded_out_below_the_deadbands() -> None:
    kw = dict(deadband_linear=0.01, deadband_angular=0.05)
    operator = np.r_[0.0, 0.12, 0.0, 0.0, 0.0, 0.0]  # a joystick translating: no rotation
    assert robot_agreement(operator, np.r_[0.0, -0.15, 0.0, 0.0, 0.0, 0.8], **kw) == 0.0  # against: the operator alone
    assert robot_agreement(operator, np.r_[0.15, 0.0, 0.0, 0.4, 0.0, 0.8], **kw) == 0.0  # at right angles: alone too
    assert robot_agreement(operator, np.r_[0.0, 0.15, 0.0, 0.4, 0.0, 0.8], **kw) == 1.0  # its way: alpha unchanged
    oblique = np.r_[0.1, 0.1, 0.0, 0.0, 0.0, 0.0]
    assert robot_agreement(operator, oblique, **kw) == pytest.approx(0.5**0.5, abs=1e-15)  # cos 45 deg
    turning = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.3]  # a turn against the robot's, no translation: the angular part's
    assert robot_agreement(turning, np.r_[0.0, -0.15, 0.0, 0.0, 0.0, -0.8], **kw) == 0.0
    assert robot_agreement(np.zeros(6), np.r_[0.0, -0.15, 0.0, 0.0, 0.0, -0.8], **kw) == 1.0  # zero h: unchanged
    assert robot_agreement(operator, np.zeros(6), **kw) == 1.0  # zero r: unchanged
    # below a deadband the disagreement fades out linearly: continuous, no threshold for a last bit to cross
    assert robot_agreement(operator, np.r_[0.0, -0.005, 0.0, 0.0, 0.0, 0.0], **kw) == pytest.approx(0.5, abs=1e-15)
    assert robot_agreement(np.r_[0.0, 0.0025, 0.0, 0.0, 0.0, 0.0], np.r_[0.0, -0.15, 0.0, 0.0, 0.0, 0.0],
                           **kw) == pytest.approx(0.75, abs=1e-15)
    edge = np.r_[0.0, -0.01, 0.0, 0.0, 0.0, 0.0]
    for bit in (-1.0, 1.0):
        near = robot_agreement(operator, np.nextafter(edge, bit), **kw)
        assert near == pytest.approx(0.0, abs=1e-12)


def test_operator_agreement_lets_the_operator_take_the_control_back() -> None:
    kw = dict(deadband_linear=0.01, deadband_angular=0.05)
    robot = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.5])
    assert operator_agreement(np.zeros(6), robot, **kw) == (None, None)  # holding still: no evidence
    assert operator_agreement(np.r_[0.005, 0, 0, 0, 0, 0], -robot, **kw) == (None, None)  # within the deadband
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, 0], robot, **kw) == (pytest.approx(1.0), None)
    assert operator_agreement(np.r_[0, 0.05, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.0)  # at right angles
    assert operator_agreement(np.r_[-0.05, 0, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.0)  # against it
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, -0.2], robot, **kw) == (pytest.approx(1.0), pytest.approx(0.0))
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, 0], np.zeros(6), **kw) == (None, None)  # the robot holds
    assert operator_agreement(np.r_[1e308, -1e308, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.5**0.5)


def test_the_part_the_operator_leaves_idle_gets_alpha_max() -> None:
    bands = dict(alpha_max=0.9, deadband_linear=0.01, deadband_angular=0.05)
    translating = np.r_[0.05, 0.0, 0.0, 0.0, 0.0, 0.04]  # the angular part within its deadband
    assert_array_equal(part_shares(0.3, translating, **bands), [0.3, 0.3, 0.3, 0.9, 0.9, 0.9])
    turning = np.r_[0.0, 0.01, 0.0, 0.0, 0.2, 0.0]  # the linear part at its deadband: idle
    assert_array_equal(part_shares(0.3, turning, **bands), [0.9, 0.9, 0.9, 0.3, 0.3, 0.3])
    both = np.r_[0.05, 0.0, 0.0, 0.0, 0.2, 0.0]
    neither = np.r_[0.005, 0.0, 0.0, 0.0, 0.02, 0.0]
    for h in (both, neither):
        assert_array_equal(part_shares(0.3, h, **bands), np.full(6, 0.3))  # nothing to take over
    assert_array_equal(part_shares(0.0, translating, **bands), np.zeros(6))  # no help at all: none in the idle part
