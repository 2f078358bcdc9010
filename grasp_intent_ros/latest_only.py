"""The newest inputs only: callbacks store the newest inputs, one thread handles the newest snapshot. No ROS.

The caller's thread (a node's executor, a viewer's slider) never blocks on a long computation (a plan, a
drawing), and the worker thread never works through a backlog: inputs that arrive while it is busy replace
each other, and it takes the newest snapshot when it is free again. Nothing here knows message types.

The hand-over: an update that finds the thread idle also hands it the GIL at once (``time.sleep(0)``
releases it). Otherwise the woken thread waits for the GIL until the updating thread gives it up by
itself: an rclpy executor thread does so only when it blocks in its next wait, after building the wait
set (a few hundred microseconds of Python), or when the switch interval forces it (``sys.getswitchinterval``),
which the hand-over saves on every update.

How the thread waits is a :class:`Wait`: a ``threading.Event`` by default (:class:`EventWait`);
:mod:`grasp_intent_ros.ros.worker` gives it an rclpy wait set, so that it can also take a subscription's
messages itself.

**The stop.** :meth:`WorkerThread.stop` asks the thread to stop and waits for its current work at most
:data:`FINISH_WAIT` s. Work that takes longer (a model's first robustness estimate, a compile) is not cut
short: nothing in it looks at the stop request, and compiled code cannot be interrupted. The thread, a
daemon, is then left to end with the process (:func:`left_running` names such threads); a node process
exits at once when its node has shut down (:func:`grasp_intent_ros.ros.run.guard_exit`), so a stop takes
at most :data:`FINISH_WAIT` s per thread, at any load. What such work yields is not wanted: a handler
publishes no answer once :attr:`WorkerThread.stopping` is true (the planner's checks it before it publishes).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

__all__ = ['Wait', 'EventWait', 'WorkerThread', 'LatestOnlyWorker', 'FINISH_WAIT', 'left_running']

T = TypeVar('T')

FINISH_WAIT = 1.0
"""Seconds :meth:`WorkerThread.stop` waits for the thread's current work before leaving it to end with the process.

Ordinary work (a plan, a model document's read, a goal set's IK) ends well within it even on a loaded machine;
a node stops at most two such threads (its work and its model follower), within the stop's grace
(:data:`grasp_intent_ros.ros.run.SHUTDOWN_GRACE`).
"""


class Wait(Protocol):
    """How a worker thread waits for work."""

    def wake(self) -> None:
        """Wake the waiting thread (safe from any thread and a signal handler)."""

    def wait(self, timeout: float | None) -> bool:
        """Wait until woken or ``timeout`` (s, None: no limit) passes; False when the thread must end."""

    def close(self) -> None:
        """Release what the wait holds (after the thread ended)."""


class EventWait:
    """The worker thread waits on a ``threading.Event``."""

    def __init__(self) -> None:
        self._event = threading.Event()

    def wake(self) -> None:
        self._event.set()

    def wait(self, timeout: float | None) -> bool:
        self._event.wait(timeout)
        self._event.clear()
        return True

    def close(self) -> None:
        pass


class _Thread(threading.Thread):
    """A worker's thread, which knows its stop request (:func:`left_running`)."""

    def __init__(self, target: Callable[[], None], name: str, stop: threading.Event) -> None:
        super().__init__(target=target, name=name, daemon=True)
        self.stop_request = stop


def left_running() -> list[str]:
    """The names of the worker threads asked to stop that still run: stops that did not wait for their work."""
    return [thread.name for thread in threading.enumerate()
            if isinstance(thread, _Thread) and thread.stop_request.is_set() and thread.is_alive()]


class WorkerThread:
    """A daemon thread with a :class:`Wait` and a stop request; ``_run`` is the subclass's loop."""

    def __init__(self, wait: Wait, name: str) -> None:
        self._wait = wait
        self._stop = threading.Event()
        self._thread: threading.Thread = _Thread(self._run, name, self._stop)
        self._thread.start()

    def stop_soon(self) -> None:
        """Ask the thread to stop after its current work (safe from any thread and a signal handler)."""
        self._stop.set()
        self._wait.wake()

    def stop(self) -> bool:
        """Stop the thread: wait for its current work at most :data:`FINISH_WAIT` s (module docstring, "The stop").

        Returns whether the thread ended (then its wait is closed); False when called from the thread itself, or
        when its work goes on: the thread then ends after it, or with the process (:func:`left_running`).
        """
        self.stop_soon()
        if threading.current_thread() is self._thread:
            return False
        self._thread.join(FINISH_WAIT)
        if self._thread.is_alive():
            return False
        self._wait.close()
        return True

    @property
    def stopping(self) -> bool:
        """Whether a stop was asked for."""
        return self._stop.is_set()

    def _run(self) -> None:
        raise NotImplementedError


class LatestOnlyWorker(WorkerThread, Generic[T]):
    """Holds the newest inputs ``T`` (immutable) and hands them to ``handle`` in a thread of its own.

    Parameters
    ----------
    initial : T
        The inputs before any update.
    handle : callable
        ``handle(snapshot)`` runs in the worker thread. It must not raise (wrap it, e.g. with
        ``NodeDiagnostics.guard``).
    ready : callable
        ``ready(snapshot) -> bool``, checked first in the worker thread: False when the snapshot cannot
        be handled yet (an input is still missing); it is offered again after the next triggering update.
    name : str
        Thread name.
    min_period : callable
        Seconds that must pass between the starts of two handled snapshots (read before each).
    prepare : callable, optional
        Run once in the worker thread before it handles anything (e.g. loading compiled code), so that the
        work overlaps with what the caller waits for at start. It must not raise.
    wait : Wait, optional
        How the thread waits (default: an :class:`EventWait`).
    """

    def __init__(self, initial: T, handle: Callable[[T], object], *, name: str,
                 ready: Callable[[T], bool] = lambda _: True,
                 min_period: Callable[[], float] = lambda: 0.0,
                 prepare: Callable[[], object] | None = None,
                 wait: Wait | None = None) -> None:
        self._lock = threading.Lock()
        self._latest = initial
        self._version = 0
        self._handle, self._ready = handle, ready
        self._min_period = min_period
        self._prepare = prepare
        self._preparing = prepare is not None
        self._idle = False  # the thread waits for an update
        self.superseded = 0
        """Triggering updates never handled because a newer one replaced them."""
        super().__init__(EventWait() if wait is None else wait, name)

    @property
    def latest(self) -> T:
        """The newest inputs."""
        with self._lock:
            return self._latest

    def update(self, change: Callable[[T], T], *, trigger: bool = True) -> None:
        """Replace the inputs by ``change(latest)`` atomically; with ``trigger`` they call for handling."""
        with self._lock:
            self._latest = change(self._latest)
            if trigger:
                self._version += 1
        if trigger and threading.current_thread() is not self._thread:  # the thread itself looks after waking
            self._wait.wake()
            if self._idle:  # hand it the GIL now (module docstring); a busy thread takes the update later
                time.sleep(0)

    @property
    def idle(self) -> bool:
        """Whether the thread waits for a triggering update (its preparation done, nothing being handled)."""
        return self._idle

    @property
    def preparing(self) -> bool:
        """Whether the thread still runs ``prepare``."""
        return self._preparing

    def _run(self) -> None:
        if self._prepare is not None:
            try:
                self._prepare()
            finally:
                self._preparing = False
        handled = 0
        last_start = -math.inf
        while not self._stop.is_set():
            self._idle = True
            waited = self._wait.wait(None)
            self._idle = False
            wait = last_start + self._min_period() - time.monotonic()
            if waited and wait > 0.0:
                if self._stop.wait(wait):
                    break
                waited = self._wait.wait(0.0)  # take what arrived meanwhile
            if self._stop.is_set() or not waited:
                break
            with self._lock:
                snapshot, version = self._latest, self._version
            if version == handled:
                continue
            if not self._ready(snapshot):
                continue
            self.superseded += max(0, version - handled - 1)
            handled, last_start = version, time.monotonic()
            self._handle(snapshot)
