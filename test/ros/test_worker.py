"""grasp_intent_ros.ros.worker: the latest-only worker (plain threads; no ROS graph needed)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

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


def test_after_first_runs_once_in_the_thread_after_the_first_handled_snapshot() -> None:
    order: list[tuple[str, str]] = []
    worker = LatestOnlyWorker(0, lambda v: order.append((f'handle {v}', threading.current_thread().name)),
                              name='test_worker', ready=lambda value: value >= 2,
                              after_first=lambda: order.append(('after first', threading.current_thread().name)))
    try:
        worker.update(lambda _: 1)  # not ready: not handled, so not yet the first
        assert wait(lambda: worker.idle)
        assert order == []
        for value in (2, 3):
            worker.update(lambda _, value=value: value)
            assert wait(lambda: len(order) == value), order
    finally:
        worker.stop()
    assert order == [('handle 2', 'test_worker'), ('after first', 'test_worker'), ('handle 3', 'test_worker')]
