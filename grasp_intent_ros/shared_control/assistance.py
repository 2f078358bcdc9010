r"""Shared control, ROS-free: the robot's twist toward the planned grasp, arbitration, blending, limits.

Policy blending (Dragan & Srinivasa, "A policy-blending formalism for shared control", 2013): the command is

.. math::

    u = \alpha\, r + (1 - \alpha)\, h,

``h`` the operator's twist, ``r`` the robot's twist toward the planned grasp, ``alpha`` in [0, 1] the
arbitration weight. Twists are 6-vectors (linear m/s, angular rad/s) of the end effector (EE) in the base
frame; the linear part is the velocity of the EE origin.

The robot's twist (:func:`robot_twist`)
---------------------------------------
Toward the pre-grasp (the grasp pose moved back by ``standoff`` along its approach axis, the EE z axis)
until the hand is in the approach corridor, then toward the grasp (:func:`assistance_target`): the hand
is in the corridor when it is within ``corridor_radius`` of the grasp, or behind it (along the approach
axis) within ``corridor_radius`` of that axis and within ``corridor_angle`` of the grasp's orientation.
With the arm's kinematics (:class:`Assistance` given a :class:`~.kinematics.MicoKinematics`), the twist is
the end effector's motion while the joints move straight toward the target's inverse kinematics q_t
(solved from the current joints q without random restarts, on the 2 pi branch nearest them, once per
target and planned grasp), ``J(q) k_q (q_t - q)`` (:func:`joint_space_twist`); without the kinematics, or
when the target has no IK solution from q, it is proportional to the pose error,
``(k_lin (p_t - p), k_ang log3(R_t R^T))`` (the rotation vector in the base frame, :func:`robot_twist`).
Either way each part is scaled down to its speed limit. Why joint space: the Cartesian twist turns the
hand along the straight rotation to the target, which for many of the MICO's grasps runs the wrist (joint
5) through 0 or pi, a singularity; there a servo's damped least squares cannot make the motion asked for
and the arm settles in the singular configuration, short of the grasp. The joint-space twist lies in the
range of J, so the servo can follow it, and following it the joints go straight to q_t. Its price: the
hand's path curves and the hand turns on the way (the image of a straight joint-space line); near the
target it agrees with the Cartesian error to first order.

Arbitration (:func:`arbitration`): alpha from the intent's confidence
---------------------------------------------------------------------
``'confidence'`` (the suite's): alpha = alpha_max * ramp(c) * a, where

- c = 1 - H(v) / ln K, the concentration of the target vector v over its K zones (0 for a uniform v, 1
  for a single zone; H the Shannon entropy), and ramp(c) = clip((c - c_low) / (c_high - c_low), 0, 1);
- a = E, the planned grasp's expected task success under v (:func:`plan_success`): v's share on the zones
  whose tasks are all among those of the grasp's reading, the zone of largest posterior P. It is the
  probability, under the intent, that the grasp serves the operator's task set, and the quantity the
  default planner ranks its candidates by; the posterior's fit to v would distrust the grasps that give
  up fit to serve the likely tasks.

and times the operator's agreement with the planned grasp, o: the smaller of the linear and the angular
agreement, each (1 + cos theta) / 2 of the angle theta between the operator's part and the same part of
the pose error toward the grasp itself, ``(k_lin (p_g - p), k_ang log3(R_g R^T))``
(:func:`operator_agreement`), as last measured while the operator moved that part faster than its
deadband (1 before; :class:`Assistance` holds them, and forgets them when the planned grasp moves by more
than the corridor's radius or angle). An operator who steers against the robot takes the control back
(alpha -> 0 as theta -> pi): the operator's input is evidence against the planned grasp (Dragan &
Srinivasa's confidence in the prediction). It is measured against the grasp, not against the robot's
twist: the pre-grasp and the joint-space path are the robot's way to the grasp, not a different proposal,
so an operator who heads straight for the grasp agrees with it (measured against the robot's twist, the
straight approach and the robot's detour disagree and the two pull against each other). The agreement is
held so that the control stays with an operator who then works the other part (a joystick's other mode)
or lets go, until the operator moves toward the grasp again.

``'blend'`` (ADA's baseline): alpha = alpha_max when v's top zone leads the second by at least
``margin``, else 0. ``'none'``: alpha = 0 (direct teleoperation). Neither looks at the operator's input.
Whatever the rule, alpha is 0 without a valid grasp, while a clarification is pending, or without the
arm's joint state: :class:`Assistance` decides that.

alpha is therefore in [0, alpha_max] for every rule: 0 means the operator's twist alone, alpha_max (< 1 by
default) the most the robot ever gets, so the operator always keeps 1 - alpha_max of the command and can
steer against any proposal. Under 'confidence' alpha reaches alpha_max * a (a the plan's expected success above)
once v is concentrated (c >= c_high) and the operator's last motion of each part was toward the grasp.

Limits (:class:`TwistLimiter`)
------------------------------
The blended twist's linear and angular parts are scaled down to their speed limits, then each part's
change since the last output is scaled down to acceleration limit times the elapsed time. A stale operator
input (older than the timeout) gives the zero twist at once, without the acceleration limit: a stop.
"""

from __future__ import annotations

import math
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.intent import parse_zones
from ..mico.kinematics import MicoKinematics
from ..planning.ranking import expected_success

__all__ = ['Arbitration', 'ARBITRATIONS', 'concentration', 'plan_success', 'arbitration', 'operator_agreement',
           'pose_error',
           'pre_grasp', 'assistance_target', 'robot_twist', 'joint_space_twist', 'blend', 'clip_norm', 'TwistLimiter',
           'AssistanceConfig',
           'Command', 'Assistance']

Arbitration = Literal['confidence', 'blend', 'none']
ARBITRATIONS: tuple[str, ...] = typing.get_args(Arbitration)


def concentration(v: ArrayLike) -> float:
    """1 - H(v) / ln K of a probability vector over K zones (1 for K = 1); v is normalised first.

    Raises
    ------
    ValueError
        If v is empty, negative, not finite or sums to 0.
    """
    p = np.asarray(v, dtype=np.float64).ravel()
    if p.size == 0 or not np.all(np.isfinite(p)) or np.any(p < 0.0) or not p.sum() > 0.0:
        raise ValueError(f'v must be a non-negative, finite, non-zero vector, got {p.tolist()}')
    if p.size == 1:
        return 1.0
    p = p / p.sum()
    nz = p[p > 0.0]
    return float(min(max(1.0 + np.sum(nz * np.log(nz)) / math.log(p.size), 0.0), 1.0))


def plan_success(posterior: ArrayLike, zone_labels: Sequence[str], task_names: Sequence[str], v: ArrayLike,
                 v_labels: Sequence[str]) -> float:
    """The planned grasp's expected task success under v: v's share on the zones its reading contains.

    The reading is the zone of largest P (the first of equal ones, in the model's zone order); a zone k is
    served when its tasks are among the reading's. This is the expected success E of a demonstration
    (:func:`~grasp_intent_ros.planning.ranking.expected_success`), with the grasp's reading as its task set.
    0 when a label is not a zone of ``task_names`` or v sums to 0.
    """
    try:
        zones = parse_zones(zone_labels, task_names)
        v_zones = parse_zones(v_labels, task_names)
    except InvalidIntentError:
        return 0.0
    values = np.asarray(v, dtype=np.float64)
    total = float(values.sum())
    if not total > 0.0 or len(v_zones) != values.size:
        return 0.0
    reading = zones[int(np.argmax(np.asarray(posterior, dtype=np.float64)))]
    return float(expected_success(np.array([reading], dtype=np.int64), v_zones, values / total)[0])


def arbitration(rule: Arbitration, v: ArrayLike, agreement: float, *, alpha_max: float, c_low: float,
                c_high: float, margin: float) -> float:
    """The arbitration weight alpha in [0, alpha_max] for target vector ``v`` and plan ``agreement`` (module docstring).

    Parameters
    ----------
    rule : 'confidence', 'blend' or 'none'
    v : array_like, shape (K,)
    agreement : float in [0, 1]
        The plan's expected success, :func:`plan_success`.
    alpha_max : float in [0, 1]
    c_low, c_high : float, 0 <= c_low < c_high <= 1
        The concentration ramp of 'confidence'.
    margin : float
        The lead of 'blend'.
    """
    if rule == 'none':
        return 0.0
    if rule == 'blend':
        top = np.sort(np.asarray(v, dtype=np.float64))[::-1]
        lead = float(top[0] - (top[1] if top.size > 1 else 0.0)) / float(top.sum())
        return alpha_max if lead >= margin else 0.0
    ramp = min(max((concentration(v) - c_low) / (c_high - c_low), 0.0), 1.0)
    return alpha_max * ramp * min(max(agreement, 0.0), 1.0)


def operator_agreement(operator: NDArray[np.float64], robot: NDArray[np.float64], *, deadband_linear: float,
                       deadband_angular: float) -> tuple[float | None, float | None]:
    """The operator's agreement with the robot per part (linear, angular): (1 + cos theta) / 2, in [0, 1].

    theta is the angle between the operator's and the robot's part; None (no evidence) for a part that
    either twist moves no faster than its deadband (m/s, rad/s).
    """
    parts: list[float | None] = []
    for part, deadband in ((slice(0, 3), deadband_linear), (slice(3, 6), deadband_angular)):
        if _norm(operator[part]) <= deadband or _norm(robot[part]) <= deadband:
            parts.append(None)
            continue
        h, r = clip_norm(operator[part], 1.0), clip_norm(robot[part], 1.0)  # no overflow in the products
        cos = float(h @ r) / (float(np.linalg.norm(h)) * float(np.linalg.norm(r)))
        parts.append(0.5 * (1.0 + min(max(cos, -1.0), 1.0)))
    return parts[0], parts[1]


def pose_error(base_T_ee: NDArray[np.float64], base_T_target: NDArray[np.float64]) -> NDArray[np.float64]:
    """(p_t - p, log3(R_t R^T)), shape (6,): the target's offset (m) and rotation vector (rad), base frame."""
    dp = base_T_target[:3, 3] - base_T_ee[:3, 3]
    dr = pin.log3(base_T_target[:3, :3] @ base_T_ee[:3, :3].T)
    return np.concatenate([dp, np.asarray(dr, dtype=np.float64)])


def pre_grasp(base_T_grasp: NDArray[np.float64], standoff: float) -> NDArray[np.float64]:
    """The grasp pose moved back by ``standoff`` (m) along its approach axis (the EE z axis)."""
    base_T_pre = base_T_grasp.copy()
    base_T_pre[:3, 3] -= standoff * base_T_grasp[:3, 2]
    return base_T_pre


def assistance_target(base_T_ee: NDArray[np.float64], base_T_grasp: NDArray[np.float64], *, standoff: float,
                      corridor_radius: float, corridor_angle: float) -> tuple[NDArray[np.float64], str]:
    """The pose the robot's twist aims at, and its name: ``'grasp'`` in the approach corridor, else ``'pre-grasp'``."""
    offset = base_T_ee[:3, 3] - base_T_grasp[:3, 3]
    if float(np.linalg.norm(offset)) <= corridor_radius:
        return base_T_grasp, 'grasp'
    axis = base_T_grasp[:3, 2]
    along = float(offset @ axis)
    lateral = float(np.linalg.norm(offset - along * axis))
    angle = float(np.linalg.norm(pin.log3(base_T_grasp[:3, :3] @ base_T_ee[:3, :3].T)))
    if along <= 0.0 and lateral <= corridor_radius and angle <= corridor_angle:
        return base_T_grasp, 'grasp'
    return pre_grasp(base_T_grasp, standoff), 'pre-grasp'


def _norm(x: NDArray[np.float64]) -> float:
    """|x|, without overflow for any finite ``x`` (inf when it exceeds the float range)."""
    size = float(np.max(np.abs(x)))
    return size * float(np.linalg.norm(x / size)) if size > 0.0 else 0.0


def clip_norm(x: NDArray[np.float64], limit: float) -> NDArray[np.float64]:
    """``x`` scaled down to norm ``limit`` when longer (direction kept; no overflow for any finite ``x``)."""
    size = float(np.max(np.abs(x)))
    if size == 0.0:
        return x
    unit = x / size
    norm = float(np.linalg.norm(unit))
    return unit * (limit / norm) if size * norm > limit else x


def robot_twist(base_T_ee: NDArray[np.float64], base_T_target: NDArray[np.float64], *, gain_linear: float,
                gain_angular: float, max_linear: float, max_angular: float) -> NDArray[np.float64]:
    """The proportional twist toward ``base_T_target``, each part within its speed limit; shape (6,)."""
    error = pose_error(base_T_ee, base_T_target)
    return np.concatenate([clip_norm(gain_linear * error[:3], max_linear),
                           clip_norm(gain_angular * error[3:], max_angular)])


def joint_space_twist(jacobian: NDArray[np.float64], q: NDArray[np.float64], q_target: NDArray[np.float64], *,
                      gain: float, max_linear: float, max_angular: float) -> NDArray[np.float64]:
    """The EE twist ``J(q) gain (q_target - q)``, each part within its speed limit; shape (6,).

    Parameters
    ----------
    jacobian : ndarray, shape (6, 6)
        The geometric Jacobian at ``q`` (:meth:`~.kinematics.MicoKinematics.jacobian`: linear rows m/rad,
        angular rows rad/rad, base frame).
    q, q_target : ndarray, shape (6,)
        Joint angles now and at the target (rad), ``q_target`` on the 2 pi branch nearest ``q``.
    gain : float
        1/s.
    max_linear, max_angular : float
        m/s, rad/s.
    """
    twist = jacobian @ (gain * (q_target - q))
    return np.concatenate([clip_norm(twist[:3], max_linear), clip_norm(twist[3:], max_angular)])


def blend(alpha: float, robot: NDArray[np.float64], operator: NDArray[np.float64]) -> NDArray[np.float64]:
    """The blended twist alpha * robot + (1 - alpha) * operator."""
    return alpha * robot + (1.0 - alpha) * operator


@dataclass
class TwistLimiter:
    """Speed and acceleration limits of an output twist stream (module docstring).

    Attributes
    ----------
    max_linear, max_angular : float
        m/s, rad/s.
    max_linear_acceleration, max_angular_acceleration : float
        m/s^2, rad/s^2.
    max_dt : float
        Longest elapsed time (s) the acceleration limit grants (a gap in the stream is no licence to jump).
    """

    max_linear: float
    max_angular: float
    max_linear_acceleration: float
    max_angular_acceleration: float
    max_dt: float = 0.02

    def __post_init__(self) -> None:
        self.last = np.zeros(6)

    def limit(self, twist: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """``twist`` (shape (6,)) within the limits, ``dt`` s after the last output; becomes the last output.

        A non-finite twist counts as zero (never a NaN out).
        """
        if not np.all(np.isfinite(twist)):
            twist = np.zeros(6)
        dt = min(max(dt, 0.0), self.max_dt)
        lin, ang = clip_norm(twist[:3], self.max_linear), clip_norm(twist[3:], self.max_angular)
        lin = self.last[:3] + clip_norm(lin - self.last[:3], self.max_linear_acceleration * dt)
        ang = self.last[3:] + clip_norm(ang - self.last[3:], self.max_angular_acceleration * dt)
        self.last = np.concatenate([lin, ang])
        return self.last.copy()

    def stop(self) -> NDArray[np.float64]:
        """The zero twist, at once; becomes the last output."""
        self.last = np.zeros(6)
        return self.last.copy()


@dataclass(frozen=True)
class AssistanceConfig:
    """The assistance's settings (the node's parameters of the same names; units m, rad, s).

    Attributes
    ----------
    arbitration : 'confidence', 'blend' or 'none'
    alpha_max, c_low, c_high, margin
        Of :func:`arbitration`.
    standoff, corridor_radius, corridor_angle
        Of :func:`assistance_target`.
    gain_linear, gain_angular, robot_max_linear, robot_max_angular
        Of :func:`robot_twist` (1/s, 1/s, m/s, rad/s); the speed limits also bound :func:`joint_space_twist`.
    gain_joint : float
        Of :func:`joint_space_twist` (1/s).
    deadband_linear, deadband_angular : float
        Of :func:`operator_agreement` ('confidence' only), m/s and rad/s.
    operator_timeout : float
        An operator twist older than this gives the zero twist.
    """

    arbitration: Arbitration = 'confidence'
    alpha_max: float = 0.9
    c_low: float = 0.2
    c_high: float = 0.7
    margin: float = 0.2
    standoff: float = 0.08
    corridor_radius: float = 0.02
    corridor_angle: float = 0.2
    gain_linear: float = 2.0
    gain_angular: float = 2.0
    robot_max_linear: float = 0.15
    robot_max_angular: float = 0.8
    gain_joint: float = 2.0
    deadband_linear: float = 0.01
    deadband_angular: float = 0.05
    operator_timeout: float = 0.1


@dataclass(frozen=True)
class Command:
    """One output of :class:`Assistance`.

    Attributes
    ----------
    twist : ndarray, shape (6,)
        The blended, limited twist (base frame).
    alpha : float
        The arbitration weight it was blended with (0 when there was nothing to assist, and for the stop of a
        stale operator input).
    phase : str
        'pre-grasp' or 'grasp' (what the robot's twist aims at), or why there is no assistance.
    """

    twist: NDArray[np.float64]
    alpha: float
    phase: str


class Assistance:
    """The newest inputs of the shared-control loop and the command they give (module docstring).

    Times are seconds of one clock (the node's). Inputs are assumed checked (finite, rigid transforms).
    With ``kin`` the arm's state comes from :meth:`set_joints` and the robot's twist is joint-space
    (module docstring); without it, from ``base_T_ee`` and the twist is Cartesian.
    """

    def __init__(self, config: AssistanceConfig, limiter: TwistLimiter, kin: MicoKinematics | None = None) -> None:
        self.config, self.limiter, self.kin = config, limiter, kin
        self.base_T_grasp: NDArray[np.float64] | None = None
        self.base_T_ee: NDArray[np.float64] | None = None
        self.q: NDArray[np.float64] | None = None
        self._jacobian: NDArray[np.float64] | None = None
        self._q_targets: dict[str, NDArray[np.float64] | None] = {}
        """IK of the grasp and the pre-grasp (None: none found), by phase, for the current grasp."""
        self.clarification_pending = False
        self.agreement = (1.0, 1.0)
        """The operator's held agreement with the robot, linear and angular (module docstring)."""
        self._posterior: tuple[NDArray[np.float64], tuple[str, ...], tuple[str, ...]] | None = None
        self._v: tuple[NDArray[np.float64], tuple[str, ...]] | None = None
        self._operator: tuple[NDArray[np.float64], float] | None = None
        self._last_output: float | None = None

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None:
        """A new planned grasp: valid from now on, and it answers any clarification pending.

        A grasp that moved by more than the corridor's radius or angle is a new proposal: the operator's held
        agreement (module docstring) starts afresh.
        """
        if self.base_T_grasp is not None:
            error = pose_error(self.base_T_grasp, base_T_grasp)
            if (float(np.linalg.norm(error[:3])) > self.config.corridor_radius
                    or float(np.linalg.norm(error[3:])) > self.config.corridor_angle):
                self.agreement = (1.0, 1.0)
        self.base_T_grasp, self.clarification_pending = base_T_grasp, False
        self._q_targets = {}

    def set_joints(self, q: NDArray[np.float64]) -> None:
        """The arm's joint angles (rad, shape (6,)): the hand's pose and the Jacobian there (needs ``kin``)."""
        if self.kin is None:
            raise ValueError('set_joints needs the kinematics (Assistance(..., kin=...))')
        self.q, self.base_T_ee, self._jacobian = q, self.kin.fk(q), self.kin.jacobian(q)

    def set_posterior(self, posterior: NDArray[np.float64], zone_labels: Sequence[str],
                      task_names: Sequence[str]) -> None:
        """The planned grasp's posterior over the model's zones of ``task_names`` (the latest is used)."""
        self._posterior = (posterior, tuple(zone_labels), tuple(task_names))

    def set_v(self, v: NDArray[np.float64], labels: Sequence[str]) -> None:
        """The newest target vector v over the zones ``labels``."""
        self._v = (v, tuple(labels))

    def clarification(self) -> None:
        """A clarification was requested: no assistance until the next grasp."""
        self.clarification_pending = True

    def set_operator(self, twist: NDArray[np.float64], now: float) -> None:
        """The operator's twist (shape (6,), base frame) received at ``now``."""
        self._operator = (twist, now)

    def operator_fresh(self, now: float) -> bool:
        """Whether the operator's twist is at most ``operator_timeout`` old."""
        return self._operator is not None and now - self._operator[1] <= self.config.operator_timeout

    def alpha(self) -> tuple[float, str]:
        """The arbitration weight now, and the robot's target phase or why alpha is 0."""
        cfg = self.config
        if cfg.arbitration == 'none':
            return 0.0, 'direct teleoperation'
        if self.clarification_pending:
            return 0.0, 'clarification pending'
        if self.base_T_grasp is None:
            return 0.0, 'no grasp'
        if self.base_T_ee is None:
            return 0.0, 'no joint state'
        if self._v is None:
            return 0.0, 'no intent'
        v, labels = self._v
        agreement = 0.0 if self._posterior is None else plan_success(*self._posterior, v, labels)
        alpha = arbitration(cfg.arbitration, v, agreement, alpha_max=cfg.alpha_max, c_low=cfg.c_low,
                            c_high=cfg.c_high, margin=cfg.margin)
        return alpha, 'assisting'

    def command(self, now: float) -> Command:
        """The twist to send at ``now``: the blend within the limits, or the zero twist for a stale operator."""
        dt = self.limiter.max_dt if self._last_output is None else now - self._last_output
        self._last_output = now
        alpha, phase = self.alpha()
        if not self.operator_fresh(now):
            return Command(self.limiter.stop(), 0.0, 'operator input stale')
        assert self._operator is not None
        robot = np.zeros(6)
        if alpha > 0.0:
            assert self.base_T_ee is not None and self.base_T_grasp is not None
            cfg = self.config
            target, phase = assistance_target(self.base_T_ee, self.base_T_grasp, standoff=cfg.standoff,
                                              corridor_radius=cfg.corridor_radius, corridor_angle=cfg.corridor_angle)
            robot = self._robot_twist(target, phase)
            if cfg.arbitration == 'confidence':
                error = pose_error(self.base_T_ee, self.base_T_grasp)  # toward the proposal, the grasp itself
                goal = np.concatenate([cfg.gain_linear * error[:3], cfg.gain_angular * error[3:]])
                measured = operator_agreement(self._operator[0], goal, deadband_linear=cfg.deadband_linear,
                                              deadband_angular=cfg.deadband_angular)
                linear, angular = (held if fresh is None else fresh for fresh, held in zip(measured, self.agreement))
                self.agreement = (linear, angular)
                alpha *= min(linear, angular)
        return Command(self.limiter.limit(blend(alpha, robot, self._operator[0]), dt), alpha, phase)

    def _robot_twist(self, base_T_target: NDArray[np.float64], phase: str) -> NDArray[np.float64]:
        """The robot's twist toward ``base_T_target`` (the grasp or the pre-grasp, ``phase``): module docstring."""
        cfg = self.config
        if self.kin is not None and self.q is not None and self._jacobian is not None:
            if phase not in self._q_targets:
                ik = self.kin.ik(base_T_target, self.q, restarts=0)  # the solution the joints descend to
                self._q_targets[phase] = ik.q if ik.success else None
            q_target = self._q_targets[phase]
            if q_target is not None:
                return joint_space_twist(self._jacobian, self.q, q_target, gain=cfg.gain_joint,
                                         max_linear=cfg.robot_max_linear, max_angular=cfg.robot_max_angular)
        assert self.base_T_ee is not None
        return robot_twist(self.base_T_ee, base_T_target, gain_linear=cfg.gain_linear, gain_angular=cfg.gain_angular,
                           max_linear=cfg.robot_max_linear, max_angular=cfg.robot_max_angular)
