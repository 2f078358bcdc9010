"""Hostile peers against the suite as real processes over loopback DDS.

- A valid model the suite cannot serve (ten tasks, not the suite's three) latched on ``model/active`` by a
  foreign publisher: refused by every node; with a model to keep, the suite keeps serving with it; with none,
  every intent gets one clarification with the reason and /diagnostics is at ERROR until a served model comes.
- Malformed w, then a valid one, under CPU load: the valid one is answered with a grasp, every time.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import Float64MultiArray, String

from grasp_intent_ros.cli.send_intent import IntentSender, NoGrasp
from grasp_intent_ros.method.data import Demonstrations
from grasp_intent_ros.method.features import APPROACH, MICO_3F
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.ros.conversions import model_to_msg
from grasp_intent_ros.ros.model_follower import KEY_REFUSED
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.wire.diagnostics import status_values

REPO = Path(__file__).resolve().parents[2]
STARTUP = 30.0
"""Seconds for the processes to start and answer (imports, DDS discovery) on a loaded 2-core machine."""

MALFORMED_W = ([], [0.5, 0.5], [0.5, math.nan, 0.5], [1.7, 0.5, 0.5], [0.5] * 5000)
"""Empty, wrong length, NaN, outside [0, 1], oversized (40 kB, over intent/w's cap)."""
LOAD_SECONDS = 120.0
"""Longest a CPU-load process spins (it is also stopped, by PID, when its test ends)."""


@contextmanager
def cpu_load(processes: int) -> Iterator[None]:
    """``processes`` busy-looping Python processes, each ending by itself after :data:`LOAD_SECONDS`."""
    code = f'import time\nend = time.monotonic() + {LOAD_SECONDS}\nwhile time.monotonic() < end: pass\n'
    procs = [subprocess.Popen([sys.executable, '-c', code], stdin=subprocess.DEVNULL) for _ in range(processes)]
    try:
        yield
    finally:
        for proc in procs:
            proc.send_signal(signal.SIGTERM)
        for proc in procs:
            proc.wait()


def _start(launch: Any, *names: str) -> None:
    for name in names or ('intent_interpreter', 'model_server', 'grasp_planner'):
        launch.start(name, '--params-file', str(REPO / 'config' / f'{name}.yaml'))


def ten_task_model() -> GraspModel:
    """A valid model on the MICO features whose ten tasks are not the suite's: one zone per task."""
    tasks = tuple('abcdefghij')
    rng = np.random.default_rng(3)
    span, centre = MICO_3F.upper - MICO_3F.lower, 0.5 * (MICO_3F.upper + MICO_3F.lower)
    x = centre + 0.05 * span * rng.standard_normal((20 * len(tasks), span.size))
    x[:, APPROACH] /= np.linalg.norm(x[:, APPROACH], axis=1, keepdims=True)
    sets = np.repeat(1 << np.arange(len(tasks)), 20)
    demos = Demonstrations(np.clip(x, MICO_3F.lower, MICO_3F.upper), sets, tasks)
    return GraspModel.fit(demos, tuple(1 << i for i in range(len(tasks))), name='ten_tasks')


def test_a_model_the_suite_cannot_serve_is_refused_and_every_intent_it_leaves_unserved_is_clarified(
        ros: Any, launch: Any) -> None:
    statuses = ros.diagnostics()
    clarifications = ros.subscribe(String, 'intent/clarification')
    sender = ros.add(IntentSender('test_sender', context=ros.context))
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')

    def status(node: str, component: str) -> Any:
        return next((s for s in reversed(statuses) if s.name == f'/{node}: {component}'), None)

    def at(level: bytes, node: str, component: str, text: str) -> bool:
        found = status(node, component)
        return found is not None and found.level == level and text in found.message

    _start(launch)
    answer = sender.send((0.9, 0.9, 0.1), ros.executor, timeout=STARTUP)  # the suite serves cup_7zone
    assert answer.posterior.zone_labels == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')

    # a foreign publisher latches a valid ten-task model: refused by both followers, which keep cup_7zone
    hostile = ros.publisher(String, 'model/active', latched_qos())
    hostile.publish(model_to_msg(ten_task_model(), name='ten_tasks', version=1))
    refused = "model/active: model 'ten_tasks' refused: its tasks [a, b, c, d, e, f, g, h, i, j] are not the " \
              'task_names [usage, transfer, handover]'
    for node, component in (('intent_interpreter', 'intent'), ('grasp_planner', 'inputs')):
        assert ros.wait_for(lambda n=node, c=component: at(DiagnosticStatus.WARN, n, c, refused[len('model/active: '):])
                            and status_values(status(n, c))[KEY_REFUSED] == f"{refused}; still serving with model "
                            "'cup_7zone'", STARTUP), status(node, component)
    answer = sender.send((0.9, 0.1, 0.9), ros.executor, timeout=STARTUP)
    assert answer.posterior.zone_labels == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH') and not clarifications

    # without the model server, restarted followers see only the ten-task model: nothing to serve with
    for name in ('model_server', 'intent_interpreter', 'grasp_planner'):
        assert launch.node(name).stop() == 0
    _start(launch, 'intent_interpreter', 'grasp_planner')
    for node, component in (('intent_interpreter', 'intent'), ('grasp_planner', 'inputs')):
        assert ros.wait_for(lambda n=node, c=component: at(DiagnosticStatus.ERROR, n, c, f'cannot serve: {refused}'),
                            STARTUP), status(node, component)
    # each intent: one clarification with the reason (the interpreter's; the planner gets no v)
    assert ros.publish_until(w_pub, Float64MultiArray(data=[0.9, 0.9, 0.1]), lambda: clarifications,
                             timeout=STARTUP, period=5.0)
    for w in ([0.2, 0.8, 0.3], [1.0, 0.0, 0.0], [0.6, 0.6, 0.6]):
        n = len(clarifications)
        w_pub.publish(Float64MultiArray(data=w))
        assert ros.wait_for(lambda n=n: len(clarifications) > n, STARTUP)
    assert {m.data for m in clarifications} == {f'cannot serve: {refused}'}
    counted = lambda: int(status_values(status('intent_interpreter', 'intent'))['clarifications requested'])  # noqa: E731
    assert ros.wait_for(lambda: counted() == len(clarifications) >= 4), (counted(), len(clarifications))
    assert ros.wait_for(lambda: status('grasp_planner', 'planning') is not None, STARTUP)  # 1 Hz, maybe none yet
    assert status_values(status('grasp_planner', 'planning'))['clarifications requested'] == '0'

    # a served model arrives: the ERROR clears and intents are answered again
    _start(launch, 'model_server')
    for node, component in (('intent_interpreter', 'intent'), ('grasp_planner', 'inputs')):
        assert ros.wait_for(lambda n=node, c=component: status(n, c).level != DiagnosticStatus.ERROR, STARTUP)
    answer = sender.send((0.9, 0.9, 0.1), ros.executor, timeout=STARTUP)
    assert answer.posterior.zone_labels == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')


@pytest.mark.parametrize('round_', range(int(os.environ.get('FLAKE_ROUNDS', '3'))))
def test_malformed_w_then_a_valid_w_is_answered_under_cpu_load(ros: Any, launch: Any, round_: int) -> None:
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')
    sender = ros.add(IntentSender('test_sender', context=ros.context))
    with cpu_load(int(os.environ.get('FLAKE_LOAD', '2'))):
        _start(launch)
        assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1, STARTUP)
        for w in MALFORMED_W:
            w_pub.publish(Float64MultiArray(data=w))
        try:
            sender.send((0.9, 0.9, 0.1), ros.executor, timeout=20.0, period=2.0)
        except NoGrasp as exc:
            logs = '\n'.join(f'--- {p.module}\n{p.stderr_tail(30)}' for p in launch.processes)
            pytest.fail(f'{exc}\n{logs}')
