"""Hand-built scenes for the intent estimator's tests: straight-line motions at goals placed by hand."""

from __future__ import annotations

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]

from grasp_intent_ros.shared_control.estimator import EstimatorConfig

STRAIGHT = EstimatorConfig(standoff=0.0)
"""An operator model heading straight for each goal (no pre-grasp): the hand-built scenes whose motions are straight
lines at a goal, which test the rules that do not depend on the pose steered to (the shown grasp's)."""
SPEED = 0.12
"""The shared-control benchmark's operator speed limit, m/s."""
DT = 0.01
"""The operator's twist period, s."""


def pose(position: tuple[float, float, float], rotvec: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """A homogeneous transform at ``position``, rotated by the rotation vector ``rotvec`` (rad)."""
    out = np.eye(4)
    out[:3, :3] = pin.exp3(np.asarray(rotvec, dtype=np.float64))
    out[:3, 3] = position
    return out
