"""grasp_intent_ros.shared_control.operator_calls: the scripted operator's service calls in sequence.

Clients, futures and episodes of the test's: every call, answer, log line and report is seen.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grasp_intent_ros.shared_control.operator_calls import OperatorCalls
from grasp_intent_ros.shared_control.operator_loop import Closed, Step
from grasp_intent_ros.shared_control.parameters import episodes_settings

EXECUTE, CLOSE, RESET = 'grasp/execute', 'grasp/close', 'mock_arm/reset'
NOW = 7.0


@dataclass
class _Answer:
    success: bool
    message: str


class _Future:
    def __init__(self) -> None:
        self.callbacks: list[Callable[[Any], None]] = []
        self.answer: _Answer | None = None
        self.error: BaseException | None = None

    def add_done_callback(self, callback: Callable[[Any], None]) -> None:
        self.callbacks.append(callback)

    def result(self) -> Any:
        return self.answer

    def exception(self) -> BaseException | None:
        return self.error

    def done(self, answer: _Answer | None = None, error: BaseException | None = None) -> None:
        self.answer, self.error = answer, error
        for callback in self.callbacks:
            callback(self)


class _Client:
    def __init__(self) -> None:
        self.ready = True
        self.futures: list[_Future] = []

    def service_is_ready(self) -> bool:
        return self.ready

    def call_async(self, request: Any) -> _Future:
        assert request == 'request'
        self.futures.append(_Future())
        return self.futures[-1]


@dataclass
class _Episodes:  # OperatorEpisodes' side the calls read and answer
    state: str = 'reaching'
    episode: int = 1
    closed: list[Closed] = field(default_factory=list)
    executed_with: list[tuple[Any, ...]] = field(default_factory=list)
    resets: list[bool] = field(default_factory=list)

    def executed(self, now: float, success: bool, message: str, duration: float | None) -> None:
        self.executed_with.append((now, success, message, duration))

    def reset_done(self, success: bool) -> None:
        self.resets.append(success)


class _Logger:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, message: str) -> None:
        self.lines.append(('info', message))

    def warning(self, message: str) -> None:
        self.lines.append(('warning', message))


def _calls() -> tuple[OperatorCalls, _Episodes, dict[str, _Client], _Logger, list[str]]:
    loop, clients, logger, reports = _Episodes(), {name: _Client() for name in (EXECUTE, CLOSE, RESET)}, _Logger(), []
    calls = OperatorCalls(loop, execute=EXECUTE, close=CLOSE, reset=RESET, clients=clients,  # type: ignore[arg-type]
                          request=lambda: 'request', logger=logger, report=reports.append, clock=lambda: NOW)
    return calls, loop, clients, logger, reports


EXECUTE_STEP = Step(np.zeros(6), False, np.eye(4), 'shown', execute=True)
CLOSE_STEP = Step(np.zeros(6), True, np.eye(4), 'own')


def test_an_executed_grasp_reports_its_answer_and_the_trajectory_s_time() -> None:
    calls, loop, clients, logger, reports = _calls()
    calls.trajectory_time = 1.5
    calls.tick(EXECUTE_STEP, True)
    assert len(clients[EXECUTE].futures) == 1 and calls.waiting_on == EXECUTE and loop.executed_with == []
    assert logger.lines == [('info', 'episode 1: at the shown grasp, at [0.0, 0.0, 0.0] m: executing it')]
    clients[EXECUTE].futures[0].done(_Answer(True, 'executing'))
    assert calls.waiting_on is None and loop.executed_with == [(NOW, True, 'executing', 1.5)]
    assert reports == ['executing (1.50 s)'] and logger.lines[-1] == ('info', f'{EXECUTE}: executing')


def test_an_execute_refused_unanswered_or_unavailable_closes_where_the_hand_is() -> None:
    for answer, error, reason in ((_Answer(False, 'no trajectory kept'), None, 'no trajectory kept'),
                                  (None, RuntimeError('gone'), 'no answer')):
        calls, loop, clients, logger, reports = _calls()
        calls.tick(EXECUTE_STEP, True)
        clients[EXECUTE].futures[0].done(answer, error)
        assert loop.executed_with == [(NOW, False, reason, None)] and reports == [f'refused: {reason}']
        assert logger.lines[-1] == ('warning', f'{EXECUTE} refused: {reason}; closing where the hand is')
    calls, loop, clients, logger, reports = _calls()
    clients[EXECUTE].ready = False
    calls.tick(EXECUTE_STEP, True)
    reason = f'{EXECUTE} is not available (no mock arm?)'
    assert clients[EXECUTE].futures == [] and calls.unavailable == reason and calls.waiting_on is None
    assert loop.executed_with == [(NOW, False, reason, None)] and reports == [f'refused: {reason}']


def test_a_close_is_called_with_close_on_reach_and_logged_either_way() -> None:
    for close_on_reach in (False, True):
        calls, loop, clients, logger, _ = _calls()
        loop.closed.append(Closed(1, 3.25, 'own', np.eye(4)))
        calls.tick(CLOSE_STEP, close_on_reach)
        assert len(clients[CLOSE].futures) == close_on_reach
        assert logger.lines == [('info', 'episode 1: at the own grasp, at [0.0, 0.0, 0.0] m, after 3.25 s')]


def test_the_reset_is_asked_once_while_in_flight_and_again_while_unavailable() -> None:
    calls, loop, clients, _, _ = _calls()
    loop.state = 'resetting'
    clients[RESET].ready = False
    calls.tick(None, True)
    assert calls.unavailable == f'{RESET} is not available (no mock arm?)' and loop.executed_with == []
    clients[RESET].ready = True
    calls.tick(None, True)  # asked again: now there
    calls.tick(None, True)  # in flight: not again
    assert len(clients[RESET].futures) == 1 and calls.unavailable == '' and calls.waiting_on == RESET
    clients[RESET].futures[0].done(_Answer(True, 'reset'))
    assert loop.resets == [True] and calls.waiting_on is None
    calls.tick(None, True)
    clients[RESET].futures[1].done(None, RuntimeError('gone'))
    assert loop.resets == [True, False]


def test_the_episodes_execute_the_shown_grasp_only_when_the_operator_closes() -> None:
    values = {'start_delay': 1.0, 'hold': 2.0, 'episodes': 3, 'execute_timeout': 4.0}
    for execute_shown, close_on_reach in ((True, True), (True, False), (False, True)):
        settings = episodes_settings({**values, 'execute_shown': execute_shown, 'close_on_reach': close_on_reach})
        assert settings == {**values, 'execute_shown': execute_shown and close_on_reach}
