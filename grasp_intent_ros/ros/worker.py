"""Work off the node's executor: a latest-only worker that can take subscriptions, and an input thread.

The latest-only worker itself (callbacks store the newest inputs, one thread handles the newest snapshot)
is ROS-free: :mod:`grasp_intent_ros.latest_only`. This module adds what needs rclpy.

Taken subscriptions: a worker built with an rclpy ``context`` can take a subscription's messages in its own
thread (:meth:`LatestOnlyWorker.take`) instead of the node's executor; an :class:`InputThread` does only
that, for an input whose every message must be answered. The thread then waits in an rclpy
wait set (the subscriptions it takes and a guard condition that updates trigger), as
``rclpy.wait_for_message`` does, and runs their callbacks itself: the input that triggers the work reaches
it without a hand-over between threads, and the node's executor thread, which would otherwise wake for
every such message, build its wait sets in Python and contend for the GIL with the work, stays asleep.
Such a subscription is created in the worker's :attr:`~LatestOnlyWorker.callback_group`, which no executor
runs; the worker's thread also runs the subscription's QoS event handlers.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, TypeVar, cast

from rclpy.callback_groups import CallbackGroup
from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from rclpy.subscription import Subscription

from .. import latest_only
from ..latest_only import Wait, WorkerThread
from .compat import new_wait_set, waiting_messages

__all__ = ['LatestOnlyWorker', 'InputThread']

T = TypeVar('T')


class _TakenByWorker(CallbackGroup):
    """A callback group that no executor runs: a worker's thread waits on its entities (:meth:`LatestOnlyWorker.take`).

    That includes the subscriptions' QoS event handlers: an executor that waited on those alone would wake at
    every message of their subscription (Fast DDS shares one status condition between a reader and its
    events) and find nothing to do, over and over (seen: the executor thread at 100% CPU).
    """

    def can_execute(self, entity: Any) -> bool:
        return False

    def beginning_execution(self, entity: Any) -> bool:
        return False

    def ending_execution(self, entity: Any) -> None:
        pass


class _WaitSetWait:
    """The worker thread waits in an rclpy wait set: a guard condition (:meth:`wake`) and the taken subscriptions.

    After the wait, the messages waiting on a ready subscription (up to its queue depth) are taken
    (:func:`~grasp_intent_ros.ros.compat.waiting_messages`, as rclpy's executor takes them)
    and handed to the subscription's callback, with its message info, in the worker's thread; so is every
    QoS event of the subscriptions' event handlers (e.g. an incompatible publisher's warning). Once the
    context is shut down (a signal does so without waking anyone), :meth:`wait` returns False: the thread ends.
    """

    def __init__(self, context: Context, name: str) -> None:
        self._context, self._name = context, name
        self._guard = GuardCondition(None, None, context=context)
        self._closed = False
        self.callback_group = _TakenByWorker()
        self.subscriptions: list[Subscription] = []

    def take(self, subscription: Subscription) -> None:
        if subscription.callback_group is not self.callback_group:
            raise ValueError(f'{subscription.topic_name}: not created in the callback group of {self._name}')
        self.subscriptions.append(subscription)
        self.wake()

    def wake(self) -> None:
        try:
            self._guard.trigger()
        except InvalidHandle:  # closed: a stop request may come after it (a context's shutdown callbacks)
            pass

    def wait(self, timeout: float | None) -> bool:
        try:
            self._wait(timeout)
        except Exception:  # noqa: BLE001 - rcl refuses a wait set or a take on a context shut down meanwhile
            if self._context.ok():
                raise
        return self._context.ok()

    def _wait(self, timeout: float | None) -> None:
        subscriptions = tuple(self.subscriptions)
        # rclpy annotates event_handlers as one EventHandler; it is a list of them
        events: list[EventHandler] = [handler for subscription in subscriptions
                                      for handler in cast(list[EventHandler], subscription.event_handlers)]
        context = self._context.handle
        if context is None:  # not initialised or destroyed: nothing to wait for
            raise RuntimeError(f'{self._context} has no rcl context')
        with ExitStack() as handles:
            handles.enter_context(context)
            handles.enter_context(self._guard.handle)
            for subscription in subscriptions:
                handles.enter_context(subscription.handle)
            for handler in events:
                handles.enter_context(handler)
            wait_set = new_wait_set(len(subscriptions), 1,
                                    sum(handler.get_num_entities().num_events for handler in events), context)
            wait_set.clear_entities()
            for subscription in subscriptions:
                wait_set.add_subscription(subscription.handle)
            for handler in events:
                handler.add_to_wait_set(wait_set)
            wait_set.add_guard_condition(self._guard.handle)
            wait_set.wait(-1 if timeout is None else round(timeout * 1e9))
            ready = wait_set.get_ready_entities('subscription')
            for handler in events:
                if handler.is_ready(wait_set) and (event := handler.take_data()):
                    handler.callback(event)
            for subscription in subscriptions:  # at most a queue's depth each: a fast stream cannot hold the thread
                if subscription.handle.pointer in ready:
                    for taken in waiting_messages(subscription, subscription.qos_profile.depth):
                        subscription.callback(*taken)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._guard.destroy()
            self.subscriptions.clear()


class _Taking:
    """Subscriptions taken in a worker's own thread (an rclpy wait set), off the node's executor."""

    _wait: Wait
    _thread: threading.Thread

    @property
    def callback_group(self) -> CallbackGroup:
        """The callback group of the subscriptions this thread takes (:meth:`take`); only with a context."""
        return self._taking().callback_group

    def take(self, subscription: Subscription) -> None:
        """Take ``subscription``'s messages in this thread: its callback runs there, with the message info.

        The subscription must have been created in :attr:`callback_group` (no executor takes it then) with a
        callback of two parameters (message, info).
        """
        self._taking().take(subscription)

    def _taking(self) -> _WaitSetWait:
        if not isinstance(self._wait, _WaitSetWait):
            raise ValueError(f'{self._thread.name}: a thread without an rclpy context takes no subscriptions')
        return self._wait


class LatestOnlyWorker(_Taking, latest_only.LatestOnlyWorker[T]):
    """:class:`grasp_intent_ros.latest_only.LatestOnlyWorker`, which can also take subscriptions.

    Parameters
    ----------
    initial, handle, name, ready, min_period, prepare
        As for :class:`grasp_intent_ros.latest_only.LatestOnlyWorker`.
    context : rclpy Context, optional
        The node's context: the thread then waits in an rclpy wait set and can take subscriptions
        (:meth:`take`); without one it waits on a ``threading.Event``.
    """

    def __init__(self, initial: T, handle: Callable[[T], object], *, name: str,
                 ready: Callable[[T], bool] = lambda _: True,
                 min_period: Callable[[], float] = lambda: 0.0,
                 prepare: Callable[[], object] | None = None,
                 context: Context | None = None) -> None:
        # a subscription's callback that calls update() (in this thread) has it handled in the same wake-up
        super().__init__(initial, handle, name=name, ready=ready, min_period=min_period, prepare=prepare,
                         wait=None if context is None else _WaitSetWait(context, name))


class InputThread(_Taking, WorkerThread):
    """A thread of its own that takes subscriptions' messages and runs their callbacks, off the node's executor.

    For a node that must answer every message of a fast input: its executor would wake for each message (or
    batch), build its wait sets in Python and contend for the GIL; this thread waits in one small wait set
    and runs the callbacks (module docstring, "Taken subscriptions"). The waiting messages are taken in
    order, up to the queue's depth per wake-up. The callbacks must not raise (wrap them, e.g. with
    ``NodeDiagnostics.guard``), and they run concurrently with the node's executor: what they share with its
    callbacks needs a lock.

    Parameters
    ----------
    context : rclpy Context
        The node's context. The thread ends when it is shut down, or on :meth:`stop`.
    name : str
        Thread name.
    """

    def __init__(self, context: Context, *, name: str) -> None:
        super().__init__(_WaitSetWait(context, name), name)

    def _run(self) -> None:
        while not self._stop.is_set() and self._wait.wait(None):
            pass
