"""A session of several objects recorded and replayed as a user does it (docs/sessions.md, several objects).

``suite --object cup=cup_7zone --object flashlight=flashlight_7zone`` runs two planning chains; a recorder
process at the root with ``--topics cup/ flashlight/ joint_states /diagnostics`` records them while the probe
(``ros`` fixture) sends one input at a time, each once the recorder has the previous answer: the arm's joint
states (both chains), each chain's w, object poses and a clarification, and last a joint state both planners
reject. ``replay --check --fast --start-suite`` then replays the bag into a fresh scene and finds every chain's
answers again; a copy with the flashlight's grasp poses moved 5 cm fails the check naming the flashlight's topic.
Only the processes this test started are signalled, by PID (the suite command by its process group).
"""

from __future__ import annotations

import math
import signal
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from bag_copies import edited_copy
from geometry_msgs.msg import PoseStamped
from processes import ctrl_c, replay, suite_command
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.mico.kinematics import HOME_Q
from grasp_intent_ros.sessions.fixtures import joints, pose, w
from grasp_intent_ros.sessions.report import write_report
from grasp_intent_ros.sessions.scenes import load_paired_scene
from grasp_intent_ros.wire.diagnostics import KEY_REJECTED
from grasp_intent_ros.wire.topics import PLAN_TOPICS

REPO = Path(__file__).resolve().parents[2]
UP = 90.0
"""Seconds for six node processes and the recorder to start on a loaded 2-core machine."""
ANSWER = 30.0
"""Seconds for an answer to reach the recorder (one plan; the recorder reports its counts every second)."""
STOP = 30.0
"""Seconds for the recorder to close its bag, and for the suite command to stop six nodes."""
MODELS = {'cup': 'cup_7zone', 'flashlight': 'flashlight_7zone'}
PLAN = ('intent/v', *PLAN_TOPICS)


def recorder_counts(statuses: list) -> dict[str, int]:
    """The recorder's latest reported count per recorded topic (its ``topic /...`` values)."""
    for status in reversed(statuses):
        if status.name == '/recorder: recorder':
            return {kv.key[len('topic '):]: int(kv.value) for kv in status.values if kv.key.startswith('topic /')}
    return {}


def moved_copy(bag: Path, out: Path, topic: str, dx: float) -> Path:
    """``bag`` with every grasp pose on ``topic`` moved ``dx`` m along x; everything else unchanged."""
    def move(name: str, msg: Any) -> bool:
        if name == topic:
            msg.pose.position.x += dx
        return name == topic
    return edited_copy(bag, out, move)


def test_a_scene_recorded_from_the_first_message_replays_each_chain_by_its_namespace(
        ros, domain_id: int, tmp_path: Path) -> None:
    bag = tmp_path / 'scene'
    objects = [arg for name, model in MODELS.items() for arg in ('--object', f'{name}={model}')]
    statuses = ros.diagnostics()
    # the probe's publishers exist before the nodes and the recorder start, so each has matched them both ways
    # by the first input (a reader that has not matched a writer yet gets its message only on a resend: the
    # recorder would stamp a w after the v it caused)
    publishers = {topic: ros.publisher(msg_type, topic) for topic, msg_type in (
        ('/joint_states', JointState), ('/flashlight/object/pose', PoseStamped),
        ('/cup/intent/w', Float64MultiArray), ('/flashlight/intent/w', Float64MultiArray))}
    with suite_command(['--domain-id', str(domain_id), *objects, '--log-dir', str(tmp_path / 'logs')],
                       cwd=tmp_path, out=tmp_path / 'suite.out') as suite:
        recorder = NodeProcess(
            [sys.executable, '-m', 'grasp_intent_ros', 'recorder', str(bag), '--topics', 'cup/', 'flashlight/',
             'joint_states', '/diagnostics'], module='recorder', env=node_environment(domain_id), log_dir=tmp_path,
            cwd=REPO)
        try:
            out = tmp_path / 'suite.out'
            assert ros.wait_for(lambda: 'suite: up' in out.read_text() or suite.poll() is not None, UP), \
                out.read_text()
            assert suite.poll() is None, out.read_text()
            assert ros.wait_for(lambda: 'recording to' in recorder.stderr() or recorder.poll() is not None, UP), \
                recorder.stderr()
            expected: Counter[str] = Counter()

            def send(topic: str, msg: object, readers: int, answer: tuple[str, ...] = ()) -> None:
                """Publish once, after ``readers`` subscriptions matched; wait until the recorder has the answer."""
                pub = publishers[topic]
                assert ros.wait_for(lambda: pub.get_subscription_count() >= readers, ANSWER), topic
                pub.publish(msg)
                expected.update([topic, *answer])
                assert ros.wait_for(lambda: all(recorder_counts(statuses).get(t, 0) >= n for t, n in expected.items()),
                                    ANSWER), (topic, expected, recorder_counts(statuses))

            send('/joint_states', joints(HOME_Q), 3)  # both planners and the recorder
            send('/flashlight/object/pose', pose(0.3, 0.3, 0.0, math.pi), 2)  # on the other side of the arm
            send('/cup/intent/w', w(0.9, 0.9, 0.1), 2, tuple(f'/cup/{t}' for t in PLAN))
            send('/flashlight/intent/w', w(0.9, 0.9, 0.1), 2, tuple(f'/flashlight/{t}' for t in PLAN))
            send('/cup/intent/w', w(0.1, 0.1, 0.1), 2, ('/cup/intent/clarification',))
            send('/flashlight/object/pose', pose(0.3, 0.35, 0.0, math.pi), 2, tuple(f'/flashlight/{t}'
                                                                                   for t in PLAN_TOPICS))

            def rejected() -> set[str]:  # the chains whose planner rejected the joint state
                return {s.name.partition('/grasp_planner')[0] for s in statuses if s.name.endswith(
                    '/grasp_planner: inputs') and {kv.key: kv.value for kv in s.values}.get(KEY_REJECTED) == '1'}
            send('/joint_states', joints([math.nan] * 6), 3)
            assert ros.wait_for(lambda: rejected() == {'/cup', '/flashlight'}, ANSWER), rejected()
            later = recorder_counts(statuses).get('/diagnostics', 0) + 14  # two periods of the 7 publishers
            assert ros.wait_for(lambda: recorder_counts(statuses).get('/diagnostics', 0) >= later, ANSWER)
            assert recorder.stop(signal.SIGINT, STOP) == 0, recorder.stderr()
        finally:
            recorder.stop(signal.SIGINT, STOP)
        assert ctrl_c(suite, STOP) == 0, (tmp_path / 'suite.out').read_text()

    scene = load_paired_scene(bag)
    assert [chain.name for chain in scene.chains] == ['cup', 'flashlight'] and len(scene.inputs) == 7
    assert [[o.topic for s in c.steps for o in s.expected if o.topic == '/diagnostics'] for c in scene.chains] == [
        ['/diagnostics'], ['/diagnostics']], 'each chain: its own planner\'s rejection'
    first_cup_w = scene.chains[0].steps[1]
    assert first_cup_w.description == 'cup: intent/w [0.9, 0.9, 0.1]' and len(first_cup_w.expected) == len(PLAN)

    # the report: one per chain, each of its own plans, clarifications and planner's rejection
    figures, _ = write_report(bag, tmp_path / 'report')
    assert {figure.partition('/')[0] for figure in figures} == {'cup', 'flashlight'}
    cup, flashlight = ((tmp_path / 'report' / name / 'summary.md').read_text() for name in ('cup', 'flashlight'))
    assert '- plans: 1' in cup and '- clarifications: 1' in cup and '- rejections (from /diagnostics): 1' in cup
    assert '- plans: 2' in flashlight and '- clarifications: 0' in flashlight, flashlight
    assert '- rejections (from /diagnostics): 1' in flashlight and '/cup/' not in flashlight

    result = replay(bag, domain_id)
    assert result.returncode == 0, f'{result.stdout}\n{result.stderr}'
    summary = result.stdout.strip().splitlines()[-1]
    assert summary.startswith(f'replay --check OK: {bag}: 7 inputs to the chains cup, flashlight of the scene in /, '
                              f'{scene.n_outputs} recorded outputs matched live'), result.stdout

    moved = moved_copy(bag, tmp_path / 'moved', '/flashlight/grasp/pose', 0.05)
    result = replay(moved, domain_id)
    assert result.returncode == 1, f'{result.stdout}\n{result.stderr}'
    header = next(line for line in result.stdout.splitlines() if line.startswith('replay --check FAILED'))
    assert header.endswith('first differing message: input #4, flashlight/grasp/pose'), result.stdout
    differing = [line for line in result.stdout.splitlines() if line.startswith('  input #')]
    assert differing and all('): flashlight/grasp/pose position: recorded' in line for line in differing), \
        result.stdout
