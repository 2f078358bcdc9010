"""The Jazzy node run idiom, written once: init, build the node, spin, shut down cleanly.

SIGINT and SIGTERM both end the process with exit code 0 and no traceback: rclpy's own signal
handlers (installed by ``rclpy.init`` for both signals) shut the context down, the executor raises
``ExternalShutdownException``, and the node is destroyed before ``rclpy.try_shutdown``. The three gaps of
rclpy 7.1 on that path (Python's KeyboardInterrupt racing rclpy's signal thread, a shutdown between two
executor steps, the signal thread waking the executor before it shuts the context down) are closed by
:mod:`grasp_intent_ros.ros.compat` (items 1 to 3); for the third, the stop watcher of this module polls the
context and wakes the executor once it is shut down. A signal that arrives while the node is being built
(its rcl calls then fail on the shut-down context) also exits 0; one that arrives before ``rclpy.init``
(during imports) gets Python's default handling. A configuration error found while the node is built (a
parameter rejected by its descriptor or validator, a missing model) is logged and ends the process with
exit code 1.

A stop request that has not ended the process :data:`SHUTDOWN_GRACE` seconds later is ended by a
watchdog (the same thread arms it): it logs an ERROR, writes every thread's stack to stderr
(``faulthandler``) and exits with code 0, so that a stop request always ends the node and leaves the
evidence in its log. This covers a hung shutdown (executor, node and context, after the spin has ended)
and a spin that a stop did not end. Two seconds later still, ``faulthandler``'s own timer (a C thread,
which needs no GIL) writes the stacks and exits with code 1, for a hang that holds the GIL. Once run_node
has returned (the shutdown finished), both are disarmed and the process is left alone. A node process's
``main`` then calls :func:`guard_exit`: the interpreter's own exit (atexit handlers, threads, the
middleware's destructors) gets the same grace, after which faulthandler writes the stacks and exits with
code 1, so that no hang, not even one after the node's shutdown, passes without output.
"""

from __future__ import annotations

import ctypes
import faulthandler
import os
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import rclpy
import rclpy.logging
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node
from rclpy.publisher import Publisher

from ..core.errors import GraspIntentError
from .compat import ShutdownSafeExecutor, ignore_python_sigint
from .params import ParameterError

__all__ = ['run_node', 'guard_exit', 'publish_all', 'release_free_memory', 'STARTUP_ERRORS', 'SHUTDOWN_GRACE']

STARTUP_ERRORS: tuple[type[Exception], ...] = (ParameterError, ParameterException, GraspIntentError)
"""Errors a node constructor raises for bad configuration: reported in one line, exit code 1."""

SHUTDOWN_GRACE = 5.0
"""Seconds a stop request may take to end a node before the watchdog ends the process."""

_STOP_POLL = 0.05
"""Seconds between two looks at the context by the stop watcher's thread."""


class _StopWatcher:
    """Wakes the executor for a stop request and, with a ``grace``, ends the process if the shutdown hangs.

    A daemon thread waits until ``context`` is shut down or the spin has ended (:meth:`spin_ended`). Then,
    unless the spin has ended, it calls ``wake`` (the executor's ``wake``: rclpy's signal thread may have
    woken the executor before it shut the context down; module docstring). With a ``grace`` it also arms a
    timer (ERROR, every thread's stack, exit code 0) and faulthandler's C timer 2 s later (stacks, exit code
    1). :meth:`finished` disarms both: once run_node's shutdown is done the process is left alone.
    """

    def __init__(self, context: Any, wake: Callable[[], None], grace: float | None) -> None:
        self._wake, self._grace = wake, grace
        self._spin_ended = threading.Event()
        self._lock = threading.Lock()
        self._finished = False
        self._timer: threading.Timer | None = None
        threading.Thread(target=self._watch, args=(context,), name='stop watcher', daemon=True).start()

    def spin_ended(self) -> None:
        """The spin is over: the executor is not woken any more (it may be shut down once this returns)."""
        with self._lock:
            self._spin_ended.set()

    def finished(self) -> None:
        with self._lock:
            self._finished = True
            if self._timer is not None:
                self._timer.cancel()
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
        os._exit(0)


_malloc_trim = getattr(ctypes.CDLL(None), 'malloc_trim', None)  # glibc only
if _malloc_trim is not None:
    _malloc_trim.argtypes, _malloc_trim.restype = [ctypes.c_size_t], ctypes.c_int


def release_free_memory() -> bool:
    """Return the pages malloc holds free to the system (glibc's ``malloc_trim(0)``, every arena).

    For after a rare, allocation-heavy step such as a model switch: its numpy temporaries of a few hundred
    kB come from the heap once glibc's mmap threshold has risen past them, and the pages they leave free
    stay resident otherwise. False where there is no ``malloc_trim`` (not glibc) or nothing was returned.
    """
    return _malloc_trim is not None and bool(_malloc_trim(0))


def run_node(node_factory: Callable[[], Node], args: Sequence[str] | None = None, *,
             executor_factory: Callable[[], Executor] | None = None,
             shutdown_grace: float | None = SHUTDOWN_GRACE) -> None:
    """Initialise rclpy, build a node and spin it until shutdown.

    Parameters
    ----------
    node_factory : callable
        Builds the node (a Node subclass or a lambda); called after ``rclpy.init``, in the default
        context, so ``--ros-args`` (remappings, ``--params-file``) apply to it.
    args : sequence of str, optional
        Command line for ``rclpy.init``; default ``sys.argv``.
    executor_factory : callable, optional
        Builds the executor, e.g. ``rclpy.executors.MultiThreadedExecutor`` for a node whose
        callbacks must run concurrently; default a :class:`ShutdownSafeExecutor`.
    shutdown_grace : float or None
        Seconds a stop request may take to end the process before the watchdog ends it (module
        docstring); None: no watchdog (e.g. a recorder, whose closing writes must not be cut short).

    Raises
    ------
    SystemExit
        With code 1 when the node cannot be built because of its configuration.
    """
    ignore_python_sigint()
    rclpy.init(args=None if args is None else list(args))
    node: Node | None = None
    executor: Executor | None = None
    watcher: _StopWatcher | None = None
    try:
        executor = ShutdownSafeExecutor() if executor_factory is None else executor_factory()
        watcher = _StopWatcher(rclpy.get_default_context(), executor.wake, shutdown_grace)
        try:
            node = node_factory()
        except STARTUP_ERRORS as exc:
            if not rclpy.ok():
                return  # SIGINT/SIGTERM while starting: the context was shut down under the node
            rclpy.logging.get_logger('grasp_intent_ros').fatal(f'cannot start: {exc}')
            raise SystemExit(1) from None
        except Exception:
            if rclpy.ok():
                raise
            return  # SIGINT/SIGTERM while starting: rcl calls fail on the shut-down context
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if watcher is not None:
            watcher.spin_ended()
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        if watcher is not None:
            watcher.finished()


def guard_exit(grace: float = SHUTDOWN_GRACE) -> None:
    """For a node process's ``main`` once :func:`run_node` has returned: the process must end within ``grace`` s.

    Else faulthandler writes every thread's stack to stderr and exits with code 1 (module docstring).
    Not for a process that goes on working after its node (e.g. a test): it would be ended.
    """
    faulthandler.dump_traceback_later(grace, exit=True, file=sys.stderr)


def publish_all(node: Node, publishers: Mapping[str, Publisher], messages: Mapping[str, Any]) -> None:
    """Publish each message on the publisher of its topic, from a thread of the node's own.

    A signal may shut the context down between two publishes: the rest is then dropped silently (there is
    nobody to send to); any other failure propagates.
    """
    try:
        for topic, msg in messages.items():
            publishers[topic].publish(msg)
    except Exception:
        if node.context.ok():
            raise
