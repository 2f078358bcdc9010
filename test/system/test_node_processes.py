"""The nodes as separate ``python -m`` processes talking over loopback DDS to an in-process probe."""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from numpy.testing import assert_allclose
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, String

from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.method.intent import interpret
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.conversions import model_from_msg
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.run import SHUTDOWN_GRACE
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.arrays import msg_to_array
from grasp_intent_ros.wire.model_document import model_document

REPO = Path(__file__).resolve().parents[2]
STARTUP = 20.0
"""Seconds a process gets to start (imports, DDS discovery) on a loaded 2-core machine."""


def test_interpreter_and_model_server_answer_in_a_namespace(ros, launch, tiny_models):
    models_dir, models = tiny_models
    launch.start('intent_interpreter', '-r', '__ns:=/robot1',
                 '--params-file', str(REPO / 'config' / 'intent_interpreter.yaml'))
    launch.start('model_server', '-r', '__ns:=/robot1',
                 '--params-file', str(REPO / 'config' / 'model_server.yaml'),
                 '-p', f'models_dir:={models_dir}')
    statuses = ros.diagnostics()
    v_msgs = ros.subscribe(Float64MultiArray, '/robot1/intent/v')
    w_pub = ros.publisher(Float64MultiArray, '/robot1/intent/w')
    active = ros.subscribe(String, '/robot1/model/active', latched_qos())
    posteriors = ros.subscribe(Float64MultiArray, '/robot1/model/posterior')
    query = ros.publisher(Float64MultiArray, '/robot1/model/query')

    w = [0.9, 0.9, 0.1]
    assert ros.publish_until(w_pub, Float64MultiArray(data=w), lambda: v_msgs, timeout=STARTUP)
    assert v_msgs[-1].layout.dim[0].label == 'U,T,H,UT,UH,TH,UTH'
    assert_allclose(msg_to_array(v_msgs[-1]), interpret(w).v, rtol=0, atol=1e-12)

    assert ros.wait_for(lambda: active, timeout=STARTUP)
    doc = model_from_msg(active[0])
    assert (doc.name, doc.version) == ('cup_7zone', 1)
    x = models['cup_7zone'].means[5]
    assert ros.publish_until(query, Float64MultiArray(data=list(x)), lambda: posteriors)
    assert_allclose(msg_to_array(posteriors[-1]), models['cup_7zone'].posterior(x), rtol=0, atol=1e-12)

    # bad input to the running process: WARN diagnostic naming the reason; it keeps serving
    warn = lambda: [s for s in statuses if s.name == '/robot1/intent_interpreter: intent'  # noqa: E731
                    and s.level == DiagnosticStatus.WARN and 'NaN or infinity' in s.message]
    assert ros.publish_until(w_pub, Float64MultiArray(data=[0.5, math.nan, 0.5]), warn)
    n = len(v_msgs)
    assert ros.publish_until(w_pub, Float64MultiArray(data=w), lambda: len(v_msgs) > n)
    assert_allclose(msg_to_array(v_msgs[-1]), interpret(w).v, rtol=0, atol=1e-12)


def test_model_switch_through_the_parameter_service(ros, launch, tiny_models):
    launch.start('model_server', '-p', f'models_dir:={tiny_models[0]}')
    active = ros.subscribe(String, 'model/active', latched_qos())
    client = ros.node.create_client(SetParameters, 'model_server/set_parameters')
    assert ros.wait_for(lambda: active and client.service_is_ready(), timeout=STARTUP)

    def set_model(name: str):
        future = client.call_async(SetParameters.Request(
            parameters=[Parameter('model', value=name).to_parameter_msg()]))
        assert ros.wait_for(future.done)
        return future.result().results[0]

    result = set_model('no_such_model')
    assert not result.successful and 'known: broken, cup_5zone, cup_7zone' in result.reason
    assert set_model('cup_5zone').successful
    assert ros.wait_for(lambda: len(active) >= 2)
    doc = model_from_msg(active[-1])
    assert (doc.name, doc.version, doc.model.zone_labels) == ('cup_5zone', 2, ('U', 'T', 'UT', 'TH', 'UTH'))


def test_sigkilled_model_server_restarts_and_republishes_latched_model(ros, launch, tiny_models):
    args = ('-p', f'models_dir:={tiny_models[0]}')
    first = launch.start('model_server', *args)
    active = ros.subscribe(String, 'model/active', latched_qos())
    assert ros.wait_for(lambda: active, timeout=STARTUP)
    assert first.stop(signal.SIGKILL) == -signal.SIGKILL
    launch.start('model_server', *args)
    assert ros.wait_for(lambda: len(active) >= 2, timeout=STARTUP), 'latched model not received again'
    again = model_from_msg(active[-1])
    assert (again.name, again.version) == ('cup_7zone', 1)
    assert again.sha256 == model_from_msg(active[0]).sha256


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_signal_gives_exit_code_0_without_traceback(ros, launch, sig):
    proc = launch.start('intent_interpreter')
    statuses = ros.diagnostics()
    assert ros.wait_for(lambda: statuses, timeout=STARTUP), 'node did not come up'
    assert proc.stop(sig) == 0, proc.stderr()
    assert 'Traceback' not in proc.stderr()


def test_bad_configuration_exits_1_with_reason(launch, tiny_models):
    proc = launch.start('model_server', '-p', f'models_dir:={tiny_models[0]}', '-p', 'model:=mug')
    assert proc.popen.wait(STARTUP) == 1
    err = proc.stderr()
    assert "unknown model 'mug'" in err and 'Traceback' not in err, err


SUITE_STARTUP = 30.0
"""Seconds for the three suite nodes to start and answer a w (imports, DDS discovery) on a loaded 2-core machine."""


def test_a_launch_stopping_the_nodes_one_at_a_time_with_sigint_ends_each_with_exit_code_0(ros, launch):
    """The stop that docs/nodes.md#shutdown asks of a launch of one's own, with all three nodes up.

    SIGINT to one node's PID, wait for its exit, then the next, the last started first (NodeSuite.stop).
    """
    launch.start_nodes()
    posteriors = ros.subscribe(Float64MultiArray, 'grasp/posterior')
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')
    assert ros.publish_until(w_pub, Float64MultiArray(data=[0.9, 0.9, 0.1]), lambda: posteriors,
                             timeout=SUITE_STARTUP, period=0.5)
    assert launch.stop(signal.SIGINT) == []


def test_a_scripted_operator_stopped_while_it_plans_its_own_grasp_exits_0_within_the_grace(ros, domain_id):
    """Ctrl-C while the goal thread plans: exit code 0 within the grace, the thread left to the process's end.

    The node's ``own_grasp`` is made to plan without end (the model's first robustness estimate, then plan after
    plan, in compiled kernels), so that the stop always finds it planning.
    """
    code = ('from grasp_intent_ros.nodes import scripted_operator\n'
            'plan = scripted_operator.own_grasp\n'
            'def plan_on(*args):\n'
            '    print("planning", flush=True)\n'
            '    while True:\n'
            '        plan(*args)\n'
            'scripted_operator.own_grasp = plan_on\n'
            'scripted_operator.main([])\n')
    proc = subprocess.Popen([sys.executable, '-c', code], cwd=REPO, env=node_environment(domain_id),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    try:
        models = ros.publisher(String, topics.MODEL_ACTIVE, latched_qos())
        models.publish(String(data=model_document(ModelFiles(config_dir() / 'models').load('cup_7zone'),
                                                  name='cup_7zone', version=1)))
        assert ros.wait_for(lambda: lines or proc.poll() is not None, timeout=3 * STARTUP), 'it never planned'
        assert lines == ['planning\n'], lines
        start = time.monotonic()
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        exit_code = proc.wait(SHUTDOWN_GRACE + 10.0)
        took = time.monotonic() - start
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
    err = proc.stderr.read()
    assert exit_code == 0 and took < SHUTDOWN_GRACE, (exit_code, took, err)
    assert 'stopped while scripted_operator_goal worked: not waiting for it' in err, err
    assert 'Traceback' not in err and 'shutdown not finished' not in err, err
