"""The robot twist's joint-space target for a pose with no IK from the arm's joints: the line IK.

The assistance's robot twist moves the joints straight toward the target's inverse kinematics
(:func:`~grasp_intent_ros.shared_control.assistance.joint_space_twist`), solved from the joints q. When that IK
fails (the descent from q stops with a joint at its limit or in the wrist's singularity), :func:`line_ik` looks
for a solution from other seeds whose straight joint line from q the servo can follow and that keeps the hand
near the grasp. ROS-free; the arm's kinematics are :class:`~grasp_intent_ros.mico.kinematics.MicoKinematics`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..mico.kinematics import HOME_Q, MicoKinematics

__all__ = ['LINE_IK_SEEDS', 'LINE_IK_CHECKS', 'line_ik']

LINE_IK_SEEDS = 32
"""Seeds tried (Home, then random ones) for a target that has no IK from the joints (:func:`line_ik`): each of a
target's IK solutions is the descent's answer from about one random seed in ten, so 32 miss a given one with
probability about 0.03 (8: 0.4)."""
LINE_IK_CHECKS = 20
"""Points (after the start) at which :func:`line_ik` checks the hand along a joint line."""


def line_ik(kin: MicoKinematics, q: NDArray[np.float64], base_T_target: NDArray[np.float64],
            base_T_grasp: NDArray[np.float64], *, slack: float) -> NDArray[np.float64] | None:
    """An IK of ``base_T_target`` reached by a straight joint line from ``q`` that keeps the hand near the grasp.

    For a target with no IK from the joints q. Candidates: the IK (no restarts) from :data:`LINE_IK_SEEDS`
    seeds, Home first, then the IK's own restart seeds about q
    (:meth:`~grasp_intent_ros.mico.kinematics.MicoKinematics.restart_seed`) from a generator seeded 0, each
    on the 2 pi branch nearest q. Admissible: the wrist (joint 5) stays on q's side of 0 and pi (sin q5
    keeps its sign: no crossing of the singularity the servo cannot follow) and the hand's origin stays
    within its present distance to the grasp plus ``slack`` of the grasp at :data:`LINE_IK_CHECKS` evenly
    spaced points of the line. Minimises |q_t - q| over the admissible candidates; ties: the earlier seed.

    Parameters
    ----------
    kin : MicoKinematics
    q : ndarray, shape (6,)
        The arm's joints (rad).
    base_T_target, base_T_grasp : ndarray, shape (4, 4)
        The target (the grasp or its pre-grasp) and the grasp, base frame.
    slack : float
        m (the assistance's ``corridor_radius``).

    Returns
    -------
    ndarray, shape (6,), or None
        The admissible candidate (rad), None when none is admissible.
    """
    grasp = base_T_grasp[:3, 3]
    bound = float(np.linalg.norm(kin.fk(q)[:3, 3] - grasp)) + slack
    rng = np.random.default_rng(0)
    seeds = [np.asarray(HOME_Q, dtype=np.float64)]
    seeds += [kin.restart_seed(q, rng) for _ in range(LINE_IK_SEEDS - 1)]
    best: NDArray[np.float64] | None = None
    best_distance = np.inf
    for seed in seeds:
        ik = kin.ik(base_T_target, seed, restarts=0)
        if not ik.success:
            continue
        q_t = kin.nearest_branch(ik.q, q)
        distance = float(np.linalg.norm(q_t - q))
        if distance >= best_distance or np.sin(q_t[4]) * np.sin(q[4]) <= 0.0:
            continue
        steps = np.linspace(0.0, 1.0, LINE_IK_CHECKS + 1)[1:]
        if all(float(np.linalg.norm(kin.fk(q + s * (q_t - q))[:3, 3] - grasp)) <= bound for s in steps):
            best, best_distance = q_t, distance
    return best
