"""grasp_intent_ros.ros.startup: a node process's start (a process per case where the settings are process-wide)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.ros import startup
from grasp_intent_ros.wire.diagnostics import KEY_KERNELS_LOAD_TIME

REPO = Path(__file__).resolve().parents[2]


def _run(code: str, env: dict[str, str] | None = None) -> None:
    """``python -c code`` in the repository; the code asserts, the test fails on its traceback."""
    result = subprocess.run([sys.executable, '-c', code], cwd=REPO, env=env, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def _without_openblas_setting() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != 'OPENBLAS_NUM_THREADS'}


def test_begin_pauses_the_collector_until_end_freezes_the_startup_objects() -> None:
    _run('import gc, os\n'
         'from grasp_intent_ros.ros import startup\n'
         'startup.begin()\n'
         'startup.begin()  # again, as main() does after the module did\n'
         'assert not gc.isenabled() and os.environ["OPENBLAS_NUM_THREADS"] == "1"\n'
         'import numpy\n'
         'assert os.listdir("/proc/self/task") == [str(os.getpid())], "OpenBLAS started worker threads"\n'
         'startup.end()\n'
         'assert gc.isenabled() and gc.get_freeze_count() > 1000, gc.get_freeze_count()\n'
         'frozen = gc.get_freeze_count()\n'
         'startup.end()\n'
         'assert gc.get_freeze_count() == frozen, "a second end froze again"\n', env=_without_openblas_setting())


def test_an_openblas_setting_is_kept() -> None:
    _run('import os\n'
         'from grasp_intent_ros.ros import startup\n'
         'startup.begin()\n'
         'assert os.environ["OPENBLAS_NUM_THREADS"] == "2"\n', env={**os.environ, 'OPENBLAS_NUM_THREADS': '2'})


def test_end_without_begin_leaves_the_collector_alone() -> None:
    _run('import gc\n'
         'from grasp_intent_ros.ros import startup\n'
         'startup.end()\n'
         'assert gc.isenabled() and gc.get_freeze_count() == 0\n'
         'gc.disable()  # a caller that turned it off itself keeps it off\n'
         'startup.begin()\n'
         'startup.end()\n'
         'assert not gc.isenabled() and gc.get_freeze_count() == 0\n')


def test_the_planner_process_collects_again_once_its_kernels_are_loaded(domain_id: int) -> None:
    """As the planner node does: begin before the imports, end in the planner thread."""
    _run('from grasp_intent_ros.ros import startup\n'
         'startup.begin()\n'
         'import gc, time\n'
         'import rclpy\n'
         'from grasp_intent_ros.nodes.grasp_planner import GraspPlanner\n'
         'rclpy.init()\n'
         'node = GraspPlanner()\n'
         'deadline = time.monotonic() + 30.0\n'
         'while not gc.isenabled() and time.monotonic() < deadline:\n'
         '    rclpy.spin_once(node, timeout_sec=0.05)\n'
         'assert gc.isenabled() and gc.get_freeze_count() > 1000, "the collector was not turned on again"\n'
         'node.destroy_node()\n'
         'rclpy.shutdown()\n', env=node_environment(domain_id))


def test_the_assistance_process_is_tuned_while_built_and_frozen_once_warmed_up(domain_id: int) -> None:
    """Its ``main`` goes through :func:`startup.run`, and the node's constructor ends the start (after its warm-up)."""
    _run('import gc, os, signal, sys\n'
         'from grasp_intent_ros.ros import startup\n'
         'from grasp_intent_ros.nodes import assistance\n'
         'seen = []\n'
         'class Node(assistance.AssistanceNode):\n'
         '    def __init__(self):\n'
         '        seen.append((gc.isenabled(), sys.getswitchinterval(), os.environ["OPENBLAS_NUM_THREADS"]))\n'
         '        super().__init__()\n'
         '        seen.append((gc.isenabled(), gc.get_freeze_count()))\n'
         '        os.kill(os.getpid(), signal.SIGINT)  # then stopped as a user stops it\n'
         'assistance.AssistanceNode = Node\n'
         'assistance.main([])\n'
         'assert seen[0] == (False, startup.GIL_SWITCH_INTERVAL, "1"), seen\n'
         'assert seen[1][0] and seen[1][1] > 1000, f"not frozen once warmed up: {seen}"\n',
         env={k: v for k, v in node_environment(domain_id).items() if k != 'OPENBLAS_NUM_THREADS'})


def test_run_tunes_the_process_before_the_node_is_built(domain_id: int) -> None:
    code = ('import gc, sys\n'
            'from grasp_intent_ros.ros import startup\n'
            'from grasp_intent_ros.ros.params import ParameterError\n'
            'def node():\n'
            '    assert sys.getswitchinterval() == startup.GIL_SWITCH_INTERVAL and not gc.isenabled()\n'
            '    raise ParameterError("tuned")\n'
            'startup.run(node, [])\n')
    result = subprocess.run([sys.executable, '-c', code], cwd=REPO, env=node_environment(domain_id),
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1 and 'cannot start: tuned' in result.stdout + result.stderr, result.stderr


def test_kernel_warm_up_loads_every_kernel_before_ready_and_counts_the_loads_after_it() -> None:
    reports: list[tuple[str, float]] = []
    warnings: list[str] = []
    ready: list[str] = []

    def failing() -> None:
        raise RuntimeError('no CPU target')

    startup.KernelWarmUp(failing, report=lambda k, v: reports.append((k, float(v))), warn=warnings.append,
                         ready=ready.append).at_start()
    assert reports == [] and warnings == ['compiled planner kernels not loaded ahead: no CPU target']
    assert ready == [''], 'ready even so: the answers load what they need and report what fails'
    warm_up = startup.KernelWarmUp(lambda: None, report=lambda k, v: reports.append((k, float(v))),
                                   warn=warnings.append, ready=ready.append)
    with pytest.raises(RuntimeError, match='still loading'):
        warm_up.loaded_late()
    warm_up.at_start()
    assert [key for key, _ in reports] == [KEY_KERNELS_LOAD_TIME] and reports[0][1] >= 0.0
    assert ready[1].startswith('compiled kernels loaded in ') and len(warnings) == 1
    assert warm_up.loaded_late() == 0
    from grasp_intent_ros.kernels import selection
    selection._distinct(np.ones((2, 3), dtype=np.float32), 1e-18)  # new argument types: a signature compiled
    assert warm_up.loaded_late() == 1


def test_a_ready_line_is_told_from_other_output() -> None:
    lines: list[str] = []
    startup.announce_ready(lines.append, 'compiled kernels loaded in 12 ms')
    assert startup.is_ready_line(f'[INFO] [1764336000.123] [robot1.grasp_planner]: {lines[0]}')
    assert not startup.is_ready_line('[INFO] [1764336000.123] [model_server]: active model ready')
    assert not startup.is_ready_line('ready')
