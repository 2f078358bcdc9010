r"""The assistance's command kept out of the object as perceived: a control-barrier-function filter of the twist.

The robot's own joint path is clear of the perceived object (:mod:`.clearance`), but the command is a blend,
``alpha r + (1 - alpha) h``: the operator's share (a joystick moves one mode at a time) can drive the open hand
through the object on the way to the grasp. :func:`clearance_filter` sends instead the twist nearest the blend
whose open hand does not go deeper into the object than the planner's limits allow, with the depth of
:meth:`~.clearance.PathClearance.intrusion_at` (the planner's collision model,
:meth:`~grasp_intent_ros.mico.collision.HandCollision.open_hand_depth`, against the tracked pose and the model's
body: never the true object).

The rule
--------
With ``d(x)`` the intrusion at the hand's pose x less the path's margin (m; > 0: deeper than the limits; the
margin is left out, for the planned grasp is only within the limits) and ``c`` its gradient with
respect to the twist (so that ``c . u`` is d's rate, m/s, under the twist u), the command solves

.. math::

    \min_u\ (u - u_b)^T W^2 (u - u_b) \quad \text{s.t.} \quad c \cdot u \le \gamma \max(-d(x), 0),

``u_b`` the blended twist, ``W = diag(1, 1, 1, rho, rho, rho)`` with ``rho`` = :data:`~.clearance.HAND_REACH`
(an angular rate times rho is the speed it gives the hand's farthest point: both parts in m/s of the hand) and
``gamma`` = :data:`RATE`. A control barrier function (Ames et al., "Control barrier functions: theory and
applications", ECC 2019): the hand may close in on the limits no faster than ``gamma`` times the room left,
so it slows as it nears them and stops at them; a hand already past them may not go deeper. The feasible set
is a half-space that holds ``u = 0``, so the problem always has a solution, and one only (a strictly convex
objective: no ties): ``u_b`` itself when it satisfies the constraint, else its projection onto the plane,
``u_b - (c . u_b - b) W^{-2} c / (c^T W^{-2} c)``. Properties:

- Motion away from the object, or along it (``c . u_b <= 0``), is never changed; only the share of the motion
  that deepens the intrusion is removed, the rest of the command is kept (no stop of the whole twist, unlike a
  velocity scaling such as MoveIt Servo's collision checking).
- The filter never moves the hand on its own: zero in, zero out, and a hand past the limits is not pushed out.
- The planned grasp stays reachable: the planner accepts it and its approach only within the same limits on
  the same perceived object (:data:`~grasp_intent_ros.mico.collision.LIMITS`), so along that approach ``d <= 0``
  and the filter lets the hand reach the grasp, slowing only where the approach runs at the limits.

The gradient ``c``: forward differences of d over one step of each twist component (:data:`STEP`: 1 mm, and
the rotation that moves the hand's farthest point by 1 mm), 6 more depths. d is the deepest part's (the palm's
or a finger's beyond its limit); with several parts near it the gradient is that of the deepest, and another
part may go deeper by the linearisation's error within one output, after which it is the one constrained.
The gradient is computed only when the constraint can bind: a twist moves no point of the hand faster than
``|v| + rho |omega|``, so when that is at most ``gamma max(-d, 0)`` the blend is returned after one depth (far
from the object, the cheap bound of :meth:`~.clearance.PathClearance.intrusion`). ROS-free.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .clearance import HAND_REACH, PathClearance

__all__ = ['RATE', 'STEP', 'WEIGHTS', 'intrusion_gradient', 'clearance_filter']

RATE = 5.0
"""1/s: gamma, the barrier's rate: the open hand closes in on the limits at most this times the room left."""
STEP = 0.001
"""m: the forward-difference step of the intrusion's gradient (a rotation: ``STEP / HAND_REACH`` rad)."""
WEIGHTS = np.array([1.0, 1.0, 1.0, HAND_REACH, HAND_REACH, HAND_REACH])
"""W's diagonal (1, 1, 1 and m): the norm in which the command is the nearest to the blend."""


def _rotation(axis: int, angle: float) -> NDArray[np.float64]:
    """The rotation by ``angle`` (rad) about the base frame's axis ``axis`` (0, 1, 2), 3x3."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


_TURNS = [_rotation(k, STEP / HAND_REACH) for k in range(3)]


def intrusion_gradient(clearance: PathClearance, base_T_ee: NDArray[np.float64],
                       depth: float) -> NDArray[np.float64]:
    """The gradient of the intrusion at ``base_T_ee`` with respect to the twist, by forward differences.

    Parameters
    ----------
    clearance : PathClearance
    base_T_ee : ndarray, shape (4, 4)
        The end effector, base frame.
    depth : float
        ``clearance.intrusion_at(base_T_ee)`` (m).

    Returns
    -------
    ndarray, shape (6,)
        m per m (linear) and m per rad (angular, about the base axes through the EE origin): the intrusion's
        rate under a twist u (the module's convention) is its dot product with u.
    """
    gradient = np.empty(6)
    for k in range(3):
        moved = base_T_ee.copy()
        moved[k, 3] += STEP
        gradient[k] = (clearance.intrusion_at(moved) - depth) / STEP
        turned = base_T_ee.copy()
        turned[:3, :3] = _TURNS[k] @ base_T_ee[:3, :3]
        gradient[3 + k] = (clearance.intrusion_at(turned) - depth) / (STEP / HAND_REACH)
    return gradient


def clearance_filter(clearance: PathClearance, base_T_ee: NDArray[np.float64], twist: NDArray[np.float64], *,
                     rate: float = RATE) -> NDArray[np.float64]:
    """The twist nearest ``twist`` whose open hand closes in on the perceived object's limits no faster than allowed.

    Parameters
    ----------
    clearance : PathClearance
        The perceived object (tracked pose, model's body) and the limits.
    base_T_ee : ndarray, shape (4, 4)
        The end effector now, base frame.
    twist : ndarray, shape (6,)
        The blended twist u_b (linear m/s of the EE origin, angular rad/s; base frame).
    rate : float
        gamma (1/s, > 0).

    Returns
    -------
    ndarray, shape (6,)
        The solution of the module's problem: ``twist`` itself (a copy) when it satisfies the constraint.
    """
    intrusion = clearance.intrusion_at(base_T_ee)
    bound = rate * max(clearance.margin - intrusion, 0.0)  # the limits alone: where grasps are planned
    if float(np.linalg.norm(twist[:3])) + HAND_REACH * float(np.linalg.norm(twist[3:])) <= bound:
        return twist.copy()
    c = intrusion_gradient(clearance, base_T_ee, intrusion)
    excess = float(c @ twist) - bound
    if excess <= 0.0:
        return twist.copy()
    direction: NDArray[np.float64] = c / WEIGHTS**2
    return twist - excess / float(c @ direction) * direction
