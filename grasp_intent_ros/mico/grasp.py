"""The grasp policy of the planner node, ROS-free: target vector + model + object pose -> one MICO grasp.

:func:`plan_grasp` restricts v to the model's zones, plans (:func:`grasp_intent_ros.planning.planner.plan`)
with the robot constraints, the hand clear of the table and the object along the approach
(:class:`~.collision.CollisionFree`, given a :class:`~.collision.HandCollision`) and the MICO's reachability,
falls back to the best candidate that meets both when the best grasp does not, and turns the plan into what a
robot executes: the end-effector pose ``base_T_ee``, the arm and finger joint targets, and the time the move
takes at the arm's velocity limits.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError, ModelError, PlanningError
from ..method.features import FINGERS, MICO_3F
from ..method.intent import restrict
from ..method.model import GraspModel
from ..planning import common, planner
from ..planning.options import DEFAULT_METHOD, Method, Options
from .collision import Clearance, CollisionFree, HandCollision, Table
from .kinematics import ARM_JOINTS, FINGER_JOINTS, HOME_Q, JOINT_LIMIT_MARGIN, MicoKinematics, Reachability

__all__ = ['MIN_TRAJECTORY_TIME', 'JOINT_NAMES', 'OUTCOMES', 'NoModelZone', 'PlanOutcome', 'Grasp', 'NoReachableGrasp',
           'check_mico_model', 'check_workspace', 'check_grasp', 'trajectory_duration', 'plan_grasp']

MIN_TRAJECTORY_TIME = 0.1
"""Shortest time to reach the grasp (s); controllers reject a trajectory point at 0."""
JOINT_NAMES: tuple[str, ...] = ARM_JOINTS + FINGER_JOINTS
"""Names of :attr:`Grasp.positions`: the six arm joints, then the three fingers."""
OUTCOMES = ('best grasp reachable', 'fallback to a reachable candidate', 'no reachable grasp')
"""The outcomes of a plan (:attr:`PlanOutcome.outcome`); reachable: IK converges and, when checked, the hand
is clear of the table and the object."""


@dataclass(frozen=True)
class NoModelZone:
    """v gives no zone of the model any probability: nothing to plan, the operator must clarify.

    Attributes
    ----------
    reason : str
        Which zones of which model v leaves out.
    """

    reason: str


@dataclass(frozen=True, kw_only=True)
class PlanOutcome:
    """What every grasp plan reports.

    Attributes
    ----------
    result : common.PlanResult
        The plan; its ``x`` is the best reachable candidate (status ``'rejected'`` when none is).
    note : str
        The reachability outcome in words.
    ik_seconds : float
        Time spent in IK (s).
    """

    result: common.PlanResult
    note: str
    ik_seconds: float

    @property
    def outcome(self) -> str:
        """Which of :data:`OUTCOMES` this is."""
        if isinstance(self, Grasp):
            return OUTCOMES[1] if self.fallback else OUTCOMES[0]
        return OUTCOMES[2]


@dataclass(frozen=True, kw_only=True)
class NoReachableGrasp(PlanOutcome):
    """IK failed for every candidate: nothing to execute.

    ``reason`` says why, with the object position and the closest IK attempt.
    """

    reason: str


@dataclass(frozen=True, kw_only=True)
class Grasp(PlanOutcome):
    """A planned, reachable grasp and what the arm does for it.

    Attributes
    ----------
    base_T_ee : ndarray, shape (4, 4)
        End-effector pose in the base frame.
    positions : ndarray, shape (9,)
        Joint targets in :data:`JOINT_NAMES` order (rad): IK on the 2 pi branch nearest the seed, then
        the planned finger closures.
    duration_s : float
        Time to reach them from the seed at the arm's velocity limits, at least :data:`MIN_TRAJECTORY_TIME`.
    fallback : bool
        True when the best grasp was unreachable and a lower-ranked candidate is published.
    clearance : Clearance or None
        The hand's clearance from the table and the object (None: not checked).
    """

    base_T_ee: NDArray[np.float64]
    positions: NDArray[np.float64]
    duration_s: float
    fallback: bool
    clearance: Clearance | None = None


def check_mico_model(model: GraspModel, name: str) -> None:
    """Raise ModelError unless ``model`` uses the MICO 3-finger features (the ones mapped to a pose)."""
    if model.feature_names != MICO_3F.names:
        raise ModelError(f'model {name!r} has features {list(model.feature_names)}; this planner '
                         f'maps the MICO 3-finger features {list(MICO_3F.names)} to a pose')


def check_workspace(position: ArrayLike, radius: float, *, what: str = 'object position') -> NDArray[np.float64]:
    """``position`` (m, shape (3,)) when it is finite and at most ``radius`` m from the base origin.

    Raises
    ------
    KinematicsError
        For a non-finite position or one farther than ``radius``.
    """
    p = np.asarray(position, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise KinematicsError(f'{what} must be 3 finite numbers (m), got {p.tolist()}')
    with np.errstate(over='ignore', invalid='ignore'):  # 1e308 m away: the distance is inf
        distance = float(np.linalg.norm(p))
        if not distance <= radius:
            raise KinematicsError(f'{what} {[float(f"{c:.4g}") for c in p]} m is {distance:.4g} m from the base, '
                                  f'outside the workspace radius {radius:g} m')
    return p


def check_grasp(grasp: Grasp, kin: MicoKinematics, *, pos_tol: float = 1e-3, rot_tol: float = 1e-2) -> None:
    """Check a grasp before anything of it is published: every number finite and physically sound.

    The plan's features, posterior and reconstructed w are finite, the arm joint targets lie within the
    joint limits and reach ``base_T_ee`` (forward kinematics within ``pos_tol`` m and ``rot_tol`` rad), and
    the trajectory time is at most the time of the longest possible move (every joint across its whole
    range, from a reading :data:`~.kinematics.JOINT_LIMIT_MARGIN` outside it).

    Raises
    ------
    PlanningError
        Saying which check failed.
    """
    result = grasp.result
    for what, values in (('features', result.x), ('posterior', result.posterior), ('reconstructed w', result.w),
                         ('end-effector pose', grasp.base_T_ee), ('joint targets', grasp.positions)):
        if not np.isfinite(values).all():
            raise PlanningError(f'the plan\'s {what} are not finite: {np.asarray(values).tolist()}')
    q = grasp.positions[:len(ARM_JOINTS)]
    try:
        kin.check_limits(q, what='arm joint targets')
    except KinematicsError as exc:
        raise PlanningError(str(exc)) from None
    # ee_T_fk = inv(base_T_ee) @ base_T_fk for a rigid base_T_ee: R_ee^T (p_fk - p_ee) and R_ee^T R_fk
    base_T_fk, base_T_ee = kin.fk(q), grasp.base_T_ee
    pos_err = float(np.linalg.norm(base_T_fk[:3, 3] - base_T_ee[:3, 3]))
    trace = float(np.vdot(base_T_ee[:3, :3], base_T_fk[:3, :3]))  # trace(R_ee^T R_fk)
    rot_err = math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0))))
    if not (pos_err <= pos_tol and rot_err <= rot_tol):
        raise PlanningError(f'the arm joint targets miss the planned end-effector pose by {1e3 * pos_err:.3g} mm '
                            f'and {rot_err:.3g} rad')
    longest = _longest_move(kin)
    if not MIN_TRAJECTORY_TIME <= grasp.duration_s <= longest:
        raise PlanningError(f'trajectory time {grasp.duration_s:.6g} s outside [{MIN_TRAJECTORY_TIME:g}, '
                            f'{longest:.4g}] s')


@functools.lru_cache(maxsize=8)
def _longest_move(kin: MicoKinematics) -> float:
    """Seconds of the longest possible move (cached: a kinematics object's limits do not change).

    Every joint across its whole range, from a reading :data:`~.kinematics.JOINT_LIMIT_MARGIN` outside it.
    """
    return float(np.max((kin.upper - kin.lower + 2.0 * JOINT_LIMIT_MARGIN) / kin.velocity_limits))


def trajectory_duration(q_from: ArrayLike, q_to: ArrayLike, velocity_limits: ArrayLike, *,
                        min_duration: float = 0.0) -> float:
    """Shortest time (s) to move every joint from ``q_from`` to ``q_to`` at its velocity limit (rad/s).

    max_i |q_to_i - q_from_i| / v_i, but at least ``min_duration``. All arrays shape (n,), limits > 0.

    Raises
    ------
    ValueError
        For limits that are not positive or of another shape.
    """
    start, end = np.asarray(q_from, dtype=np.float64), np.asarray(q_to, dtype=np.float64)
    limits = np.asarray(velocity_limits, dtype=np.float64)
    if start.shape != limits.shape or end.shape != limits.shape or not np.all(limits > 0.0):
        raise ValueError(f'need positive velocity limits of shape {end.shape}, got {limits.tolist()}')
    # per joint in Python floats (once per plan, where numpy's machinery costs more than the arithmetic)
    return max(max((abs(b - a) / v for a, b, v in zip(start.tolist(), end.tolist(), limits.tolist())), default=0.0),
               float(min_duration))


def plan_grasp(model: GraspModel, v: ArrayLike, zones: tuple[int, ...], base_T_obj: NDArray[np.float64],
               kin: MicoKinematics, *, name: str = 'model', q_arm: NDArray[np.float64] | None = None,
               method: Method = DEFAULT_METHOD, options: Options | None = None, ik_restarts: int = 8,
               warm_start: NDArray[np.float64] | None = None, hand: HandCollision | None = None,
               table_plane: ArrayLike | None = None) -> Grasp | NoReachableGrasp | NoModelZone:
    """Plan the grasp for target ``v`` over ``zones`` on ``model`` with the object at ``base_T_obj``.

    Parameters
    ----------
    model : GraspModel
        MICO 3-finger features (:func:`check_mico_model`).
    v : array_like, shape (len(zones),)
        Target over ``zones`` (e.g. all zones of the model's tasks, :func:`~.intent.match_zones`).
    zones : tuple of int
        Must cover the model's zones.
    base_T_obj : ndarray, shape (4, 4)
        Object pose in the base frame.
    kin : MicoKinematics
    name : str
        The model's name, for messages.
    q_arm : ndarray, shape (6,), optional
        Latest arm joint reading (rad): seeds IK and starts the trajectory; :data:`HOME_Q` if None.
    method, options, warm_start
        As for :func:`grasp_intent_ros.planning.planner.plan`.
    ik_restarts : int
        Random IK restarts after the seeded attempt fails.
    hand : HandCollision, optional
        Checks the hand's clearance from the table and the model's body; a candidate in collision is turned
        down before IK is tried (None: not checked).
    table_plane : array_like, shape (4,), optional
        The table in the base frame, ``(nx, ny, nz, d)`` with ``n . p >= d`` above it (m); None: the plane the
        object stands on (z = 0 of the object frame).

    Returns
    -------
    Grasp, NoReachableGrasp or NoModelZone
        The last two ask the operator for clarification.

    Raises
    ------
    InvalidIntentError
        When v does not match ``zones``.
    KinematicsError
        For a malformed ``table_plane``.
    """
    v_model = restrict(v, zones, model.zones)
    if v_model is None:
        return NoModelZone(f'v gives no probability to the zones {",".join(model.zone_labels)} of model {name!r}')
    reachable = Reachability(kin, base_T_obj, q_arm, restarts=ik_restarts)
    table = None if table_plane is None else Table.in_object_frame(table_plane, base_T_obj)
    clear = None if hand is None else CollisionFree(hand, model.body, table)

    def accept(x: NDArray[np.float64]) -> bool:
        return (clear is None or clear(x)) and reachable(x)

    result = planner.plan(model, v_model, method=method, options=options, warm_start=warm_start, accept=accept)
    n = len(result.candidates)
    faults = {} if clear is None else clear.faults
    colliding = f'{len(faults)} in collision (first: {next(iter(faults.values()))}), ' if faults else ''
    if result.status == 'rejected':
        position = base_T_obj[:3, 3]
        where = (f'with the object at {np.round(position, 3).tolist()} m '
                 f'({np.linalg.norm(position):.2f} m from the base)')
        if not reachable.answers:
            reason = (f'no grasp clear of the table and the object: all {n} candidates in collision (first: '
                      f'{next(iter(faults.values()))}) {where}')
        else:
            closest = min(reachable.answers.values(), key=lambda a: a.pos_error_m)
            tried = f'all {n} candidates' if not faults else f'the other {len(reachable.answers)} candidates'
            reason = (f'no reachable grasp: {colliding}IK failed for {tried} {where}; closest: {closest.message}')
        note = f'none of {n} candidates reachable' + (f' ({colliding}{len(reachable.answers)} unreachable)'
                                                       if faults else '')
        return NoReachableGrasp(result=result, note=note, ik_seconds=reachable.seconds, reason=reason)
    if result.rejected:
        note = (f'best grasp unreachable: published candidate {result.rejected + 1} of {n} ({colliding}'
                f'objective {result.objective:.3g}, best {result.candidates[0].objective:.3g})')
    else:
        note = f'best of {n} candidates reachable'
    q = reachable.answer(result.x).q
    duration = trajectory_duration(HOME_Q if q_arm is None else q_arm, q, kin.velocity_limits,
                                   min_duration=MIN_TRAJECTORY_TIME)
    return Grasp(result=result, note=note, ik_seconds=reachable.seconds,
                 base_T_ee=reachable.target(result.x),
                 positions=np.concatenate([q, result.x[FINGERS]]), duration_s=duration,
                 fallback=bool(result.rejected), clearance=None if clear is None else clear.clearance(result.x))
