"""grasp_intent_ros.shared_control.output_cadence: the assistance's outputs at the operator's cadence.

A timer and a clock of the test's: every re-arm and output is seen, on a clock that moves only when told.
"""

from __future__ import annotations

import pytest

from grasp_intent_ros.shared_control.output_cadence import OutputCadence

PERIOD = 0.01


class _Timer:
    """An rclpy timer's period and reset, recorded."""

    def __init__(self) -> None:
        self.timer_period_ns = round(PERIOD * 1e9)
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1


class _Loop:
    def __init__(self) -> None:
        self.now = 100.0
        self.outputs: list[float] = []
        self.rearms: list[float] = []  # the periods each re-arm set
        self.publish_takes = 0.0  # how long an output takes (s)
        self.timer = _Timer()
        self.cadence = OutputCadence(PERIOD, self.timer, self.publish, clock=lambda: self.now)

    def publish(self) -> None:
        self.outputs.append(self.now)
        self.now += self.publish_takes

    def after_output(self, periods: float) -> None:
        """The clock ``periods`` after the last output's start."""
        self.now = self.cadence.last_output + periods * PERIOD

    def rearmed(self) -> float:
        assert self.timer.resets == len(self.rearms) + 1
        self.rearms.append(self.timer.timer_period_ns / (PERIOD * 1e9))
        return self.rearms[-1]


def test_operator_twists_set_the_output_cadence() -> None:
    """At once 0.95 period after an output, or half a period after the timer's; sooner, half a period after it.

    The timer's grace after an answer counts from the answer's start.
    """
    loop = _Loop()
    cadence = loop.cadence
    cadence.on_timer()  # the timer's own output, at the period: not re-armed
    assert loop.outputs == [100.0] and loop.timer.resets == 0
    loop.after_output(0.1)
    cadence.on_operator()  # just after it: answered half a period after that output, not now
    assert len(loop.outputs) == 1 and loop.rearmed() == pytest.approx(0.4)
    loop.after_output(0.2)
    cadence.on_operator()  # a second one meanwhile: the answer is set already
    assert len(loop.outputs) == 1 and loop.timer.resets == 1
    loop.after_output(0.5)
    cadence.on_timer()  # that answer; then the timer waits 1.25 periods from its start for the next twist
    assert len(loop.outputs) == 2 and loop.rearmed() == pytest.approx(1.25)
    loop.after_output(0.6)
    cadence.on_operator()  # 0.6 period after an answer: held (the timer's grace)
    assert len(loop.outputs) == 2 and loop.timer.resets == 2
    loop.after_output(0.96)
    cadence.on_operator()  # 0.96 period: at once
    assert len(loop.outputs) == 3 and loop.rearmed() == pytest.approx(1.25)
    loop.publish_takes = 0.003
    loop.after_output(0.96)
    cadence.on_operator()  # an answer that took 3 ms: the grace counts from its start, 0.3 period before
    assert len(loop.outputs) == 4 and loop.rearmed() == pytest.approx(0.95)
    loop.publish_takes = 0.0
    loop.after_output(0.95)
    cadence.on_timer()  # no twist within the grace: the timer's output, then one per period
    assert len(loop.outputs) == 5 and loop.rearmed() == 1.0 and loop.timer.timer_period_ns == 10_000_000
    loop.after_output(0.6)
    cadence.on_operator()  # 0.6 period after the timer's output: at once
    assert len(loop.outputs) == 6 and loop.rearmed() == pytest.approx(1.25)
    assert loop.outputs == sorted(loop.outputs) and cadence.last_output == loop.outputs[-1]
