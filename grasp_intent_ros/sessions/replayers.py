"""The replay's engine: a session's inputs paced and sent through its clients, each answer awaited and checked.

The clients are :class:`~.replay_client.SessionClient` nodes; the comparison is :mod:`.compare`; the command
line is :mod:`grasp_intent_ros.sessions.replay`.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import numpy as np
from rclpy.executors import SingleThreadedExecutor
from rclpy.task import Future

from ..wire.topics import DIAGNOSTICS, MODEL_ACTIVE
from .closed_loop import ClosedLoopSession, estimator_ready
from .compare import Difference, Tolerances, answered, compare_step, diverged
from .outputs import Output
from .pairing import PairedSession, Step
from .replay_client import SessionClient
from .scenes import PairedScene

__all__ = ['ReplayOptions', 'ReplayResult', 'ReplayError', 'SessionReplayer', 'Replayer', 'SceneReplayer',
           'ClosedLoopReplayer', 'await_answer']


def await_answer(spin: Callable[[], None], outputs: list[Output], mark: int, step: Step, *,
                 timeout_s: float, quiet_s: float = 0.25, settle_s: float = 0.02,
                 future: Future | None = None) -> tuple[list[Output], str]:
    """Spin until the answer to ``step`` (sent when ``outputs`` had ``mark`` entries) is complete.

    Complete: every recorded output topic has as many live messages as recorded and nothing new came for
    ``settle_s``; or the answer diverges (an unrecorded message) and nothing new came for 0.5 s; or, for a
    step recorded without outputs, nothing came for ``quiet_s``; or ``timeout_s`` passed. ``future`` (a
    SetParameters call) must be done too; a refused parameter ends the wait.

    Returns
    -------
        (the live outputs since ``mark``, '' | 'timeout' | 'rejected: <reason>')
    """
    start = last_change = time.monotonic()
    seen = 0
    while True:
        spin()
        now = time.monotonic()
        live = outputs[mark:]
        if len(live) != seen:
            seen, last_change = len(live), now
        if future is not None and future.done():
            result = future.result().results[0]
            if not result.successful:
                return live, f'rejected: {result.reason}'
            future = None
        quiet = now - last_change
        if future is None:
            if step.expected:
                if answered(step, live) and (quiet >= settle_s or diverged(step, live)):
                    return live, ''
                if diverged(step, live) and quiet >= 0.5:
                    return live, ''
            elif quiet >= quiet_s:
                return live, ''
        if now - start >= timeout_s:
            return live, 'timeout'


@dataclass(frozen=True)
class ReplayOptions:
    """How to replay.

    Attributes
    ----------
    rate
        Recorded pace multiplier (> 0); ignored with ``fast``.
    fast
        Send each input once the previous one was answered, without waiting for its recorded time.
    check
        Wait for every answer and compare it with the recording.
    timeout_s
        Longest wait for one answer (s).
    startup_timeout_s
        Longest wait for the live system to be ready (s).
    settle_s
        Once ready, how long every node must have been visible before the first input (s):
        one discovery announcement period (3 s) for a suite started together with the replay, so its
        nodes have met each other; 0 for a system that was running already.
    quiet_s
        For an input recorded without any answer: how long nothing must arrive (s).
    max_failed_inputs
        Stop after this many inputs with differences (0: never stop early).
    tolerances
        Of the comparison.
    """

    rate: float = 1.0
    fast: bool = False
    check: bool = False
    timeout_s: float = 10.0
    startup_timeout_s: float = 60.0
    settle_s: float = 0.0
    quiet_s: float = 0.25
    max_failed_inputs: int = 5
    tolerances: Tolerances = field(default_factory=Tolerances)


@dataclass
class ReplayResult:
    """What a replay did: inputs sent, outputs received, differences (with --check), timings (s)."""

    inputs_sent: int = 0
    outputs_received: int = 0
    differences: list[Difference] = field(default_factory=list)
    timed_out: list[int] = field(default_factory=list)
    stopped_early: bool = False
    ready_s: float = 0.0
    replay_s: float = 0.0

    @property
    def failures(self) -> list[Difference]:
        """The differences that fail a check (notes excluded)."""
        return [d for d in self.differences if d.fatal]


class ReplayError(RuntimeError):
    """The live system did not come up or could not be put into the session's initial state."""


S = TypeVar('S', PairedSession, ClosedLoopSession)
"""The session a replayer replays."""


class SessionReplayer(Generic[S]):
    """What both replayers share: a session replayed through a :class:`SessionClient` spun by ``executor``.

    Parameters
    ----------
    session
        The recorded session.
    client
        Added to ``executor`` by the caller.
    executor
        Spun with ``spin_once`` while waiting.
    options
        See :class:`ReplayOptions`.
    alive
        Called while waiting; a non-empty return (e.g. a suite process died) aborts with ReplayError.
    """

    def __init__(self, session: S, client: SessionClient, executor: SingleThreadedExecutor,
                 options: ReplayOptions, *, alive: Callable[[], str] = lambda: '') -> None:
        self.session: S = session
        self.client, self.executor, self.options = client, executor, options
        self._alive = alive

    def _spin(self, seconds: float = 0.005) -> None:
        self.executor.spin_once(timeout_sec=seconds)
        if problem := self._alive():
            raise ReplayError(problem)

    def wait_for(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Spin ``executor`` (every client it spins) until ``predicate()`` holds: True, or False after ``timeout`` s.

        Raises ReplayError when the live system died meanwhile.
        """
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() >= deadline:
                return predicate()
            self._spin(min(0.05, max(0.0, deadline - time.monotonic())))
        return True

    def prepare(self) -> list[Difference]:
        """Wait until the live system is ready and runs the session's initial model.

        Returns notes (a model with the recorded name but other content). Raises ReplayError.
        """
        need_parameters = self._needs_parameters()
        missing = lambda: self.client.missing(need_parameters=need_parameters)  # noqa: E731
        if not self.wait_for(lambda: not missing() and self.client.settled(self.options.settle_s),
                          self.options.startup_timeout_s):
            raise ReplayError(f'the live system is not ready after {self.options.startup_timeout_s:g} s: '
                              f'{"; ".join(missing()) or "nodes still appearing"}')
        initial = self.session.initial_model
        notes = []
        if initial is not None and self.client.model is not None and self.client.model.name != initial.name:
            self._activate(initial.name)
            self._quiet(0.5)  # a running planner replans its current v for the new model: not an answer
        if initial is not None and self.client.model is not None and self.client.model.sha256 != initial.sha256:
            notes.append(Difference(0, 'initial model', MODEL_ACTIVE, 'model content', f'sha256 {initial.sha256[:12]}',
                                    f'sha256 {self.client.model.sha256[:12]} (same name, different model)', False))
        return notes

    def _needs_parameters(self) -> bool:
        """Whether the session activates a model (then the model server's parameters must be reachable)."""
        raise NotImplementedError

    def _quiet(self, seconds: float) -> None:
        """Spin until no output arrived for ``seconds`` (at most the answer timeout)."""
        last = [len(self.client.outputs), time.monotonic()]

        def quiet() -> bool:
            if len(self.client.outputs) != last[0]:
                last[:] = [len(self.client.outputs), time.monotonic()]
            return time.monotonic() - last[1] >= seconds

        self.wait_for(quiet, self.options.timeout_s)

    def _activate(self, name: str) -> None:
        future = self.client.set_model(name)
        if not self.wait_for(future.done, self.options.timeout_s):
            raise ReplayError(f'no answer from the parameter service when setting model {name!r}')
        result = future.result().results[0]
        if not result.successful:
            raise ReplayError(f'the model server rejected model {name!r}: {result.reason}')
        if not self.wait_for(lambda: self.client.model is not None and self.client.model.name == name,
                          self.options.timeout_s):
            raise ReplayError(f'model {name!r} was accepted but no {MODEL_ACTIVE} for it arrived')


class Replayer(SessionReplayer[PairedSession]):
    """One chain of a paired session (:mod:`grasp_intent_ros.sessions.pairing`) and its client.

    Its inputs are sent and its answers awaited and compared here; :class:`SceneReplayer` runs the chains of a
    session.
    """

    def _needs_parameters(self) -> bool:
        return any(s.model is not None for s in self.session.steps) or self.session.initial_model is not None

    def send(self, step: Step) -> Future | None:
        """Publish ``step``'s input (or ask for its model switch: the SetParameters future)."""
        if step.model is not None:
            return self.client.set_model(step.model)
        self.client.publish(step.topic, step.cdr)
        return None

    def answer(self, step: Step, index: int, mark: int, future: Future | None) -> list[Difference]:
        """The differences of the answer to ``step``, awaited (:func:`await_answer`).

        ``step`` was sent as input ``index`` of the session when the client had ``mark`` outputs. With ``check``
        every difference from the recording, else only a timeout's or a refused model's. The differences name
        input ``index`` and, in a chain of a scene, the chain's output topics by the chain's name
        ('cup/grasp/pose').
        """
        live, problem = await_answer(self._spin, self.client.outputs, mark, step, future=future,
                                     timeout_s=self.options.timeout_s, quiet_s=self.options.quiet_s)
        diffs = []
        if problem == 'timeout':
            diffs.append(Difference(step.index, step.description, '(answer)', 'timeout',
                                    f'{len(step.expected)} output(s)',
                                    f'{len(live)} output(s) within {self.options.timeout_s:g} s', False))
            statuses = '\n'.join(f'  {name}: {text}' for name, text in sorted(self.client.last_status.items()))
            chain = f' ({self.session.name})' if self.session.name else ''
            print(f'replay: input #{index}{chain} got {len(live)} of {len(step.expected)} recorded outputs within '
                  f'{self.options.timeout_s:g} s; latest node statuses:\n{statuses}', file=sys.stderr)
        elif problem:
            diffs.append(Difference(step.index, step.description, MODEL_ACTIVE, 'parameter model',
                                    f'{step.model!r} accepted', problem))
        if self.options.check:
            diffs += compare_step(step, live, self.options.tolerances)
        name = self.session.name
        return [dataclasses.replace(d, step=index, topic=f'{name}/{d.topic}' if name and d.topic != DIAGNOSTICS
                                    else d.topic) for d in diffs]


class SceneReplayer:
    """Replays a paired session, of one chain or a scene (:class:`~grasp_intent_ros.sessions.scenes.PairedScene`).

    Each input is sent once, through the replayer of the first chain it feeds, at its recorded time (``rate``) or,
    with ``fast`` or ``check``, once the previous input was answered; then the answer of every chain it feeds
    is awaited and, with ``check``, compared with that chain's recording.

    Parameters
    ----------
    scene
        The recorded session.
    chains
        One :class:`Replayer` per chain of ``scene.chains``, in its order, their clients spun by one executor.
    options
        See :class:`ReplayOptions` (the chains' own).
    """

    def __init__(self, scene: PairedScene, chains: Sequence[Replayer], options: ReplayOptions) -> None:
        self.scene, self.chains, self.options = scene, tuple(chains), options

    def run(self) -> ReplayResult:
        """Replay every input; compare with --check. Raises ReplayError (system not ready, suite died)."""
        result = ReplayResult()
        started = time.monotonic()
        for chain in self.chains:
            result.differences += chain.prepare()
        result.ready_s = time.monotonic() - started
        paced_by_answers = self.options.check or self.options.fast
        inputs, wait = self.scene.inputs, self.chains[0].wait_for
        t_first = inputs[0].steps[0][1].t_ns
        begin = time.monotonic()
        failed_inputs = 0
        first_marks = marks = [len(chain.client.outputs) for chain in self.chains]
        for item in inputs:
            if not self.options.fast:
                send_at = begin + 1e-9 * (item.steps[0][1].t_ns - t_first) / self.options.rate
                wait(lambda: time.monotonic() >= send_at, max(0.0, send_at - time.monotonic()) + 1.0)
            marks = [len(chain.client.outputs) for chain in self.chains]
            sender, sent = item.steps[0]
            future = self.chains[sender].send(sent)
            result.inputs_sent += 1
            if not paced_by_answers:
                continue
            diffs = [d for i, step in item.steps
                     for d in self.chains[i].answer(step, item.index, marks[i], future if step is sent else None)]
            result.timed_out += [item.index] if any(d.field == 'timeout' for d in diffs) else []
            if self.options.check:
                result.differences += diffs
                if any(d.fatal for d in diffs):
                    failed_inputs += 1
                    if failed_inputs >= self.options.max_failed_inputs > 0:
                        result.stopped_early = item is not inputs[-1]
                        break
        if not paced_by_answers:  # let the last answer arrive
            wait(lambda: all(answered(step, self.chains[i].client.outputs[marks[i]:]) for i, step in inputs[-1].steps),
                 self.options.timeout_s)
        result.replay_s = time.monotonic() - begin
        result.outputs_received = sum(len(c.client.outputs) - m for c, m in zip(self.chains, first_marks))
        return result


class ClosedLoopReplayer(SessionReplayer[ClosedLoopSession]):
    """Replays a closed-loop session (:mod:`grasp_intent_ros.sessions.closed_loop`) at its recorded pace.

    The live system must run the assistance and an arm (the suite with ``shared_control``), with the arm where
    the recording's started; for an estimated session the intent estimator instead (the recorded hand is
    sent). The client must have been made with ``closed_loop=True`` and ``estimated`` as the session's.
    :meth:`run` sends every
    message at its recorded time after the first, then waits until the arm has stopped (no joint moved by more
    than 1e-6 rad over :data:`STOPPED_S`, once the operator's last twist is older than :data:`STOPPED_S`), at most
    ``options.timeout_s``.
    """

    STOPPED_S = 0.3
    """Seconds without arm motion that end the replay: the assistance stops 0.1 s after the operator's last twist
    (operator_timeout) and the mock arm 0.1 s after the last blended twist (command_timeout)."""

    def _needs_parameters(self) -> bool:
        return self.session.initial_model is not None or any(s.model is not None for s in self.session.sends)

    def run(self) -> ReplayResult:
        """Send every message, wait for the arm to stop; raises ReplayError (system not ready, suite died)."""
        result = ReplayResult()
        started = time.monotonic()
        result.differences += self.prepare()
        result.ready_s = time.monotonic() - started
        if self.session.estimated:
            if not self.wait_for(lambda: estimator_ready(self.client.last_status), self.options.startup_timeout_s):
                raise ReplayError('the live intent estimator did not report its goals ready')
        elif not self.wait_for(lambda: bool(self.client.tracer.trace().joints), self.options.startup_timeout_s):
            raise ReplayError('no joint state from the live arm')
        self.client.tracer.restart()
        sends = self.session.sends
        begin = time.monotonic()
        for send in sends:
            send_at = begin + 1e-9 * (send.t_ns - send.lead_ns - sends[0].t_ns + sends[0].lead_ns)
            self.wait_for(lambda: time.monotonic() >= send_at, max(0.0, send_at - time.monotonic()) + 1.0)
            if send.model is not None:
                self.client.set_model(send.model)  # not awaited: the recorded operator did not wait either
            else:
                self.client.publish(send.topic, send.cdr)
                self.client.tracer.add(send.topic, self.client.get_clock().now().nanoseconds + send.lead_ns, send.cdr)
            result.inputs_sent += 1
        last_send = time.monotonic()
        if not self.wait_for(lambda: time.monotonic() - last_send >= self.STOPPED_S and self._arm_stopped(),
                          self.options.timeout_s):
            result.timed_out.append(len(sends))
        result.replay_s = time.monotonic() - begin
        result.outputs_received = len(self.client.outputs)
        return result

    def _arm_stopped(self) -> bool:
        joints = self.client.tracer.trace().joints
        if not joints:
            return False
        since = joints[-1][0] - int(self.STOPPED_S * 1e9)
        recent = [q for t, q in joints if t >= since]
        return len(recent) > 1 and all(float(np.max(np.abs(q - recent[-1]))) <= 1e-6 for q in recent)
