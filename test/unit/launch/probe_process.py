"""A plain ``python -c`` process started as a node process ('probe'), for the launch tests: no ROS node."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.ros.startup import READY_LOG

SLEEPER = 'import time; time.sleep(60)'
READY_SLEEPER = f'print("[INFO] [1.0] [probe]: {READY_LOG}"); {SLEEPER}'
"""A sleeper that first logs a node's ready line: dying by SIGTERM after it is a problem."""


def run(tmp_path: Path, code: str) -> NodeProcess:
    """``python -c <code>`` as process 'probe', its logs in ``tmp_path``."""
    return NodeProcess([sys.executable, '-c', code], module='probe', env=node_environment(97), log_dir=tmp_path)


def wait_logged_ready(proc: NodeProcess) -> NodeProcess:
    """``proc`` once it has logged its ready line (30 s deadline)."""
    deadline = time.monotonic() + 30.0
    while not proc.logged_ready():
        assert time.monotonic() < deadline and proc.poll() is None, proc.stderr()
        time.sleep(0.01)
    return proc
