"""How deep the hand may go into the scene before a grasp counts as in collision, and a margin for the object's pose.

:class:`Limits` are the thresholds of :meth:`~.grasp_clearance.Clearance.fault` (the planner's :data:`LIMITS`, also
the judge's of the closed-loop simulation's sweeps); :meth:`Limits.less` lowers the object's two by a margin, and
:func:`tracker_margin` states one for a tracker's error. Re-exported by :mod:`.collision`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import KinematicsError

__all__ = ['Limits', 'LIMITS', 'tracker_margin']


@dataclass(frozen=True)
class Limits:
    """How deep (m) a hand part may go into the scene before the grasp counts as in collision.

    Attributes
    ----------
    table : float
        Any hand part below the table, fingers open along the approach.
    palm : float
        The palm/wrist into the object along the approach.
    finger : float
        An open finger into the object along the approach.
    """

    table: float = 0.002
    palm: float = 0.001
    finger: float = 0.005

    def less(self, margin: float) -> Limits:
        """These limits with the object's two (``palm``, ``finger``) lowered by ``margin`` (m, >= 0; the table's kept).

        A grasp then needs its palm/wrist and open fingers ``margin`` shallower in the object than these limits
        allow, so that the object's pose may be off by that much along the contact before the grasp, planned on
        the tracked pose, goes past them in the true one (:func:`tracker_margin`). The table is not the
        tracker's: its limit stays.

        Raises
        ------
        KinematicsError
            For a margin that is not finite and >= 0.
        """
        if not (math.isfinite(margin) and margin >= 0.0):
            raise KinematicsError(f'an object margin is finite and >= 0 m, got {margin!r}')
        return Limits(self.table, self.palm - margin, self.finger - margin)


LIMITS = Limits()
"""The planner's limits: a margin under the judge's (5 mm into the table, 2 mm of the wrist into the object)."""


def tracker_margin(position_rms: float, angle_rms: float, lever_arm: float) -> float:
    """A bound (m) on the standard deviation of a contact's depth when the object's pose is off by a tracker's error.

    The error as :func:`grasp_intent_ros.shared_control.simulator.perturb_pose` draws it: the position off by
    N(0, (position_rms^2 / 3) I) m, the orientation turned about the object's origin by a rotation vector
    N(0, (angle_rms^2 / 3) I) rad. A contact at r (object frame) with normal n moves along n by
    ``delta . n + omega . (r x n)``, of variance ``(position_rms^2 + angle_rms^2 |r x n|^2) / 3``; with
    ``|r x n| <= |r| <= lever_arm`` (m, e.g. :attr:`~grasp_intent_ros.method.body.ObjectBody.reach`) that is at most

        sqrt((position_rms^2 + (angle_rms lever_arm)^2) / 3).

    Raises
    ------
    KinematicsError
        For an argument that is not finite and >= 0.
    """
    values = (position_rms, angle_rms, lever_arm)
    if not all(math.isfinite(v) and v >= 0.0 for v in values):
        raise KinematicsError(f'a tracker error and a lever arm are finite and >= 0, got {values!r}')
    return math.sqrt((position_rms ** 2 + (angle_rms * lever_arm) ** 2) / 3.0)
