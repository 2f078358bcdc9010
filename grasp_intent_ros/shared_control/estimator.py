r"""Intent from the operator's motion, ROS-free: operator twists -> a posterior over grasps -> task probabilities w.

The method (docs/intent_estimation.md states it in full, with what it assumes and what it cannot tell apart)
------------------------------------------------------------------------------------------------------------
**Goals.** Every labelled demonstration of the active model, placed at the object
(``base_T_g = base_T_obj @ features_to_obj_T_ee(x_g)``) and reachable by the arm, is a goal ``g`` serving
its task set ``S_g`` (:class:`.goals.Goals`, built in :mod:`.goals`). Only the pose is used: the finger closures,
which the motion of the hand does not show, are not.

**Prior.** Uniform over the task sets that some reachable goal serves, then uniform over the goals of a set:
``pi_g = 1 / (n_sets * n_{S_g})``.

**A classifier's w as the prior (optional):** :meth:`IntentEstimator.set_task_prior`, :mod:`.task_prior`.

**The approach.** An operator who wants goal g steers the hand to g's **approach target** for the hand's
present pose (:mod:`.approach`, the assistance's and the scripted operators' rule): g's pre-grasp
``p_g - standoff z_g`` (``z_g`` g's approach axis, the EE z axis; orientation ``R_g``) until the hand is in g's
approach corridor (within ``corridor_radius`` of ``p_g``, or behind it along ``z_g`` within ``corridor_radius``
of that axis and ``corridor_angle`` of ``R_g``), then g itself. Write ``t_g(p, R)`` for the target's position;
its orientation is always ``R_g``. ``standoff`` 0 heads straight for g.

**Evidence: progress toward each goal's approach target** (goal inference as in ADA's ``GoalPredictor``,
Javdani et al. 2015, and Dragan & Srinivasa 2013: an operator moves so as to reduce a cost-to-go to the goal,
and a motion's likelihood under goal g is ``exp(-beta (Q_g - V_g))``, here ``exp(beta * progress_g)``). The
cost-to-go is a Huber pose distance to the approach target,
``D_g = h(|t_g - p|) + rho * c(theta_g)``, ``theta_g`` the angle of ``R_g R^T``: ``h(e) = e^2 / (2 delta_p)``
below ``delta_p`` and ``e - delta_p / 2`` above; ``c(theta) = (1 - cos theta) / (2 sin(delta_theta / 2))``
below ``delta_theta`` and ``2 sin(theta / 2) - sin(delta_theta / 2)`` above (the chord, continuous with a
continuous slope). Its rate of decrease under the operator's twist
``(v, omega)`` (base frame, the hand at ``(p, R)``) is

.. math::

    s_g = v \cdot \frac{t_g - p}{\max(|t_g - p|, \delta_p)}
        + \rho\, \omega \cdot \frac{a_g}{4 \max(\sin(\theta_g / 2), \sin(\delta_\theta / 2))},
    \qquad a_g = \operatorname{vee}(R_g R^T - R R_g^T),

in m/s (:func:`progress_rates`; ``a_g = 2 sin(theta_g) axis_g``, so the rotation part is
``rho cos(theta_g / 2) omega . axis_g`` away from the goal: the rate at which the angle closes, weighted as
the chord ``2 sin(theta / 2)`` shrinks). It is bounded (by ``|v| + rho |omega|``) and defined for every
pose, the goal's own included. ``t_g`` is piecewise constant in the hand's pose (the pre-grasp or the goal), so
``s_g`` is the rate of decrease of ``D_g`` wherever the hand stays on one side of g's corridor boundary; on
the boundary ``D_g`` jumps (up by about ``standoff`` when the hand enters the corridor at the pre-grasp: the
target moves on to g) and ``s_g`` is the one-sided rate toward the target of the hand's present side. The
cost-to-go does not count the rest of the approach (pre-grasp to goal, ``standoff`` along the axis) before the
hand is in the corridor: it is the same for every goal and moves no goal's progress.

**Forgetting.** The log-evidence ``E_g`` (log posterior minus log prior, up to a constant) follows
``dE_g / dl = -E_g / L + beta s_g / u`` along the hand's pose path ``l`` (``u = |v| + rho |omega|`` its
rate), solved exactly over each operator twist held for ``dt`` seconds:

.. math::

    E_g \leftarrow \gamma\, E_g + \beta L (1 - \gamma)\, s_g / u, \qquad \gamma = \exp(-u\, dt / L),

(``beta s_g dt`` for a short step), so evidence fades with the operator's own motion (memory ``L`` metres of
pose motion), not with time: an operator who holds still or lets go keeps the estimate, and one who changes
their mind is followed after moving at most ``L ln 2`` toward the new goal's approach target (when the
targets lie farther apart than ``delta_p``). Since ``|s_g| <= u``, ``E_g`` stays within ``beta L`` in magnitude:
no goal's posterior runs to 0 or 1, which is what ADA's cap of 0.99 per goal does. The approach changes none of
this: the rule takes whatever ``s_g`` the targets give.

**The shown grasp.** The operator sees the planner's grasp (the proposal) and takes it for its own when its
own lies near it (within ``proposal_radius`` and ``proposal_angle``): it then heads for the proposal, whichever
of the goals near it it wants, by the approach (its pre-grasp, then the proposal). So while a proposal is
shown, every goal within those bounds of it is credited with the progress toward the proposal's approach
target (:meth:`IntentEstimator.set_proposal`; which goals are near it does not depend on the hand): following
the proposal raises the whole neighbourhood against the goals outside it, and tells the goals inside it apart only by
their prior (their differences fade with the memory). Why: the final approach to a proposal passes within
millimetres of other sets' goals; crediting each with its own progress there drives w to its bounds on the
fine motion, and the planner then proposes a neighbouring grasp that may miss a task the operator wants, which
the operator takes (docs/intent_estimation.md, the closed loop).

**At the shown grasp.** While the hand lies within ``position_scale`` and ``angle_scale`` of a shown grasp that
has a goal near it (:meth:`IntentEstimator.at_proposal`: the core of the distance to it, where its progress
fades to 0), a twist that does not move the hand away from it (progress toward it >= 0) is the operator placing
the hand on the grasp it took (there the approach target is the shown grasp itself when ``position_scale <=
corridor_radius``, as by default: the hand is then within the corridor's radius of it): no evidence, and the
evidence neither grows nor fades with it (the update changes nothing). A twist that moves the hand away from it
there (turning off it toward a goal elsewhere while the assistance holds the hand on it, or backing off) is
read as anywhere else. Why: there the progress toward the shown grasp, and so its neighbourhood's, fades to 0
while a goal outside the neighbourhood that lies on past it (a few cm on along the approach) gains the full
progress of the last corrections, which a reaction-delayed operator aims at a hand it saw a moment earlier: in
the last second w flipped to that goal's set and the planner proposed it. With the approach, such a goal gains
that progress only while the hand is in its corridor (within ``corridor_angle`` of its orientation, so at the
shown grasp one beyond ``proposal_radius`` of it rather than beyond ``proposal_angle``, or within
``corridor_radius`` of it); otherwise it steers to its pre-grasp, behind the hand, and loses on those
corrections. The rule is kept for the former.

**Task marginals.** ``P(g) = pi_g exp(E_g) / sum``; the task set posterior ``P(S) = sum_{S_g = S} P(g)``;
``p_i = sum_{S : i in S} P(S)``, clipped to ``[w_floor, 1 - w_floor]``, then calibrated (below) into ``w_i``.
The interpreter's eq. 3 rebuilds joint events from the marginals as if tasks were independent; the joint
``P(S)`` here is not (two exclusive alternatives U or H give ``w = (0.5, 0, 0.5)``, which eq. 3 reads as a
quarter each U, H, UH and no task): that correlation is what passing w loses.

**Calibration (optional; none by default).** ``w_i = sigma(a logit(p_i) + b)``, clipped again
(:mod:`.calibration`; ``calibration_slope`` a, ``calibration_offset`` b; 1 and 0: none, ``w_i = p_i``): a
monotone map of each marginal, the same for every task, fitted per model by the log loss of w on training
reaches against their true set. It changes how far w spreads, not the evidence: the goal and task set
posteriors, the order of the tasks' w and how fast a change of mind is followed stay as they are.
docs/intent_estimation.md says why no shipped model is mapped (the map calibrates w and closes the loop worse).

Contracts: every public function checks shapes and finiteness of what it is given and raises a
:class:`~grasp_intent_ros.errors.GraspIntentError` subclass; w is always finite and inside
``[w_floor, 1 - w_floor]``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError, KinematicsError
from ..method.intent import zone_label
from ..method.log_space import softmax
from ..mico.frames import PRE_GRASP_STANDOFF, check_transform, check_vector, rotation_angle, rotation_angles
from .approach import approach_positions
from .assistance_config import AssistanceConfig
from .calibration import calibrate
from .goals import Goals
from .task_prior import check_task_prior, task_log_prior

__all__ = ['EstimatorConfig', 'progress_rates', 'TwistTiming', 'Motion', 'checked_motion', 'IntentEstimator']


@dataclass(frozen=True)
class EstimatorConfig:
    """The estimator's constants (module docstring; units m, rad, s).

    Attributes
    ----------
    rationality : float
        beta, 1/m: log-likelihood per metre of progress toward a goal.
    memory : float
        L, m of pose motion over which the evidence fades by a factor e.
    rotation_length : float
        rho, m per rad: the length one radian of the hand's rotation counts as (the fingers' reach).
    position_scale, angle_scale : float
        delta_p (m), delta_theta (rad): below these distances to a goal the progress toward it fades
        linearly to 0 (the Huber distance's quadratic core).
    w_floor : float
        w is clipped to [w_floor, 1 - w_floor], in (0, 0.5).
    max_dt : float
        Longest time (s) one operator twist is taken to act (a gap in the stream is not motion).
    proposal_radius, proposal_angle : float
        m, rad: an operator takes a shown grasp (the planner's proposal) for its own when its own lies within
        these of it; while a proposal is shown, every goal within them of it is credited with the progress
        toward the proposal's approach target (:meth:`IntentEstimator.set_proposal`), and within ``position_scale`` and
        ``angle_scale`` of it motion that does not move away from it is no evidence
        (:meth:`IntentEstimator.at_proposal`). 0: proposals are ignored.
    standoff, corridor_radius, corridor_angle : float
        m, m, rad: the operator's approach (module docstring; :mod:`.approach`), by default the assistance's and
        the scripted operators'. ``standoff`` 0: the operator heads straight for each goal.
    calibration_slope, calibration_offset : float
        a (> 0) and b of the calibration map of each marginal, ``w_i <- sigmoid(a logit(w_i) + b)``
        (:mod:`.calibration`); 1 and 0: none.
    """

    rationality: float = 1000.0
    memory: float = 0.1
    rotation_length: float = 0.1
    position_scale: float = 0.02
    angle_scale: float = 0.2
    w_floor: float = 0.01
    max_dt: float = 0.1
    proposal_radius: float = 0.06
    proposal_angle: float = 0.8
    standoff: float = PRE_GRASP_STANDOFF
    corridor_radius: float = AssistanceConfig.corridor_radius
    corridor_angle: float = AssistanceConfig.corridor_angle
    calibration_slope: float = 1.0
    calibration_offset: float = 0.0

    def __post_init__(self) -> None:
        positive = {'rationality': self.rationality, 'memory': self.memory, 'rotation_length': self.rotation_length,
                    'position_scale': self.position_scale, 'angle_scale': self.angle_scale, 'max_dt': self.max_dt,
                    'calibration_slope': self.calibration_slope}
        bad = [f'{name} = {value!r}' for name, value in positive.items()
               if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0)]
        if not (isinstance(self.w_floor, (int, float)) and 0.0 < self.w_floor < 0.5):
            bad.append(f'w_floor = {self.w_floor!r} (must lie in (0, 0.5))')
        for name, value in (('proposal_radius', self.proposal_radius), ('proposal_angle', self.proposal_angle),
                            ('standoff', self.standoff), ('corridor_radius', self.corridor_radius),
                            ('corridor_angle', self.corridor_angle)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                bad.append(f'{name} = {value!r} (must be finite and >= 0)')
        if not (isinstance(self.calibration_offset, (int, float)) and math.isfinite(self.calibration_offset)):
            bad.append(f'calibration_offset = {self.calibration_offset!r} (must be finite)')
        if self.angle_scale > math.pi:
            bad.append(f'angle_scale = {self.angle_scale!r} (at most pi)')
        if bad:
            raise InvalidIntentError(f'estimator settings must be finite and positive: {", ".join(bad)}')


class TwistTiming:
    """How long each operator twist is taken to act: until the next one, so from the previous one to it.

    The difference of two successive twists' header stamps (s) when both are set: the operator's own timing,
    which delivery delays do not change; else of their arrival times (s, one clock); ``max_dt`` for the first
    twist. :meth:`IntentEstimator.update` clips it to [0, ``max_dt``].
    """

    def __init__(self) -> None:
        self.arrival: float | None = None
        """Arrival time (s) of the last twist; None before the first."""
        self.stamp: float | None = None
        """Its header stamp (s); None when unset."""

    def duration(self, stamp: float | None, arrival: float, max_dt: float) -> float:
        """The duration (s) of a twist stamped ``stamp`` (None: unset) that arrived at ``arrival`` (now the last)."""
        if stamp is not None and self.stamp is not None:
            dt = stamp - self.stamp
        else:
            dt = max_dt if self.arrival is None else arrival - self.arrival
        self.arrival, self.stamp = arrival, stamp
        return dt


def progress_rates(goals: Goals, base_T_ee: NDArray[np.float64], twist: NDArray[np.float64],
                   config: EstimatorConfig) -> NDArray[np.float64]:
    """s_g, the rate (m/s) at which the twist reduces the pose distance to each goal's approach target (module doc).

    The target is g's pre-grasp until the hand is in g's approach corridor, then g (:mod:`.approach`); ``s_g`` is the
    derivative of ``D_g`` where the hand stays on one side of g's corridor boundary (``D_g`` jumps on it).

    Parameters
    ----------
    goals : Goals
    base_T_ee : ndarray, shape (4, 4)
        The hand's pose (a rigid transform; not checked here).
    twist : ndarray, shape (6,)
        The operator's twist (m/s, rad/s), base frame, finite.
    config : EstimatorConfig

    Returns
    -------
    ndarray, shape (N,)
    """
    return _progress(_targets(goals.positions, goals.rotations, base_T_ee, config), goals.rotations, base_T_ee, twist,
                     config)


def _targets(positions: NDArray[np.float64], rotations: NDArray[np.float64], base_T_ee: NDArray[np.float64],
             config: EstimatorConfig) -> NDArray[np.float64]:
    """The approach targets' positions (N, 3) for goals at ``positions``, ``rotations`` (:mod:`.approach`)."""
    return approach_positions(base_T_ee, positions, rotations, standoff=config.standoff,
                              corridor_radius=config.corridor_radius, corridor_angle=config.corridor_angle)


def _progress(positions: NDArray[np.float64], rotations: NDArray[np.float64], base_T_ee: NDArray[np.float64],
              twist: NDArray[np.float64], config: EstimatorConfig) -> NDArray[np.float64]:
    """The progress rates toward fixed poses at ``positions`` (N, 3), ``rotations`` (N, 3, 3)."""
    offset = positions - base_T_ee[:3, 3]
    distance = np.sqrt(np.einsum('ni,ni->n', offset, offset))
    linear = (offset @ twist[:3]) / np.maximum(distance, config.position_scale)
    r_rel = rotations @ base_T_ee[:3, :3].T  # R_g R^T, (N, 3, 3)
    a = np.stack([r_rel[:, 2, 1] - r_rel[:, 1, 2], r_rel[:, 0, 2] - r_rel[:, 2, 0],
                  r_rel[:, 1, 0] - r_rel[:, 0, 1]], axis=1)
    trace = r_rel[:, 0, 0] + r_rel[:, 1, 1] + r_rel[:, 2, 2]
    half_sin = np.sqrt(np.clip(0.25 * (3.0 - trace), 0.0, 1.0))  # sin(theta / 2)
    angular = (a @ twist[3:]) / (4.0 * np.maximum(half_sin, math.sin(0.5 * config.angle_scale)))
    out: NDArray[np.float64] = linear + config.rotation_length * angular
    return out


@dataclass(frozen=True)
class Motion:
    """One operator twist held for a time, as the evidence takes it (module docstring, "Forgetting").

    Attributes
    ----------
    unit : ndarray, shape (6,)
        The twist's direction: the twist divided by its largest absolute component (base frame).
    unit_speed : float
        u of ``unit``: ``|v| + rho |omega|`` (> 0).
    fade : float
        ``1 - gamma``, the share of the evidence the motion forgets, in (0, 1].
    """

    unit: NDArray[np.float64]
    unit_speed: float
    fade: float


def checked_motion(base_T_ee: ArrayLike, twist: ArrayLike, dt: float,
                   config: EstimatorConfig) -> tuple[NDArray[np.float64], Motion | None]:
    """The hand's pose (4x4, checked) and the motion of ``twist`` held for ``dt`` s, None when it is no motion.

    ``dt`` is clipped to [0, ``max_dt``]; a zero twist or ``dt`` is no motion. Any finite twist is taken: only its
    direction and the motion ``u dt`` matter, computed without overflow. Raises KinematicsError for a malformed
    pose, twist or ``dt``.
    """
    hand = check_transform(base_T_ee, 'base_T_ee')
    xi = check_vector(twist, 6, 'twist')
    if not math.isfinite(dt):
        raise KinematicsError(f'dt must be finite, got {dt!r}')
    dt = min(max(dt, 0.0), config.max_dt)
    size = float(np.max(np.abs(xi)))
    if size == 0.0 or dt == 0.0:
        return hand, None
    unit = xi / size
    unit_speed = float(np.linalg.norm(unit[:3])) + config.rotation_length * float(np.linalg.norm(unit[3:]))
    fade = -math.expm1(-(size * dt) * unit_speed / config.memory)  # 1 - gamma; 1 when u dt overflows
    return hand, Motion(unit, unit_speed, fade)


class IntentEstimator:
    """The posterior over ``goals`` from a stream of operator twists, and the task marginals w (module docstring).

    Parameters
    ----------
    goals : Goals
    config : EstimatorConfig
    proposal : array_like, shape (4, 4), optional
        The grasp shown now (:meth:`set_proposal`).
    """

    def __init__(self, goals: Goals, config: EstimatorConfig = EstimatorConfig(),
                 proposal: ArrayLike | None = None) -> None:
        self.goals, self.config = goals, config
        self.evidence = np.zeros(len(goals))
        """E_g, the log-evidence of each goal (0: the prior)."""
        self.log_prior = goals.log_prior
        """log pi_g: the goals' default prior, or the one :meth:`set_task_prior` set."""
        self.task_prior: NDArray[np.float64] | None = None
        """The classifier's w the prior was set from (clipped), or None for the default prior."""
        self.updates = 0
        self._proposal: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]] | None = None
        self.set_proposal(proposal)

    def reset(self) -> None:
        """Back to the prior (a new scene); the proposal is forgotten, a classifier's prior is kept."""
        self.evidence = np.zeros(len(self.goals))
        self.updates = 0
        self._proposal = None

    def set_task_prior(self, w: ArrayLike | None) -> None:
        """The prior from a classifier's task probabilities ``w`` (shape (m,), in [0, 1]), None for the default.

        :func:`.task_prior.task_log_prior`, ``w`` clipped to ``[w_floor, 1 - w_floor]``. The evidence is kept: the
        posterior changes at once. Raises InvalidIntentError for a w of another length than the goals' tasks, or
        with a value outside [0, 1] or not finite (the prior is then unchanged).
        """
        if w is None:
            self.log_prior, self.task_prior = self.goals.log_prior, None
            return
        clipped = np.clip(check_task_prior(w, self.goals.n_tasks), self.config.w_floor, 1.0 - self.config.w_floor)
        self.log_prior = task_log_prior(self.goals.task_sets, self.goals.membership, clipped)
        self.task_prior = clipped

    def set_proposal(self, base_T_grasp: ArrayLike | None) -> None:
        """The grasp shown to the operator now (4x4, base frame), None for none (module docstring).

        Raises KinematicsError for a pose that is not a rigid transform (the proposal is then unchanged).
        """
        if base_T_grasp is None:
            self._proposal = None
            return
        pose = check_transform(base_T_grasp, 'base_T_grasp')
        cfg = self.config
        if cfg.proposal_radius == 0.0 or cfg.proposal_angle == 0.0:  # the shown grasp is ignored
            self._proposal = None
            return
        offset = self.goals.positions - pose[:3, 3]
        near = np.sqrt(np.einsum('ni,ni->n', offset, offset)) <= cfg.proposal_radius
        near &= rotation_angles(self.goals.rotations, pose[:3, :3]) <= cfg.proposal_angle
        self._proposal = (pose[None, :3, 3].copy(), pose[None, :3, :3].copy(), near)

    def at_proposal(self, base_T_ee: NDArray[np.float64]) -> bool:
        """Whether the hand is in the core of the distance to the shown grasp (module docstring).

        True when a grasp is shown, some goal lies near it, and ``base_T_ee`` (4x4, not checked here) is within
        ``position_scale`` and ``angle_scale`` of it.
        """
        if self._proposal is None or not self._proposal[2].any():
            return False
        position, rotation, _ = self._proposal
        offset = position[0] - base_T_ee[:3, 3]
        return (float(np.sqrt(offset @ offset)) <= self.config.position_scale
                and rotation_angle(rotation[0], base_T_ee[:3, :3]) <= self.config.angle_scale)

    def update(self, base_T_ee: ArrayLike, twist: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Take one operator twist held for ``dt`` s with the hand at ``base_T_ee``; returns the new w.

        ``dt`` is clipped to [0, ``max_dt``]; any finite twist is taken (its size enters only through the
        motion ``u dt``); with the hand at the shown grasp (:meth:`at_proposal`) a twist that does not move it away
        from it changes nothing. Raises KinematicsError for a malformed pose, twist or ``dt`` (the estimate is then
        unchanged).
        """
        hand, motion = checked_motion(base_T_ee, twist, dt, self.config)
        self.updates += 1
        if motion is None:
            return self.w
        shown = self.shown_progress(hand, motion)
        if self.placing(hand, shown):
            return self.w  # placing the hand on the shown grasp: no evidence (module docstring)
        self.take(hand, motion, shown)
        return self.w

    def shown_progress(self, base_T_ee: NDArray[np.float64], motion: Motion) -> float | None:
        """The progress rate of ``motion.unit`` toward the shown grasp's approach target (:func:`progress_rates`).

        None when no grasp with a goal near it is shown. ``base_T_ee``: the hand, 4x4, checked by the caller.
        """
        proposal = self._proposal
        if proposal is None or not proposal[2].any():
            return None
        return float(_progress(_targets(proposal[0], proposal[1], base_T_ee, self.config), proposal[1], base_T_ee,
                               motion.unit, self.config)[0])

    def placing(self, base_T_ee: NDArray[np.float64], shown: float | None) -> bool:
        """Whether a motion of progress ``shown`` (:meth:`shown_progress`) places the hand on the shown grasp.

        True when it does not move the hand away from the grasp, the hand in its core (:meth:`at_proposal`): such
        a motion is no evidence (module docstring, "At the shown grasp").
        """
        return shown is not None and shown >= 0.0 and self.at_proposal(base_T_ee)

    def take(self, base_T_ee: NDArray[np.float64], motion: Motion, shown: float | None) -> None:
        """The evidence step of ``motion`` with the hand at ``base_T_ee`` (module docstring, "Forgetting").

        The goals near the shown grasp are credited with ``shown`` (:meth:`shown_progress`). Neither the placing test
        (:meth:`placing`, the caller's) nor the update count.
        """
        rates = progress_rates(self.goals, base_T_ee, motion.unit, self.config) / motion.unit_speed  # s_g / u: [-1, 1]
        if shown is not None:
            assert self._proposal is not None
            rates[self._proposal[2]] = shown / motion.unit_speed
        # the exact solution over the step of dE/dl = -E / L + beta s / u (l the pose path): |E| <= beta L
        cfg = self.config
        self.evidence = (1.0 - motion.fade) * self.evidence + (cfg.rationality * cfg.memory * motion.fade) * rates

    @property
    def posterior(self) -> NDArray[np.float64]:
        """P(g), shape (N,): the prior times exp(E_g), normalised."""
        return softmax(self.log_prior + self.evidence)

    @property
    def w(self) -> NDArray[np.float64]:
        """The task marginals, calibrated (module docstring), shape (m,), in [w_floor, 1 - w_floor]."""
        cfg = self.config
        return calibrate(self.posterior @ self.goals.membership, cfg.calibration_slope, cfg.calibration_offset,
                         cfg.w_floor)

    def set_posterior(self) -> dict[int, float]:
        """P(S) per task set served by some goal (bitmask -> probability)."""
        return self.goals.set_posterior(self.posterior)

    def likely_sets(self, task_names: Sequence[str], count: int = 3) -> str:
        """The ``count`` likeliest task sets as 'label: P(S)' (ties: the smaller bitmask first), for a status."""
        top = sorted(self.set_posterior().items(), key=lambda item: (-item[1], item[0]))[:count]
        return ', '.join(f'{zone_label(s, task_names)}: {p:.2f}' for s, p in top)

