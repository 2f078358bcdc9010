"""A child process that ends with the process that started it (Linux ``PR_SET_PDEATHSIG``).

:func:`ended_with_this_process` is the ``preexec_fn`` every node process gets
(:class:`~grasp_intent_ros.launch.process.NodeProcess`): a test run, suite command or benchmark killed
without its cleanup (SIGKILL, a crash) leaves no node serving on its ROS domain.

Never imports rclpy.
"""

from __future__ import annotations

import ctypes
import os
import signal
from collections.abc import Callable

__all__ = ['ended_with_this_process']

_PR_SET_PDEATHSIG = 1
"""prctl(2) option: the signal this process gets when the thread that started it ends."""


def ended_with_this_process(then: Callable[[], None] | None = None) -> Callable[[], None]:
    """A ``preexec_fn`` for :class:`subprocess.Popen`: the child gets SIGTERM when this thread ends.

    Run in the child: ``prctl(PR_SET_PDEATHSIG, SIGTERM)``, so the kernel sends SIGTERM to the child when the
    thread that started it ends (the whole process killed, even by SIGKILL, included); a child whose parent
    has already ended by then ends itself by SIGTERM; then ``then``. Where prctl(2) is not available (not
    Linux), only ``then`` runs. The C function is looked up here, in the parent: between fork and exec the
    child only calls it.
    """
    parent_pid = os.getpid()
    libc = ctypes.CDLL(None, use_errno=True)
    prctl = getattr(libc, 'prctl', None)

    def in_child() -> None:
        if prctl is not None:
            prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
            if os.getppid() != parent_pid:
                os.kill(os.getpid(), signal.SIGTERM)
        if then is not None:
            then()

    return in_child
