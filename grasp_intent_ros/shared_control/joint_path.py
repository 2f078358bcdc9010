"""The robot twist's joint-space path: the wrist's branch of a straight line's end, the line IK and its via point.

The assistance's robot twist moves the joints straight toward the target's inverse kinematics
(:func:`~grasp_intent_ros.shared_control.robot_twist.joint_space_twist`), solved from the joints q, its end on the
2 pi branch of the wrist's joints that turns the hand the short way (:func:`line_turns`). When that IK
fails (the descent from q stops with a joint at its limit or in the wrist's singularity), :func:`joint_path`
looks for a solution from other seeds reached by a joint path the servo can follow and that keeps the hand near
the grasp: a straight line (the line IK) or, when no straight line qualifies, two straight lines through one via
point. ROS-free; the arm's kinematics are :class:`~grasp_intent_ros.mico.kinematics.MicoKinematics`.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from ..mico.frames import rotation_angle
from ..mico.kinematics import HOME_Q, MicoKinematics

__all__ = ['LINE_IK_SEEDS', 'LINE_IK_CHECKS', 'VIA_REACHED', 'WRIST_TURNS', 'TURN_SLACK', 'TURN_STEP', 'TIME_STEP',
           'ik_candidates', 'near_grasp', 'line_turns', 'joint_path']

LINE_IK_SEEDS = 32
"""Seeds tried (Home, then random ones) for a target that has no IK from the joints (:func:`joint_path`): each of
a target's IK solutions is the descent's answer from about one random seed in ten, so 32 miss a given one with
probability about 0.03 (8: 0.4)."""
LINE_IK_CHECKS = 20
"""Points (after the start) at which :func:`joint_path` checks the hand along each straight joint line."""
VIA_REACHED = 0.05
"""rad: the joints within this (Euclidean) distance of a via point have reached it (the assistance then aims at
the path's next point)."""
WRIST_TURNS = (3, 5)
"""The joints (0-based: joints 4 and 6, the hand's continuous wrist joints) whose 2 pi branch :func:`line_turns`
chooses."""
TURN_SLACK = 0.25
"""rad: how far the hand's orientation error to the target may rise above its value at the line's start before
:func:`line_turns` counts the line as turning the hand the long way."""
TURN_STEP = 0.05
"""rad: the quantum of :func:`line_turns`'s orientation cost (so that float noise never decides)."""
TIME_STEP = 0.1
"""s: the quantum of :func:`line_turns`'s time cost."""


def ik_candidates(kin: MicoKinematics, q: NDArray[np.float64],
                  base_T_target: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """The target's IK solutions from the :data:`LINE_IK_SEEDS` seeds, in seed order, each once (the first seed's).

    The IK (no restarts) from Home, then from the IK's restart seeds about q
    (:meth:`~grasp_intent_ros.mico.kinematics.MicoKinematics.restart_seed`) from a generator seeded 0; each solution
    on the 2 pi branch nearest q, kept when the wrist (joint 5) is on q's side of 0 and pi (sin q5 keeps its sign).
    """
    rng = np.random.default_rng(0)
    seeds = [np.asarray(HOME_Q, dtype=np.float64)]
    seeds += [kin.restart_seed(q, rng) for _ in range(LINE_IK_SEEDS - 1)]
    found: list[NDArray[np.float64]] = []
    for seed in seeds:
        ik = kin.ik(base_T_target, seed, restarts=0)
        if not ik.success:
            continue
        q_t = kin.nearest_branch(ik.q, q)
        if np.sin(q_t[4]) * np.sin(q[4]) > 0.0 and all(np.max(np.abs(q_t - f)) > 1e-6 for f in found):
            found.append(q_t)
    return found


def _distances(kin: MicoKinematics, start: NDArray[np.float64], end: NDArray[np.float64],
               grasp: NDArray[np.float64]) -> list[float]:
    """The hand's distance to ``grasp`` (m) at the :data:`LINE_IK_CHECKS` points of the line after ``start``."""
    steps = np.linspace(0.0, 1.0, LINE_IK_CHECKS + 1)[1:]
    return [float(np.linalg.norm(kin.fk(start + s * (end - start))[:3, 3] - grasp)) for s in steps]


def _via(kin: MicoKinematics, q: NDArray[np.float64], q_t: NDArray[np.float64], grasp: NDArray[np.float64],
         radius: float) -> NDArray[np.float64] | None:
    """The via point toward ``q_t``: the line's farthest check point, its hand pulled to ``radius`` of the grasp.

    The hand's pose at the first of the line's check points farthest from the grasp, with its origin moved
    along the ray from the grasp to ``radius`` of it (its nearest point at that distance; orientation kept),
    solved by the IK (no restarts) seeded there, on the 2 pi branch nearest q; None when the IK fails.
    """
    distances = _distances(kin, q, q_t, grasp)
    s = (int(np.argmax(distances)) + 1) / LINE_IK_CHECKS
    q_s = q + s * (q_t - q)
    base_T_via = kin.fk(q_s)
    away = base_T_via[:3, 3] - grasp
    base_T_via[:3, 3] = grasp + radius * away / float(np.linalg.norm(away))
    ik = kin.ik(base_T_via, q_s, restarts=0)
    return kin.nearest_branch(ik.q, q) if ik.success else None


def near_grasp(kin: MicoKinematics, q: NDArray[np.float64], path: list[NDArray[np.float64]],
               base_T_grasp: NDArray[np.float64], *, slack: float, reference: float = 0.0) -> bool:
    """Whether the path from ``q`` through ``path`` keeps the hand near the grasp (:func:`joint_path`'s bound).

    Near: the hand's origin within ``max(d, reference) + slack`` of the grasp (d: its present distance, at q) at
    the :data:`LINE_IK_CHECKS` evenly spaced points of each of the path's straight joint lines.
    """
    grasp = base_T_grasp[:3, 3]
    bound = max(float(np.linalg.norm(kin.fk(q)[:3, 3] - grasp)), reference) + slack
    points = [q, *path]
    return all(max(_distances(kin, a, b, grasp)) <= bound for a, b in zip(points[:-1], points[1:]))


def _turn_away(kin: MicoKinematics, q: NDArray[np.float64], q_t: NDArray[np.float64],
               base_R_target: NDArray[np.float64]) -> float:
    """rad: the largest rise of the hand's orientation error to ``base_R_target`` along the line q -> q_t.

    The error is the angle of R_target^T R(q); the rise is over its value at q, at the :data:`LINE_IK_CHECKS`
    points of the line after q (0 when it never rises).
    """
    def error(q_s: NDArray[np.float64]) -> float:
        return rotation_angle(base_R_target, kin.fk(q_s)[:3, :3])

    start = error(q)
    steps = np.linspace(0.0, 1.0, LINE_IK_CHECKS + 1)[1:]
    return max(0.0, max(error(q + s * (q_t - q)) for s in steps) - start)


def line_turns(kin: MicoKinematics, q: NDArray[np.float64], q_t: NDArray[np.float64],
               base_T_target: NDArray[np.float64], base_T_grasp: NDArray[np.float64], *, slack: float,
               reference: float = 0.0) -> NDArray[np.float64]:
    """The 2 pi branch of the wrist's joints 4 and 6 at which the straight joint line from ``q`` to ``q_t`` ends.

    ``q_t`` is an IK solution of ``base_T_target`` on its 2 pi branch nearest ``q``; the hand's pose at the
    line's end is the same on every branch, but the line's way there is not: where joint 6 (or 4) has to turn
    about pi, the nearest branch may turn the hand away from the target, its orientation error up through pi
    and back (the long way round), while the branch one turn the other way turns it straight on.

    Candidates: ``q_t`` with each of joints 4 and 6 (:data:`WRIST_TURNS`) shifted by 0, -2 pi or +2 pi
    within the joint limits (9 at most), in that order (joint 4's shift outer), the unshifted first.
    Admissible: the unshifted one always (the IK's own answer); a shifted one when its line keeps the hand
    near the grasp (:func:`near_grasp`, the bound of :func:`joint_path`). Minimises, lexicographically:

    1. the line's turn away: how far the hand's orientation error to the target rises over its value at
       ``q`` at the :data:`LINE_IK_CHECKS` points of the line, less :data:`TURN_SLACK` (0 when not above), in
       whole :data:`TURN_STEP`;
    2. the line's time under the joints' speed limits, max_j |q_t,j - q_j| / v_j, in whole :data:`TIME_STEP`;
    3. the candidates' order (so the IK's own answer wins every tie).

    The costs are whole quanta (rounded down), so float noise can decide only at a quantum's edge. Joints 1, 2,
    3 and 5 stay as the IK gave them (joint 5 keeps the wrist on its side of its singularity).

    When the IK's own answer costs no turn away and its wrist joints are within pi of q, it is returned without
    the other candidates: a 2 pi shift makes such a joint's turn at least pi, no shorter, so no candidate's cost
    is lower (the same answer, and only one line's forward kinematics in the common case).

    Returns
    -------
    ndarray, shape (6,)
        The chosen end of the line (rad), ``q_t`` itself when no other branch is better.
    """
    base_R_target = base_T_target[:3, :3]
    best, best_cost = q_t, (0, 0)
    for turns in itertools.product((0, -1, 1), repeat=len(WRIST_TURNS)):
        candidate = q_t.copy()
        candidate[list(WRIST_TURNS)] += 2.0 * math.pi * np.array(turns, dtype=np.float64)
        if np.any(candidate < kin.lower) or np.any(candidate > kin.upper):
            continue
        away = max(0.0, _turn_away(kin, q, candidate, base_R_target) - TURN_SLACK)
        time = float(np.max(np.abs(candidate - q) / kin.velocity_limits))
        cost = (math.floor(away / TURN_STEP), math.floor(time / TIME_STEP))
        if not any(turns):
            best, best_cost = candidate, cost
            if cost[0] == 0 and np.all(np.abs(candidate - q)[list(WRIST_TURNS)] <= math.pi):
                return best
        elif cost < best_cost and near_grasp(kin, q, [candidate], base_T_grasp, slack=slack, reference=reference):
            best, best_cost = candidate, cost
    return best


def joint_path(kin: MicoKinematics, q: NDArray[np.float64], base_T_target: NDArray[np.float64],
               base_T_grasp: NDArray[np.float64], *, slack: float,
               reference: float = 0.0) -> list[NDArray[np.float64]] | None:
    """The points of a joint path from ``q`` to an IK of ``base_T_target`` that keeps the hand near the grasp.

    For a target with no IK from the joints q. Candidates: the IK (no restarts) from :data:`LINE_IK_SEEDS`
    seeds, Home first, then the IK's own restart seeds about q
    (:meth:`~grasp_intent_ros.mico.kinematics.MicoKinematics.restart_seed`) from a generator seeded 0, each
    on the 2 pi branch nearest q, with the wrist (joint 5) on q's side of 0 and pi (sin q5 keeps its sign: no
    crossing of the singularity the servo cannot follow), each solution once (the first seed's). A path is
    admissible when the hand's origin stays within the bound, ``max(d, reference) + slack`` of the grasp (d:
    the hand's present distance to it), at :data:`LINE_IK_CHECKS` evenly spaced points of each of its
    straight lines.

    1. **The line IK**: the admissible straight line from q to a candidate q_t minimising |q_t - q|, its end
       then on the wrist's 2 pi branch of :func:`line_turns` (joint 5 unchanged, so the wrist keeps its side).
    2. Only when no straight line is admissible, **one via point**: for each candidate q_t, v is the IK of
       the hand's pose at the line's farthest check point from the grasp (the first on a tie), moved toward
       the grasp onto the sphere of the hand's present distance (the allowed region's nearest pose,
       ``slack`` inside the bound), seeded at that point of the line; admissible when v keeps the wrist's
       side and both lines q -> v and v -> q_t are admissible. Minimises |v - q| + |q_t - v|.

    Ties: the earlier seed (of q_t). Both endpoints on q's side of 0 and pi within pi of q5 keep every point
    of a line between them on that side.

    Parameters
    ----------
    kin : MicoKinematics
    q : ndarray, shape (6,)
        The arm's joints (rad).
    base_T_target, base_T_grasp : ndarray, shape (4, 4)
        The target (the grasp or its pre-grasp) and the grasp, base frame.
    slack : float
        m (the assistance's ``corridor_radius``).
    reference : float
        m: a distance the bound never falls below (the assistance's: the hand's distance to the grasp when it
        first sought a path to this grasp), so that a path admissible then stays admissible as the hand nears
        the grasp; 0 for the present distance alone.

    Returns
    -------
    list of ndarray, shape (6,), or None
        ``[q_t]`` (a straight line) or ``[v, q_t]`` (through the via point v), rad; None when no path is
        admissible.
    """
    grasp = base_T_grasp[:3, 3]
    present = float(np.linalg.norm(kin.fk(q)[:3, 3] - grasp))
    candidates = ik_candidates(kin, q, base_T_target)
    best: list[NDArray[np.float64]] | None = None
    best_length = np.inf
    for q_t in candidates:
        length = float(np.linalg.norm(q_t - q))
        if length < best_length and near_grasp(kin, q, [q_t], base_T_grasp, slack=slack, reference=reference):
            best, best_length = [q_t], length
    if best is not None:
        return [line_turns(kin, q, best[0], base_T_target, base_T_grasp, slack=slack, reference=reference)]
    for q_t in candidates:
        via = _via(kin, q, q_t, grasp, present)
        if via is None or np.sin(via[4]) * np.sin(q[4]) <= 0.0:
            continue
        length = float(np.linalg.norm(via - q)) + float(np.linalg.norm(q_t - via))
        if length < best_length and near_grasp(kin, q, [via, q_t], base_T_grasp, slack=slack, reference=reference):
            best, best_length = [via, q_t], length
    return best
