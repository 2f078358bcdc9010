"""The MICO's inverse kinematics: joint angles that put the end effector at a pose, with random restarts.

Frames, units and joint angles as in :mod:`.kinematics`; the arm's model, limits and 2 pi branches are
:class:`~.kinematics.MicoKinematics`', whose :meth:`~.kinematics.MicoKinematics.ik` checks its arguments and
calls :func:`solve_ik`. The compiled descent is :func:`grasp_intent_ros.kernels.ik_descent`, on the joint chain
:func:`chain_arrays` reads from the Pinocchio model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import NDArray

from ..errors import KinematicsError
from ..kernels import ik_descent

if TYPE_CHECKING:
    from .kinematics import MicoKinematics

__all__ = ['IK_POS_TOL', 'IK_ROT_TOL', 'IK_MAX_ITER', 'MAX_REACH', 'IkResult', 'chain_arrays', 'solve_ik']

IK_POS_TOL, IK_ROT_TOL, IK_MAX_ITER = 1e-4, 1e-3, 100
"""IK's default success tolerances (m, rad) and iterations per attempt (:func:`solve_ik`)."""

_SHOULDER = np.array([0.0, 0.0, 0.2755])
"""Joint 2's axis point in the base frame (m): height D1 of the DH table."""

MAX_REACH = 0.7285
"""Upper bound on the distance from :data:`_SHOULDER` to the EE origin (m): the sum of the link lengths
D2 + D3 + D4 + D5 + D6 + e2; FK of 20,000 random joint vectors reaches at most 0.708 m. IK answers a
target beyond it at once instead of spending its restarts."""


@dataclass(frozen=True)
class IkResult:
    """Outcome of :func:`solve_ik` (and :meth:`~.kinematics.MicoKinematics.ik`).

    Attributes
    ----------
    q : ndarray, shape (6,)
        Joint angles (rad) within the limits; the best attempt when ``success`` is False.
    success : bool
        True when both errors are within the requested tolerances.
    pos_error_m : float
        Distance between the reached and the target EE origin (m).
    rot_error_rad : float
        Angle of the rotation between the reached and the target EE orientation (rad).
    iterations : int
        Solver iterations summed over all attempts.
    attempts : int
        1 + number of random restarts used.
    message : str
        Human-readable summary.
    """

    q: NDArray[np.float64]
    success: bool
    pos_error_m: float
    rot_error_rad: float
    iterations: int
    attempts: int
    message: str


def chain_arrays(model: Any, tip_frame: int) -> tuple[NDArray[np.float64], ...]:
    """The serial chain of 1-dof revolute joints of a Pinocchio model, as the compiled IK takes it.

    Returns each joint's placement in its parent's frame (rotations (n, 3, 3), translations (n, 3)), its
    axis in its own frame (n, 3; read from the joint's motion subspace, which must be a pure rotation),
    and the tip frame's placement in the last joint's frame (3, 3) and (3,).

    Raises
    ------
    KinematicsError
        If a joint is not revolute or the joints do not form one chain from the world to the tip.
    """
    n = model.njoints - 1
    data = model.createData()
    q0 = pin.neutral(model)
    pin.computeJointJacobians(model, data, q0)
    axes = np.empty((n, 3))
    for jid in range(1, n + 1):
        if model.parents[jid] != jid - 1 or model.nqs[jid] != 1 or model.idx_vs[jid] != jid - 1:
            raise KinematicsError(f'joint {model.names[jid]!r} is not the next 1-dof joint of a serial chain')
        twist = np.array(pin.getJointJacobian(model, data, jid, pin.LOCAL))[:, jid - 1]
        if not (np.allclose(twist[:3], 0.0, atol=1e-12) and abs(np.linalg.norm(twist[3:]) - 1.0) < 1e-12):
            raise KinematicsError(f'joint {model.names[jid]!r} is not a revolute joint about an axis through '
                                  'its origin')
        axes[jid - 1] = twist[3:]
    tip = model.frames[tip_frame]
    if tip.parentJoint != n:
        raise KinematicsError(f'frame {tip.name!r} is not fixed to the last joint')
    rots = np.stack([np.array(model.jointPlacements[jid].rotation) for jid in range(1, n + 1)])
    trans = np.stack([np.array(model.jointPlacements[jid].translation) for jid in range(1, n + 1)])
    # C order throughout (Pinocchio hands out Fortran-ordered matrices): the types the kernels are warmed up with
    return tuple(np.ascontiguousarray(a) for a in (rots, trans, axes, tip.placement.rotation,
                                                   tip.placement.translation))


def solve_ik(kin: MicoKinematics, base_T_target: NDArray[np.float64], q_ref: NDArray[np.float64], *,
             restarts: int, pos_tol: float, rot_tol: float, max_iter: int,
             rng: np.random.Generator | int | None) -> IkResult:
    """Joint angles of ``kin``'s arm that put the EE at ``base_T_target``, on arguments already checked.

    Minimises the EE pose error in the EE frame, e = (R^T (p_t - p), log3(R^T R_t)), over joint angles within
    the limits: Levenberg-Marquardt (damped least squares with adaptive damping and step acceptance), iterates
    clipped to the limits, run to the solution (errors below 1e-10), so that the answer does not depend on
    where the errors first fell within the tolerances. An attempt succeeds when its position error |e_p| and
    rotation error |log3| are within ``pos_tol`` and ``rot_tol``. The first attempt starts from ``q_ref``
    (wrapped into the limits, :meth:`~.kinematics.MicoKinematics.into_limits`); if it fails, up to ``restarts``
    further attempts start from :meth:`~.kinematics.MicoKinematics.restart_seed` about ``q_ref``. Of equal
    answers the first attempt's wins: the answer is the attempt with the least ``pos_err / pos_tol + rot_err /
    rot_tol`` (the first that succeeds ends the search), wrapped per joint to the 2 pi branch nearest ``q_ref``
    (:meth:`~.kinematics.MicoKinematics.nearest_branch`). A target farther than :data:`MAX_REACH` (+ ``pos_tol``)
    from the shoulder is answered at once: ``q_ref``, no attempt. Never raises for an unreachable target:
    ``success`` is then False.

    Parameters
    ----------
    kin : MicoKinematics
    base_T_target : ndarray, shape (4, 4)
        Target pose of the EE in the base frame, a rigid transform (as
        :func:`~.frames.check_transform` returns it).
    q_ref : ndarray, shape (6,)
        Start and branch reference (rad), finite.
    restarts : int
        Maximum number of random restarts (>= 0).
    pos_tol, rot_tol : float
        Success tolerances on the position (m) and orientation (rad) errors (> 0).
    max_iter : int
        Iterations per attempt (>= 1).
    rng : numpy.random.Generator or int or None
        Source of the restart seeds; an int seeds a new generator, None seed 0 (made at the first restart),
        so equal calls give equal answers.

    Returns
    -------
    IkResult
    """
    generator = rng if isinstance(rng, np.random.Generator) else None  # made at the first restart
    shoulder_to_target = float(np.linalg.norm(base_T_target[:3, 3] - _SHOULDER))
    if shoulder_to_target > MAX_REACH + pos_tol:
        return IkResult(q=q_ref.copy(), success=False, pos_error_m=shoulder_to_target - MAX_REACH,
                        rot_error_rad=math.nan, iterations=0, attempts=0,
                        message=f'target {shoulder_to_target:.3f} m from the shoulder, beyond the arm\'s '
                                f'reach of {MAX_REACH:.3f} m')
    world_T_target = kin.world_T_base @ base_T_target
    R_t, p_t = np.ascontiguousarray(world_T_target[:3, :3]), np.ascontiguousarray(world_T_target[:3, 3])
    q_start = kin.into_limits(q_ref)
    best: tuple[float, NDArray[np.float64], float, float] | None = None
    iterations = 0
    for attempt in range(restarts + 1):
        if attempt > 0:
            if generator is None:
                generator = np.random.default_rng(0 if rng is None else rng)
            q_start = kin.restart_seed(q_ref, generator)
        q, pos_err, rot_err, used = ik_descent(q_start, kin.lower, kin.upper, kin.ik_chain, R_t, p_t, max_iter)
        iterations += used
        score = pos_err / pos_tol + rot_err / rot_tol
        if best is None or score < best[0]:
            best = (score, q, pos_err, rot_err)
        if pos_err <= pos_tol and rot_err <= rot_tol:
            break
    assert best is not None
    _, q, pos_err, rot_err = best
    success = pos_err <= pos_tol and rot_err <= rot_tol
    message = (f'{"converged" if success else "did not converge"} after {attempt + 1} attempt(s), '
               f'{iterations} iterations: position error {pos_err:.3g} m (tol {pos_tol:g}), '
               f'rotation error {rot_err:.3g} rad (tol {rot_tol:g})')
    return IkResult(q=kin.nearest_branch(q, q_ref), success=success, pos_error_m=pos_err,
                    rot_error_rad=rot_err, iterations=iterations, attempts=attempt + 1, message=message)
