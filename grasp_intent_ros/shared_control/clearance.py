"""The robot path's clearance from the object as the robot perceives it: a joint path the open hand takes clear.

The assistance's robot twist moves the joints along straight joint lines (:mod:`.joint_path`), and the hand's path,
their image, curves: on its way to a pre-grasp that is itself clear it can cross the object. :class:`PathClearance`
checks a joint path's hand poses, fingers open, against the object's body at the pose the robot perceives (the
tracked pose and the active model's body) with the planner's collision model
(:meth:`~grasp_intent_ros.mico.collision.HandCollision.open_hand_depth`,
:data:`~grasp_intent_ros.mico.collision.LIMITS`), and :func:`clear_path` replaces a path that goes in by a clear
one. Never the true object: the robot knows only what it perceives. ROS-free.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..method.body import ObjectBody
from ..mico.collision import LIMITS, SWEEP_STEP, HandCollision, Limits
from ..mico.frames import check_transform
from ..mico.kinematics import MicoKinematics
from .joint_path import ik_candidates

__all__ = ['HAND_REACH', 'default_hand', 'JOINT_REACH', 'RETREATS', 'LIFTS', 'FAR', 'MAX_CHECKED', 'PathClearance',
           'clear_path']

HAND_REACH = 0.17
"""Upper bound (m) on the distance of any point of the open hand's collision primitives from the end effector
(the URDF's: 0.169)."""
JOINT_REACH = np.array([0.88, 0.88, 0.6, 0.44, 0.36, 0.17])
"""m: upper bounds on the distance of any point of the open hand from each joint's axis (the end effector's
largest distance from the axes over 5,000 random configurations of the URDF, 0.705, 0.708, 0.418, 0.256, 0.176
and 0 m, plus :data:`HAND_REACH`, rounded up): a joint step dq moves every hand
point by at most sum_j JOINT_REACH_j |dq_j|."""
RETREATS = (0.0, 0.08)
"""m: how far :func:`clear_path`'s via points lie behind the target along the grasp's approach axis."""
FAR = 0.03
"""m: hand parts farther than this (beyond the margin) from the body count at this distance (:meth:`PathClearance.
intrusion`): the check's steps need no more room than that, and coal's distances are computed within it only."""
MAX_CHECKED = 8
"""The most candidates :func:`clear_path` checks (the shortest): each check near the body costs milliseconds."""
LIFTS = (0.0, 0.1)
"""m: how far :func:`clear_path`'s via points lie above the target, along the table's normal (the object's z)."""


@functools.cache
def default_hand() -> HandCollision:
    """The MICO hand of the package's URDF, built once per process."""
    return HandCollision()


class PathClearance:
    """The open hand against the object as perceived, at the arm's joints and along joint paths.

    Parameters
    ----------
    kin : MicoKinematics
    hand : HandCollision
        The planner's hand model.
    body : ObjectBody
        The active model's body (object frame).
    base_T_obj : ndarray, shape (4, 4)
        The object's pose as the robot perceives it (the tracked pose, the planner's), base frame.
    limits : Limits
        The depths a hand part may go in (the planner's, :data:`~grasp_intent_ros.mico.collision.LIMITS`).
    margin : float
        m, >= 0: how far beyond the limits the open hand keeps from the body (0: the limits alone).

    Raises
    ------
    KinematicsError
        If ``base_T_obj`` is not a rigid transform.
    """

    def __init__(self, kin: MicoKinematics, hand: HandCollision, body: ObjectBody, base_T_obj: NDArray[np.float64],
                 limits: Limits = LIMITS, margin: float = 0.0) -> None:
        base_T_obj = check_transform(base_T_obj, 'base_T_obj')
        self.kin, self.hand, self.body, self.limits, self.margin = kin, hand, body, limits, margin
        self.base_T_obj = base_T_obj.copy()
        self.obj_T_base = np.eye(4)
        self.obj_T_base[:3, :3] = base_T_obj[:3, :3].T
        self.obj_T_base[:3, 3] = -base_T_obj[:3, :3].T @ base_T_obj[:3, 3]
        self.up = base_T_obj[:3, 2].copy()
        """The object's z axis in the base frame: the normal of the table it stands on."""
        self._centres = np.array([prim.centre for prim in body.primitives])
        self._radii = np.array([prim.bounding_radius for prim in body.primitives])

    def intrusion(self, q: NDArray[np.float64]) -> float:
        """How far the open hand at joints ``q`` goes into the body beyond the limits less the margin (m; a bound).

        ``max(palm - limits.palm, finger - limits.finger) + margin``, the depths those of
        :meth:`~grasp_intent_ros.mico.collision.HandCollision.open_hand_depth` (> 0: too deep). A part whose
        bounding sphere lies farther than the margin plus :data:`FAR` from every primitive's counts at that
        distance, and when the end effector lies farther than
        :data:`HAND_REACH` plus that from every primitive's bounding sphere (gap:
        its least distance to one), the hand counts at ``gap - HAND_REACH``, without the collision model.
        """
        return self.intrusion_at(self.kin.fk(q))

    def intrusion_at(self, base_T_ee: NDArray[np.float64]) -> float:
        """:meth:`intrusion` of the open hand with its end effector at ``base_T_ee`` (4x4, base frame), m."""
        far = self.margin + FAR
        obj_T_ee = self.obj_T_base @ base_T_ee
        gap = float((np.linalg.norm(self._centres - obj_T_ee[:3, 3], axis=1) - self._radii).min())
        if gap - HAND_REACH > far:
            return HAND_REACH - gap - min(self.limits.palm, self.limits.finger) + self.margin
        palm, finger = self.hand.open_hand_depth(obj_T_ee, self.body, within=far)
        return max(max(palm, -far) - self.limits.palm, max(finger, -far) - self.limits.finger) + self.margin

    def goes_in(self, q: NDArray[np.float64], path: Sequence[NDArray[np.float64]]) -> bool:
        """Whether the path from ``q`` through the points ``path`` takes the open hand into the body.

        It goes in when at a check point of its straight joint lines :meth:`intrusion` exceeds the allowance
        ``max(0, intrusion at q, intrusion at the path's end)``: a path never counts as going in for a depth its
        start or its end has already (a hand already in, or a target the planner's limits allow, is not the
        path's doing). The check points (conservative advancement, as the planner's corridor check): each line's
        end, and from its start on, the next point where a hand part may have moved by the room left at the last,
        ``allowance - intrusion``, but at least :data:`~grasp_intent_ros.mico.collision.SWEEP_STEP`, at the
        speed bound of :data:`JOINT_REACH` (no part goes deeper than the allowance between two points but by
        less than that step). Stops at the first point too deep.
        """
        allowance = max(0.0, self.intrusion(q), self.intrusion(path[-1]))
        start = q
        for end in path:
            speed = float(JOINT_REACH @ np.abs(end - start))  # m of hand motion per unit of the line
            s, room = 0.0, allowance - self.intrusion(start)
            while s < 1.0:
                s = min(1.0, s + max(room, SWEEP_STEP) / speed) if speed > 0.0 else 1.0
                room = allowance - self.intrusion(start + s * (end - start))
                if room < 0.0:
                    return True
            start = end
        return False


def _length(q: NDArray[np.float64], path: Sequence[NDArray[np.float64]]) -> float:
    """The joint-space length of the path from ``q`` through ``path``: the sum of its lines' Euclidean lengths."""
    points = [q, *path]
    return sum(float(np.linalg.norm(b - a)) for a, b in zip(points[:-1], points[1:]))


def clear_path(clearance: PathClearance, q: NDArray[np.float64], path: list[NDArray[np.float64]],
               base_T_target: NDArray[np.float64], previous: list[NDArray[np.float64]] | None = None,
               admissible: Callable[[list[NDArray[np.float64]]], bool] | None = None) -> list[NDArray[np.float64]]:
    """A joint path from ``q`` to an IK of ``base_T_target`` whose open hand stays clear of the perceived object.

    ``path`` (the assistance's: ``[q_t]`` or ``[v, q_t]``) is returned unchanged when it does not go in
    (:meth:`PathClearance.goes_in`). Else, given ``previous`` (this function's earlier answer for the same
    proposal, its points still ahead, when that answer replaced the assistance's path), the previous path
    re-targeted: its points but the last, then the IK (no restarts) of ``base_T_target`` seeded at its last point,
    on the branch nearest q; returned when that IK succeeds, keeps the wrist (joint 5) on q's side of 0 and pi,
    is ``admissible`` and does not go in. So a plan that moves by millimetres keeps the clear way it had (no switching
    between clear ways as the plan jitters) for one check instead of a search. Else the candidates are, in this
    order:

    1. the straight lines to the target's IK solutions from the seeds of :func:`~.joint_path.ik_candidates`
       (Home, then the IK's restart seeds about q, on the 2 pi branch nearest q, the wrist on q's side);
    2. for each end q_e (``path``'s, then those of 1.) and each via pose in order, ``[v, q_e]``: v the IK
       (no restarts, seeded at q_e, on the branch nearest q) of the target moved back by r along its approach
       axis (the EE z axis) and up by h along the table's normal (:attr:`PathClearance.up`), for (r, h) in
       :data:`RETREATS` x :data:`LIFTS` but (0, 0), r the outer loop; kept when the IK succeeds and v keeps the
       wrist (joint 5) on q's side of 0 and pi.

    Candidates that are not ``admissible`` (when given; the assistance's: the hand stays near the grasp on the
    way, :func:`~.joint_path.near_grasp`, so that no clear way is a detour around the workspace) are dropped.
    The answer minimises the joint-space length (the sum of the lines' Euclidean lengths) over the
    :data:`MAX_CHECKED` shortest candidates left, among those that do not go in; ties: the earlier candidate. They are
    checked in that order (length, then position), so only those shorter than the answer are checked. When none
    of them is clear: ``path`` (the assistance's own choice; the operator's share still steers the hand).

    Parameters
    ----------
    clearance : PathClearance
    q : ndarray, shape (6,)
        The arm's joints (rad).
    path : list of ndarray, shape (6,)
        The path's points after q (rad), its last an IK solution of ``base_T_target``.
    base_T_target : ndarray, shape (4, 4)
        The target (the grasp or its pre-grasp), base frame.
    previous : list of ndarray, shape (6,), optional
        The earlier answer that replaced a path for this proposal (its points ahead), rad.
    admissible : callable, optional
        A path (its points after q) -> whether it may be taken; None: every path may.

    Returns
    -------
    list of ndarray, shape (6,)
        ``path``, or ``[q_e]`` or ``[v, q_e]``, rad.
    """
    if not clearance.goes_in(q, path):
        return path
    kin = clearance.kin
    if previous:
        ik = kin.ik(base_T_target, previous[-1], restarts=0)
        if ik.success:
            kept = [*previous[:-1], kin.nearest_branch(ik.q, q)]
            if (np.sin(kept[-1][4]) * np.sin(q[4]) > 0.0 and (admissible is None or admissible(kept))
                    and not clearance.goes_in(q, kept)):
                return kept
    ends = [path[-1], *ik_candidates(kin, q, base_T_target)]
    candidates: list[list[NDArray[np.float64]]] = [[q_e] for q_e in ends[1:]]
    axis, up = base_T_target[:3, 2], clearance.up
    for q_e in ends:
        for r in RETREATS:
            for h in LIFTS:
                if r == 0.0 and h == 0.0:
                    continue
                base_T_via = base_T_target.copy()
                base_T_via[:3, 3] += h * up - r * axis
                ik = kin.ik(base_T_via, q_e, restarts=0)
                if not ik.success:
                    continue
                via = kin.nearest_branch(ik.q, q)
                if np.sin(via[4]) * np.sin(q[4]) > 0.0:
                    candidates.append([via, q_e])
    order = sorted(range(len(candidates)), key=lambda i: (_length(q, candidates[i]), i))
    checked = 0
    for i in order:  # admissibility is asked in this order too, only until MAX_CHECKED admissible ones are checked
        if checked == MAX_CHECKED:
            break
        if admissible is None or admissible(candidates[i]):
            checked += 1
            if not clearance.goes_in(q, candidates[i]):
                return candidates[i]
    return path
