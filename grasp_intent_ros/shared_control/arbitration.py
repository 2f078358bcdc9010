r"""Arbitration, ROS-free: how much of the command the robot gets, alpha, from the grasp and the operator's twist.

The command blends the robot's twist r and the operator's h as ``u = alpha r + (1 - alpha) h``
(:mod:`.assistance`); this module is the rule for alpha (:func:`arbitration`) and the evidence it weighs.

Alpha from the probability that the grasp serves the operator's task
--------------------------------------------------------------------
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
  the pose error toward the grasp's approach target (:func:`~.robot_twist.assistance_target`: its pre-grasp out
  of the corridor, then itself; the grasp's orientation either way) (:func:`operator_agreement`,
  :func:`approach_agreement`): the share of the operator's motion toward the grasp by its approach, so the
  robot's share falls as fast as the operator turns away from it (a changed goal: 0.5 at 60 degrees, 0.17 at
  80, 0 from right angles on). Each is as last measured while the operator moved that part faster than its
  deadband (1 before; :class:`~.assistance.Assistance` holds them, and forgets them when the planned grasp
  moves by more than the corridor's radius or angle, :func:`new_proposal`). The target is the pose the
  operators and the intent estimator steer to (:mod:`.approach`): near the pre-grasp the grasp lies at any
  angle to the way in, and a held linear agreement would starve a two-mode operator's rotation.

``'blend'`` (a baseline after ADA's blend: alpha = alpha_max when v's top zone leads the second by at
least ``margin``, else 0). ``'none'``: alpha = 0 (direct teleoperation). Neither looks at the operator's
input. Whatever the rule, alpha is 0 without a valid grasp, while a clarification is pending, or without
the arm's joint state: :class:`~.assistance.Assistance` decides that.

alpha is therefore in [0, alpha_max] for every rule: 0 means the operator's twist alone, alpha_max (< 1 by
default) the most the robot ever gets, so the operator always keeps 1 - alpha_max of the command.

**Agreeing with the robot's twist** (``robot_agreement``, off by default; :func:`robot_agreement`). A remedy for
the robot's twist running against the operator's (:mod:`.robot_twist`, "Keeping the operator's pace"): alpha is
also multiplied by the operator's agreement with the robot's own twist (per part max(cos, 0), faded out below the
deadbands; the smaller part's), so where the robot's twist runs against the operator's the operator moves alone at
full speed, and where it goes the operator's way the robot helps.

**The part the operator leaves idle** (``assist_idle_part``, on by default; :func:`part_shares`). A two-mode
device (a joystick that translates or rotates, never both) leaves one part at zero while it moves the other. There
the blend has nothing to weigh: ``alpha r + (1 - alpha) 0`` only slows the robot. With ``assist_idle_part`` the
robot's share in a part the operator leaves within its deadband, while it moves the other, is ``alpha_max``
whenever alpha > 0 (the robot assists at all: not yielded, a grasp, an intent); in the part the operator moves it
stays alpha. The operator takes the idle part back by moving it (its agreement is measured there, and opposition
yields as ever); no input at all is still no motion.
"""

from __future__ import annotations

import typing
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.intent import parse_zones
from ..mico.frames import pose_error
from ..planning.ranking import expected_success
from .limits import clip_norm, norm

if TYPE_CHECKING:
    from .assistance_config import AssistanceConfig

__all__ = ['Arbitration', 'ARBITRATIONS', 'serving_probability', 'ServingMemo', 'grasp_task_set', 'arbitration',
           'part_shares', 'operator_agreement', 'robot_agreement', 'approach_agreement', 'new_proposal']

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


class ServingMemo:
    """:func:`serving_probability` of the newest inputs, computed again only when an input changed.

    The assistance asks at every output, and its inputs change with each plan (every 0.1 s): the answer is kept
    with its inputs (the arrays' dtype, shape and bytes; the label sequences, the task names and the task set as
    tuples) and returned while a call's inputs equal them, bit for bit: the function is pure, so a kept answer is
    the one it would compute again. One entry: a changed input replaces it.
    """

    def __init__(self) -> None:
        self._key: tuple[object, ...] | None = None
        self._value = 0.0

    def __call__(self, v: NDArray[np.float64], v_labels: Sequence[str], task_names: Sequence[str], *,
                 task_set: int | None, posterior: NDArray[np.float64], zone_labels: Sequence[str]) -> float:
        """:func:`serving_probability` (its arguments), kept for the next call with the same inputs."""
        key = (*_array_key(v), tuple(v_labels), tuple(task_names), task_set, *_array_key(posterior),
               tuple(zone_labels))
        if key != self._key:
            self._value = serving_probability(v, v_labels, task_names, task_set=task_set, posterior=posterior,
                                              zone_labels=zone_labels)
            self._key = key
        return self._value


def _array_key(x: ArrayLike) -> tuple[str, tuple[int, ...], bytes]:
    """An array's dtype, shape and bytes: equal for two arrays exactly when they hold the same numbers, bit for bit."""
    array = np.asarray(x)
    return array.dtype.str, array.shape, array.tobytes()


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


def part_shares(alpha: float, operator: NDArray[np.float64], *, alpha_max: float, deadband_linear: float,
                deadband_angular: float) -> NDArray[np.float64]:
    """The robot's share of each component of the command under ``assist_idle_part`` (module docstring); shape (6,).

    ``alpha`` in the components of a part (linear, angular) the operator moves faster than its deadband (m/s,
    rad/s); ``alpha_max`` in those of a part it leaves within it while it moves the other, when ``alpha`` > 0.
    ``alpha`` everywhere when ``alpha`` is 0 or the operator moves both parts or neither.
    """
    idle = (norm(operator[:3]) <= deadband_linear, norm(operator[3:]) <= deadband_angular)
    shares = np.full(6, alpha)
    if alpha > 0.0 and idle[0] != idle[1]:
        shares[slice(0, 3) if idle[0] else slice(3, 6)] = alpha_max
    return shares


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
