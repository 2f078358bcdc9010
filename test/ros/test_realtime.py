"""raise_to_fifo: every thread of the process, set back when one is refused; no real priority is set here."""

from __future__ import annotations

import errno
import os
import threading

import pytest

from grasp_intent_ros.ros import realtime


def test_every_thread_is_asked_for_fifo_reset_on_fork_and_all_set_back_when_one_is_refused(monkeypatch) -> None:
    calls: list[tuple[int, int, int]] = []
    refuse = {'at': None}

    def fake(tid: int, policy: int, param: os.sched_param) -> None:
        if policy != os.SCHED_OTHER and len(calls) == refuse['at']:
            raise PermissionError(errno.EPERM, 'Operation not permitted')
        calls.append((tid, policy, param.sched_priority))

    stop = threading.Event()
    helper = threading.Thread(target=stop.wait)
    helper.start()
    try:
        monkeypatch.setattr(os, 'sched_setscheduler', fake)
        tids = set(realtime.thread_policies())
        assert len(tids) >= 2 and os.getpid() in tids
        assert realtime.raise_to_fifo(50) == ''
        assert {tid for tid, _, _ in calls} == tids
        assert {(policy, priority) for _, policy, priority in calls} == {
            (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50)}
        calls.clear()
        refuse['at'] = 1  # the second thread refused: the first set back to the normal policy
        assert realtime.raise_to_fifo(50) == 'PermissionError: Operation not permitted'
        assert [(policy, priority) for _, policy, priority in calls] == [
            (os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 50), (os.SCHED_OTHER, 0)]
        assert calls[0][0] == calls[1][0]
    finally:
        stop.set()
        helper.join()


@pytest.mark.parametrize('priority', [0, 100])
def test_a_priority_outside_1_to_99_is_a_callers_error(priority: int) -> None:
    with pytest.raises(ValueError, match='1-99'):
        realtime.raise_to_fifo(priority)
