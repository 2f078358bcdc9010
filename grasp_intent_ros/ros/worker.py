"""Work off the node's executor: a latest-only worker, and an input thread that answers every message.

Latest-only worker: callbacks store the newest inputs, one thread handles the newest snapshot.

The node's executor thread never blocks on a long computation (a plan), and the thread never works
through a backlog: inputs that arrive while it is busy replace each other, and it takes the newest
snapshot when it is free again. Nothing here knows message types: it is rclpy's threading idiom, written once.

The hand-over: an update that finds the thread idle also hands it the GIL at once (``time.sleep(0)``
releases it). Otherwise the woken thread waits for the GIL until the updating thread gives it up by
itself: an rclpy executor thread does so only when it blocks in its next wait, after building the wait
set (a few hundred microseconds of Python), or when the switch interval forces it (``sys.getswitchinterval``,
the planner's 0.5 ms), which the hand-over saves on every update.

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

import math
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, Generic, TypeVar, cast

from rclpy.callback_groups import CallbackGroup
from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from rclpy.subscription import Subscription

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


class _EventWait:
    """The worker thread waits on a ``threading.Event`` (a worker without ROS)."""

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


class _OffExecutorThread:
    """What the module's threads share: the thread, its wait (an Event or an rclpy wait set), stopping."""

    def __init__(self, wait: _EventWait | _WaitSetWait, name: str) -> None:
        self._wait = wait
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

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

    def stop_soon(self) -> None:
        """Ask the thread to stop after its current work (safe from any thread and a signal handler)."""
        self._stop.set()
        self._wait.wake()

    def stop(self) -> None:
        """Stop the thread and wait for it (unless called from it); then release its guard condition, if any."""
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


class LatestOnlyWorker(_OffExecutorThread, Generic[T]):
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
        work overlaps with what the node waits for at start (discovery, its first inputs). It must not raise.
    context : rclpy Context, optional
        The node's context: the thread then waits in an rclpy wait set and can take subscriptions
        (:meth:`take`); without one it waits on a ``threading.Event``.
    """

    def __init__(self, initial: T, handle: Callable[[T], object], *, name: str,
                 ready: Callable[[T], bool] = lambda _: True,
                 min_period: Callable[[], float] = lambda: 0.0,
                 prepare: Callable[[], object] | None = None,
                 context: Context | None = None) -> None:
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
        # a subscription's callback that calls update() (in this thread) has it handled in the same wake-up
        super().__init__(_EventWait() if context is None else _WaitSetWait(context, name), name)

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


class InputThread(_OffExecutorThread):
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
