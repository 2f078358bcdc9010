"""Model ambiguity: KL divergence against closed forms, matrix properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import ModelError
from grasp_intent_ros.method import ambiguity
from grasp_intent_ros.method.model import GraspModel


def test_kl_univariate_closed_form() -> None:
    # KL(N(m1, s1^2) || N(m2, s2^2)) = ln(s2/s1) + (s1^2 + (m1-m2)^2) / (2 s2^2) - 1/2
    m1, s1, m2, s2 = 0.3, 0.5, -0.2, 1.5
    expected = math.log(s2 / s1) + (s1 ** 2 + (m1 - m2) ** 2) / (2 * s2 ** 2) - 0.5
    got = ambiguity.kl_gaussian([m1], [[s1 ** 2]], [m2], [[s2 ** 2]])
    assert got == pytest.approx(expected, rel=1e-12)


def test_kl_multivariate_closed_form() -> None:
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
    sp, sq = a @ a.T + np.eye(4), b @ b.T + np.eye(4)
    mp, mq = rng.normal(size=4), rng.normal(size=4)
    inv = np.linalg.inv(sq)
    expected = 0.5 * (np.trace(inv @ sp) + (mq - mp) @ inv @ (mq - mp) - 4
                      + math.log(np.linalg.det(sq) / np.linalg.det(sp)))
    # numpy's inv and det run LAPACK in the CPU's kernels' order: within about d * eps * cond (1e-14 for these
    # well-conditioned 4 x 4 matrices) of the exact value in any order; 1e-10 leaves four orders to spare
    assert ambiguity.kl_gaussian(mp, sp, mq, sq) == pytest.approx(expected, rel=1e-10)
    assert ambiguity.kl_gaussian(mp, sp, mp, sp) == pytest.approx(0.0, abs=1e-12)


def test_kl_matrix_properties(toy_model: GraspModel) -> None:
    kl = ambiguity.kl_matrix(toy_model)
    assert kl.shape == (3, 3)
    assert_allclose(np.diag(kl), 0.0)
    assert np.all(kl >= 0.0)
    assert kl[0, 1] == pytest.approx(ambiguity.kl_gaussian(toy_model.task_means[0], toy_model.task_covariances[0],
                                                           toy_model.task_means[1], toy_model.task_covariances[1]))
    rep = ambiguity.report(toy_model)
    assert_allclose(rep.symmetric, kl + kl.T)
    assert_allclose(rep.pinsker, np.minimum(np.sqrt(kl / 2), 1.0))
    assert_allclose(sorted(rep.symmetric_eigenvalues), sorted(np.linalg.eigvalsh(kl + kl.T)))


def test_kl_rejects_bad_input() -> None:
    with pytest.raises(ModelError):
        ambiguity.kl_gaussian([0.0], [[-1.0]], [0.0], [[1.0]])
    with pytest.raises(ModelError):
        ambiguity.kl_gaussian([0.0, 1.0], [[1.0]], [0.0], [[1.0]])
