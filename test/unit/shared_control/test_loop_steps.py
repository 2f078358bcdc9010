"""grasp_intent_ros.shared_control.loop_steps: the steps both simulated loops take.

Here the grasp command's rule and the operator's twist taken. The plan fed, the grasp command and the sweep's
figures are exercised through the loops (test_simulator.py, test_scene_simulator.py).
"""

from __future__ import annotations

import numpy as np

from grasp_intent_ros.shared_control.loop_steps import Episode, executes_shown, take_operator_twist


def test_only_the_shown_grasp_is_executed_and_only_under_the_suites_assistance() -> None:
    assert executes_shown('shown', True)
    assert not executes_shown('own', True)  # the operator's own grasp: the fingers close where the hand is
    assert not executes_shown('shown', False)  # direct, ADA, or the grasp command's execute off


class Evidence:
    """Records what an estimator is fed."""

    def __init__(self) -> None:
        self.fed: list[tuple[np.ndarray, np.ndarray, float]] = []

    def update(self, base_T_ee: np.ndarray, twist: np.ndarray, dt: float) -> None:
        self.fed.append((base_T_ee, twist, dt))


def test_the_operators_twist_is_the_estimators_evidence_and_the_episodes_effort() -> None:
    episode, evidence, hand = Episode(), Evidence(), np.eye(4)
    twist = np.array([0.03, 0.0, 0.04, 0.0, 0.6, 0.8])  # 0.05 m/s, 1 rad/s
    take_operator_twist(episode, twist, hand, 0.01, evidence)
    take_operator_twist(episode, twist, hand, 0.01, None)  # no estimator: the effort alone
    assert len(evidence.fed) == 1 and evidence.fed[0][0] is hand and evidence.fed[0][1] is twist
    assert evidence.fed[0][2] == 0.01
    assert np.isclose(episode.effort_linear, 2 * 0.05 * 0.01, rtol=1e-12, atol=0.0)
    assert np.isclose(episode.effort_angular, 2 * 1.0 * 0.01, rtol=1e-12, atol=0.0)
