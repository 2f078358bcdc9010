"""Session pairing and comparison (grasp_intent_ros.tools.outputs, session, compare).

Pairing a recorded session's inputs with their outputs, and the comparison of live outputs with recorded ones at
the replay tolerances. Bags are written in tmp_path; no rclpy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from grasp_intent_ros.bag import QosSpec, SessionWriter, read_messages, topics_info
from grasp_intent_ros.protocol import DIAGNOSTICS, MSGTYPES, PLAN_TOPICS, ModelHeader
from grasp_intent_ros.tools.compare import Difference, Tolerances, answered, compare_step, diverged
from grasp_intent_ros.tools.outputs import (
    Joints,
    Output,
    Pose,
    Rejection,
    RejectionTracker,
    SessionError,
    Text,
    Trajectory,
    Undecodable,
    Vector,
    decode,
    output_of,
)
from grasp_intent_ros.tools.session import Step, compact_session, detect_namespace, load_session, pair_messages

STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types
T0 = 1_700_000_000_000_000_000
MS = 1_000_000
ZONES = 'U,T,H,UT,UH,TH,UTH'
TASKS = 'usage,transfer,handover'
ARM = tuple(f'm1n6s300_joint_{i}' for i in range(1, 7)) + tuple(f'm1n6s300_joint_finger_{i}' for i in range(1, 4))
SHA_A, SHA_B = 'a' * 64, 'b' * 64


# ---------------------------------------------------------------- rosbags message builders
def header(frame: str = 'm1n6s300_link_base', sec: int = 1) -> Any:
    return T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](sec=sec, nanosec=5), frame_id=frame)


def f64(values: list[float], *labels: tuple[str, int]) -> Any:
    data = np.array(values, dtype=np.float64)
    dims, stride = [], data.size
    for label, size in labels:
        dims.append(T['std_msgs/msg/MultiArrayDimension'](label=label, size=size, stride=stride))
        stride //= max(size, 1)
    return T['std_msgs/msg/Float64MultiArray'](layout=T['std_msgs/msg/MultiArrayLayout'](dim=dims, data_offset=0),
                                               data=data)


def v_msg(values: list[float]) -> Any:
    return f64(values, (ZONES, 7))


def posterior_msg(p: list[float], w: list[float], stamp: str = 'stamp=1.000000005') -> Any:
    return f64(p + w, (stamp, 1), (f'{ZONES}|{TASKS}', 10))


def features_msg(x: list[float]) -> Any:
    names = 'palm_x,palm_y,palm_z,approach_x,approach_y,approach_z,roll,finger_1,finger_2,finger_3'
    return f64(x, ('stamp=1.000000005', 1), (names, 10))


def text(value: str) -> Any:
    return T['std_msgs/msg/String'](data=value)


def model_doc(name: str, sha: str = SHA_A, version: int = 1) -> Any:
    return text(f'# model_name: {name}\n# model_version: {version}\n# model_sha256: {sha}\nname: {name}\n')


def pose_msg(position: tuple[float, float, float], q: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0),
             frame: str = 'm1n6s300_link_base') -> Any:
    point = T['geometry_msgs/msg/Point'](x=position[0], y=position[1], z=position[2])
    pose = T['geometry_msgs/msg/Pose'](position=point,
                                       orientation=T['geometry_msgs/msg/Quaternion'](x=q[0], y=q[1], z=q[2], w=q[3]))
    return T['geometry_msgs/msg/PoseStamped'](header=header(frame), pose=pose)


def joint_msg(positions: list[float], names: tuple[str, ...] = ARM) -> Any:
    empty = np.array([], dtype=np.float64)
    return T['sensor_msgs/msg/JointState'](header=header(), name=list(names),
                                           position=np.array(positions, dtype=np.float64), velocity=empty, effort=empty)


def trajectory_msg(positions: list[float], seconds: float = 1.5) -> Any:
    sec = int(seconds)
    point = T['trajectory_msgs/msg/JointTrajectoryPoint'](
        positions=np.array(positions, dtype=np.float64), velocities=np.zeros(len(positions)),
        accelerations=np.array([], dtype=np.float64), effort=np.array([], dtype=np.float64),
        time_from_start=T['builtin_interfaces/msg/Duration'](sec=sec, nanosec=round((seconds - sec) * 1e9)))
    return T['trajectory_msgs/msg/JointTrajectory'](header=header(), joint_names=list(ARM), points=[point])


def diagnostics(name: str, *, received: int, rejected: int, reason: str = '', level: int = 1) -> Any:
    values = [T['diagnostic_msgs/msg/KeyValue'](key=k, value=v) for k, v in (
        ('messages received', str(received)), ('messages rejected', str(rejected)), ('last error', reason))]
    status = T['diagnostic_msgs/msg/DiagnosticStatus'](
        level=level, name=name, message=f'rejected input: {reason}' if reason else 'ok', hardware_id='',
        values=values)
    return T['diagnostic_msgs/msg/DiagnosticArray'](header=header(''), status=[status])


Q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 1.0, 1.1, 1.2]
P = [0.05, 0.05, 0.05, 0.6, 0.05, 0.05, 0.15]
W_OUT = [0.85, 0.8, 0.3]
X = [0.05, 0.02, 0.03, -0.8, -0.1, -0.59, 3.5, 1.0, 1.1, 1.2]


def plan(position: tuple[float, float, float] = (0.3, -0.25, 0.1)) -> list[tuple[str, Any]]:
    """The five outputs of one plan, relative topic names."""
    return [('grasp/posterior', posterior_msg(P, W_OUT)), ('grasp/features', features_msg(X)),
            ('grasp/pose', pose_msg(position)), ('grasp/joint_targets', joint_msg(Q)),
            ('grasp/trajectory', trajectory_msg(Q))]


def write_bag(path: Path, messages: list[tuple[str, Any]], *, namespace: str = '', qos: QosSpec | None = None) -> Path:
    """Write (relative topic, message) pairs 1 ms apart; '/diagnostics' and other absolute names as given."""
    with SessionWriter(path) as bag:
        for k, (topic, msg) in enumerate(messages):
            full = topic if topic.startswith('/') else f'{namespace}/{topic}'
            if full not in bag.topics:
                latched = QosSpec('reliable', 'transient_local', 0)
                bag.add_topic(full, msg.__msgtype__, qos=qos or (latched if topic == 'model/active' else QosSpec()))
            bag.write_message(full, T0 + k * MS, msg)
    return path


def session_messages() -> list[tuple[str, Any]]:
    """A session with an input of every kind.

    Initial model, joint state, a planned w, a rejected w, a clarification, a model switch, a repeated model
    document, a moved object; periodic diagnostics in between.
    """
    interp = '/intent_interpreter: intent'
    return [
        (DIAGNOSTICS, diagnostics(interp, received=0, rejected=0, level=0)),
        ('intent/v', v_msg([1 / 7] * 7)),                        # before any input: unpaired
        ('model/active', model_doc('cup_7zone')),                  # initial model
        ('joint_states', joint_msg(Q[:6], ARM[:6])),               # 1: no answer
        ('intent/w', f64([0.9, 0.9, 0.1])),                        # 2: v + plan
        ('intent/v', v_msg(P)),
        *plan(),
        (DIAGNOSTICS, diagnostics(interp, received=1, rejected=0, level=0)),  # periodic: no event
        ('intent/w', f64([0.5, math.nan, 0.5])),                   # 3: rejection
        (DIAGNOSTICS, diagnostics(interp, received=2, rejected=1, reason='w contains NaN')),
        (DIAGNOSTICS, diagnostics(interp, received=2, rejected=1, reason='w contains NaN')),  # repeat
        ('intent/w', f64([0.1, 0.1, 0.1])),                        # 4: clarification
        ('intent/clarification', text('P(no task) = 0.729 >= 0.5')),
        ('model/active', model_doc('cup_5zone', SHA_B, 2)),        # 5: model switch + plan
        *plan((0.31, -0.25, 0.1)),
        ('model/active', model_doc('cup_5zone', SHA_B, 2)),        # exact repeat: ignored
        ('object/pose', pose_msg((0.35, -0.2, 0.0))),              # 6: plan
        *plan((0.35, -0.2, 0.1)),
        ('grasp/markers', T['visualization_msgs/msg/MarkerArray'](markers=[])),  # not a session topic
    ]


@pytest.fixture
def session_bag(tmp_path: Path) -> Path:
    return write_bag(tmp_path / 'session', session_messages())


def outputs(pairs: list[tuple[str, Any]], t0: int = 0) -> list[Output]:
    """Live-like outputs from (relative topic, rosbags message) pairs, through the serialized path."""
    return [output_of(topic, t0 + k, bytes(STORE.serialize_cdr(msg, MSGTYPES[topic]))) for k, (topic, msg) in
            enumerate(pairs)]


# ---------------------------------------------------------------- pairing
def test_each_input_is_paired_with_the_outputs_that_follow_it(session_bag: Path) -> None:
    session = load_session(session_bag)

    assert session.namespace == ''
    assert session.initial_model == ModelHeader('cup_7zone', 1, SHA_A)
    assert [s.topic for s in session.steps] == ['joint_states', 'intent/w', 'intent/w', 'intent/w',
                                                'model/active', 'object/pose']
    assert [s.index for s in session.steps] == [1, 2, 3, 4, 5, 6]
    assert [sorted(o.topic for o in s.expected) for s in session.steps] == [
        [],
        sorted(['intent/v', *PLAN_TOPICS]),
        [DIAGNOSTICS],
        ['intent/clarification'],
        sorted(['model/active', *PLAN_TOPICS]),
        sorted(PLAN_TOPICS),
    ]
    assert [o.topic for o in session.unpaired] == ['intent/v']
    assert session.n_outputs == 6 + 1 + 1 + 6 + 5
    rejection = session.steps[2].expected[0].value
    assert rejection == Rejection('/intent_interpreter: intent', 1, 'w contains NaN')
    assert session.steps[4].model == 'cup_5zone' and session.steps[1].model is None
    assert session.steps[1].description == 'intent/w [0.9, 0.9, 0.1]'
    assert session.steps[2].description == 'intent/w [0.5, nan, 0.5]'
    assert session.steps[4].description == 'model switch to cup_5zone'
    assert session.steps[5].description.startswith('object/pose (0.350, -0.200, 0.000) m')
    assert session.duration_s == pytest.approx((session.steps[-1].t_ns - session.steps[0].t_ns) * 1e-9)
    # the recorded bytes are kept for publishing again
    w = decode('std_msgs/msg/Float64MultiArray', session.steps[1].cdr)
    assert list(w.data) == [0.9, 0.9, 0.1]


def test_the_reduced_outputs_carry_what_is_compared(session_bag: Path) -> None:
    step = load_session(session_bag).steps[1]
    values = {o.topic: o.value for o in step.expected}
    assert isinstance(values['intent/v'], Vector) and values['intent/v'].labels == (ZONES,)
    np.testing.assert_array_equal(values['intent/v'].data, P)
    posterior = values['grasp/posterior']
    assert isinstance(posterior, Vector) and posterior.labels == ('stamp=1.000000005', f'{ZONES}|{TASKS}')
    pose = values['grasp/pose']
    assert isinstance(pose, Pose) and pose.frame_id == 'm1n6s300_link_base'
    np.testing.assert_array_equal(pose.position, [0.3, -0.25, 0.1])
    joints = values['grasp/joint_targets']
    assert isinstance(joints, Joints) and joints.names == ARM
    trajectory = values['grasp/trajectory']
    assert isinstance(trajectory, Trajectory) and trajectory.positions.shape == (1, 9)
    np.testing.assert_allclose(trajectory.times_s, [1.5], rtol=0, atol=1e-9)


def test_namespace_is_detected_and_other_namespaces_are_rejected(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'ns', session_messages(), namespace='/robot1')
    session = load_session(bag)
    assert session.namespace == '/robot1' and len(session.steps) == 6
    assert detect_namespace(['/rosout', '/a/b/intent/w', '/a/b/grasp/pose']) == '/a/b'
    with pytest.raises(SessionError, match='several namespaces'):
        detect_namespace(['/r1/intent/w', '/r2/intent/v'])
    with pytest.raises(SessionError, match='no session topic'):
        detect_namespace(['/rosout'])


def test_a_bag_without_inputs_is_not_a_session(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'outputs_only', [('model/active', model_doc('cup_7zone')), ('intent/v', v_msg(P))])
    with pytest.raises(SessionError, match='no inputs'):
        load_session(bag)


def test_a_malformed_model_document_is_a_session_error(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'bad_model', [('model/active', text('name: cup_7zone\n')),
                                             ('intent/w', f64([0.9, 0.9, 0.1]))])
    with pytest.raises(SessionError, match='header lines'):
        load_session(bag)


def test_pair_messages_accepts_any_message_stream() -> None:
    class Raw:
        def __init__(self, topic: str, t: int, msg: Any) -> None:
            self.topic, self.msgtype, self.timestamp_ns = topic, msg.__msgtype__, t
            self.cdr = bytes(STORE.serialize_cdr(msg, msg.__msgtype__))

    stream = [Raw('/intent/w', 1, f64([0.9, 0.1, 0.1])), Raw('/intent/v', 2, v_msg(P))]
    initial, steps, unpaired = pair_messages(stream)
    assert initial is None and unpaired == () and [len(s.expected) for s in steps] == [1]


# ---------------------------------------------------------------- rejections
def test_rejection_tracker_reports_each_rejection_once() -> None:
    tracker = RejectionTracker()
    name = '/grasp_planner: inputs'
    assert tracker.update(diagnostics(name, received=3, rejected=0, level=0)) == []
    assert tracker.update(diagnostics(name, received=4, rejected=1, reason='v is empty')) == [
        Rejection(name, 1, 'v is empty')]
    assert tracker.update(diagnostics(name, received=4, rejected=1, reason='v is empty')) == []  # periodic repeat
    assert tracker.update(diagnostics(name, received=5, rejected=2, reason='internal', level=2)) == [
        Rejection(name, 2, 'internal')]
    foreign = T['diagnostic_msgs/msg/DiagnosticArray'](header=header(''), status=[
        T['diagnostic_msgs/msg/DiagnosticStatus'](level=1, name='other', message='x', hardware_id='', values=[])])
    assert tracker.update(foreign) == []
    assert tracker.update_cdr(b'\x00\x01\x00\x00garbage') == []


# ---------------------------------------------------------------- comparison
@pytest.fixture(scope='module')
def plan_step(tmp_path_factory: pytest.TempPathFactory) -> Step:
    return load_session(write_bag(tmp_path_factory.mktemp('s') / 'plan', session_messages())).steps[1]


def live_plan(**changes: Any) -> list[Output]:
    """The live answer to the planned w of session_messages(), with one message replaced."""
    pairs = dict([('intent/v', v_msg(P)), *plan()])
    pairs.update(changes)
    return outputs(list(pairs.items()))


def rotation_z(angle: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


def test_identical_answers_match(plan_step: Step) -> None:
    assert compare_step(plan_step, live_plan()) == []
    assert compare_step(plan_step, list(reversed(live_plan()))) == []  # order across topics does not matter


def test_stamps_are_not_compared(plan_step: Step) -> None:
    later = posterior_msg(P, W_OUT, stamp='stamp=99.000000001')
    assert compare_step(plan_step, live_plan(**{'grasp/posterior': later})) == []


CASES: list[tuple[str, Callable[[float], dict[str, Any]], float, str]] = [
    # (what, live message built from a perturbation, tolerance, field named in the difference)
    ('v', lambda d: {'intent/v': v_msg([P[0] + d, *P[1:]])}, 1e-9, 'v[U]'),
    ('P', lambda d: {'grasp/posterior': posterior_msg([*P[:3], P[3] + d, *P[4:]], W_OUT)}, 1e-4, 'P[UT]'),
    ('w', lambda d: {'grasp/posterior': posterior_msg(P, [W_OUT[0] + d, *W_OUT[1:]])}, 1e-4, 'w[usage]'),
    ('position', lambda d: {'grasp/pose': pose_msg((0.3, -0.25 + d, 0.1))}, 1e-3, 'position'),
    ('orientation', lambda d: {'grasp/pose': pose_msg((0.3, -0.25, 0.1), rotation_z(d))}, 0.01, 'orientation'),
    ('joints', lambda d: {'grasp/joint_targets': joint_msg([*Q[:2], Q[2] + d, *Q[3:]])}, 1e-3,
     'position[m1n6s300_joint_3]'),
    ('trajectory', lambda d: {'grasp/trajectory': trajectory_msg([*Q[:8], Q[8] + d])}, 1e-3,
     'points[0].positions[m1n6s300_joint_finger_3]'),
    ('palm feature', lambda d: {'grasp/features': features_msg([X[0] + d, *X[1:]])}, 1e-3, '[palm_x]'),
]


@pytest.mark.parametrize(('what', 'perturbed', 'tol', 'field'), CASES, ids=[c[0] for c in CASES])
def test_each_quantity_is_compared_at_its_tolerance(plan_step: Step, what: str,
                                                    perturbed: Callable[[float], dict[str, Any]],
                                                    tol: float, field: str) -> None:
    assert compare_step(plan_step, live_plan(**perturbed(0.8 * tol))) == []
    diffs = compare_step(plan_step, live_plan(**perturbed(1.5 * tol)))
    assert len(diffs) == 1 and diffs[0].field == field and diffs[0].fatal, diffs
    assert diffs[0].step == 2 and diffs[0].input == 'intent/w [0.9, 0.9, 0.1]'


def test_a_nan_never_matches(plan_step: Step) -> None:
    diffs = compare_step(plan_step, live_plan(**{'intent/v': v_msg([math.nan, *P[1:]])}))
    assert [d.field for d in diffs] == ['v[U]']


def test_names_and_frames_must_be_identical(plan_step: Step) -> None:
    other_frame = pose_msg((0.3, -0.25, 0.1), frame='world')
    assert [d.field for d in compare_step(plan_step, live_plan(**{'grasp/pose': other_frame}))] == ['frame_id']
    renamed = joint_msg(Q, names=(*ARM[:8], 'other'))
    assert [d.field for d in compare_step(plan_step, live_plan(**{'grasp/joint_targets': renamed}))] == ['name']
    relabelled = f64(P, ('U,T,H,UT,UH,TH,X', 7))
    assert [d.field for d in compare_step(plan_step, live_plan(**{'intent/v': relabelled}))] == ['layout']


def test_missing_and_extra_messages_are_differences(plan_step: Step) -> None:
    live = [o for o in live_plan() if o.topic != 'grasp/pose']
    diffs = compare_step(plan_step, live)
    assert [(d.topic, d.field, d.live) for d in diffs] == [('grasp/pose', 'message', 'nothing')]
    extra = live_plan() + outputs([('intent/clarification', text('why'))])
    diffs = compare_step(plan_step, extra)
    assert [(d.topic, d.recorded, d.live) for d in diffs] == [('intent/clarification', 'nothing', "'why'")]


def test_differences_list_the_cause_first_and_read_well(plan_step: Step) -> None:
    live = live_plan(**{'intent/v': v_msg([P[0] + 1e-3, *P[1:]]),
                        'grasp/features': features_msg([X[0] + 1.0, *X[1:]]),
                        'grasp/posterior': posterior_msg([*P[:3], P[3] + 0.1, *P[4:]], W_OUT)})
    diffs = compare_step(plan_step, live)
    assert [d.topic for d in diffs] == ['intent/v', 'grasp/posterior', 'grasp/features']
    line = str(diffs[1])
    assert line.startswith('input #2 (intent/w [0.9, 0.9, 0.1]): grasp/posterior P[UT]: recorded 0.6, live 0.7')
    assert '> 0.0001' in line


def test_clarifications_and_rejections_must_be_identical(session_bag: Path) -> None:
    steps = load_session(session_bag).steps
    assert compare_step(steps[3], outputs([('intent/clarification', text('P(no task) = 0.729 >= 0.5'))])) == []
    diffs = compare_step(steps[3], outputs([('intent/clarification', text('P(no task) = 0.73 >= 0.5'))]))
    assert [d.field for d in diffs] == ['text']
    same = Output(DIAGNOSTICS, 0, Rejection('/intent_interpreter: intent', 1, 'w contains NaN'))
    assert compare_step(steps[2], [same]) == []
    other = Output(DIAGNOSTICS, 0, Rejection('/intent_interpreter: intent', 1, 'w is empty'))
    diffs = compare_step(steps[2], [other])
    assert [d.field for d in diffs] == ['rejection'] and "'w is empty'" in diffs[0].live
    # a rejection instead of a plan
    diffs = compare_step(steps[5], [other])
    assert {d.topic for d in diffs} == {*PLAN_TOPICS, DIAGNOSTICS}


def test_model_name_must_match_and_other_content_is_a_note(session_bag: Path) -> None:
    step = load_session(session_bag).steps[4]
    answer = [o for o in step.expected if o.topic != 'model/active']
    assert compare_step(step, outputs([('model/active', model_doc('cup_5zone', SHA_B, 7))]) + answer) == []
    notes = compare_step(step, outputs([('model/active', model_doc('cup_5zone', SHA_A))]) + answer)
    assert [(d.field, d.fatal) for d in notes] == [('model content', False)]
    assert str(notes[0]).startswith('note: input #5 (model switch to cup_5zone): model/active model content')
    wrong = compare_step(step, outputs([('model/active', model_doc('cup_4zone', SHA_B))]) + answer)
    assert [(d.field, d.fatal) for d in wrong] == [('model name', True)]


def test_an_undecodable_live_message_is_a_difference(plan_step: Step) -> None:
    broken = output_of('grasp/pose', 0, b'\x00\x01\x00\x00\x01')
    assert isinstance(broken.value, Undecodable)
    live = [o for o in live_plan() if o.topic != 'grasp/pose'] + [broken]
    diffs = compare_step(plan_step, live)
    assert [(d.topic, d.field) for d in diffs] == [('grasp/pose', 'message')] and 'undecodable' in diffs[0].live


def test_answered_and_diverged_count_messages_per_topic(plan_step: Step) -> None:
    live = live_plan()
    assert not answered(plan_step, live[:-1]) and answered(plan_step, live)
    assert not diverged(plan_step, live)
    assert diverged(plan_step, live + outputs([('intent/v', v_msg(P))]))
    silent = Step(1, 'joint_states', 0, '', b'', (), 'joint_states')
    assert answered(silent, []) and not diverged(silent, []) and diverged(silent, live[:1])


def test_difference_text_names_input_topic_field_and_values() -> None:
    d = Difference(3, 'intent/w [0.9, 0.1, 0.9]', 'grasp/pose', 'position', '(0, 0, 0) m', '(1, 0, 0) m')
    assert str(d) == 'input #3 (intent/w [0.9, 0.1, 0.9]): grasp/pose position: recorded (0, 0, 0) m, live (1, 0, 0) m'
    assert Tolerances().v == 1e-9 and Tolerances().posterior == 1e-4


# ---------------------------------------------------------------- compaction
def test_compaction_keeps_only_rejections_of_the_diagnostics(session_bag: Path, tmp_path: Path) -> None:
    counts = compact_session(session_bag, tmp_path / 'compact', drop_topics=['/grasp/markers'])

    original = [m for m in read_messages(session_bag) if m.topic != '/grasp/markers']
    kept = list(read_messages(tmp_path / 'compact'))
    assert counts[DIAGNOSTICS] == 1 and '/grasp/markers' not in counts
    assert sum(counts.values()) == len(kept) == len(original) - 3  # 2 periodic statuses and 1 repeat dropped
    others = [(m.topic, m.timestamp_ns, m.cdr) for m in original if m.topic != DIAGNOSTICS]
    assert [(m.topic, m.timestamp_ns, m.cdr) for m in kept if m.topic != DIAGNOSTICS] == others
    assert topics_info(tmp_path / 'compact')['/model/active'].qos == (QosSpec('reliable', 'transient_local', 0),)
    before, after = load_session(session_bag), load_session(tmp_path / 'compact')
    assert [[(o.topic, o.t_ns) for o in s.expected] for s in before.steps] == \
        [[(o.topic, o.t_ns) for o in s.expected] for s in after.steps]


def test_reduced_values_of_every_kind_render_on_one_line() -> None:
    from grasp_intent_ros.tools.compare import summarize

    values = [Vector(('a',), np.arange(12.0)), Text('x'), Pose('f', np.zeros(3), np.array([0, 0, 0, 1.0])),
              Joints(('j',), np.zeros(1)), Trajectory(('j',), np.zeros((1, 1)), np.zeros(1)),
              ModelHeader('m', 1, SHA_A), Rejection('n', 1, 'r'), Undecodable('bad')]
    assert all('\n' not in summarize(v) and summarize(v) for v in values)
