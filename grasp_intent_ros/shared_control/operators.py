r"""Scripted teleoperators and their intents: stated models that never read an object's task rules.

An operator is an intent script (what it wants, over time: its true task set T and the w an intent estimator
reports) and a device model (how it moves the hand toward the grasp it pursues). Both are seeded; an intent
estimator under test (or the benchmarks) can reuse them.

Intents (:class:`IntentScript`: ``task_set(t)``, ``w(t, rng)``)
---------------------------------------------------------------
- :class:`PersistentIntent`: the estimator's w held at one case (e.g. the paper's (0.9, 0.9, 0.1)) with
  N(0, ``noise``^2) per task and report, clipped to [0.02, 0.98]; T drawn from the case under the
  independent-task model (task i with probability w_i, redrawn until not empty).
- :class:`SharpeningIntent`: a prior w0 ~ U(0.2, 0.8)^3, T drawn from it, w moving linearly from w0 to the
  certain w_T (0.95 on T, 0.05 elsewhere) over ``sharpen`` s, noise N(0, (0.08 (1 - s))^2).
- :class:`ChangingIntent`: a persistent intent whose true set changes once, at ``t_change``, to another set
  T2; the estimator's w follows ``delay`` s later (then the certain w_T2 with the same noise).

Goals (:class:`ScriptedOperator`)
---------------------------------
The operator's own goal for T is a grasp it picks without the rules (the caller gives it: the benchmark
uses the planner's grasp for the certain w_T). It follows the *shown* grasp (the planner's, on the screen)
when that is on its way, i.e. within ``accept_position`` and ``accept_angle`` of its own goal (it looks like
the grasp it wanted), else drives to its own goal. It closes the hand (the grasp command) once the hand it
sees is within :data:`~grasp_intent_ros.mico.frames.REACH_POS` / ``REACH_ROT`` of the goal it
pursues.

The approach (:meth:`ScriptedOperator.approach_target`)
-------------------------------------------------------
A person reaching for a grasp does not push the object over: it brings the open hand in front of the grasp,
lined up with it, then moves it in along the hand's approach axis (the approach that the planner's collision
check clears, :mod:`~grasp_intent_ros.mico.collision`, and the assistance takes). So the
operator steers to the goal's **pre-grasp**, the goal moved back by ``standoff`` along its approach axis (the
EE z axis; default :data:`~grasp_intent_ros.mico.frames.PRE_GRASP_STANDOFF`, the assistance's), until the hand
it sees is **in the approach corridor**, then to the goal itself. The corridor is the assistance's
(:func:`~.robot_twist.assistance_target`, with ``corridor_radius`` and ``corridor_angle``, by default the
assistance's): the hand is within ``corridor_radius`` of the goal, or behind it along the approach axis,
within ``corridor_radius`` of that axis and within ``corridor_angle`` of the goal's orientation. The rule holds
no state: a hand that leaves the corridor (a new goal, noise) is steered to the pre-grasp again. ``standoff``
0 steers straight at the goal (the pre-grasp is the goal). Why the model needs the rule: the simulation has no
contact, so a hand steered straight at the goal passes through the object's side when the line crosses it, or
(the joystick: translation, then rotation) turns through the object at the goal, which a real hand cannot.

Devices (:meth:`ScriptedOperator.twist`)
----------------------------------------
The hand and the shown grasp are perceived ``reaction`` s late. The command is proportional to the pose
error toward the pose steered to (the approach's; gain ``gain`` 1/s), each part limited to ``max_linear`` /
``max_angular``, plus Ornstein-Uhlenbeck noise (time constant ``noise_tau``; ``noise_linear`` m/s,
``noise_angular`` rad/s) on the parts moved:

- ``'joystick'``: two modes, as in ADA's studies: translation (3 axes) or rotation (3 axes), never both;
  switching costs ``switch_time`` of no input. It translates until within ``translate_until`` of that pose,
  then rotates until within 0.6 ``rotate_until``, back to translation beyond ``back_to_translation``.
- ``'spacemouse'``: six axes at once, both parts every tick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from ..mico.frames import PRE_GRASP_STANDOFF, offset, pose_error, reached
from .assistance_config import AssistanceConfig
from .limits import clip_norm
from .robot_twist import assistance_target

__all__ = ['Device', 'DEVICES', 'AMBIGUOUS_CASES', 'IntentScript', 'PersistentIntent', 'SharpeningIntent',
           'ChangingIntent', 'certain_w', 'draw_task_set', 'OperatorConstants', 'ScriptedOperator']

Device = Literal['joystick', 'spacemouse']
DEVICES: tuple[Device, ...] = ('joystick', 'spacemouse')

AMBIGUOUS_CASES: tuple[tuple[float, float, float], ...] = (
    (0.9, 0.9, 0.1), (0.9, 0.1, 0.9), (0.1, 0.9, 0.9), (0.9, 0.5, 0.5), (0.7, 0.7, 0.7))
"""The paper's ambiguous intents over (usage, transfer, handover) that a :class:`PersistentIntent` holds in the
closed-loop benchmarks (:meth:`PersistentIntent.draw`: episode i on case i mod 5)."""


def certain_w(task_set: int, m: int = 3) -> NDArray[np.float64]:
    """The w of an estimator certain of ``task_set`` (bitmask): 0.95 on its tasks, 0.05 elsewhere."""
    return np.array([0.95 if task_set >> i & 1 else 0.05 for i in range(m)])


def draw_task_set(w: NDArray[np.float64], rng: np.random.Generator) -> int:
    """A task set drawn under the independent-task model (task i with probability w_i), redrawn until not empty."""
    task_set = 0
    while not task_set:
        task_set = sum(1 << i for i in range(w.size) if rng.uniform() < w[i])
    return task_set


class IntentScript(Protocol):
    """What an operator wants at time t (s from the episode's start) and what the estimator reports."""

    def task_set(self, t: float) -> int:
        """The operator's true task set (bitmask) at ``t``."""

    def w(self, t: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """The estimator's report at ``t`` (noise from ``rng``)."""


@dataclass(frozen=True)
class PersistentIntent:
    """w held at ``case`` with noise; true set ``true_set`` (module docstring)."""

    case: tuple[float, ...]
    true_set: int
    noise: float = 0.05

    @classmethod
    def draw(cls, index: int, rng: np.random.Generator) -> PersistentIntent:
        """Episode ``index``'s intent: the case :data:`AMBIGUOUS_CASES` [index mod 5], T drawn from it with ``rng``."""
        case = AMBIGUOUS_CASES[index % len(AMBIGUOUS_CASES)]
        return cls(case, draw_task_set(np.asarray(case), rng))

    def task_set(self, t: float) -> int:
        return self.true_set

    def w(self, t: float, rng: np.random.Generator) -> NDArray[np.float64]:
        return np.clip(np.asarray(self.case) + rng.normal(0.0, self.noise, len(self.case)), 0.02, 0.98)


@dataclass(frozen=True)
class SharpeningIntent:
    """w sharpening from ``w0`` to the certain w of ``true_set`` over ``sharpen`` s (module docstring)."""

    w0: tuple[float, ...]
    true_set: int
    sharpen: float

    @classmethod
    def draw(cls, rng: np.random.Generator) -> SharpeningIntent:
        """One operator's intent over three tasks: w0 ~ U(0.2, 0.8)^3, T drawn from it, ``sharpen`` ~ U(1.5, 4) s.

        The draws come from ``rng`` in that order (the benchmarks' seeded operators depend on it).
        """
        w0 = rng.uniform(0.2, 0.8, 3)
        return cls(tuple(w0.tolist()), draw_task_set(w0, rng), float(rng.uniform(1.5, 4.0)))

    def task_set(self, t: float) -> int:
        return self.true_set

    def w(self, t: float, rng: np.random.Generator) -> NDArray[np.float64]:
        s = min(max(t / self.sharpen, 0.0), 1.0)
        w = (1.0 - s) * np.asarray(self.w0) + s * certain_w(self.true_set, len(self.w0))
        return np.clip(w + rng.normal(0.0, 0.08 * (1.0 - s), len(self.w0)), 0.02, 0.98)


@dataclass(frozen=True)
class ChangingIntent:
    """``before`` until ``t_change``, then ``after_set``; w follows ``delay`` s later (module docstring)."""

    before: PersistentIntent
    after_set: int
    t_change: float
    delay: float = 1.0

    def task_set(self, t: float) -> int:
        return self.after_set if t >= self.t_change else self.before.task_set(t)

    def w(self, t: float, rng: np.random.Generator) -> NDArray[np.float64]:
        if t < self.t_change + self.delay:
            return self.before.w(t, rng)
        m = len(self.before.case)
        return np.clip(certain_w(self.after_set, m) + rng.normal(0.0, self.before.noise, m), 0.02, 0.98)


@dataclass(frozen=True)
class OperatorConstants:
    """The scripted operator's constants (module docstring; m, rad, s)."""

    max_linear: float = 0.12
    max_angular: float = 0.6
    gain: float = 1.5
    reaction: float = 0.25
    noise_linear: float = 0.01
    noise_angular: float = 0.05
    noise_tau: float = 0.3
    switch_time: float = 0.5
    translate_until: float = 0.03
    rotate_until: float = 0.05
    back_to_translation: float = 0.06
    accept_position: float = 0.06
    accept_angle: float = 0.8
    standoff: float = PRE_GRASP_STANDOFF
    corridor_radius: float = AssistanceConfig.corridor_radius
    corridor_angle: float = AssistanceConfig.corridor_angle


class ScriptedOperator:
    """One operator's device and goal choice (module docstring); ``rng`` drives its noise.

    Parameters
    ----------
    device : 'joystick' or 'spacemouse'
    constants : OperatorConstants
    rng : numpy Generator
    period : float
        Seconds between two calls of :meth:`twist`.
    """

    def __init__(self, device: Device, constants: OperatorConstants, rng: np.random.Generator,
                 period: float = 0.01) -> None:
        self.device, self.c, self.rng, self.period = device, constants, rng, period
        self.mode = 'translate'
        self._switching_until = -math.inf
        self._noise = np.zeros(6)
        self._decay = math.exp(-period / constants.noise_tau)
        self._scale = math.sqrt(1.0 - self._decay**2)

    def choose_goal(self, shown: NDArray[np.float64] | None, own: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                                                 str]:
        """The goal pursued: ``shown`` when it is on the way (near ``own``), else ``own``; with 'shown'/'own'."""
        if shown is not None:
            distance, angle = offset(own, shown)
            if distance <= self.c.accept_position and angle <= self.c.accept_angle:
                return shown, 'shown'
        return own, 'own'

    def at_goal(self, hand: NDArray[np.float64], goal: NDArray[np.float64]) -> bool:
        """Whether the operator closes the hand: the hand it sees is at the goal it pursues."""
        return reached(hand, goal)

    def approach_target(self, hand: NDArray[np.float64], goal: NDArray[np.float64]) -> NDArray[np.float64]:
        """The pose (4x4, base frame) steered to for ``goal`` with the seen ``hand`` (module docstring, the approach).

        ``goal``'s pre-grasp (``standoff`` back along its approach axis) until ``hand`` is in the approach
        corridor (within ``corridor_radius`` of ``goal``, or behind it within ``corridor_radius`` of its approach
        axis and ``corridor_angle`` of its orientation), then ``goal``.
        """
        c = self.c
        target, _ = assistance_target(hand, goal, standoff=c.standoff, corridor_radius=c.corridor_radius,
                                      corridor_angle=c.corridor_angle)
        return target

    def twist(self, now: float, hand: NDArray[np.float64] | None, goal: NDArray[np.float64]) -> NDArray[np.float64]:
        """The device's twist (shape (6,), base frame) at ``now`` for the seen ``hand`` and ``goal`` (4x4 each).

        The twist steers to :meth:`approach_target` (the pre-grasp, then ``goal``). ``hand`` None: the operator
        has not seen the hand yet (the first reaction time); the twist is zero, and the device's noise still
        advances, so the draws do not depend on when the hand is first seen.
        """
        c = self.c
        sigma = np.r_[[c.noise_linear] * 3, [c.noise_angular] * 3]
        self._noise = self._decay * self._noise + self._scale * self.rng.normal(0.0, 1.0, 6) * sigma
        if hand is None:
            return np.zeros(6)
        error = pose_error(hand, self.approach_target(hand, goal))
        linear = clip_norm(c.gain * error[:3], c.max_linear)
        angular = clip_norm(c.gain * error[3:], c.max_angular)
        command = np.zeros(6)
        if self.device == 'spacemouse':
            return np.concatenate([linear, angular]) + self._noise
        if now < self._switching_until:
            return command
        distance, angle = float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))
        wanted = self.mode
        if self.mode == 'translate' and distance < c.translate_until and angle > c.rotate_until:
            wanted = 'rotate'
        elif self.mode == 'rotate' and (angle < 0.6 * c.rotate_until or distance > c.back_to_translation):
            wanted = 'translate'
        if wanted != self.mode:
            self.mode, self._switching_until = wanted, now + c.switch_time
        elif self.mode == 'translate':
            command[:3] = linear + self._noise[:3]
        else:
            command[3:] = angular + self._noise[3:]
        return command
