"""grasp_intent_ros.ros.worker: the latest-only worker (plain threads; no ROS graph needed)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from grasp_intent_ros.ros.worker import LatestOnlyWorker


def wait(predicate: Callable[[], bool], timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() >= deadline:
            return predicate()
        time.sleep(0.001)
    return True


def test_newest_snapshot_only_never_a_backlog() -> None:
    busy, release = threading.Event(), threading.Event()
    handled: list[int] = []

    def handle(value: int) -> None:
        busy.set()
        release.wait(5.0)
        handled.append(value)

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
