"""Grasp features for the 3-finger Kinova MICO (d = 10), with names, units and bounds.

All positions are in the object frame ``obj``: origin at the centre of the object's base, +z up
(away from the table), +x towards the object's handle or characteristic side.

=====  ===========  ====  =====================================================================
index  name         unit  meaning
=====  ===========  ====  =====================================================================
0-2    palm_x/y/z   m     palm centre in the object frame
3-5    approach_x..  1    unit approach direction of the palm (the hand's z axis), object frame
6      roll         rad   wrist roll about the approach axis (see mico.kinematics for the frame)
7-9    finger_1..3  rad   finger closure, 0 open .. 1.51 closed (stands in for finger force)
=====  ===========  ====  =====================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    'FeatureSpace',
    'MICO_3F',
    'FINGER_CLOSED',
    'APPROACH',
    'PALM',
    'ROLL',
    'FINGERS',
]

FINGER_CLOSED = 1.51
"""Closure of a MICO finger when fully closed (rad)."""

PALM = slice(0, 3)
APPROACH = slice(3, 6)
ROLL = 6
FINGERS = slice(7, 10)


@dataclass(frozen=True, eq=False)
class FeatureSpace:
    """Names, units and box bounds of a grasp feature vector.

    Attributes
    ----------
    names : tuple of str, length d
    units : tuple of str, length d
    lower, upper : ndarray, shape (d,)
        Box bounds used by the planner.
    approach_range : tuple of int
        (start, stop) of the entries that form the unit palm approach direction (norm constraint).
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    approach_range: tuple[int, int] = (APPROACH.start, APPROACH.stop)

    @property
    def approach(self) -> slice:
        """Slice of the unit approach direction entries."""
        return slice(*self.approach_range)

    @property
    def dim(self) -> int:
        """Number of features d."""
        return len(self.names)


MICO_3F = FeatureSpace(
    names=('palm_x', 'palm_y', 'palm_z', 'approach_x', 'approach_y', 'approach_z', 'roll',
           'finger_1', 'finger_2', 'finger_3'),
    units=('m', 'm', 'm', '1', '1', '1', 'rad', 'rad', 'rad', 'rad'),
    lower=np.array([-0.20, -0.20, -0.05, -1.0, -1.0, -1.0, -math.pi / 2, 0.0, 0.0, 0.0]),
    upper=np.array([0.20, 0.20, 0.30, 1.0, 1.0, 1.0, 3 * math.pi / 2,
                    FINGER_CLOSED, FINGER_CLOSED, FINGER_CLOSED]),
)
"""Default feature space of the 3-finger MICO. Roll runs over [-pi/2, 3pi/2] so that both the
usual grasp (roll near 0) and the wrist turned by 180 degrees (roll near pi) lie inside the box."""
