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
With the arm's kinematics (:class:`Assistance` given a :class:`~.kinematics.MicoKinematics`), the twist is the
end effector's motion while the joints move straight toward the target's inverse kinematics q_t (solved from
the current joints q without random restarts, its wrist on the 2 pi branch that turns the hand the short way,
:func:`~.joint_path.line_turns`, once per target and planned grasp), ``J(q) k_q (q_t - q)``
(:func:`joint_space_twist`). When the target has no IK solution from q (the descent from q stops at a joint
limit or in the wrist's singularity), q_t is an IK solution from other seeds whose straight joint line from q
keeps the hand near the grasp and the wrist on its side, or, when no straight line does, whose two lines
through one via point do: the joints aim at the via point until within :data:`~.joint_path.VIA_REACHED` of it,
then at q_t (:func:`~.joint_path.joint_path`; "near": within the hand's distance to the grasp when the first
path to this proposal was sought, or its present distance if larger, plus ``corridor_radius``). A path whose
open hand goes into the object as perceived (:meth:`Assistance.set_object`) is replaced by a clear one
(:func:`~.clearance.clear_path`). Without the kinematics, or when there is no such path either, it is
proportional to the pose error, ``(k_lin (p_t - p), k_ang log3(R_t R^T))`` (the rotation vector in the base
frame, :func:`robot_twist`). Either way each part is scaled down to its speed limit. Why joint space: the
Cartesian twist turns the hand along the straight rotation to the target, which for many of the MICO's grasps
runs the wrist (joint 5) through 0 or pi, a singularity; there a servo's damped least squares cannot make the
motion asked for and the arm settles in the singular configuration, short of the grasp. The joint-space twist
lies in the range of J, so the servo can follow it, and following it the joints go straight to q_t. Its price:
the hand's path curves and the hand turns on the way (the image of a straight joint-space line); near the
target it agrees with the Cartesian error to first order.

Arbitration (:func:`arbitration`): alpha from the probability that the grasp serves the operator's task
----------------------------------------------------------------------------------------------------------
``'confidence'`` (the suite's): alpha = alpha_max * s * o, where

- s = P(the grasp serves T | w) (:func:`serving_probability`), T the operator's task set under the paper's
  independent-task model (eq. 3: task i in T with probability w_i, independently; T not empty, eq. 4's
  v). A grasp whose task set is S *serves* T when T is a subset of S: the object's rules hold for every
  task the operator wants, which is how the benchmark judges success. So s = sum of v_k over the zones k
  contained in S (the planner's expected success E of S). For the chosen demonstration S is its label
  (:func:`grasp_task_set` finds it among the model's demonstrations); for a grasp that is no
  demonstration (a moved grasp, e.g. the paper's planner) S is unknown and s is the model's expectation,
  sum_k P(k | x) E(zone k). A grasp that serves every likely task has s near 1 however spread v is: v's
  concentration does not enter (an ambiguous intent is exactly where a grasp serving every likely task
  helps most).
- o, the operator's agreement with the planned grasp: the smaller of the linear and the angular
  agreement, each max(cos theta, 0) of the angle theta between the operator's part and the same part of
  the pose error toward the grasp's approach target (:func:`assistance_target`: its pre-grasp out of the
  corridor, then itself; the grasp's orientation either way) (:func:`operator_agreement`): the share of the
  operator's motion toward the grasp by its approach, so the robot's share falls as fast as the operator turns
  away from it (a changed goal: 0.5 at 60 degrees, 0.17 at 80, 0 from right angles on). Each is as last
  measured while the operator moved that part faster than its deadband (1 before; :class:`Assistance` holds
  them, and forgets them when the planned grasp moves by more than the corridor's radius or angle). The target
  is the pose the operators and the intent estimator steer to (:mod:`.approach`): near the pre-grasp the grasp
  lies at any angle to the way in, and a held linear agreement would starve a two-mode operator's rotation.

**The operator wins** (:class:`Assistance`). A part more than pi / 3 off the approach target (o < 0.5) is
opposition. Opposition sustained for ``yield_time`` makes the robot yield: alpha = 0 for this grasp until the
operator heads toward it again (every measured part within pi / 3, o >= 0.5) for ``yield_time``, or a new grasp
is planned. While the operator gives no input (both parts within their deadbands) the output is the operator's
twist (the robot does not move the hand on its own) unless ``assist_without_input``. Assistance switched off
(:attr:`Assistance.enabled` False) gives the operator's twist exactly.

``'blend'`` (a baseline after ADA's blend: alpha = alpha_max when v's top zone leads the second by at
least ``margin``, else 0). ``'none'``: alpha = 0 (direct teleoperation). Neither looks at the operator's
input. Whatever the rule, alpha is 0 without a valid grasp, while a clarification is pending, or without
the arm's joint state: :class:`Assistance` decides that.

alpha is therefore in [0, alpha_max] for every rule: 0 means the operator's twist alone, alpha_max (< 1 by
default) the most the robot ever gets, so the operator always keeps 1 - alpha_max of the command.

**Keeping the operator's pace** (``keep_pace``, off by default; :func:`keep_pace`). The robot's twist follows a
straight line in joint space, so its linear part can point well away from the approach target's Cartesian error
(against which the agreement is measured) while the operator heads straight at it: a two-mode operator's
translation then meets a robot's twist that runs against it, and at alpha about 0.4 the two cancel
(docs/shared_control.md, "Keeping the operator's pace"). With ``keep_pace``, before blending, the robot's twist
is raised in each part the operator moves (faster than its deadband) to at least the operator's speed along
the operator's direction of that part: the blend then never slows the operator's own motion, and the robot adds
what lies across it (its turn of the hand, its correction sideways).

**Agreeing with the robot's twist** (``robot_agreement``, off by default; :func:`robot_agreement`). The other
remedy for the same cancellation: alpha is also multiplied by the operator's agreement with the robot's own twist
(per part max(cos, 0), faded out below the deadbands; the smaller part's), so where the robot's twist runs against
the operator's the operator moves alone at full speed, and where it goes the operator's way the robot helps.

Limits (:class:`~.limits.TwistLimiter`)
---------------------------------------
The blended twist's linear and angular parts are scaled down to their speed limits, then each part's
change since the last output is scaled down to acceleration limit times the elapsed time. A stale operator
input (older than the timeout) gives the zero twist at once, without the acceleration limit: a stop. Last, given the
object as perceived (set_object) and a rule but 'none', the hand is kept out of it (:func:`~.barrier.clearance_filter`).
"""

from __future__ import annotations

import typing
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.body import ObjectBody
from ..method.intent import all_zones, default_task_names, parse_zones, zone_labels
from ..mico.collision import HandCollision
from ..mico.frames import PRE_GRASP_STANDOFF, REACH_POS, REACH_ROT, offset, pose_error, pre_grasp, reached
from ..mico.kinematics import HOME_Q, MicoKinematics
from ..planning.ranking import expected_success
from .approach import in_corridor
from .barrier import clearance_filter
from .clearance import PathClearance, default_hand
from .joint_path import VIA_REACHED
from .limits import TwistLimiter, clip_norm, norm
from .path_search import PathRequest, PathSearch, PathSource, warm_up_scene

__all__ = ['Arbitration', 'ARBITRATIONS', 'serving_probability', 'grasp_task_set', 'arbitration', 'operator_agreement',
           'approach_agreement', 'new_proposal', 'pose_error', 'REACH_POS', 'REACH_ROT', 'offset', 'reached',
           'assistance_target', 'robot_twist', 'joint_space_twist', 'keep_pace', 'robot_agreement', 'blend',
           'clip_norm', 'TwistLimiter', 'AssistanceConfig', 'Command', 'Assistance', 'warm_up']

Arbitration = Literal['confidence', 'blend', 'none']
ARBITRATIONS: tuple[str, ...] = typing.get_args(Arbitration)


def serving_probability(v: ArrayLike, v_labels: Sequence[str], task_names: Sequence[str], *,
                        task_set: int | None = None, posterior: ArrayLike | None = None,
                        zone_labels: Sequence[str] = ()) -> float:
    """P(the grasp serves T | w): v's share on the zones contained in the grasp's task set (module docstring).

    Parameters
    ----------
    v : array_like, shape (K,)
        The target over the zones ``v_labels`` (normalised here).
    v_labels, task_names : sequence of str
        v's zone labels and the tasks they are made of.
    task_set : int or None
        The grasp's task set (bitmask over ``task_names``) when it is a labelled demonstration.
    posterior, zone_labels
        Without ``task_set``: the model's posterior P(k | x) of the grasp over its zones ``zone_labels``;
        the result is then sum_k P_k E(zone k) / sum_k P_k.

    Returns
    -------
    float in [0, 1]
        0 when a label is not a zone of ``task_names``, v sums to 0, or neither a task set nor a posterior
        is given.
    """
    try:
        v_zones = parse_zones(v_labels, task_names)
        zones = parse_zones(zone_labels, task_names) if task_set is None else (task_set,)
    except InvalidIntentError:
        return 0.0
    values = np.asarray(v, dtype=np.float64)
    total = float(values.sum())
    if not total > 0.0 or len(v_zones) != values.size or not zones:
        return 0.0
    per_set = expected_success(np.array(zones, dtype=np.int64), v_zones, values / total)
    if task_set is not None:
        return float(min(per_set[0], 1.0))
    p = np.asarray(posterior, dtype=np.float64)
    if p.shape != per_set.shape or not float(p.sum()) > 0.0:
        return 0.0
    return float(min(max(float(p @ per_set) / float(p.sum()), 0.0), 1.0))


def grasp_task_set(x: NDArray[np.float64], demo_x: NDArray[np.float64], demo_sets: NDArray[np.int64],
                   feature_scale: NDArray[np.float64], *, tolerance: float = 1e-6) -> int | None:
    """The task set (bitmask) of the demonstration the grasp features ``x`` (shape (d,)) are, None for none.

    ``x`` is demonstration n when its scaled distance max_j |x_j - demo_x[n, j]| / feature_scale[j] is at most
    ``tolerance`` (the planner publishes a chosen demonstration's features, projected onto the feasible set,
    which moves a feasible demonstration by rounding at most); the first such demonstration wins.
    """
    gap = np.max(np.abs(demo_x - x) / feature_scale, axis=1)
    hits = np.flatnonzero(gap <= tolerance)
    return int(demo_sets[hits[0]]) if hits.size else None


def arbitration(rule: Arbitration, v: ArrayLike, serving: float, *, alpha_max: float, margin: float) -> float:
    """The arbitration weight alpha in [0, alpha_max] before the operator's agreement (module docstring).

    Parameters
    ----------
    rule : 'confidence', 'blend' or 'none'
    v : array_like, shape (K,)
    serving : float in [0, 1]
        P(the grasp serves T | w), :func:`serving_probability` ('confidence' only).
    alpha_max : float in [0, 1]
    margin : float
        The lead of 'blend'.
    """
    if rule == 'none':
        return 0.0
    if rule == 'blend':
        top = np.sort(np.asarray(v, dtype=np.float64))[::-1]
        lead = float(top[0] - (top[1] if top.size > 1 else 0.0)) / float(top.sum())
        return alpha_max if lead >= margin else 0.0
    return alpha_max * min(max(serving, 0.0), 1.0)


def operator_agreement(operator: NDArray[np.float64], robot: NDArray[np.float64], *, deadband_linear: float,
                       deadband_angular: float) -> tuple[float | None, float | None]:
    """The operator's agreement with the robot per part (linear, angular): max(cos theta, 0), in [0, 1].

    theta is the angle between the operator's and the robot's part; None (no evidence) for a part that
    either twist moves no faster than its deadband (m/s, rad/s).
    """
    parts: list[float | None] = []
    for part, deadband in ((slice(0, 3), deadband_linear), (slice(3, 6), deadband_angular)):
        if norm(operator[part]) <= deadband or norm(robot[part]) <= deadband:
            parts.append(None)
            continue
        parts.append(_agreement(operator[part], robot[part]))
    return parts[0], parts[1]


def _agreement(h: NDArray[np.float64], r: NDArray[np.float64]) -> float:
    """max(cos theta, 0) of the angle theta between two non-zero vectors, in [0, 1]; no overflow for finite ones."""
    h, r = clip_norm(h, 1.0), clip_norm(r, 1.0)  # no overflow in the products
    cos = float(h @ r) / (float(np.linalg.norm(h)) * float(np.linalg.norm(r)))
    return min(max(cos, 0.0), 1.0)


def robot_agreement(operator: NDArray[np.float64], robot: NDArray[np.float64], *, deadband_linear: float,
                    deadband_angular: float) -> float:
    """The factor in [0, 1] by which the operator's disagreement with the robot's own twist lowers alpha.

    Per part (linear, angular), with h and r the operator's and the robot's part, d the part's deadband
    (m/s, rad/s) and c = max(cos theta, 0) of their angle theta: ``1 - (1 - c) min(|h| / d, 1) min(|r| / d, 1)``;
    the factor is the smaller of the two parts'. So where both move beyond the deadband it is c (0 where r runs
    at right angles to h or against it: the operator moves alone; 1 where r goes h's way: alpha unchanged), and
    the disagreement fades out linearly below the deadband of either: 1 (alpha unchanged) at zero h or zero r.
    Continuous in h and r everywhere (the weights vanish where theta is undefined), with no threshold: no
    decision turns on a last bit.
    """
    factor = 1.0
    for part, deadband in ((slice(0, 3), deadband_linear), (slice(3, 6), deadband_angular)):
        h_speed, r_speed = norm(operator[part]), norm(robot[part])
        if h_speed == 0.0 or r_speed == 0.0:
            continue  # the weight is 0: no disagreement (the cosine undefined)
        weight = min(h_speed / deadband, 1.0) * min(r_speed / deadband, 1.0) if deadband > 0.0 else 1.0
        factor = min(factor, 1.0 - (1.0 - _agreement(operator[part], robot[part])) * weight)
    return factor


def approach_agreement(config: AssistanceConfig, operator: NDArray[np.float64], base_T_ee: NDArray[np.float64],
                       base_T_target: NDArray[np.float64]) -> tuple[float | None, float | None]:
    """:func:`operator_agreement` with the gain-scaled pose error toward ``base_T_target`` (an approach target)."""
    error = pose_error(base_T_ee, base_T_target)  # toward the proposal by its approach (module docstring)
    goal = np.concatenate([config.gain_linear * error[:3], config.gain_angular * error[3:]])
    return operator_agreement(operator, goal, deadband_linear=config.deadband_linear,
                              deadband_angular=config.deadband_angular)


def new_proposal(config: AssistanceConfig, old: NDArray[np.float64], new: NDArray[np.float64]) -> bool:
    """Whether grasp ``new`` moved from ``old`` by more than the approach corridor's radius or angle."""
    error = pose_error(old, new)
    return (float(np.linalg.norm(error[:3])) > config.corridor_radius
            or float(np.linalg.norm(error[3:])) > config.corridor_angle)


def assistance_target(base_T_ee: NDArray[np.float64], base_T_grasp: NDArray[np.float64], *, standoff: float,
                      corridor_radius: float, corridor_angle: float) -> tuple[NDArray[np.float64], str]:
    """The pose the robot's twist aims at, and its name: ``'grasp'`` in the approach corridor, else ``'pre-grasp'``.

    The corridor is :func:`~.approach.in_corridor`'s.
    """
    if in_corridor(base_T_ee, base_T_grasp[None, :3, 3], base_T_grasp[None, :3, :3], corridor_radius=corridor_radius,
                   corridor_angle=corridor_angle)[0]:
        return base_T_grasp, 'grasp'
    return pre_grasp(base_T_grasp, standoff), 'pre-grasp'


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
        Joint angles now and at the target (rad), ``q_target`` on the 2 pi branch the joints are to turn to.
    gain : float
        1/s.
    max_linear, max_angular : float
        m/s, rad/s.
    """
    twist = jacobian @ (gain * (q_target - q))
    return np.concatenate([clip_norm(twist[:3], max_linear), clip_norm(twist[3:], max_angular)])


def keep_pace(robot: NDArray[np.float64], operator: NDArray[np.float64], *, deadband_linear: float,
              deadband_angular: float) -> NDArray[np.float64]:
    """``robot`` (shape (6,)) at least as fast as ``operator`` along the operator's direction, per part.

    For each part (linear, angular) the operator moves faster than its deadband (m/s, rad/s), with e the unit
    vector of the operator's part h: the part of ``robot`` nearest it (Euclidean) whose component along e is at
    least |h|, i.e. ``r + max(0, |h| - r . e) e`` (the projection onto that half-space: unique); its part across
    e is kept. The other parts are ``robot``'s. So ``alpha r' + (1 - alpha) h`` has at least h's speed along h.
    Not clipped to the robot's speed limits (the output's limits follow the blend).
    """
    out = np.array(robot, dtype=np.float64)
    for part, deadband in ((slice(0, 3), deadband_linear), (slice(3, 6), deadband_angular)):
        speed = norm(operator[part])
        if speed <= deadband:
            continue
        unit = operator[part] / speed
        out[part] += max(0.0, speed - float(out[part] @ unit)) * unit
    return out


def blend(alpha: float, robot: NDArray[np.float64], operator: NDArray[np.float64]) -> NDArray[np.float64]:
    """The blended twist alpha * robot + (1 - alpha) * operator."""
    return alpha * robot + (1.0 - alpha) * operator


@dataclass(frozen=True)
class AssistanceConfig:
    """The assistance's settings (the node's parameters of the same names; units m, rad, s).

    Attributes
    ----------
    arbitration : 'confidence', 'blend' or 'none'
    alpha_max, margin
        Of :func:`arbitration`.
    standoff, corridor_radius, corridor_angle
        Of :func:`assistance_target`.
    gain_linear, gain_angular, robot_max_linear, robot_max_angular, gain_joint
        Of :func:`robot_twist` (1/s, 1/s, m/s, rad/s; the limits bound :func:`joint_space_twist` too), its gain (1/s).
    deadband_linear, deadband_angular : float
        Operator speeds (m/s, rad/s) up to which a part is no input: no evidence for
        :func:`operator_agreement`, and no input at all when both parts are within them.
    yield_time : float
        Seconds of sustained opposition after which the robot yields, and of heading toward the grasp
        after which it assists again ('confidence').
    assist_without_input : bool
        Whether the robot's twist moves the hand while the operator gives no input (default False).
    keep_pace : bool
        Whether the robot's twist is raised to the operator's speed along the operator's direction in each part
        the operator moves, before blending (:func:`keep_pace`; module docstring). Default False: the blend as is.
    robot_agreement : bool
        Whether alpha is also multiplied by the operator's agreement with the robot's own twist (the one blended,
        after ``keep_pace``) (:func:`robot_agreement`; module docstring). Default False: alpha as is.
    operator_timeout : float
        An operator twist older than this gives the zero twist.
    clearance_margin : float
        m: :class:`~.clearance.PathClearance`'s ``margin`` (beyond the planner's limits).
    """

    arbitration: Arbitration = 'confidence'
    alpha_max: float = 0.9
    margin: float = 0.2
    standoff: float = PRE_GRASP_STANDOFF
    corridor_radius: float = 0.02
    corridor_angle: float = 0.2
    gain_linear: float = 2.0
    gain_angular: float = 2.0
    robot_max_linear: float = 0.15
    robot_max_angular: float = 0.8
    gain_joint: float = 2.0
    deadband_linear: float = 0.01
    deadband_angular: float = 0.05
    yield_time: float = 0.15
    assist_without_input: bool = False
    keep_pace: bool = False
    robot_agreement: bool = False
    operator_timeout: float = 0.1
    clearance_margin: float = 0.0


@dataclass(frozen=True)
class Command:
    """One output of :class:`Assistance`.

    Attributes
    ----------
    twist : ndarray, shape (6,)
        The blended, limited and filtered twist (base frame).
    alpha : float
        The arbitration weight it was blended with (0: nothing to assist, or the stop of a stale operator input).
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
    (module docstring); without it, from ``base_T_ee`` and the twist is Cartesian. ``hand``: :meth:`set_object`'s.
    ``paths`` runs the joint path's searches (:mod:`.path_search`): at once by default. Every :meth:`set_grasp`
    and :meth:`set_object` asks for each phase's path to be sought again, from the joints when it is next
    needed. While one is sought elsewhere (a :class:`~.path_search.PathWorker`), the robot's twist follows the
    phase's previous path when the grasp and the object are bit-identical to those it was sought for (its
    points still ahead: via points reached stay popped); else there is none and the output is the operator's
    twist alone (alpha 0, phase ``'seeking a path'``): the Cartesian twist is neither checked against the
    object nor free of the wrist's singularity.
    """

    def __init__(self, config: AssistanceConfig, limiter: TwistLimiter, kin: MicoKinematics | None = None,
                 hand: HandCollision | None = None) -> None:
        self.config, self.limiter, self.kin, self.hand = config, limiter, kin, hand
        self.clearance: PathClearance | None = None  # the perceived object (set_object)
        self.base_T_grasp: NDArray[np.float64] | None = None
        self.base_T_ee: NDArray[np.float64] | None = None
        self.q: NDArray[np.float64] | None = None
        self.enabled = True
        """False: the output is the operator's twist, exactly (the operator's switch)."""
        self.object_probability = 1.0
        """P(o) of the grasp's object in a scene ('confidence': a factor of s; 1, one object's, changes nothing)."""
        self._jacobian: NDArray[np.float64] | None = None
        self.paths: PathSource | None = None if kin is None else PathSearch(kin)
        self._epoch = 0
        """Counts the changes of the grasp or the object (not bit-identical): a path is for one epoch."""
        self._generation = 0
        """Counts the grasps and objects set: each asks for the paths to be sought again (class docstring)."""
        self._object: tuple[bytes, ObjectBody | None, float] | None = None
        self._path_reference: float | None = None
        """The hand's distance to the grasp (m) when a joint path to this proposal was first sought (joint_path)."""
        self._q_targets: dict[str, tuple[int, list[NDArray[np.float64]] | None]] = {}
        """By phase, for this epoch: the generation a joint path was sought for and its points still ahead toward
        the grasp or the pre-grasp (None: none found); ``_cleared``: the clear paths that replaced one, by phase,
        for this proposal."""
        self._cleared: dict[str, list[NDArray[np.float64]]] = {}
        self.clarification_pending = False
        self.agreement = (1.0, 1.0)
        """The operator's held agreement with the grasp's approach target, linear and angular (module docstring)."""
        self.yielded = False
        """Whether the robot yields to the operator's sustained opposition (alpha 0) for this grasp."""
        self._since: float | None = None
        """When the operator's current opposition (or, yielded, agreement) began."""
        self._task_set: int | None = None
        self._posterior: tuple[NDArray[np.float64], tuple[str, ...], tuple[str, ...]] | None = None
        self._v: tuple[NDArray[np.float64], tuple[str, ...]] | None = None
        self._operator: tuple[NDArray[np.float64], float] | None = None
        self._last_output: float | None = None

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None:
        """A new planned grasp: valid from now on, and it answers any clarification pending.

        A grasp that moved by more than the corridor's radius or angle is a new proposal: the operator's held
        agreement and the robot's yielding (module docstring) start afresh. The paths are sought again; a grasp
        bit-identical to the current one (the planner's same plan, sent again) keeps them in use meanwhile.
        """
        same = self.base_T_grasp is not None and np.array_equal(self.base_T_grasp, base_T_grasp)
        if self.base_T_grasp is not None and not same and new_proposal(self.config, self.base_T_grasp, base_T_grasp):
            self.agreement, self.yielded, self._since = (1.0, 1.0), False, None
            self._path_reference, self._cleared = None, {}
        self.base_T_grasp, self.clarification_pending = base_T_grasp, False
        self._generation += 1
        if not same:
            self._q_targets, self._epoch = {}, self._epoch + 1

    def set_joints(self, q: NDArray[np.float64]) -> None:
        """The arm's joint angles (rad, shape (6,)): the hand's pose and the Jacobian there (needs ``kin``)."""
        if self.kin is None:
            raise ValueError('set_joints needs the kinematics (Assistance(..., kin=...))')
        self.q, self.base_T_ee, self._jacobian = q, self.kin.fk(q), self.kin.jacobian(q)

    def set_object(self, base_T_obj: NDArray[np.float64] | None, body: ObjectBody | None) -> None:
        """Tracked object pose (base), model's body: new paths clear of it (None: none). KinematicsError: not rigid.

        The paths are sought again; the same pose (bit-identical), body (the same object) and
        ``clearance_margin`` as before keep them in use meanwhile.
        """
        key = (b'' if base_T_obj is None else np.asarray(base_T_obj, dtype=np.float64).tobytes(), body,
               self.config.clearance_margin)
        if self._object is None or any(a is not b and a != b for a, b in zip(key, self._object)):  # body: identity
            clearance = None if self.kin is None or base_T_obj is None or body is None else PathClearance(
                self.kin, self.hand or default_hand(), body, base_T_obj, margin=self.config.clearance_margin)
            self.clearance, self._q_targets, self._epoch, self._object = clearance, {}, self._epoch + 1, key
        self._generation += 1

    def set_posterior(self, posterior: NDArray[np.float64], zone_labels: Sequence[str],
                      task_names: Sequence[str]) -> None:
        """The planned grasp's posterior over the model's zones of ``task_names`` (the latest is used)."""
        self._posterior = (posterior, tuple(zone_labels), tuple(task_names))

    def set_task_set(self, task_set: int | None) -> None:
        """The planned grasp's task set (bitmask over the posterior's tasks), None when it is no demonstration."""
        self._task_set = task_set

    @property
    def task_set(self) -> int | None:
        """The planned grasp's task set as last set (None: none, or no demonstration)."""
        return self._task_set

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

    def serving(self) -> float:
        """P(the planned grasp serves T | w) now (:func:`serving_probability`; 0 without v or a posterior)."""
        if self._v is None or self._posterior is None:
            return 0.0
        posterior, zone_labels, task_names = self._posterior
        v, labels = self._v
        return serving_probability(v, labels, task_names, task_set=self._task_set, posterior=posterior,
                                   zone_labels=zone_labels)

    def alpha(self) -> tuple[float, str]:
        """The arbitration weight now before the operator's agreement, and the robot's phase or why it is 0."""
        cfg = self.config
        if not self.enabled:
            return 0.0, 'assistance off'
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
        serving = self.object_probability * self.serving() if cfg.arbitration == 'confidence' else 0.0
        alpha = arbitration(cfg.arbitration, self._v[0], serving, alpha_max=cfg.alpha_max, margin=cfg.margin)
        return alpha, 'assisting'

    def _agree(self, operator: NDArray[np.float64], now: float, target: NDArray[np.float64]) -> float:
        """Update the held agreement and the yielding from the operator's twist at ``now``, toward :meth:`target`."""
        cfg = self.config
        assert self.base_T_ee is not None
        measured = approach_agreement(cfg, operator, self.base_T_ee, target)
        linear, angular = (held if fresh is None else fresh for fresh, held in zip(measured, self.agreement))
        self.agreement = (linear, angular)
        parts = [m for m in measured if m is not None]
        if parts:  # evidence: against the approach target in some part, or toward it in every measured part
            against = min(parts) < 0.5
            if against == self.yielded:  # the state holds: nothing is building up
                self._since = None
            elif self._since is None:
                self._since = now
            if self._since is not None and now - self._since >= cfg.yield_time:
                self.yielded, self._since = not self.yielded, None
        return 0.0 if self.yielded else min(linear, angular)

    def command(self, now: float) -> Command:
        """The twist to send at ``now``: the blend within the limits, filtered; the zero twist for a stale operator."""
        dt, self._last_output = self.limiter.max_dt if self._last_output is None else now - self._last_output, now
        if not self.operator_fresh(now):
            return Command(self.limiter.stop(), 0.0, 'operator input stale')
        assert self._operator is not None
        operator = self._operator[0]
        if not self.enabled:
            self.limiter.last = operator.copy()
            return Command(operator.copy(), 0.0, 'assistance off')
        (alpha, phase), cfg, robot = self.alpha(), self.config, np.zeros(6)
        if alpha > 0.0:
            aim = self.target()  # one approach target for the agreement and the robot's twist
            if cfg.arbitration == 'confidence':
                alpha *= self._agree(operator, now, aim[0])
            idle = norm(operator[:3]) <= cfg.deadband_linear and norm(operator[3:]) <= cfg.deadband_angular
            if idle and not cfg.assist_without_input:
                alpha, phase = 0.0, 'no operator input'
            elif alpha > 0.0:
                twist, phase = self.robot(aim)
                if twist is not None and cfg.keep_pace:
                    twist = keep_pace(twist, operator, deadband_linear=cfg.deadband_linear,
                                      deadband_angular=cfg.deadband_angular)
                if twist is not None and cfg.robot_agreement:
                    alpha *= robot_agreement(operator, twist, deadband_linear=cfg.deadband_linear,
                                             deadband_angular=cfg.deadband_angular)
                alpha, robot, phase = (0.0, robot, 'seeking a path') if twist is None else (alpha, twist, phase)
            else:
                phase = 'yielded to the operator' if self.yielded else phase
        twist = self.limiter.limit(blend(alpha, robot, operator), dt)
        if self.clearance is not None and self.base_T_ee is not None and cfg.arbitration != 'none':
            twist = self.limiter.last = clearance_filter(self.clearance, self.base_T_ee, twist)  # the limiter's last
        return Command(twist.copy(), alpha, phase)

    def target(self) -> tuple[NDArray[np.float64], str]:
        """The grasp's approach target for the hand now, and its phase (:func:`assistance_target`); needs both poses."""
        cfg = self.config
        assert self.base_T_ee is not None and self.base_T_grasp is not None
        return assistance_target(self.base_T_ee, self.base_T_grasp, standoff=cfg.standoff,
                                 corridor_radius=cfg.corridor_radius, corridor_angle=cfg.corridor_angle)

    def robot(self, aim: tuple[NDArray[np.float64], str] | None = None) -> tuple[NDArray[np.float64] | None, str]:
        """The robot's twist (before blending) toward the grasp now, None while its path is sought, and its phase.

        ``aim``: :meth:`target`, when the caller has it.
        """
        target, phase = self.target() if aim is None else aim
        return self._robot_twist(target, phase), phase

    def _robot_twist(self, base_T_target: NDArray[np.float64], phase: str) -> NDArray[np.float64] | None:
        """The robot's twist toward ``base_T_target`` (the grasp or the pre-grasp, ``phase``; module docstring).

        None while its path is sought (``paths``).
        """
        cfg = self.config
        if self.paths is not None and self.q is not None and self._jacobian is not None:
            targets = self._q_targets  # set_grasp and set_object replace it
            entry = targets.get(phase)
            if entry is None or entry[0] != self._generation:
                answer = self.paths.seek(self.path_request(phase, base_T_target))
                if answer is not None and answer.key[0] == self._epoch and (entry is None or answer.key[1] > entry[0]):
                    entry = targets[phase] = (answer.key[1], answer.path)
                    if answer.cleared and answer.path is not None:
                        self._cleared[phase] = answer.path
                if entry is None:
                    return None
            path = entry[1]
            if path is not None:
                if len(path) > 1 and float(np.linalg.norm(path[0] - self.q)) <= VIA_REACHED:
                    path.pop(0)  # the via point reached: on to the target
                return joint_space_twist(self._jacobian, self.q, path[0], gain=cfg.gain_joint,
                                         max_linear=cfg.robot_max_linear, max_angular=cfg.robot_max_angular)
        assert self.base_T_ee is not None
        return robot_twist(self.base_T_ee, base_T_target, gain_linear=cfg.gain_linear, gain_angular=cfg.gain_angular,
                           max_linear=cfg.robot_max_linear, max_angular=cfg.robot_max_angular)

    def path_request(self, phase: str, base_T_target: NDArray[np.float64]) -> PathRequest:
        """The path search's snapshot for ``phase``'s target now: slack ``corridor_radius``, :meth:`_reference`."""
        assert self.q is not None and self.base_T_grasp is not None
        return PathRequest((self._epoch, self._generation, phase), self.q.copy(), base_T_target, self.base_T_grasp,
                           self.config.corridor_radius, self._reference(), self.clearance,
                           tuple(self._cleared.get(phase, ())))

    def _reference(self) -> float:
        """m: the hand's distance to the grasp when a path to this proposal was first sought (set_grasp resets)."""
        assert self.base_T_ee is not None and self.base_T_grasp is not None
        if self._path_reference is None:
            self._path_reference = float(np.linalg.norm(self.base_T_ee[:3, 3] - self.base_T_grasp[:3, 3]))
        return self._path_reference


def warm_up(assistance: Assistance) -> None:
    """One assisted command on a copy of ``assistance`` (needs ``kin``): its first calls paid before an output.

    At Home, toward a grasp 7 cm away with a cup below it: the kinematics, the Jacobian, arbitration, the joint
    path and its clearance run once (in this thread, whatever ``assistance.paths``). ``assistance`` is unchanged.
    """
    assert assistance.kin is not None
    warm = Assistance(assistance.config, TwistLimiter(1.0, 1.0, 1.0, 1.0), assistance.kin, assistance.hand)
    warm.set_joints(HOME_Q.copy())
    grasp, base_T_obj, body = warm_up_scene(assistance.kin)
    warm.set_grasp(grasp)
    warm.set_object(base_T_obj, body)
    labels = zone_labels(all_zones(3), default_task_names(3))
    warm.set_v(np.full(7, 1.0 / 7.0), labels)
    warm.set_posterior(np.full(7, 1.0 / 7.0), labels, default_task_names(3))
    warm.set_operator(np.r_[0.05, 0.0, -0.05, 0.0, 0.0, 0.0], 0.0)
    warm.command(0.0)
