"""A user's first minutes on a fresh installation: an empty compile cache, the suite command, Ctrl-C.

numba's cache is redirected to an empty directory (``NUMBA_CACHE_DIR``), as on a fresh installation: the
planner compiles every kernel before it says it is ready. What is checked is behaviour, not speed: once the
suite has printed that it is up, no answer compiles or loads a kernel (the planner's count of kernel
signatures loaded after ready stays 0), whichever model or intent comes. How long the answers take is a
figure of docs/measurements.md, not an assertion here. Only processes and process groups started here are
signalled.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from processes import ctrl_c, suite_command
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray

from grasp_intent_ros.launch.suite import NodeSuite
from grasp_intent_ros.ros.run import SHUTDOWN_GRACE
from grasp_intent_ros.ros.startup import WATCHDOG_EXIT_CODE
from grasp_intent_ros.wire.arrays import read_posterior
from grasp_intent_ros.wire.diagnostics import KEY_KERNELS_LOADED_LATE

REPO = Path(__file__).resolve().parents[2]
COMPILE = 900.0
"""Seconds for a planner to compile every kernel from an empty cache on a loaded 2-core machine."""
ANSWER = 30.0
"""Seconds to wait for an answer (a deadline for the wait, not a speed requirement)."""
STOP = 20.0
"""Seconds for the suite command to stop every node and exit after Ctrl-C."""


def _read(path: Path) -> str:
    return path.read_text(errors='replace') if path.is_file() else ''


@pytest.mark.timeout(COMPILE + 300)
def test_from_an_empty_compile_cache_no_answer_after_up_waits_on_a_kernel(ros, domain_id: int,
                                                                          tmp_path: Path) -> None:
    out_path = tmp_path / 'suite.out'
    env = {**os.environ, 'NUMBA_CACHE_DIR': str(tmp_path / 'numba_cache')}
    with suite_command(['--domain-id', str(domain_id)], cwd=tmp_path, out=out_path, env=env) as suite:
        assert ros.wait_for(lambda: 'suite: up after' in _read(out_path) or suite.poll() is not None,
                            timeout=COMPILE) and suite.poll() is None, _read(out_path)
        assert (tmp_path / 'numba_cache').is_dir(), 'the kernels were compiled into the empty cache'
        statuses = ros.diagnostics()
        posteriors = ros.subscribe(Float64MultiArray, 'grasp/posterior')
        w_pub = ros.publisher(Float64MultiArray, 'intent/w')
        client = ros.node.create_client(SetParameters, 'model_server/set_parameters')
        assert ros.wait_for(lambda: w_pub.get_subscription_count() and client.service_is_ready(), timeout=ANSWER)
        answered: list[float] = []
        for request in ('w', 'w', 'model', 'w'):
            if request == 'model':
                future = client.call_async(SetParameters.Request(
                    parameters=[Parameter('model', value='cup_5zone').to_parameter_msg()]))
                assert ros.wait_for(future.done, timeout=ANSWER) and future.result().results[0].successful
                five_zones = lambda: read_posterior(posteriors[-1]).zone_labels == ('U', 'T', 'UT', 'TH', 'UTH')  # noqa: E731
                assert ros.wait_for(five_zones, timeout=ANSWER)  # the planner re-plans the last v with it
                continue
            n, start, w = len(posteriors), time.monotonic(), Float64MultiArray(data=[0.9, 0.9, 0.1])
            if not posteriors:  # the first w again until the planner has heard the interpreter (discovery)
                assert ros.publish_until(w_pub, w, lambda: posteriors, timeout=ANSWER, period=0.5), _read(out_path)
                continue
            w_pub.publish(w)
            assert ros.wait_for(lambda n=n: len(posteriors) > n, timeout=ANSWER), _read(out_path)
            answered.append(time.monotonic() - start)
        assert read_posterior(posteriors[-1]).zone_labels == ('U', 'T', 'UT', 'TH', 'UTH')  # the new model's
        late = lambda: [kv.value for s in statuses for kv in s.values if kv.key == KEY_KERNELS_LOADED_LATE]  # noqa: E731
        assert ros.wait_for(lambda: len(late()) >= 1, timeout=ANSWER)
        assert set(late()) == {'0'}, (late(), answered)
        up = next(line for line in _read(out_path).splitlines() if line.startswith('suite: up after'))
        print(f'{up}; answer times after it [s]: {", ".join(f"{t:.3f}" for t in answered)}')
        assert ctrl_c(suite, STOP) == 0, _read(out_path)
    assert _read(out_path).rstrip().endswith('suite: stopped cleanly'), _read(out_path)


@pytest.mark.timeout(COMPILE)
def test_a_planner_stopped_while_it_compiles_exits_at_once_without_the_watchdog(ros, domain_id: int,
                                                                                tmp_path: Path) -> None:
    suite = NodeSuite(domain_id, log_dir=tmp_path, cwd=REPO, env={'NUMBA_CACHE_DIR': str(tmp_path / 'numba')})
    try:
        planner = suite.start('grasp_planner')
        statuses = ros.diagnostics()
        assert ros.wait_for(lambda: statuses or planner.poll() is not None, timeout=ANSWER), planner.stderr()
        assert 'ready' not in planner.stderr(), 'the test needs a planner still compiling'
        start = time.monotonic()
        code = planner.stop(signal.SIGINT, timeout=SHUTDOWN_GRACE + 5.0)
        took = time.monotonic() - start
    finally:
        suite.stop()
    err = planner.stderr()
    assert code == 0 and planner.problem() == '', err
    assert took < SHUTDOWN_GRACE, f'{took:.1f} s: a stop during a compile must not wait for it'
    assert 'stopped while grasp_planner_planning worked: not waiting for it' in err, err  # its compile
    assert 'shutdown not finished' not in err and 'most recent call first' not in err, err  # no stacks


def test_the_suite_command_says_when_a_stop_needed_the_watchdog(tmp_path: Path) -> None:
    """A node whose stop hung (the watchdog's exit code): the suite's last line and exit code say so.

    The node stands in for a hung one: it exits with the watchdog's code when stopped
    (test/ros/test_run.py checks that a real hang ends with that code).
    """
    node = ("import signal, sys, time\n"
            "signal.signal(signal.SIGTERM, lambda *_: sys.exit(%d))\n"
            "print('[INFO] [0.0] [grasp_planner]: ready', flush=True)\n"
            "time.sleep(60)\n") % WATCHDOG_EXIT_CODE
    command = ("import os, signal, sys, threading\n"
               "from grasp_intent_ros.launch import process, suite, suite_command\n"
               "def start_nodes(self, **_):\n"
               "    self.processes.append(process.NodeProcess([sys.executable, '-c', %r], module='grasp_planner',\n"
               "                                              env=self.env, log_dir=self.log_dir))\n"
               "suite.NodeSuite.start_nodes = start_nodes\n"
               "threading.Timer(3.0, os.kill, (os.getpid(), signal.SIGINT)).start()\n"
               "sys.exit(suite_command.main(['--domain-id', '0']))\n") % node
    result = subprocess.run([sys.executable, '-c', command], cwd=tmp_path, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 1, result
    last = result.stdout.rstrip().splitlines()[-1]
    assert last.startswith('suite: stopped not cleanly: grasp_planner (pid ') and 'was ended by its watchdog' in last, \
        result
    assert 'suite: up after' in result.stdout, result
