"""grasp_intent_ros.sessions.report on a synthetic session bag written in tmp_path (no rclpy).

The bag holds what the node suite publishes (layouts as in the report's module docstring, i.e. as the
nodes write them): intent/w without layout, labelled intent/v, a clarification, the model document of a
model fitted here, stamped grasp/posterior ("<zones>|<tasks>"), grasp/features, grasp/pose and
grasp/joint_targets, and /diagnostics with one rejection and the planner's planning times.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.image import imread
from rosbags.typesys import Stores, get_typestore

from grasp_intent_ros.method.features import FINGERS, MICO_3F
from grasp_intent_ros.method.intent import interpret, reconstruct_w
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import matrix_to_pose
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.sessions import report
from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter
from grasp_intent_ros.wire.model_document import model_document

T0 = 1_700_000_000_000_000_000  # ns
S = 1_000_000_000  # ns per s
NS = '/robot1'
F64MA, STRING, DIAG_T = 'std_msgs/msg/Float64MultiArray', 'std_msgs/msg/String', 'diagnostic_msgs/msg/DiagnosticArray'
POSE_T, JOINTS_T = 'geometry_msgs/msg/PoseStamped', 'sensor_msgs/msg/JointState'
CASES = [(0.9, 0.9, 0.1), (1.0, 0.0, 0.0), (0.9, 0.1, 0.9)]
CLARIFY = (0.1, 0.1, 0.1)
LATCHED = QosSpec('reliable', 'transient_local', 1)


@pytest.fixture(scope='module')
def store() -> Any:
    return get_typestore(Stores.ROS2_JAZZY)


def f64ma(store: Any, values: Any, label: str | None = None) -> Any:
    t = store.types
    data = np.asarray(values, dtype=np.float64)
    dims = [] if label is None else [t['std_msgs/msg/MultiArrayDimension'](label=label, size=data.size,
                                                                             stride=data.size)]
    return t[F64MA](layout=t['std_msgs/msg/MultiArrayLayout'](dim=dims, data_offset=0), data=data)


def stamped(store: Any, values: Any, label: str, stamp_ns: int) -> Any:
    """A (1, n) array with the planner's stamp axis, as ``ros.robot.stamped_array_to_msg`` writes it."""
    t = store.types
    data = np.asarray(values, dtype=np.float64)
    dim = t['std_msgs/msg/MultiArrayDimension']
    dims = [dim(label=f'stamp={stamp_ns // S}.{stamp_ns % S:09d}', size=1, stride=data.size),
            dim(label=label, size=data.size, stride=1)]
    return t[F64MA](layout=t['std_msgs/msg/MultiArrayLayout'](dim=dims, data_offset=0), data=data)


def status(store: Any, level: int, name: str, message: str, values: dict[str, str]) -> Any:
    t = store.types
    kvs = [t['diagnostic_msgs/msg/KeyValue'](key=k, value=v) for k, v in values.items()]
    st = t['diagnostic_msgs/msg/DiagnosticStatus'](level=level, name=name, message=message, hardware_id='',
                                                    values=kvs)
    header = t['std_msgs/msg/Header'](stamp=t['builtin_interfaces/msg/Time'](sec=0, nanosec=0), frame_id='')
    return t[DIAG_T](header=header, status=[st])


def header(store: Any, stamp_ns: int, frame_id: str = '') -> Any:
    t = store.types
    return t['std_msgs/msg/Header'](stamp=t['builtin_interfaces/msg/Time'](sec=stamp_ns // S, nanosec=stamp_ns % S),
                                    frame_id=frame_id)


def plan_pose_and_targets(store: Any, x: np.ndarray, stamp_ns: int) -> tuple[Any, Any]:
    """grasp/pose and grasp/joint_targets of a plan with the arm at HOME_Q grasping x (an object it implies)."""
    t = store.types
    position, xyzw = matrix_to_pose(MicoKinematics().fk(HOME_Q))
    pose = t[POSE_T](header=header(store, stamp_ns, BASE_FRAME), pose=t['geometry_msgs/msg/Pose'](
        position=t['geometry_msgs/msg/Point'](x=position[0], y=position[1], z=position[2]),
        orientation=t['geometry_msgs/msg/Quaternion'](x=xyzw[0], y=xyzw[1], z=xyzw[2], w=xyzw[3])))
    joints = t[JOINTS_T](header=header(store, stamp_ns), name=[*ARM_JOINTS, *FINGER_JOINTS],
                         position=np.r_[HOME_Q, x[FINGERS]], velocity=np.array([]), effort=np.array([]))
    return pose, joints


def write_session_bag(store: Any, path: Path, model: GraspModel, *, planner: bool = True) -> None:
    """The node suite's outputs for CASES and one clarification, 1 s apart.

    ``planner=False`` leaves out model and grasp topics (a bag lacking topics).
    """
    with SessionWriter(path, typestore=store) as bag:
        if planner:
            bag.add_topic('/diagnostics', DIAG_T, qos=QosSpec())
        write_chain(store, bag, model, NS, planner=planner)


def write_chain(store: Any, bag: Any, model: GraspModel, ns: str, *, planner: bool = True) -> None:
    """:func:`write_session_bag`'s messages in namespace ``ns``, into an open ``bag`` (``/diagnostics`` added)."""
    zones = ','.join(model.zone_labels)
    bag.add_topic(f'{ns}/intent/w', F64MA, qos=QosSpec())
    if planner:
        bag.add_topic(f'{ns}/intent/v', F64MA, qos=QosSpec())
        bag.add_topic(f'{ns}/intent/clarification', STRING, qos=QosSpec())
        bag.add_topic(f'{ns}/model/active', STRING, qos=LATCHED)
        bag.add_topic(f'{ns}/grasp/posterior', F64MA, qos=QosSpec())
        bag.add_topic(f'{ns}/grasp/features', F64MA, qos=QosSpec())
        bag.add_topic(f'{ns}/grasp/pose', POSE_T, qos=QosSpec())
        bag.add_topic(f'{ns}/grasp/joint_targets', JOINTS_T, qos=QosSpec())
        doc = model_document(model, name='toy_7zone', version=1)
        bag.write_message(f'{ns}/model/active', T0, store.types[STRING](data=doc))
        bag.write_message('/diagnostics', T0 + 1, status(store, 0, f'{ns}/grasp_planner: planning',
                                                         'waiting for intent/v', {'plans': '0'}))
    for k, w in enumerate([*CASES, CLARIFY]):
        t = T0 + (k + 1) * S
        bag.write_message(f'{ns}/intent/w', t, f64ma(store, w))
        if not planner:
            continue
        result = interpret(w)
        if result.needs_clarification:
            bag.write_message(f'{ns}/intent/clarification', t + 1000, store.types[STRING](data=result.reason))
            continue
        bag.write_message(f'{ns}/intent/v', t + 1000, f64ma(store, result.v, 'U,T,H,UT,UH,TH,UTH'))
        x = model.means[int(np.argmax(result.v))]  # stands in for the planned grasp
        p = model.posterior(x)
        w_rec = reconstruct_w(p, model.zones, 3)
        label = f'{zones}|{",".join(model.task_names)}'
        plan_ns = t + 50_000_000
        bag.write_message(f'{ns}/grasp/posterior', plan_ns, stamped(store, np.r_[p, w_rec], label, t))
        bag.write_message(f'{ns}/grasp/features', plan_ns, stamped(store, x, ','.join(MICO_3F.names), t))
        pose, joints = plan_pose_and_targets(store, x, t)
        bag.write_message(f'{ns}/grasp/pose', plan_ns, pose)
        bag.write_message(f'{ns}/grasp/joint_targets', plan_ns, joints)
        for repeat in (0, 1):  # the periodic status repeats the last planning time: one sample
            bag.write_message('/diagnostics', plan_ns + repeat + 1, status(
                store, 0, f'{ns}/grasp_planner: planning', 'ok',
                {'plans': str(k + 1), 'last planning time [ms]': f'{40.0 + 10 * k:.3f}'}))
    if planner:  # a NaN w rejected by the interpreter: one WARN, then its periodic repeat
        for dt in (6 * S, 7 * S):
            bag.write_message('/diagnostics', T0 + dt, status(
                store, 1, f'{ns}/intent_interpreter: intent', 'rejected input: w contains NaN or infinity',
                {'messages received': '5', 'messages rejected': '1',
                 'last error': 'w contains NaN or infinity (first at index 1: nan)'}))


def assert_png(path: Path, min_size: tuple[int, int] = (300, 300)) -> None:
    """A real picture: large enough and not a blank canvas."""
    assert path.is_file(), path
    image = imread(path)
    assert image.shape[0] >= min_size[0] and image.shape[1] >= min_size[1], image.shape
    rgb = image[..., :3]
    assert float(rgb.std()) > 0.05, f'{path.name} looks blank'
    assert (rgb.reshape(-1, 3) < 0.9).any(axis=1).mean() > 0.01, f'{path.name} has almost nothing drawn'


def test_report_writes_figures_and_summary(store, toy_model, tmp_path: Path, capsys) -> None:
    bag, out = tmp_path / 'session', tmp_path / 'report'
    write_session_bag(store, bag, toy_model)
    assert report.main([str(bag), '--out', str(out)]) == 0
    assert 'report: 7 figures' in capsys.readouterr().out
    scenes = [f'grasp_scene_{k:02d}.png' for k in (1, 2, 3)]
    for name in ('intent_cases.png', 'w_over_time.png', 'kl_matrices.png', 'grasps_3d.png', *scenes):
        assert_png(out / name)
    summary = (out / 'summary.md').read_text()
    for line in (f'| {NS}/intent/w | {F64MA} | 4 |', f'| {NS}/intent/v | {F64MA} | 3 |',
                 f'| {NS}/model/active | {STRING} | 1 |', f'| /diagnostics | {DIAG_T} | 9 |',
                 '- intent messages (w): 4; target vectors (v): 3', '- plans: 3', '- clarifications: 1',
                 '- rejections (from /diagnostics): 1', '  - /robot1/intent_interpreter: intent: 1',
                 '  - reason: w contains NaN or infinity (first at index 1: nan)',
                 '- planning time: 3 plans reported, mean 50.0 ms, median 50.0 ms, max 60.0 ms',
                 '- models: toy_7zone (version 1) at 0.0 s (7 zones)',
                 '- [intent_cases.png](intent_cases.png)', '- [grasps_3d.png](grasps_3d.png)',
                 *(f'- [{name}]({name})' for name in scenes)):
        assert line in summary, f'{line!r} not in\n{summary}'
    assert 'P(no task) = 0.7290' in summary
    assert 'skipped' not in summary


def test_a_scene_gets_one_report_per_chain_each_of_its_own_topics_and_nodes(store, toy_model, tmp_path: Path,
                                                                           capsys) -> None:
    bag, out = tmp_path / 'scene', tmp_path / 'report'
    with SessionWriter(bag, typestore=store) as writer:
        writer.add_topic('/diagnostics', DIAG_T, qos=QosSpec())
        writer.add_topic('/joint_states', JOINTS_T, qos=QosSpec())
        writer.write_message('/joint_states', T0, store.types[JOINTS_T](
            header=header(store, T0), name=[*ARM_JOINTS, *FINGER_JOINTS], position=np.r_[HOME_Q, 0.0, 0.0, 0.0],
            velocity=np.array([]), effort=np.array([])))
        write_chain(store, writer, toy_model, '/cup')
        write_chain(store, writer, toy_model, '/flashlight', planner=False)
    assert report.main([str(bag), '--out', str(out)]) == 0
    assert 'report: 8 figures' in capsys.readouterr().out  # the cup's 7, the flashlight's w over time
    root = (out / 'summary.md').read_text()
    assert '- [/cup](cup/summary.md): 7 figures' in root and '- [/flashlight](flashlight/summary.md): 1 figures' in root
    cup, flashlight = (out / 'cup' / 'summary.md').read_text(), (out / 'flashlight' / 'summary.md').read_text()
    assert_png(out / 'cup' / 'grasp_scene_01.png')
    assert '- plans: 3' in cup and '- rejections (from /diagnostics): 1' in cup and '/cup/intent_interpreter' in cup
    assert '- planning time: 3 plans reported' in cup and '/flashlight/' not in cup
    assert '- plans: 0' in flashlight and '- rejections (from /diagnostics): 0' in flashlight
    assert 'planning time: not in this bag' in flashlight and '/cup/' not in flashlight
    assert sorted(p.name for p in (out / 'flashlight').glob('*.png')) == ['w_over_time.png']


def test_bag_lacking_topics_skips_figures_and_says_so(store, toy_model, tmp_path: Path) -> None:
    bag, out = tmp_path / 'inputs_only', tmp_path / 'report'
    write_session_bag(store, bag, toy_model, planner=False)
    assert report.main([str(bag), '--out', str(out)]) == 0
    assert sorted(p.name for p in out.glob('*.png')) == ['w_over_time.png']
    assert_png(out / 'w_over_time.png')
    summary = (out / 'summary.md').read_text()
    for reason in ('intent cases (v and P bars): no intent/v messages',
                   'KL heat maps: no model/active or model/ambiguity messages',
                   '3-D grasps: no grasp/features messages',
                   'planning time: not in this bag'):
        assert f'{reason}' in summary, summary
    assert '- plans: 0' in summary and '- clarifications: 0' in summary


def test_the_shared_control_loop_is_drawn(store, tmp_path: Path) -> None:
    bag, out = tmp_path / 'shared', tmp_path / 'report'
    t = store.types
    twist_t = 'geometry_msgs/msg/TwistStamped'

    def twist(vx: float, wz: float) -> Any:
        header = t['std_msgs/msg/Header'](stamp=t['builtin_interfaces/msg/Time'](sec=0, nanosec=0),
                                         frame_id='m1n6s300_link_base')
        return t[twist_t](header=header, twist=t['geometry_msgs/msg/Twist'](
            linear=t['geometry_msgs/msg/Vector3'](x=vx, y=0.0, z=0.0),
            angular=t['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=wz)))

    with SessionWriter(bag, typestore=store) as writer:
        for topic, msgtype in (('/operator/twist', twist_t), ('/assistance/twist', twist_t),
                               ('/assistance/alpha', 'std_msgs/msg/Float64')):
            writer.add_topic(topic, msgtype, qos=QosSpec())
        for k in range(200):
            alpha = min(k / 100, 0.9)
            now = T0 + k * 10_000_000
            writer.write_message('/operator/twist', now, twist(0.1, 0.0))
            writer.write_message('/assistance/twist', now + 1, twist((1 - alpha) * 0.1, alpha * 0.5))
            writer.write_message('/assistance/alpha', now + 2, t['std_msgs/msg/Float64'](data=alpha))
    assert report.main([str(bag), '--out', str(out)]) == 0
    assert_png(out / 'shared_control.png')
    summary = (out / 'summary.md').read_text()
    assert '- [shared_control.png](shared_control.png)' in summary and '| /assistance/alpha |' in summary


def test_malformed_messages_are_counted_not_fatal(store, toy_model, tmp_path: Path) -> None:
    bag, out = tmp_path / 'bad', tmp_path / 'report'
    with SessionWriter(bag, typestore=store) as writer:
        writer.add_topic('/grasp/posterior', F64MA, qos=QosSpec())
        writer.add_topic('/model/active', STRING, qos=LATCHED)
        writer.write_message('/grasp/posterior', T0, stamped(store, [0.5, 0.5], 'U,usage', T0))
        writer.write_message('/model/active', T0 + 1, store.types[STRING](data='name: [not a model'))
    assert report.main([str(bag), '--out', str(out)]) == 0
    summary = (out / 'summary.md').read_text()
    assert '- malformed messages skipped: /grasp/posterior 1, /model/active 1' in summary, summary


def test_missing_or_invalid_bag_exits_2(tmp_path: Path, capsys) -> None:
    assert report.main([str(tmp_path / 'nope'), '--out', str(tmp_path / 'out')]) == 2
    assert 'is not a rosbag2 directory' in capsys.readouterr().err
    broken = tmp_path / 'broken'
    broken.mkdir()
    (broken / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: 9}\n')
    assert report.main([str(broken), '--out', str(tmp_path / 'out')]) == 2
    assert f'invalid bag {broken}' in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


def test_report_does_not_import_rclpy() -> None:
    code = 'import sys, grasp_intent_ros.sessions.report; sys.exit("rclpy" in sys.modules)'
    assert subprocess.run([sys.executable, '-c', code], timeout=60).returncode == 0
