"""The Jazzy node run idiom, written once: init, build the node, spin, shut down cleanly.

SIGINT and SIGTERM both end the process with exit code 0 and no traceback: rclpy's own signal
handlers (installed by ``rclpy.init`` for both signals) shut the context down, the executor raises
``ExternalShutdownException``, and the node is destroyed before ``rclpy.try_shutdown``.

Python's own SIGINT handling is switched off first, the executor is a
:class:`~grasp_intent_ros.ros.compat.ShutdownSafeExecutor` and a
:class:`~grasp_intent_ros.ros.compat.StopWatcher` wakes it for a stop request: three workarounds of
rclpy 7.1's signal handling (:mod:`grasp_intent_ros.ros.compat` says what each works around). A signal
that arrives while the node is being built (its rcl calls then fail on the shut-down context) also exits
0; one that arrives before ``rclpy.init`` (during imports) gets Python's default handling. A
configuration error found while the node is built (a parameter rejected by its descriptor or validator,
a missing model) is logged and ends the process with exit code 1.

A stop request that has not ended the process :data:`SHUTDOWN_GRACE` seconds later is ended by a
watchdog (the stop watcher's thread arms it): it logs an ERROR, writes every thread's stack to stderr
(``faulthandler``) and exits with code :data:`~grasp_intent_ros.ros.startup.WATCHDOG_EXIT_CODE`, so
that a stop request always ends the node, leaves the evidence in its log and tells its parent. This covers
a hung shutdown (executor, node and context, after the spin has ended) and a spin that a stop did not
end. Two seconds later still, ``faulthandler``'s own timer (a C thread,
which needs no GIL) writes the stacks and exits with code 1, for a hang that holds the GIL (it is armed again
from the main thread when the spin ends, before the teardown, which may hold the GIL from its start: the
middleware's shutdown livelock of docs/nodes.md). Once run_node
has returned (the shutdown finished), both are disarmed and the process is left alone. A node process's
``main`` then calls :func:`guard_exit`: the interpreter's own exit (atexit handlers, threads, the
middleware's destructors) gets the same grace, after which faulthandler writes the stacks and exits with
code 1, so that no hang, not even one after the node's shutdown, passes without output.

A stop during a worker thread's long work (a model's first robustness estimate, a compile) does not wait
for it: the node's ``destroy_node`` waits at most :data:`~grasp_intent_ros.latest_only.FINISH_WAIT` s per
thread (:meth:`WorkerThread.stop <grasp_intent_ros.latest_only.WorkerThread.stop>`), and :func:`guard_exit`
then ends the process at once with code 0 (``os._exit``), saying on stderr which threads it left. Not the
interpreter's exit: it would finalize the modules while the thread may still run in their compiled code, and
it has nothing left to do: the shutdown has finished by then (rclpy's logging too).
"""

from __future__ import annotations

import ctypes
import faulthandler
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import rclpy
import rclpy.logging
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node
from rclpy.publisher import Publisher

from ..errors import GraspIntentError
from ..latest_only import left_running
from .compat import ShutdownSafeExecutor, StopWatcher, ignore_python_sigint
from .params import ParameterError
from .startup import announce_ready

__all__ = ['run_node', 'guard_exit', 'publish_all', 'release_free_memory', 'STARTUP_ERRORS', 'SHUTDOWN_GRACE']

STARTUP_ERRORS: tuple[type[Exception], ...] = (ParameterError, ParameterException, GraspIntentError)
"""Errors a node constructor raises for bad configuration: reported in one line, exit code 1."""

SHUTDOWN_GRACE = 5.0
"""Seconds a stop request may take to end a node before the watchdog ends the process."""

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
    watcher: StopWatcher | None = None
    try:
        executor = ShutdownSafeExecutor() if executor_factory is None else executor_factory()
        watcher = StopWatcher(rclpy.get_default_context(), executor.wake, shutdown_grace)
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
        if not getattr(node, 'announces_ready', False):  # a node that warms up announces it itself
            announce_ready(node.get_logger().info)
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
    A process whose stop left a worker thread at its work (:func:`~grasp_intent_ros.latest_only.left_running`)
    exits here at once, with code 0. Not for a process that goes on working after its node (e.g. a test): it
    would be ended.
    """
    if busy := left_running():  # module docstring: not the interpreter's exit under a thread in compiled code
        print(f'stopped while {", ".join(busy)} worked: not waiting for it', file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(0)
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
