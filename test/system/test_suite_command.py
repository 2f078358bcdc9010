"""The suite command as a user runs it: ``python -m grasp_intent_ros suite ...`` in a terminal, then Ctrl-C.

The command runs in a session of its own, and Ctrl-C is what a terminal sends: SIGINT to the whole
foreground process group. The node processes are in sessions of their own, so only the command gets it,
and it stops them one at a time. Only that process group, which this test started, is signalled.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

from processes import alive, ctrl_c, suite_command
from std_msgs.msg import Float64MultiArray

from grasp_intent_ros.wire.arrays import read_posterior

REPO = Path(__file__).resolve().parents[2]
STARTUP = 30.0
"""Seconds for the suite to start and answer (imports, DDS discovery) on a loaded 2-core machine."""
STOP = 20.0
"""Seconds for the command to stop every node and exit after Ctrl-C."""


def test_one_command_starts_the_suite_with_a_namespace_and_params_file_and_ctrl_c_stops_it(
        ros, domain_id: int, tmp_path: Path) -> None:
    params = tmp_path / 'mine.yaml'
    params.write_text('/**/model_server:\n  ros__parameters:\n    model: cup_5zone\n')
    args = ['--namespace', '/robot7', '--domain-id', str(domain_id), '--params-file', str(params), '--log-dir',
            str(tmp_path / 'logs')]
    with suite_command(args, cwd=tmp_path, out=tmp_path / 'suite.out') as suite:
        posteriors = ros.subscribe(Float64MultiArray, '/robot7/grasp/posterior')
        w_pub = ros.publisher(Float64MultiArray, '/robot7/intent/w')
        assert ros.publish_until(w_pub, Float64MultiArray(data=[0.9, 0.9, 0.1]), lambda: posteriors,
                                 timeout=STARTUP, period=0.5), (tmp_path / 'suite.out').read_text()
        answer = read_posterior(posteriors[-1])
        assert answer.zone_labels == ('U', 'T', 'UT', 'TH', 'UTH')  # cup_5zone: the params file was read
        first = (tmp_path / 'suite.out').read_text().splitlines()[0]
        pids = {m: int(p) for m, p in re.findall(r'(\w+) \(pid (\d+)\)', first)}
        assert set(pids) == {'intent_interpreter', 'model_server', 'grasp_planner'}, first
        assert f'ROS_DOMAIN_ID={domain_id}' in first and 'namespace /robot7' in first

        assert ctrl_c(suite, STOP) == 0, (tmp_path / 'suite.out').read_text()
    text = (tmp_path / 'suite.out').read_text()
    assert text.rstrip().endswith('suite: stopped cleanly'), text
    assert "[model_server] [INFO]" in text and "active model 'cup_5zone'" in text, text  # the nodes' output
    assert 'Traceback' not in text, text
    assert not [m for m, pid in pids.items() if alive(pid)], 'a node outlived the suite command'
    assert sorted(p.name for p in (tmp_path / 'logs').iterdir()) == sorted(
        f'{m}.{ext}' for m in pids for ext in ('out', 'err'))


def test_the_scripted_operator_starts_once_every_other_node_is_ready(domain_id: int, tmp_path: Path) -> None:
    # started with the others it moved before the assistance could move the arm, and a session recorded from the
    # start did not replay (docs/sessions.md, "Closed-loop sessions")
    out = tmp_path / 'suite.out'
    args = ['--domain-id', str(domain_id), '--shared-control', '--with', 'scripted_operator']
    with suite_command(args, cwd=tmp_path, out=out) as suite:
        deadline = time.monotonic() + 2 * STARTUP  # five nodes, then the operator
        while 'suite: up' not in out.read_text() and suite.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)  # another process writes the file: no event to wait on
        assert ctrl_c(suite, STOP) == 0, out.read_text()
    lines = out.read_text().splitlines()
    assert 'suite: up' in '\n'.join(lines), lines
    assert lines[0].endswith('; scripted_operator once they are ready; Ctrl-C stops them'), lines[0]
    started = next(i for i, line in enumerate(lines) if re.fullmatch(r'suite: started scripted_operator \(pid \d+\)',
                                                                    line))
    ready = {m for m in re.findall(r'^\[(\w+)\] .*\]: ready', '\n'.join(lines[:started]), re.MULTILINE)}
    assert ready == {'intent_interpreter', 'model_server', 'grasp_planner', 'mock_arm', 'assistance'}, lines
    assert not [line for line in lines[:started] if line.startswith('[scripted_operator]')], lines


def test_a_node_that_dies_stops_the_suite_with_exit_code_1(domain_id: int, tmp_path: Path) -> None:
    bad = tmp_path / 'bad.yaml'
    bad.write_text('/**/model_server:\n  ros__parameters:\n    model: no_such_model\n')
    result = subprocess.run([sys.executable, '-m', 'grasp_intent_ros', 'suite', '--domain-id', str(domain_id),
                             '--params-file', str(bad)], cwd=tmp_path, capture_output=True, text=True,
                            timeout=STARTUP + STOP)
    assert result.returncode == 1, result
    assert re.search(r'model_server \(pid \d+\) exited with code 1; stopping the others', result.stderr), result
    assert 'no_such_model' in result.stdout, result  # the node's own reason, echoed
    last = result.stdout.rstrip().splitlines()[-1]
    assert re.fullmatch(r'suite: stopped not cleanly: model_server \(pid \d+\) exited with code 1', last), result


def test_bad_arguments_exit_2_before_anything_starts(tmp_path: Path) -> None:
    for args, reason in ((['--namespace', 'robot1'], 'must be absolute'),
                         (['--params-file', str(tmp_path / 'missing.yaml')], 'no parameters file'),
                         (['--with', 'no_such_node'], 'no optional node no_such_node'),
                         (['--domain-id', '300'], '0..101'),
                         (['--object', 'cup=cup_7zone', '--object', 'cup=cup_5zone', '--object', 'mug=mug'],
                          "object 'cup' is named twice; object 'mug': no model 'mug'"),
                         (['--object', 'cup=cup_7zone', '--shared-control', '--with', 'scripted_operator',
                           '--operator-object', 'mug'],
                          "the scripted operator's object 'mug' is not one of the objects cup"),
                         (['--shared-control', '--with', 'scripted_operator', '--operator-object', 'cup'],
                          '--operator-object names the object of a scene')):
        result = subprocess.run([sys.executable, '-m', 'grasp_intent_ros', 'suite', *args], cwd=tmp_path,
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 2 and reason in result.stderr, (args, result)
        assert 'started' not in result.stdout, (args, result)
