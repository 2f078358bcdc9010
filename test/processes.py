"""Process helpers for the tests that start real processes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest

from grasp_intent_ros.launch.parent_death import ended_with_this_process

REPO = Path(__file__).resolve().parents[1]
REPLAY_TIMEOUT = 120.0
"""Seconds one replay command may take before it is stopped (SIGTERM, then SIGKILL)."""


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


def replay(bag: Path, domain_id: int, *extra: str, fast: bool = True) -> subprocess.CompletedProcess[str]:
    """``python -m grasp_intent_ros replay BAG --check [--fast] --start-suite <extra>`` on ``domain_id`` (LOCALHOST).

    Stopped by PID (SIGTERM: it stops its suite, then SIGKILL) and the test failed if it overruns
    :data:`REPLAY_TIMEOUT`.
    """
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'ROS_DOMAIN_ID': str(domain_id),
           'PYTHONUNBUFFERED': '1'}
    env.pop('ROS_STATIC_PEERS', None)
    cmd = [sys.executable, '-m', 'grasp_intent_ros', 'replay', str(bag), '--check', *(['--fast'] if fast else []),
           '--start-suite', *extra]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=REPLAY_TIMEOUT)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGTERM)
        try:
            out, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
        pytest.fail(f'replay of {bag.name} did not finish within {REPLAY_TIMEOUT:g} s:\n{out}\n{err}')
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)
