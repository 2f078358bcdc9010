r"""Shared control, ROS-free: the operator's twist blended with the robot's toward the planned grasp, within limits.

Policy blending (Dragan & Srinivasa, "A policy-blending formalism for shared control", 2013): the command is

.. math::

    u = \alpha\, r + (1 - \alpha)\, h,

``h`` the operator's twist, ``r`` the robot's twist toward the planned grasp (:mod:`.robot_twist`), ``alpha`` in
[0, 1] the arbitration weight (:mod:`.arbitration`). Twists are 6-vectors (linear m/s, angular rad/s) of the end
effector (EE) in the base frame; the linear part is the velocity of the EE origin. :class:`Assistance` holds the
loop's newest inputs and composes these into the command; its settings are
:class:`~.assistance_config.AssistanceConfig`.

**The operator wins** (:class:`Assistance`). With the ``'confidence'`` rule, a part more than pi / 3 off the
approach target (the operator's agreement o < 0.5, :func:`~.arbitration.approach_agreement`) is opposition.
Opposition sustained for ``yield_time`` makes the robot yield: alpha = 0 for this grasp until the operator heads
toward it again (every measured part within pi / 3, o >= 0.5) for ``yield_time``, or a new grasp is planned. While
the operator gives no input (both parts within their deadbands) the output is the operator's twist (the robot does
not move the hand on its own) unless ``assist_without_input``. Assistance switched off (:attr:`Assistance.enabled`
False) gives the operator's twist exactly.

Limits (:class:`~.limits.TwistLimiter`)
---------------------------------------
The blended twist's linear and angular parts are scaled down to their speed limits, then each part's
change since the last output is scaled down to acceleration limit times the elapsed time. A stale operator
input (older than the timeout) gives the zero twist at once, without the acceleration limit: a stop. Last, given the
object as perceived (set_object) and a rule but 'none', the hand is kept out of it (:func:`~.barrier.clearance_filter`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..method.body import ObjectBody
from ..method.intent import all_zones, default_task_names, zone_labels
from ..mico.collision import HandCollision
from ..mico.kinematics import HOME_Q, MicoKinematics
from .arbitration import ServingMemo, approach_agreement, arbitration, new_proposal, part_shares, robot_agreement
from .assistance_config import AssistanceConfig
from .barrier import clearance_filter
from .clearance import PathClearance, default_hand
from .joint_path import VIA_REACHED
from .limits import TwistLimiter, norm
from .path_search import PathRequest, PathSearch, PathSource, warm_up_scene
from .robot_twist import assistance_target, joint_space_twist, keep_pace, robot_twist

__all__ = ['blend', 'Command', 'Assistance', 'warm_up']


def blend(alpha: float | NDArray[np.float64], robot: NDArray[np.float64],
          operator: NDArray[np.float64]) -> NDArray[np.float64]:
    """The blended twist alpha * robot + (1 - alpha) * operator (alpha a number, or one share per component)."""
    return alpha * robot + (1.0 - alpha) * operator


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
    (:mod:`.robot_twist`); without it, from ``base_T_ee`` and the twist is Cartesian. ``hand``: :meth:`set_object`'s.
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
        """The operator's held agreement with the grasp's approach target, linear and angular (:mod:`.arbitration`)."""
        self.yielded = False
        """Whether the robot yields to the operator's sustained opposition (alpha 0) for this grasp."""
        self._since: float | None = None
        """When the operator's current opposition (or, yielded, agreement) began."""
        self._task_set: int | None = None
        self._posterior: tuple[NDArray[np.float64], tuple[str, ...], tuple[str, ...]] | None = None
        self._v: tuple[NDArray[np.float64], tuple[str, ...]] | None = None
        self._operator: tuple[NDArray[np.float64], float] | None = None
        self._last_output: float | None = None
        self._serving = ServingMemo()

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None:
        """A new planned grasp: valid from now on, and it answers any clarification pending.

        A grasp that moved by more than the corridor's radius or angle is a new proposal: the operator's held
        agreement (:mod:`.arbitration`) and the robot's yielding (module docstring) start afresh. The paths are
        sought again; a grasp bit-identical to the current one (the planner's same plan, sent again) keeps them in
        use meanwhile.
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
        """P(the planned grasp serves T | w) now, 0 without v or a posterior.

        :func:`~.arbitration.serving_probability` of the latest v, posterior and task set.
        """
        if self._v is None or self._posterior is None:
            return 0.0
        posterior, zone_labels, task_names = self._posterior
        v, labels = self._v
        return self._serving(v, labels, task_names, task_set=self._task_set, posterior=posterior,
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
        shares = (part_shares(alpha, operator, alpha_max=cfg.alpha_max, deadband_linear=cfg.deadband_linear,
                              deadband_angular=cfg.deadband_angular) if cfg.assist_idle_part else alpha)
        twist = self.limiter.limit(blend(shares, robot, operator), dt)
        if self.clearance is not None and self.base_T_ee is not None and cfg.arbitration != 'none':
            twist = self.limiter.last = clearance_filter(self.clearance, self.base_T_ee, twist)  # the limiter's last
        return Command(twist.copy(), alpha, phase)

    def target(self) -> tuple[NDArray[np.float64], str]:
        """The grasp's approach target for the hand now and its phase (:func:`~.robot_twist.assistance_target`).

        Needs both poses (the hand's and the grasp's).
        """
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
        """The robot's twist toward ``base_T_target`` (the grasp or the pre-grasp, ``phase``; :mod:`.robot_twist`).

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
                                         max_linear=cfg.robot_max_linear, max_angular=cfg.robot_max_angular,
                                         whole=cfg.keep_joint_line)
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
