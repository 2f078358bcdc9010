"""System-test fixtures: nodes as real ``python -m grasp_intent_ros.<node>`` processes.

Every process gets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and the test's own ROS_DOMAIN_ID (the same
one as the test's in-process ``ros`` harness, which talks to the processes over loopback DDS). At
teardown each process still running gets SIGTERM and must exit with code 0 within a deadline (else
SIGKILL and the test errors); only processes started here are ever signalled, by PID.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

from grasp_intent_ros.processes import NodeProcess, node_environment

REPO = Path(__file__).resolve().parents[2]


class Launcher:
    """Starts node processes for one test on its domain id."""

    def __init__(self, domain_id: int, log_dir: Path) -> None:
        self.domain_id = domain_id
        self.log_dir = log_dir
        self.processes: list[NodeProcess] = []
        self.env = node_environment(domain_id)

    def start(self, module: str, *ros_args: str) -> NodeProcess:
        """``python -m grasp_intent_ros.<module> --ros-args <ros_args>``, in the repository."""
        proc = NodeProcess.start(module, ros_args, env=self.env, log_dir=self.log_dir,
                                 prefix=f'{len(self.processes):02d}_', cwd=REPO)
        self.processes.append(proc)
        return proc

    def stop_all(self) -> list[str]:
        """SIGTERM every process still running; the problems found (non-zero exit, traceback, killed)."""
        problems = []
        for proc in self.processes:
            if proc.poll() is not None:
                continue
            proc.stop(signal.SIGTERM)
            if problem := proc.problem():
                problems.append(f'{problem}:\n{proc.stderr_tail(40)}')
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
