"""grasp_intent_ros.mico.limits: the margin for the object pose's error (the simulated tracker's)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.mico.limits import tracker_margin


def test_the_tracker_margin_bounds_the_depth_error_of_the_simulated_tracker() -> None:
    """tracker_margin is the depth sigma of perturb_pose's errors for a contact at the lever arm, across the normal.

    20,000 draws (seeded): a contact at r with normal n moves along n with the formula's sigma for r perpendicular
    to n at |r| = lever arm (within 3 %), and less for r along n.
    """
    from grasp_intent_ros.shared_control.simulator import perturb_pose

    rng = np.random.default_rng(7)
    position_rms, angle_rms, lever = 0.005, math.radians(3.0), 0.12
    bound = tracker_margin(position_rms, angle_rms, lever)
    assert bound == pytest.approx(math.sqrt((position_rms ** 2 + (angle_rms * lever) ** 2) / 3.0), rel=1e-12)
    n = np.array([0.0, 0.0, 1.0])
    moves = {'across': [], 'along': []}
    for _ in range(20_000):
        T = perturb_pose(np.eye(4), position_rms, angle_rms, rng)
        moves['across'].append(float((T[:3, :3] @ np.array([lever, 0.0, 0.0]) + T[:3, 3]) @ n))
        moves['along'].append(float((T[:3, :3] @ (lever * n) + T[:3, 3]) @ n) - lever)
    assert float(np.std(moves['across'])) == pytest.approx(bound, rel=0.03)
    assert float(np.std(moves['along'])) < 0.75 * bound
    assert tracker_margin(0.0, 0.0, 1.0) == 0.0
    with pytest.raises(KinematicsError):
        tracker_margin(-0.001, 0.0, 0.1)
