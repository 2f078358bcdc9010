"""Every workaround of rclpy's internals, in one place, each checked against :data:`CHECKED_RCLPY`.

rclpy 7.1 (ROS 2 Jazzy) as these nodes use it has three gaps that this module closes, and two of its private
interfaces that this package uses because the public ones cost too much. ``test/ros/test_compat.py`` fails
when the installed rclpy is not :data:`CHECKED_RCLPY`: then re-check each item below against the new
release's sources (``rclpy/executors.py``, ``rclpy/signals.py``, ``_rclpy_pybind11``'s ``signal_handler``),
drop what it fixed and update the version.

1. **SIGINT and Python's KeyboardInterrupt** (:func:`ignore_python_sigint`). rclpy chains its SIGINT handler
   to Python's, whose KeyboardInterrupt ends the spin while rclpy's signal thread is still triggering the
   executor's guard condition, which is then destroyed under it: a use-after-free (a segfault on about one
   SIGINT in five). Ignored at the Python level, SIGINT ends the spin as SIGTERM does.
2. **A shutdown between two executor steps** (:class:`ShutdownSafeExecutor`). The executor checks
   ``context.ok()`` and then builds the next wait set; a signal handled in between makes ``WaitSet()`` raise
   RCLError ("context is not valid"): a traceback and exit code 1 instead of a clean stop.
3. **The signal thread's order** (``ros.run``'s stop watcher). rclpy's C++ signal thread first triggers the
   executors' guard conditions, then shuts the contexts down: an executor that wakes in between finds no work
   and waits again, and nothing wakes it for the shutdown (in a node without timers, never). The run idiom's
   watcher polls the context and wakes the executor once it is shut down.
4. **Taking waiting messages in a burst** (:func:`take_waiting`): ``Subscription.handle.take_message``, as
   rclpy's executor takes them, so that one wake-up handles every waiting message.
5. **A wait set of the worker's own** (:func:`wait_and_dispatch`): ``rclpy.impl.implementation_singleton``'s
   ``WaitSet``, as rclpy's executor builds it, so that a worker thread waits on its own subscriptions
   without an executor (rclpy has no public wait-set API).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator, Mapping, Sequence
from contextlib import ExitStack
from importlib import metadata
from typing import Any, cast

from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription

__all__ = ['CHECKED_RCLPY', 'rclpy_version', 'ignore_python_sigint', 'ShutdownSafeExecutor', 'take_waiting',
           'wait_and_dispatch']

CHECKED_RCLPY = '7.1.5'
"""The rclpy release (its distribution's version) the workarounds were checked against: the PyPI wheel
ros-rclpy 7.1.6 installs rclpy 7.1.5."""


def rclpy_version() -> str:
    """The installed rclpy's version (its distribution metadata)."""
    return metadata.version('rclpy')


def ignore_python_sigint() -> None:
    """Item 1: SIGINT is left to rclpy's handler (call before ``rclpy.init``, from the main thread only)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


class ShutdownSafeExecutor(SingleThreadedExecutor):
    """Item 2: a SingleThreadedExecutor whose spin ends with ExternalShutdownException when shut down under it.

    Never with an RCLError.
    """

    def spin_once(self, timeout_sec: float | None = None) -> None:
        try:
            super().spin_once(timeout_sec)
        except RuntimeError:  # rclpy's RCLError derives from RuntimeError
            if self.context.ok():
                raise
            raise ExternalShutdownException() from None


def take_waiting(subscription: Subscription, limit: int) -> Iterator[tuple[bytes, Mapping[str, Any]]]:
    """Item 4: up to ``limit`` messages already waiting on the raw ``subscription``, in order, with their info."""
    for _ in range(limit):
        with subscription.handle:
            waiting = subscription.handle.take_message(subscription.msg_type, True)
        if waiting is None:
            return
        yield waiting


def wait_and_dispatch(context: Context, guard: GuardCondition, subscriptions: Sequence[Subscription],
                      timeout: float | None) -> None:
    """Item 5: wait until ``guard`` is triggered or a subscription or one of its QoS events is ready.

    Then hand every ready QoS event to its handler's callback and, for each ready subscription, the messages
    waiting on it (at most its queue's depth, so a fast stream cannot hold the thread) to its callback, with
    their info, in the calling thread. ``timeout`` in seconds; None: no limit.

    Raises
    ------
    RuntimeError
        If ``context`` has no rcl context; rcl's own errors when the context is shut down meanwhile.
    """
    # rclpy annotates event_handlers as one EventHandler; it is a list of them
    events: list[EventHandler] = [handler for subscription in subscriptions
                                  for handler in cast(list[EventHandler], subscription.event_handlers)]
    rcl_context = context.handle
    if rcl_context is None:  # not initialised or destroyed: nothing to wait for
        raise RuntimeError(f'{context} has no rcl context')
    with ExitStack() as handles:
        handles.enter_context(rcl_context)
        handles.enter_context(guard.handle)
        for subscription in subscriptions:
            handles.enter_context(subscription.handle)
        for handler in events:
            handles.enter_context(handler)
        wait_set = _rclpy.WaitSet(len(subscriptions), 1, 0, 0, 0,
                                  sum(handler.get_num_entities().num_events for handler in events), rcl_context)
        wait_set.clear_entities()
        for subscription in subscriptions:
            wait_set.add_subscription(subscription.handle)
        for handler in events:
            handler.add_to_wait_set(wait_set)
        wait_set.add_guard_condition(guard.handle)
        wait_set.wait(-1 if timeout is None else round(timeout * 1e9))
        ready = wait_set.get_ready_entities('subscription')
        for handler in events:
            if handler.is_ready(wait_set) and (event := handler.take_data()):
                handler.callback(event)
        for subscription in subscriptions:
            if subscription.handle.pointer in ready:
                for taken in take_waiting(subscription, subscription.qos_profile.depth):
                    subscription.callback(*taken)
