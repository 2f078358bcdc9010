"""System-test fixtures: nodes as real ``python -m grasp_intent_ros.<node>`` processes.

Every process gets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and the test's own ROS_DOMAIN_ID (the same
one as the test's in-process ``ros`` harness, which talks to the processes over loopback DDS). At
teardown each process still running gets SIGTERM and must exit with code 0 within a deadline (else
SIGKILL and the test errors); only processes started here are ever signalled, by PID.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
STOP_TIMEOUT = 10.0
"""Seconds a node gets to exit after SIGTERM/SIGINT before it is SIGKILLed."""


class NodeProcess:
    """One node process; stdout and stderr go to files (no pipe can fill up and block the node)."""

    def __init__(self, module: str, ros_args: list[str], env: dict[str, str], log_dir: Path,
                 index: int) -> None:
        self.module = module
        self.stdout_path = log_dir / f'{index:02d}_{module}.out'
        self.stderr_path = log_dir / f'{index:02d}_{module}.err'
        cmd = [sys.executable, '-m', f'grasp_intent_ros.{module}']
        if ros_args:
            cmd += ['--ros-args', *ros_args]
        with self.stdout_path.open('wb') as out, self.stderr_path.open('wb') as err:
            self.popen = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=out, stderr=err,
                                          stdin=subprocess.DEVNULL)

    @property
    def pid(self) -> int:
        return self.popen.pid

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors='replace')

    def stop(self, sig: int = signal.SIGTERM, timeout: float = STOP_TIMEOUT) -> int:
        """Send ``sig`` (unless already exited), wait up to ``timeout`` s, then SIGKILL. Returns the exit code
        (negative: killed by that signal)."""
        if self.popen.poll() is None:
            self.popen.send_signal(sig)
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        return self.popen.returncode


class Launcher:
    """Starts node processes for one test on its domain id."""

    def __init__(self, domain_id: int, log_dir: Path) -> None:
        self.domain_id = domain_id
        self.log_dir = log_dir
        self.processes: list[NodeProcess] = []
        self.env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                    'ROS_DOMAIN_ID': str(domain_id), 'PYTHONUNBUFFERED': '1',
                    'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}  # keep the log of a SIGKILLed node
        self.env.pop('ROS_STATIC_PEERS', None)

    def start(self, module: str, *ros_args: str) -> NodeProcess:
        """``python -m grasp_intent_ros.<module> --ros-args <ros_args>``."""
        proc = NodeProcess(module, list(ros_args), self.env, self.log_dir, len(self.processes))
        self.processes.append(proc)
        return proc

    def stop_all(self) -> list[str]:
        """SIGTERM every process still running; the problems found (non-zero exit, traceback)."""
        problems = []
        for proc in self.processes:
            if proc.popen.poll() is not None:
                continue
            code = proc.stop(signal.SIGTERM)
            if code != 0:
                problems.append(f'{proc.module} (pid {proc.pid}) exited with {code} on SIGTERM:\n'
                                f'{proc.stderr()[-2000:]}')
            elif 'Traceback' in proc.stderr():
                problems.append(f'{proc.module} (pid {proc.pid}) printed a traceback:\n'
                                f'{proc.stderr()[-2000:]}')
        return problems


@pytest.fixture
def launch(domain_id: int, tmp_path: Path) -> Iterator[Launcher]:
    """A :class:`Launcher` on the test's domain id; stops its processes at teardown and asserts a clean
    exit (code 0, no traceback) on SIGTERM."""
    launcher = Launcher(domain_id, tmp_path)
    try:
        yield launcher
    finally:
        problems = launcher.stop_all()
    assert not problems, '\n'.join(problems)
