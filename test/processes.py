"""Process helpers for the tests that start real processes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

from grasp_intent_ros.launch.parent_death import ended_with_this_process


def alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (a zombie counts: it has not been reaped)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@contextmanager
def suite_command(args: Sequence[str], *, cwd: Path, out: Path,
                  env: Mapping[str, str] | None = None) -> Iterator[subprocess.Popen[bytes]]:
    """``python -m grasp_intent_ros suite <args>`` in a session of its own, stdout and stderr written to ``out``.

    Ended with its whole process group (SIGKILL) if it still runs when the block is left, and with this process.
    """
    with out.open('w') as file:
        suite = subprocess.Popen([sys.executable, '-m', 'grasp_intent_ros', 'suite', *args], cwd=cwd, env=env,
                                 stdout=file, stderr=subprocess.STDOUT, start_new_session=True,
                                 preexec_fn=ended_with_this_process())
    try:
        yield suite
    finally:
        if suite.poll() is None:
            os.killpg(suite.pid, signal.SIGKILL)
            suite.wait()


def ctrl_c(suite: subprocess.Popen[bytes], timeout: float) -> int:
    """SIGINT to the suite command's process group, as a terminal's Ctrl-C; its exit code (TimeoutExpired)."""
    os.killpg(suite.pid, signal.SIGINT)
    return suite.wait(timeout)
