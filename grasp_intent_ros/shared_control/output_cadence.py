"""When the assistance publishes: one output per period, at the operator's cadence when its source streams.

ROS-free: the caller hands in its timer (anything with a settable ``timer_period_ns`` and ``reset()``, e.g. an
rclpy timer) and its output; times are on the monotonic clock. The assistance node's rule
(:mod:`grasp_intent_ros.nodes.assistance`):

- an operator twist is answered at once when the last output is at least :data:`EARLY` ``period`` old, or at
  least :data:`HALF` of it when that output was the timer's; one that comes sooner after the timer's output is
  answered half a period after it (by the timer, re-armed so);
- after answering an operator twist the timer waits :data:`GRACE` ``period`` from that answer's start; after its
  own output, one ``period``, whatever arrived (a slower operator source, or a stale one).

Without the half-period rule a source at the period whose twists come just after the timer's outputs would have
every twist held for most of a period; with it the twists are answered at once after one re-phasing, whose two
gaps are at least half a period.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol

__all__ = ['EARLY', 'HALF', 'GRACE', 'Timer', 'OutputCadence']

EARLY = 0.95
"""An operator twist is answered at once when the last output is at least this many periods old."""
HALF = 0.5
"""Periods after the timer's output from which an operator twist is answered at once (sooner: at this age)."""
GRACE = 1.25
"""Periods the timer waits for the next operator twist after answering one (then one period after its own)."""


class Timer(Protocol):
    """A periodic timer whose period can be changed, restarting it (an rclpy timer)."""

    timer_period_ns: int

    def reset(self) -> None: ...


class OutputCadence:
    """Calls ``publish`` for each output by the rule of the module docstring.

    Parameters
    ----------
    period : float
        The output period (s); ``timer`` fires every ``period`` until this re-arms it.
    timer : Timer
        The timer that calls :meth:`on_timer`; re-armed here (its period set, then reset).
    publish : callable
        Makes one output.
    clock : callable
        Seconds on a monotonic clock.
    """

    def __init__(self, period: float, timer: Timer, publish: Callable[[], None],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.period, self._timer, self._publish, self._clock = period, timer, publish, clock
        self.last_output = -math.inf
        """When the last output started (``clock`` s)."""
        self.by_timer, self.answer_due = True, False  # the last output the timer's; an answer set

    def on_operator(self) -> None:
        """An operator twist arrived: answered now, or by the timer half a period after its output."""
        age = (self._clock() - self.last_output) / self.period
        if age >= EARLY or (self.by_timer and age >= HALF):
            self._answer()
        elif self.by_timer and not self.answer_due:
            self.answer_due = True  # the timer answers it half a period after its own output
            self._rearm(HALF - age)

    def on_timer(self) -> None:
        """The timer fired: the answer due, or the timer's own output (then one per period from now)."""
        if self.answer_due:
            self._answer()
            return
        self._output()
        self.by_timer = True
        if self._timer.timer_period_ns != round(self.period * 1e9):
            self._rearm(1.0)  # back to one output per period from now

    def _output(self) -> None:
        self.last_output = self._clock()
        self._publish()

    def _answer(self) -> None:
        self._output()
        self.by_timer, self.answer_due = False, False
        self._rearm(GRACE - (self._clock() - self.last_output) / self.period)  # the grace from its start

    def _rearm(self, periods: float) -> None:
        self._timer.timer_period_ns = max(1, round(periods * self.period * 1e9))
        self._timer.reset()
