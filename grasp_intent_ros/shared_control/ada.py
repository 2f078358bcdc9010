"""ADA's shared autonomy as published, the simulated closed loop's baseline (ROS-free).

Javdani et al.; personalrobotics/ada_assistance_policy; :mod:`.simulator`, condition ``'ada'``.

A goal distribution, uniform at the start, updated from each operator twist u by
``log p(g) -= Q_g(x, u) - V_g(x)`` (Huber distance costs with ADA's constants, the action applied for
:data:`ADA_APPLY_TIME`; no goal above 0.99), and the command ``u + sum_g p(g) a_g``, ``a_g`` ADA's Huber-gradient
twist toward goal g, within the assistance's output limits.

A goal has one or more *targets* (poses), as ADA's ``Goal`` holds an object's grasp poses: its value, its
Q-value and its action are those of its target of least value at the hand's pose (``AssistancePolicyOneGoal``:
the first of equal ones), so ``Q_g - V_g`` is that target's. One object's task-serving grasps are one target
each (:mod:`.simulator`, condition ``'ada'``); over several objects a goal is an object and its targets are its
task-serving grasps (:mod:`.scene_simulator`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..mico.frames import pose_error
from .limits import TwistLimiter

__all__ = ['ADA_APPLY_TIME', 'AdaAssistance']

ADA_APPLY_TIME = 0.1
"""Seconds ADA's goal predictor applies the operator's action for (its ``ACTION_APPLY_TIME``)."""


def _huber(d: float, linear: float, delta: float, constant: float) -> tuple[float, float]:
    """ADA's Huber cost-to-go of distance ``d`` and its derivative."""
    if d <= delta:
        return 0.5 * linear / delta * d * d + constant * d, linear / delta * d + constant
    return (linear + constant) * d - 0.5 * linear * delta, linear + constant


class AdaAssistance:
    """ADA's shared autonomy over ``goals`` (each a sequence of target poses, 4x4, base frame; module docstring).

    Constants are ADA's (its HuberAssistancePolicy): translation 2.25 /m beyond 0.07 m plus 0.2, rotation
    0.07 (0.2 /rad beyond pi/32 plus 0.01), robot cost 40 (translation) and 0.05 (rotation).
    """

    def __init__(self, goals: Sequence[Sequence[NDArray[np.float64]]], limiter: TwistLimiter) -> None:
        if not goals or not all(goals):
            raise ValueError('ADA needs at least one goal, each with at least one target')
        self.goals, self.limiter = [list(targets) for targets in goals], limiter
        self.log_p = np.full(len(goals), -math.log(len(goals)))

    def distribution(self) -> NDArray[np.float64]:
        """p(g), shape (len(goals),)."""
        p: NDArray[np.float64] = np.exp(self.log_p)
        return p

    @staticmethod
    def _value(error: NDArray[np.float64]) -> float:
        trans = _huber(float(np.linalg.norm(error[:3])), 2.25, 0.07, 0.2)[0]
        rot = 0.07 * _huber(float(np.linalg.norm(error[3:])), 0.2, math.pi / 32.0, 0.01)[0]
        return trans + rot

    @staticmethod
    def _action(error: NDArray[np.float64]) -> NDArray[np.float64]:
        d, a = float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))
        out = np.zeros(6)
        if d > 0.0:
            out[:3] = _huber(d, 2.25, 0.07, 0.2)[1] * error[:3] / d / 40.0 * min(d / 0.02, 1.0)
        if a > 0.0:
            out[3:] = 0.07 * _huber(a, 0.2, math.pi / 32.0, 0.01)[1] * error[3:] / a / 0.05 * min(a / (math.pi / 12.0),
                                                                                                 1.0)
        return out

    def command(self, hand: NDArray[np.float64], operator: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """The limited command for the operator's twist (base frame) with the hand at ``hand``."""
        errors = []
        for targets in self.goals:  # each goal's target of least value (the first of equal ones)
            target_errors = [pose_error(hand, t) for t in targets]
            values = [self._value(e) for e in target_errors]
            best = int(np.argmin(values))
            errors.append((target_errors[best], values[best]))
        moved = operator * ADA_APPLY_TIME
        for i, (e, value) in enumerate(errors):
            after = e - moved  # the error after the operator's action (first order in the rotation)
            self.log_p[i] -= self._value(after) - value
        self.log_p -= np.logaddexp.reduce(self.log_p)
        p = self.distribution()
        top = int(np.argmax(p))
        if p.size > 1 and p[top] > 0.99:  # ADA's cap, the excess spread evenly over the others
            extra = (p[top] - 0.99) / (p.size - 1)
            p = p + extra
            p[top] = 0.99
            self.log_p = np.log(p)
        assist = sum((pg * self._action(e) for pg, (e, _) in zip(p, errors)), np.zeros(6))
        return self.limiter.limit(operator + assist, dt)
