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
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

__all__ = ['Wait', 'EventWait', 'WorkerThread', 'LatestOnlyWorker']

T = TypeVar('T')


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


class WorkerThread:
    """A daemon thread with a :class:`Wait` and a stop request; ``_run`` is the subclass's loop."""

    def __init__(self, wait: Wait, name: str) -> None:
        self._wait = wait
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def stop_soon(self) -> None:
        """Ask the thread to stop after its current work (safe from any thread and a signal handler)."""
        self._stop.set()
        self._wait.wake()

    def stop(self) -> None:
        """Stop the thread and wait for it (unless called from it); then close its wait."""
        self.stop_soon()
        if threading.current_thread() is not self._thread:
            self._thread.join()
            self._wait.close()

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

    def stop(self) -> None:
        """Stop the thread and wait for it, unless it still runs ``prepare``.

        A preparation (a compile, say) cannot be cut short: the thread (a daemon) is then only asked to stop,
        and ends with the process (:func:`grasp_intent_ros.ros.startup.run` ends a process left so at once).
        """
        if self._preparing:
            self.stop_soon()
        else:
            super().stop()

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
