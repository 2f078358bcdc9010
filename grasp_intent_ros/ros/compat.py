"""Every workaround of rclpy internals, in one place: what each works around, and in which rclpy.

Each was written for rclpy 7.1 (ROS 2 Jazzy) and last checked against :data:`CHECKED_RCLPY`.
test/ros/test_compat.py fails when another rclpy is installed: re-check each workaround below against
it (drop those it no longer needs), then update :data:`CHECKED_RCLPY`.

1. Python's SIGINT handling off (:func:`ignore_python_sigint`). rclpy 7.1 chains its SIGINT handler to
   Python's, whose KeyboardInterrupt would end the spin while rclpy's signal thread is still triggering
   the executor's guard condition, which is then destroyed under it: a use-after-free, seen as a segfault
   on about one SIGINT in five. Ignored at the Python level, SIGINT ends the spin as SIGTERM does.
2. :class:`ShutdownSafeExecutor`. rclpy 7.1 checks ``context.ok()`` and then builds the next wait set; a
   signal handled in between makes ``WaitSet()`` raise RCLError, which would surface as a traceback with
   exit code 1 instead of the normal ExternalShutdownException.
3. :class:`StopWatcher`. rclpy's C++ signal thread first triggers the executors' signal guard conditions
   and then shuts the contexts down (``rcl_shutdown``, without Python's shutdown callbacks; rclpy 7.1.6's
   ``_rclpy_pybind11`` calls them in that order after its ``sem_wait``). An executor that wakes up in
   between sees its context still valid, finds no work and waits again, and nothing wakes it for the
   shutdown: its spin ends only at the node's next timer or message, or never in a node with neither
   (reproduced with real SIGTERMs on timer-less nodes, some still blocked in ``rcl_wait`` seconds later).
   So a daemon thread polls the context every 50 ms and wakes the executor once the context is shut down.
   The same thread arms the stop watchdog of :mod:`grasp_intent_ros.ros.run` (not a workaround: the
   node's own guarantee that a stop request ends the process).
4. rclpy's private C extension (``rclpy.impl.implementation_singleton``) and its ``WaitSet``
   (:func:`new_wait_set`). rclpy 7.1 has no public way to wait on chosen subscriptions, their QoS event
   handlers and a guard condition in a thread of one's own without an executor; ``rclpy.wait_for_message``
   builds the same private WaitSet for its one subscription. Used by :mod:`grasp_intent_ros.ros.worker`
   to take a subscription's messages off the executor.
5. Taking a raw subscription's waiting messages without the executor (:func:`waiting_messages`):
   rclpy 7.1 has no public call for it, so they are taken with the subscription's C handle
   (``handle.take_message``), as rclpy's executor takes them.
"""

from __future__ import annotations

import faulthandler
import importlib.metadata
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import rclpy.logging
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription

from .startup import WATCHDOG_EXIT_CODE

__all__ = ['CHECKED_RCLPY', 'rclpy_version', 'ignore_python_sigint', 'ShutdownSafeExecutor', 'StopWatcher',
           'new_wait_set', 'waiting_messages']

CHECKED_RCLPY = '7.1.6'
"""The rclpy version (the ``ros-rclpy`` distribution's) that every workaround here was checked against."""


def rclpy_version() -> str:
    """The installed rclpy's version: the ``ros-rclpy`` distribution's (the locked PyPI install), else ``rclpy``'s.

    'unknown' when neither distribution is installed (rclpy on ``PYTHONPATH`` only).
    """
    for name in ('ros-rclpy', 'rclpy'):
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    return 'unknown'


def ignore_python_sigint() -> None:
    """Workaround 1: Python ignores SIGINT (rclpy's handler, installed by ``rclpy.init``, still sees it).

    Call before ``rclpy.init``; only the main thread may set a handler, elsewhere nothing is done.
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def new_wait_set(subscriptions: int, guard_conditions: int, events: int, context: Any) -> Any:
    """Workaround 4: rclpy's C ``WaitSet`` for that many subscriptions, guard conditions and QoS events.

    ``context`` is the rcl context (``Context.handle``), entered by the caller for the wait set's life.
    """
    return _rclpy.WaitSet(subscriptions, guard_conditions, 0, 0, 0, events, context)


_STOP_POLL = 0.05
"""Seconds between two looks at the context by the stop watcher's thread."""


class StopWatcher:
    """Wakes the executor for a stop request and, with a ``grace``, ends the process if the shutdown hangs.

    A daemon thread waits until ``context`` is shut down or the spin has ended (:meth:`spin_ended`). Then,
    unless the spin has ended, it calls ``wake`` (the executor's ``wake``: rclpy's signal thread may have
    woken the executor before it shut the context down: workaround 3 above). With a ``grace`` it also arms a
    timer (ERROR, every thread's stack, exit code :data:`~grasp_intent_ros.ros.startup.WATCHDOG_EXIT_CODE`) and
    faulthandler's C timer 2 s later (stacks, exit code 1). :meth:`spin_ended` arms faulthandler's timer
    itself too, from the caller's thread, before the
    teardown: a teardown that holds the GIL from its start (the middleware's shutdown livelock, docs/nodes.md)
    would keep this thread from ever arming anything. :meth:`finished` disarms both: once run_node's shutdown
    is done the process is left alone.
    """

    def __init__(self, context: Any, wake: Callable[[], None], grace: float | None) -> None:
        self._wake, self._grace = wake, grace
        self._spin_ended = threading.Event()
        self._lock = threading.Lock()
        self._finished = False
        self._timer: threading.Timer | None = None
        threading.Thread(target=self._watch, args=(context,), name='stop watcher', daemon=True).start()

    def spin_ended(self) -> None:
        """The spin is over: the executor is not woken any more (it may be shut down once this returns).

        With a ``grace``, faulthandler's timer is armed now: the teardown that follows must end within it.
        """
        with self._lock:
            self._spin_ended.set()
            if self._grace is not None and not self._finished:
                faulthandler.dump_traceback_later(self._grace + 2.0, exit=True, file=sys.stderr)

    def finished(self) -> None:
        with self._lock:
            self._finished = True
            if self._timer is not None:
                self._timer.cancel()
            if self._grace is not None:
                faulthandler.cancel_dump_traceback_later()

    def _watch(self, context: Any) -> None:
        while context.ok() and not self._spin_ended.wait(_STOP_POLL):
            pass
        with self._lock:
            if not self._spin_ended.is_set():
                self._wake()
            if self._finished or self._grace is None:
                return
            faulthandler.dump_traceback_later(self._grace + 2.0, exit=True, file=sys.stderr)
            self._timer = threading.Timer(self._grace, self._expire)
            self._timer.daemon = True
            self._timer.start()

    def _expire(self) -> None:
        rclpy.logging.get_logger('grasp_intent_ros').error(
            f'shutdown not finished {self._grace:g} s after the stop request: exiting now; the threads follow')
        faulthandler.dump_traceback(file=sys.stderr, all_threads=True)
        sys.stderr.flush()
        os._exit(WATCHDOG_EXIT_CODE)


class ShutdownSafeExecutor(SingleThreadedExecutor):
    """A SingleThreadedExecutor whose spin ends with ExternalShutdownException when shut down under it.

    Never with an RCLError.

    rclpy 7.1 checks ``context.ok()`` and then builds the next wait set; a signal handled in between
    (rclpy's signal thread shuts the context down) makes ``WaitSet()`` raise RCLError ("the given
    context is not valid"), which would otherwise surface as a traceback with exit code 1.
    """

    def spin_once(self, timeout_sec: float | None = None) -> None:
        try:
            super().spin_once(timeout_sec)
        except RuntimeError:  # rclpy's RCLError derives from RuntimeError
            if self.context.ok():
                raise
            raise ExternalShutdownException() from None


def waiting_messages(subscription: Subscription, limit: int) -> Iterator[tuple[bytes, Mapping[str, Any]]]:
    """Workaround 5: up to ``limit`` messages waiting on the raw ``subscription``, in order, with their info.

    Taken as rclpy's executor takes them (``handle.take_message``), so that a callback can handle a burst
    in one executor wake-up instead of one wake-up (a wait set and a task) per message.
    """
    for _ in range(limit):
        with subscription.handle:
            waiting = subscription.handle.take_message(subscription.msg_type, True)
        if waiting is None:
            return
        yield waiting
