"""grasp_intent_ros.ros.worker: the latest-only worker (plain threads; no ROS graph needed)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from grasp_intent_ros.latest_only import FINISH_WAIT, left_running
from grasp_intent_ros.ros.worker import LatestOnlyWorker


def wait(predicate: Callable[[], bool], timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() >= deadline:
            return predicate()
        time.sleep(0.001)
    return True


def blocking_handler() -> tuple[threading.Event, threading.Event, list[int], Callable[[int], None]]:
    """(busy, release, handled, handle): ``handle`` sets busy, waits for release, then records its value."""
    busy, release = threading.Event(), threading.Event()
    handled: list[int] = []

    def handle(value: int) -> None:
        busy.set()
        release.wait(5.0)
        handled.append(value)
    return busy, release, handled, handle


def test_newest_snapshot_only_never_a_backlog() -> None:
    busy, release, handled, handle = blocking_handler()
    worker = LatestOnlyWorker(0, handle, name='test_worker')
    try:
        worker.update(lambda _: 1)
        assert busy.wait(5.0)  # handling 1; the next updates replace each other meanwhile
        for value in range(2, 10):
            worker.update(lambda _, value=value: value)
        release.set()
        assert wait(lambda: handled == [1, 9]), handled
        assert worker.superseded == 7 and worker.latest == 9
        worker.update(lambda v: v + 100, trigger=False)  # stored, not handled
        worker.update(lambda v: v + 1)
        assert wait(lambda: handled == [1, 9, 110]), handled
    finally:
        worker.stop()
    assert worker.stopping


def test_not_ready_snapshots_wait_for_the_next_update_and_min_period_spaces_them() -> None:
    starts: list[float] = []
    worker = LatestOnlyWorker(0, lambda _: starts.append(time.monotonic()), name='test_worker',
                              ready=lambda value: value >= 2, min_period=lambda: 0.2)
    try:
        worker.update(lambda _: 1)
        worker.update(lambda _: 2)
        assert wait(lambda: len(starts) == 1)
        worker.update(lambda _: 3)
        assert wait(lambda: len(starts) == 2)
        assert starts[1] - starts[0] >= 0.2
    finally:
        worker.stop()


def test_prepare_runs_once_in_the_thread_before_anything_is_handled() -> None:
    order: list[tuple[str, str]] = []
    prepared = threading.Event()

    def prepare() -> None:
        order.append(('prepare', threading.current_thread().name))
        prepared.wait(5.0)

    worker = LatestOnlyWorker(0, lambda v: order.append((f'handle {v}', threading.current_thread().name)),
                              name='test_worker', prepare=prepare)
    try:
        worker.update(lambda _: 1)  # arrives while the thread prepares: handled after
        assert wait(lambda: bool(order))
        prepared.set()
        assert wait(lambda: len(order) == 2), order
        assert order == [('prepare', 'test_worker'), ('handle 1', 'test_worker')]
    finally:
        worker.stop()


def test_an_update_hands_an_idle_thread_the_gil_and_a_busy_one_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    yields: list[str] = []
    sleep = time.sleep

    def recording_sleep(seconds: float) -> None:
        if seconds == 0 and threading.current_thread() is threading.main_thread():
            yields.append('yield')  # time.sleep(0) releases the GIL: the woken thread runs at once
        sleep(seconds)
    monkeypatch.setattr(time, 'sleep', recording_sleep)  # the module the worker calls
    busy, release, handled, handle = blocking_handler()
    worker = LatestOnlyWorker(0, handle, name='test_worker')
    try:
        assert wait(lambda: worker.idle)
        worker.update(lambda _: 1, trigger=False)  # stored only: nothing to hand over
        assert yields == []
        worker.update(lambda _: 2)
        assert yields == ['yield']
        assert busy.wait(5.0) and not worker.idle
        worker.update(lambda _: 3)  # the thread is busy: it takes this one when it is done, no hand-over
        assert yields == ['yield']
        release.set()
        assert wait(lambda: handled == [2, 3] and worker.idle), handled
    finally:
        worker.stop()


def test_stop_waits_for_long_work_at_most_finish_wait_and_the_thread_ends_after_it_handling_nothing_more() -> None:
    busy, release, handled = threading.Event(), threading.Event(), []

    def handle(value: int) -> None:
        busy.set()
        release.wait(10.0)  # far beyond the bound: never set before the stop has returned
        handled.append(value)

    worker = LatestOnlyWorker(0, handle, name='test_busy_worker')
    try:
        worker.update(lambda _: 1)
        assert busy.wait(5.0)
        worker.update(lambda _: 2)  # waits behind the work in progress
        start = time.monotonic()
        assert not worker.stop(), 'the thread cannot have ended: its work goes on'
        took = time.monotonic() - start
        assert FINISH_WAIT <= took < FINISH_WAIT + 0.5, took
        assert 'test_busy_worker' in left_running() and worker.stopping
    finally:
        release.set()
    assert wait(lambda: 'test_busy_worker' not in left_running())
    assert handled == [1], 'the update that waited behind the work was handled after the stop'
    assert worker.stop()  # ended: joined at once, its wait closed


def test_stop_does_not_wait_for_a_preparation_beyond_the_bound_and_nothing_is_handled_after_it() -> None:
    release, handled = threading.Event(), []
    worker = LatestOnlyWorker(0, handled.append, name='test_preparing_worker', prepare=lambda: release.wait(30.0))
    try:
        assert worker.preparing
        worker.update(lambda _: 1)
        start = time.monotonic()
        assert not worker.stop()  # returns while the preparation goes on (a compile cannot be cut short)
        assert time.monotonic() - start < FINISH_WAIT + 0.5
        assert worker.preparing and worker.stopping and 'test_preparing_worker' in left_running()
    finally:
        release.set()
    assert wait(lambda: not worker.preparing)
    assert worker.stop()  # now it joins the thread, which ends without handling the update
    assert handled == [] and 'test_preparing_worker' not in left_running()


def test_a_stop_from_the_thread_itself_asks_only() -> None:
    stopped: list[bool] = []
    worker: LatestOnlyWorker[int] = LatestOnlyWorker(0, lambda _: stopped.append(worker.stop()), name='test_worker')
    worker.update(lambda _: 1)
    assert wait(lambda: bool(stopped)) and stopped == [False] and worker.stopping
    assert wait(lambda: 'test_worker' not in left_running())
    assert worker.stop()


# ------------------------------------------------------------ a worker that takes a subscription (ROS)
def test_a_taken_subscription_is_handled_in_the_worker_thread_and_the_executor_stays_asleep(ros, capfd) -> None:
    """Its messages reach the callback in the worker's thread, whose update is handled in the same wake-up.

    The node's executor never wakes for them: while they wait unread, each of its waits ends with work or with
    its timeout, never with nothing to do. Before the worker also waited on the subscription's QoS event
    handler, the executor waited on that handler alone, woke at every message (Fast DDS shares one status
    condition between a reader and its events) and found nothing to do, over and over: its thread used all
    the CPU of the spin below while the messages waited. The executor's waits are counted by its gathering of
    the node's other subscription, which it does once before each wait.
    """
    import rclpy
    from rclpy.qos import ReliabilityPolicy
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import input_qos

    node = ros.add(rclpy.create_node('worker_probe', context=ros.context))
    handled: list[tuple[int, str]] = []
    release = threading.Event()
    release.set()

    def handle(value: int) -> None:
        release.wait(10.0)
        handled.append((value, threading.current_thread().name))

    worker = LatestOnlyWorker(0, handle, name='test_worker', context=ros.context)
    received: list[str] = []

    def on_message(msg: Float64MultiArray, info: object) -> None:
        received.append(threading.current_thread().name)
        worker.update(lambda v: v + 1)

    try:
        with pytest.raises(ValueError, match='callback group'):
            worker.take(other := node.create_subscription(Float64MultiArray, 'other', on_message, input_qos()))
        worker.take(node.create_subscription(Float64MultiArray, 'taken', on_message, input_qos(depth=100),
                                             callback_group=worker.callback_group))
        pub = ros.publisher(Float64MultiArray, 'taken')
        assert ros.wait_for(lambda: pub.get_subscription_count() == 1, 10.0)
        for _ in range(20):
            pub.publish(Float64MultiArray(data=[1.0]))
        assert wait(lambda: len(received) == 20 and handled and handled[-1][0] == 20), (received, handled)
        assert set(received) == {'test_worker'} and {name for _, name in handled} == {'test_worker'}

        # messages wait unread while the worker is busy; the executor spins for 0.5 s meanwhile
        release.clear()
        pub.publish(Float64MultiArray(data=[1.0]))
        assert wait(lambda: len(received) == 21)  # the worker handles it and blocks
        for _ in range(5):
            pub.publish(Float64MultiArray(data=[1.0]))
        ros.executor.spin_once(timeout_sec=0.0)  # the wake-up rclpy left for the subscriptions made above
        waits, spins = 0, 0
        gathers = ros.executor.can_execute

        def counting(entity: object) -> bool:
            nonlocal waits
            waits += entity is other
            return gathers(entity)

        ros.executor.can_execute, end = counting, time.monotonic() + 0.5
        try:
            while (left := end - time.monotonic()) > 0.0:
                ros.executor.spin_once(timeout_sec=left)  # after work or its timeout; a wake for nothing waits again
                spins += 1
        finally:
            del ros.executor.can_execute
        release.set()
        assert wait(lambda: len(received) == 26 and handled[-1][0] == 26), (len(received), handled[-1])
        assert waits <= spins, f'the executor woke {waits - spins} times for nothing: for the taken subscription'

        # the subscription's incompatible-QoS warning comes from the worker's thread
        best_effort = input_qos()
        best_effort.reliability = ReliabilityPolicy.BEST_EFFORT
        worker.take(node.create_subscription(Float64MultiArray, 'strict', on_message, input_qos(),
                                             callback_group=worker.callback_group))
        ros.publisher(Float64MultiArray, 'strict', best_effort)
        err: list[str] = []
        expected = "New publisher discovered on topic 'strict', offering incompatible QoS"  # rclpy's default handler
        assert wait(lambda: err.append(capfd.readouterr().err) or expected in ''.join(err), 10.0), err
    finally:
        worker.stop()
    worker.stop_soon()  # after the stop (as a context's shutdown callback may): nothing happens
