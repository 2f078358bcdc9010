"""The grasp policy of the planner node, ROS-free: target vector + model + object pose -> one MICO grasp.

:func:`plan_grasp` restricts v to the model's zones, plans (:func:`grasp_intent_ros.planning.planner.plan`)
with the robot constraints, the hand clear of the table and the object along the approach
(:class:`~.collision.CollisionFree`, given a :class:`~.collision.HandCollision`) and the MICO's reach of the
grasp and of its whole approach (:class:`ApproachReach`: the pre-grasp and the corridor from it to the grasp
within the joint limits, the way the assistance brings the hand in), falls back to the best candidate that
meets them all when the best grasp does not, and turns the plan into what a robot executes: the
end-effector pose ``base_T_ee``, the arm and finger joint targets, and the time the move takes at the arm's
velocity limits.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError, ModelError, PlanningError
from ..method.features import FINGERS, MICO_3F
from ..method.intent import restrict
from ..method.model import GraspModel
from ..planning import common, planner
from ..planning.options import DEFAULT_METHOD, Method, Options
from .collision import LIMITS, CollisionFree, HandCollision, Limits
from .frames import PRE_GRASP_STANDOFF, pre_grasp, rotation_angle
from .grasp_clearance import Clearance, Table
from .kinematics import ARM_JOINTS, FINGER_JOINTS, HOME_Q, JOINT_LIMIT_MARGIN, MicoKinematics
from .reachability import Reachability

__all__ = ['MIN_TRAJECTORY_TIME', 'JOINT_NAMES', 'OUTCOMES', 'APPROACH_STEP', 'NoModelZone', 'PlanOutcome', 'Grasp',
           'NoReachableGrasp', 'ApproachReach', 'check_mico_model', 'check_workspace', 'check_grasp',
           'trajectory_duration', 'plan_grasp']

MIN_TRAJECTORY_TIME = 0.1
"""Shortest time to reach the grasp (s); controllers reject a trajectory point at 0."""
JOINT_NAMES: tuple[str, ...] = ARM_JOINTS + FINGER_JOINTS
"""Names of :attr:`Grasp.positions`: the six arm joints, then the three fingers."""
OUTCOMES = ('best grasp reachable', 'fallback to a reachable candidate', 'no reachable grasp')
"""The outcomes of a plan (:attr:`PlanOutcome.outcome`); reachable: IK converges for the grasp and along its
approach (:class:`ApproachReach`) and, when checked, the hand is clear of the table and the object."""
APPROACH_STEP = 0.01
"""Largest spacing (m) of the poses IK follows along the approach corridor (:class:`ApproachReach`)."""


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


class ApproachReach:
    """The MICO's reach of a grasp and of its approach, as a robot constraint (``accept=`` of the planner).

    A grasp x is taken when the arm reaches it and can follow its approach corridor, from the pre-grasp
    (``standoff`` m behind the grasp along its approach axis, :func:`~.frames.pre_grasp`) to the grasp, within
    its joint limits. *Following* a corridor from joint angles q: IK of the poses ``s = standoff k / n``
    (n = ceil(standoff / APPROACH_STEP)) along it, each started from the answer of the pose before it without
    random restarts, converges to the IK tolerances at every pose. Following from a neighbouring answer keeps
    one arm configuration along the corridor; IK's iterates stay within the limits, so a corridor that needs a
    joint past its limit stops the follow there. Two tries, the first that holds gives the grasp's joint
    targets (:meth:`joints`):

    1. back from the grasp's IK answer (``reachable``, :class:`~.reachability.Reachability`) to the pre-grasp
       (the targets are that answer);
    2. IK of the pre-grasp (from the seed, with the random restarts of ``reachable``), then forward to the
       grasp (the targets are the follow's end, another configuration of the arm at the grasp).

    A grasp neither holds for is turned down with the first try's reason (:attr:`faults`), as an unreachable
    one. Each candidate is checked once (cached by ``x.tobytes()``).

    Parameters
    ----------
    reachable : Reachability
        The grasp's IK.
    standoff : float
        The pre-grasp's distance behind the grasp (m), >= 0 (0: the grasp alone).

    Raises
    ------
    KinematicsError
        For a standoff that is not finite and >= 0.
    """

    def __init__(self, reachable: Reachability, *, standoff: float = PRE_GRASP_STANDOFF) -> None:
        if not (math.isfinite(standoff) and standoff >= 0.0):
            raise KinematicsError(f'standoff must be finite and >= 0, got {standoff!r}')
        self.reachable, self.standoff = reachable, float(standoff)
        self.faults: dict[bytes, str] = {}
        """Why the approach of a candidate whose grasp IK converged is out of reach (key: ``x.tobytes()``)."""
        self._joints: dict[bytes, NDArray[np.float64]] = {}

    def _follow(self, grasp: NDArray[np.float64], q: NDArray[np.float64], back: bool) -> tuple[NDArray[np.float64],
                                                                                                str | None]:
        """Follow the corridor of ``grasp`` (base_T_ee) from q, back to the pre-grasp or forward from it.

        Returns the joints at the follow's end (or at its start, when it stops) and why it stopped (None: it did not).
        """
        kin = self.reachable.kin
        n = math.ceil(self.standoff / APPROACH_STEP)
        for k in range(1, n + 1):
            s = self.standoff * ((k if back else n - k) / n)
            ik = kin.ik(pre_grasp(grasp, s), q, restarts=0)
            if not ik.success:
                pinned = [name for name, value, lo, hi in zip(kin.joint_names, ik.q.tolist(), kin.lower.tolist(),
                                                              kin.upper.tolist()) if value in (lo, hi)]
                at_limit = f'; at its limit: {", ".join(pinned)}' if pinned else ''
                return q, (f'the approach leaves the arm\'s reach {1e3 * s:.0f} mm behind the grasp (pre-grasp '
                           f'{1e3 * self.standoff:.0f} mm): position error {1e3 * ik.pos_error_m:.3g} mm, rotation '
                           f'error {ik.rot_error_rad:.3g} rad{at_limit}')
            q = ik.q
        return q, None

    def joints(self, x: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """The arm's joint targets (rad, shape (6,)) for grasp x at the end of its approach (class docstring).

        None when the arm reaches the grasp or follows its approach on no configuration tried.
        """
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key in self._joints or key in self.faults:
            return self._joints.get(key)
        reach = self.reachable
        answer = reach.answer(x)
        if not answer.success:
            return None
        start = time.perf_counter()
        grasp = reach.target(x)
        _, fault = self._follow(grasp, answer.q, back=True)
        if fault is None:
            self._joints[key] = answer.q
        else:
            pre = reach.kin.ik(pre_grasp(grasp, self.standoff), reach.q_seed, restarts=reach.restarts)
            q, forward_fault = self._follow(grasp, pre.q, back=False) if pre.success else (pre.q, fault)
            if forward_fault is None:
                self._joints[key] = q
            else:
                self.faults[key] = fault
        reach.seconds += time.perf_counter() - start
        return self._joints.get(key)

    def __call__(self, x: NDArray[np.float64]) -> bool:
        """Whether the arm reaches the grasp x and follows its approach (class docstring)."""
        return self.joints(x) is not None


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
    rot_err = rotation_angle(base_T_ee[:3, :3], base_T_fk[:3, :3])
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
               table_plane: ArrayLike | None = None, limits: Limits = LIMITS,
               margin: float = 0.0) -> Grasp | NoReachableGrasp | NoModelZone:
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
    limits : Limits
        The depths the collision check allows (with ``hand``).
    margin : float
        m, >= 0, with ``hand``: the object margin preferred for the error of the object's pose. The candidates
        are asked first under ``limits.less(margin)`` (:meth:`~.limits.Limits.less`: the palm and the open
        fingers that much shallower in the object), but the warm start's grasp under ``limits`` alone (a
        stream's held grasp is not moved for the margin: that would make the plan jump between grasps as v's
        likely tasks flicker); only when that plan is rejected, again under ``limits`` alone, so a margin never
        turns down the last grasp the limits take (the cup's usage-transfer-handover grasps nearly all put the
        palm within 3 mm of its limit). Among those it takes, the method's own order decides, as without a margin.
        0: ``limits`` alone.

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
    approach = ApproachReach(reachable)
    table = None if table_plane is None else Table.in_object_frame(table_plane, base_T_obj)
    clear = None if hand is None else CollisionFree(hand, model.body, table, limits=limits)
    kept = None if hand is None or margin == 0.0 else CollisionFree(hand, model.body, table,
                                                                     limits=limits.less(margin))
    held = None if warm_start is None else np.asarray(warm_start, dtype=np.float64).tobytes()

    def keeps_margin(x: NDArray[np.float64]) -> bool:
        assert kept is not None
        ok = kept(x) or (x.tobytes() == held and (clear is None or clear(x)))  # the held grasp: the limits alone
        return ok and approach(x)

    result = None if kept is None else planner.plan(model, v_model, method=method, options=options,
                                                    warm_start=warm_start, accept=keeps_margin)
    margin_faults = {} if kept is None else kept.faults
    if result is None or result.status == 'rejected':
        result = planner.plan(model, v_model, method=method, options=options, warm_start=warm_start,
                              accept=lambda x: (clear is None or clear(x)) and approach(x))
        margin_faults = {}
    n = len(result.candidates)
    collisions = {} if clear is None else clear.faults
    turned_down = []
    for faults, what in ((collisions, 'in collision'), (margin_faults, 'within the object margin'),
                         (approach.faults, 'with the approach out of reach')):
        if faults:
            turned_down.append(f'{len(faults)} {what} (first: {next(iter(faults.values()))})')
    failed = [answer for answer in reachable.answers.values() if not answer.success]
    if result.status == 'rejected':
        position = base_T_obj[:3, 3]
        where = (f'with the object at {np.round(position, 3).tolist()} m '
                 f'({np.linalg.norm(position):.2f} m from the base)')
        if not reachable.answers:
            reason = (f'no grasp clear of the table and the object: all {n} candidates in collision (first: '
                      f'{next(iter(collisions.values()))}) {where}')
        elif failed:
            closest = min(failed, key=lambda a: a.pos_error_m)
            tried = f'all {n} candidates' if len(failed) == n else f'the other {len(failed)} candidates'
            reason = ('no reachable grasp: ' + ''.join(f'{t}, ' for t in turned_down)
                      + f'IK failed for {tried} {where}; closest: {closest.message}')
        else:
            reason = f'no reachable grasp: {", ".join(turned_down)} {where}'
        note = f'none of {n} candidates reachable' + (f' ({", ".join(turned_down)}, {len(failed)} unreachable)'
                                                       if turned_down else '')
        return NoReachableGrasp(result=result, note=note, ik_seconds=reachable.seconds, reason=reason)
    if result.rejected:
        note = (f'best grasp unreachable: published candidate {result.rejected + 1} of {n} ('
                + ''.join(f'{t}, ' for t in turned_down)
                + f'objective {result.objective:.3g}, best {result.candidates[0].objective:.3g})')
    else:
        note = f'best of {n} candidates reachable'
    if kept is not None and not margin_faults and kept.faults:
        note += '; none with the object margin: planned at the limits'
    q = approach.joints(result.x)
    assert q is not None  # the plan's x was accepted
    duration = trajectory_duration(HOME_Q if q_arm is None else q_arm, q, kin.velocity_limits,
                                   min_duration=MIN_TRAJECTORY_TIME)
    return Grasp(result=result, note=note, ik_seconds=reachable.seconds,
                 base_T_ee=reachable.target(result.x),
                 positions=np.concatenate([q, result.x[FINGERS]]), duration_s=duration,
                 fallback=bool(result.rejected), clearance=None if clear is None else clear.clearance(result.x))
