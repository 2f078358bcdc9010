"""shared_control.goals: the estimator's goals, their prior, and the shipped cup model placed at the object."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import InvalidIntentError, KinematicsError
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.goals import goals_at, goals_from_poses

from .hand_built import pose

U, T, H = 1, 2, 4


def test_prior_is_uniform_over_task_sets_then_over_goals() -> None:
    goals = goals_from_poses([pose((0.1 * k, 0.0, 0.0)) for k in range(4)], [U, U, U, T | H], 3)
    assert_allclose(np.exp(goals.log_prior), [1 / 6, 1 / 6, 1 / 6, 1 / 2], rtol=1e-12)
    assert goals.membership.tolist() == [[1, 0, 0]] * 3 + [[0, 1, 1]]
    assert goals.demo_index.tolist() == [0, 1, 2, 3] and len(goals) == 4 and goals.n_tasks == 3


def test_bad_goals_are_refused() -> None:
    with pytest.raises(InvalidIntentError):
        goals_from_poses(np.zeros((0, 4, 4)), [], 3)
    with pytest.raises(InvalidIntentError):
        goals_from_poses([np.eye(4)], [8], 3)
    with pytest.raises(KinematicsError):
        goals_from_poses([2 * np.eye(4)], [1], 3)


def test_the_cup_models_demonstrations_placed_at_the_object_are_its_goals() -> None:
    model = ModelFiles(config_dir() / 'models').load('cup_7zone')
    base_T_obj = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
    goals = goals_at(model, base_T_obj)
    assert len(goals) == model.demo_x.shape[0] and goals.n_tasks == 3
    keep = np.arange(model.demo_x.shape[0]) % 2 == 1
    kept = goals_at(model, base_T_obj, keep)
    assert kept.demo_index.tolist() == np.flatnonzero(keep).tolist()
    assert_allclose(kept.positions, goals.positions[keep], rtol=0, atol=0)
    with pytest.raises(InvalidIntentError):
        goals_at(model, base_T_obj, np.zeros(model.demo_x.shape[0], dtype=bool))
