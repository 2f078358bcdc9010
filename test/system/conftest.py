"""System-test fixtures: nodes as real ``python -m grasp_intent_ros.<node>`` processes.

Every process gets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and the test's own ROS_DOMAIN_ID (the same
one as the test's in-process ``ros`` harness, which talks to the processes over loopback DDS): one
:class:`~grasp_intent_ros.launch.suite.NodeSuite` per test. At teardown each process still running gets
SIGTERM and must exit with code 0 within a deadline (else SIGKILL and the test errors); only processes
started here are ever signalled, by PID.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

from grasp_intent_ros.launch.suite import NodeSuite

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def launch(domain_id: int, tmp_path: Path) -> Iterator[NodeSuite]:
    """A :class:`NodeSuite` on the test's domain id, run in the repository, logs numbered in ``tmp_path``.

    Stops its processes at teardown and asserts a clean exit (code 0, no traceback) on SIGTERM.
    """
    suite = NodeSuite(domain_id, log_dir=tmp_path, cwd=REPO, numbered_logs=True)
    try:
        yield suite
    finally:
        problems = suite.stop(signal.SIGTERM, tail_lines=40, include_exited=False)
    assert not problems, '\n'.join(problems)
