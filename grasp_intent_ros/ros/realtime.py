"""A node process's threads at a real-time priority (Linux ``SCHED_FIFO``), opt-in, never fatal.

:func:`raise_to_fifo` sets every thread the process has at the call (the executor's, which calls it, and the
middleware's receive and event threads, which carry each input to the executor) to ``SCHED_FIFO`` at the given
priority, with ``SCHED_RESET_ON_FORK``: a thread or process started afterwards (e.g. a child interpreter) starts at
the normal policy (``SCHED_OTHER``), so a node raises only what it had when it called, e.g. after its warm-up and
after starting its helper processes. A ``SCHED_FIFO`` thread runs before every ``SCHED_OTHER`` thread on its core
whenever it is runnable; the kernel's real-time throttling (``/proc/sys/kernel/sched_rt_runtime_us``, 0.95 s of
each second by default) keeps the rest for the others, so a node that raises itself must do little per wake-up.

It needs the privilege (``CAP_SYS_NICE``, or ``RLIMIT_RTPRIO`` at least the priority: e.g. ``ulimit -r 99`` or a
``rtprio`` line in /etc/security/limits.conf for the user); without it the threads stay as they were and the reason
is returned, for the node to warn and go on (the anchor: ros2_control's ``configure_sched_fifo`` in
``realtime_tools``, which the controller manager calls with its ``thread_priority`` and warns when it fails).

ROS-free; Linux only (``os.sched_setscheduler``): elsewhere the reason says so.
"""

from __future__ import annotations

import os
from collections.abc import Callable

__all__ = ['raise_to_fifo', 'apply_thread_priority', 'thread_policies', 'OFF']

OFF = 0
"""The priority that leaves the process's threads as they are (the parameter's default)."""

_RESET_ON_FORK: int = getattr(os, 'SCHED_RESET_ON_FORK', 0)


def thread_policies(pid: int | str = 'self') -> dict[int, int]:
    """Thread id -> scheduling policy (``os.SCHED_*``, the reset-on-fork flag removed) of every thread of ``pid``.

    Read from ``/proc/<pid>/task``; a thread that ends while it is read is left out. Raises OSError when the
    process does not exist.
    """
    policies = {}
    for entry in os.listdir(f'/proc/{pid}/task'):
        try:
            policies[int(entry)] = os.sched_getscheduler(int(entry)) & ~_RESET_ON_FORK
        except ProcessLookupError:
            continue  # the thread ended meanwhile
    return policies


def raise_to_fifo(priority: int) -> str:
    """Every thread of this process at ``SCHED_FIFO`` ``priority`` (1-99), reset on fork; '' done, else the reason.

    On a failure (no privilege: PermissionError; no such policy on this system) the threads already changed are set
    back to ``SCHED_OTHER`` and the reason is returned; nothing raises. A thread that ends meanwhile is skipped.

    Raises
    ------
    ValueError
        For a priority outside 1-99 (a caller's error: the parameter's range excludes it).
    """
    if not 1 <= priority <= 99:
        raise ValueError(f'a SCHED_FIFO priority is 1-99, got {priority}')
    if not hasattr(os, 'sched_setscheduler'):
        return 'SCHED_FIFO is not available on this system'
    done: list[int] = []
    try:
        for tid in thread_policies():
            try:
                os.sched_setscheduler(tid, os.SCHED_FIFO | _RESET_ON_FORK, os.sched_param(priority))
            except ProcessLookupError:
                continue
            done.append(tid)
    except OSError as exc:
        for tid in done:
            try:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            except OSError:
                pass  # ended meanwhile: lowering needs no privilege
        return f'{type(exc).__name__}: {exc.strerror or exc}'
    return ''


def apply_thread_priority(priority: int, *, report: Callable[[str, str], object],
                          warn: Callable[[str], object]) -> None:
    """A node's ``thread_priority``: :data:`OFF` leaves all as it is; 1-99 :func:`raise_to_fifo`, never raising.

    Then ``report('thread_priority', got)`` with ``'SCHED_FIFO <priority>'`` or ``'normal'`` (e.g. a
    :meth:`NodeDiagnostics.set_value <grasp_intent_ros.ros.diagnostics.NodeDiagnostics.set_value>`), and, when it was
    refused, ``warn(text)`` with the reason (e.g. a WARN status and a log line); the node runs on either way.
    """
    if priority == OFF:
        return
    reason = raise_to_fifo(priority)
    report('thread_priority', 'normal' if reason else f'SCHED_FIFO {priority}')
    if reason:
        warn(f'thread_priority {priority} not set ({reason}): running at the normal priority')
