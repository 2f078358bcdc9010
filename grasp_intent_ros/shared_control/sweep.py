"""The judge's measure of what the simulated loop does not model: how deep the open hand's path goes into the object.

The simulator (:mod:`.simulator`) has no contact model: a hand path may pass through the object, and the run
is judged at the pose where the hand closed. :class:`PathSweep` measures the passage: at poses along the
path of the arm's joints, the depths of the palm/wrist and of the open fingers in the object's body, in the
TRUE object frame (the judge's; :meth:`~grasp_intent_ros.mico.collision.HandCollision.open_hand_depth`,
coal's signed distance, the planner's own clearance measure), and keeps the deepest. A path swept into the
object (:attr:`PathSweep.swept`) when the palm went deeper than
:data:`~grasp_intent_ros.mico.collision.LIMITS` ``.palm`` or an open finger deeper than ``.finger`` anywhere
on it, the limits the planner holds its grasps' approach corridors to.

It is a judge's measurement: nothing that plans, assists, operates or estimates reads it.

Spacing of the checks: the teleoperated loop checks every :data:`SWEEP_TICKS` simulator steps. Under the
assistance's output limits (0.2 m/s, 1 rad/s; ADA's command has the same limiter) every hand part, within
:data:`~.clearance.HAND_REACH` of the end effector, moves at most 0.2 + 1.0 x 0.17 = 0.37 m/s,
so at most 7.4 mm between two checks 0.02 s apart. The executed grasp's trajectory
(:func:`.loop_steps.execute_grasp`) runs at the joints' speed limits, so it is checked at every step (0.01 s).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..method.body import ObjectBody
from ..mico.collision import LIMITS, HandCollision, Limits
from ..mico.kinematics import MicoKinematics
from .clearance import HAND_REACH, default_hand

__all__ = ['SWEEP_TICKS', 'HAND_REACH', 'PathSweep', 'default_hand']

SWEEP_TICKS = 2
"""Simulator steps (of 0.01 s) between two checks of the teleoperated path (module docstring)."""


class PathSweep:
    """The deepest the open hand goes into ``body`` over the poses it is shown (:meth:`check`), true object frame.

    Parameters
    ----------
    kin : MicoKinematics
    body : ObjectBody or None
        The object's body (its model's ``body``); None: no body, nothing is ever swept.
    base_T_obj_true : ndarray, shape (4, 4)
        The object's true pose in the base frame (the judge's, never the tracker's).
    hand : HandCollision, optional
        :func:`default_hand` when None.

    Attributes
    ----------
    palm, finger : float
        The deepest (m) the palm/wrist and an open finger went into the body over the checked poses; negative:
        clear by that much; ``-inf``: never near the body (:meth:`HandCollision.open_hand_depth`).
    closing_palm, closing_finger : float
        The same at the pose where the hand closed (:meth:`close`); ``-inf`` until then.
    """

    def __init__(self, kin: MicoKinematics, body: ObjectBody | None, base_T_obj_true: NDArray[np.float64],
                 hand: HandCollision | None = None) -> None:
        self.kin, self.body = kin, body
        self.hand = hand if hand is not None else default_hand()
        self.obj_T_base = np.linalg.inv(base_T_obj_true)
        self.palm = self.finger = self.closing_palm = self.closing_finger = -math.inf

    def check(self, q_arm: NDArray[np.float64]) -> tuple[float, float]:
        """Take the hand, fingers open, at the arm's joints ``q_arm`` (rad, shape (6,)) into the maxima.

        Returns its palm/wrist and finger depths there (m; ``-inf`` without a body).
        """
        if self.body is None:
            return -math.inf, -math.inf
        palm, finger = self.hand.open_hand_depth(self.obj_T_base @ self.kin.fk(q_arm), self.body)
        self.palm, self.finger = max(self.palm, palm), max(self.finger, finger)
        return palm, finger

    def close(self, q_arm: NDArray[np.float64]) -> None:
        """:meth:`check` at the pose where the hand closed (or stood at the end), kept as the closing depths."""
        self.closing_palm, self.closing_finger = self.check(q_arm)

    def swept(self, limits: Limits = LIMITS) -> bool:
        """Whether the palm went deeper than ``limits.palm`` or an open finger deeper than ``limits.finger``."""
        return self.palm > limits.palm or self.finger > limits.finger

    def in_at_closing(self, limits: Limits = LIMITS) -> bool:
        """Whether the closing pose itself (:meth:`close`) is deeper than ``limits`` (then the run swept)."""
        return self.closing_palm > limits.palm or self.closing_finger > limits.finger
