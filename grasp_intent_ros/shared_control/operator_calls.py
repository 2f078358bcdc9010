"""The scripted operator's service calls in sequence: the grasp command's execute and close, the arm's reset.

ROS-free: the calls go through the caller's clients (the scripted operator node's std_srvs/Trigger clients: anything
with :class:`Client`'s methods), their answers come back in the thread their futures call back in (the node's
executor); this says which call each tick asks for and what an answer means for the episodes
(:class:`~.operator_loop.OperatorEpisodes`), and logs and reports them.

Each tick, after :meth:`~.operator_loop.OperatorEpisodes.step` (:meth:`OperatorCalls.tick`): a step with ``execute``
asks the execute, a step with ``close`` the close (with ``close_on_reach``), and ``resetting`` the reset whenever no
call is in flight (the answered reset ends ``resetting``). The grasp command: on the operator's own grasp the close
at once; on the shown grasp (with ``execute_shown``) zero twists until the hand is at rest, the execute, zero twists
until the latest ``grasp/trajectory``'s time has passed, then the close (:class:`~.operator_loop.GraspCommand`). An
execute refused, unanswered or whose service is not available is logged (a warning) and reported, and the fingers
close where the hand is; a close whose service is not available is not asked again; a reset is asked again the next
tick.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any, Protocol

from .operator_loop import OperatorEpisodes, Step

__all__ = ['Future', 'Client', 'Logger', 'OperatorCalls']


class Future(Protocol):
    """A call's future (an rclpy future): its answer (with ``success`` and ``message``), or its exception."""

    def add_done_callback(self, callback: Callable[[Any], None]) -> None: ...

    def result(self) -> Any: ...

    def exception(self) -> BaseException | None: ...


class Client(Protocol):
    """A service's client (an rclpy client)."""

    def service_is_ready(self) -> bool: ...

    def call_async(self, request: Any) -> Future: ...


class Logger(Protocol):
    """Where lines are logged (an rclpy logger)."""

    def info(self, message: str) -> object: ...

    def warning(self, message: str) -> object: ...


class OperatorCalls:
    """The service calls of ``loop``'s ticks (module docstring).

    Parameters
    ----------
    loop : OperatorEpisodes
    execute, close, reset : str
        The services' names, each a key of ``clients``.
    clients : mapping of str to Client
    request : callable
        A new request (every call's: the services take one type, std_srvs/Trigger).
    logger : Logger
        Logs each call and answer (a warning: an execute not done).
    report : callable
        The last execute's answer, for a status ('refused: <reason>' when not done).
    clock : callable
        Seconds on the clock of ``loop``'s steps.
    """

    def __init__(self, loop: OperatorEpisodes, *, execute: str, close: str, reset: str, clients: Mapping[str, Client],
                 request: Callable[[], object], logger: Logger, report: Callable[[str], object],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.loop, self.execute, self.close, self.reset = loop, execute, close, reset
        self._clients, self._request, self._logger, self._report, self._clock = clients, request, logger, report, clock
        self.waiting_on: str | None = None
        """The call in flight (None: none)."""
        self.unavailable = ''
        """Why the service last asked was not available ('' once a call is made)."""
        self.trajectory_time: float | None = None
        """The latest ``grasp/trajectory``'s last ``time_from_start`` (s): how long an executed grasp takes."""

    def tick(self, step: Step | None, close_on_reach: bool) -> None:
        """The calls of the tick whose step is ``step`` (``loop.step``'s), in order: execute, close, reset."""
        loop = self.loop
        if step is not None and step.execute:
            self._logger.info(f'episode {loop.episode}: at the shown grasp, at {step.goal[:3, 3].round(3).tolist()} '
                              'm: executing it')
            self._start(self.execute)
        if step is not None and step.close:
            done = loop.closed[-1]
            self._logger.info(f'episode {done.episode}: at the {done.pursued} grasp, at '
                              f'{done.goal[:3, 3].round(3).tolist()} m, after {done.time_to_grasp:.2f} s'
                              + (' (executed)' if done.executed else ''))
            if close_on_reach:
                self._start(self.close)
        if loop.state == 'resetting' and self.waiting_on is None:
            self._start(self.reset)

    def answered(self, name: str, future: Future) -> None:
        """The call ``name`` done: the reset's answer to the episodes; the execute's, or its refusal, too."""
        self.waiting_on = None
        answer = future.result() if future.exception() is None else None
        self._logger.info(f'{name}: ' + ('no answer' if answer is None else answer.message))
        if name == self.reset:
            self.loop.reset_done(answer is not None and answer.success)
        elif name == self.execute:
            if answer is None or not answer.success:
                self._refused('no answer' if answer is None else answer.message)
            else:
                self.loop.executed(self._clock(), True, answer.message, self.trajectory_time)
                self._report(answer.message + ('' if self.trajectory_time is None else
                                               f' ({self.trajectory_time:.2f} s)'))

    def _start(self, name: str) -> None:
        client = self._clients[name]
        if not client.service_is_ready():  # a close is not asked again, an execute closes at once, a reset is retried
            self.unavailable = f'{name} is not available (no mock arm?)'
            if name == self.execute:
                self._refused(self.unavailable)
            return
        self.unavailable, self.waiting_on = '', name
        future = client.call_async(self._request())
        future.add_done_callback(lambda done: self.answered(name, done))

    def _refused(self, reason: str) -> None:  # an execute not done: the fingers close where the hand is
        self._logger.warning(f'{self.execute} refused: {reason}; closing where the hand is')
        self._report(f'refused: {reason}')
        self.loop.executed(self._clock(), False, reason, None)
