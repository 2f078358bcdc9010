"""Recorded-session builders shared by test_outputs, test_session and test_compare.

rosbags messages and bags in tmp_path; no rclpy.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter
from grasp_intent_ros.sessions.outputs import Output, output_of
from grasp_intent_ros.wire.topics import DIAGNOSTICS, MSGTYPES

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


def twist_msg(vx: float = 0.0) -> Any:
    vector = T['geometry_msgs/msg/Vector3']
    return T['geometry_msgs/msg/TwistStamped'](header=header(), twist=T['geometry_msgs/msg/Twist'](
        linear=vector(x=vx, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)))


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


def outputs(pairs: list[tuple[str, Any]], t0: int = 0) -> list[Output]:
    """Live-like outputs from (relative topic, rosbags message) pairs, through the serialized path."""
    return [output_of(topic, t0 + k, bytes(STORE.serialize_cdr(msg, MSGTYPES[topic]))) for k, (topic, msg) in
            enumerate(pairs)]


def live_plan(**changes: Any) -> list[Output]:
    """The live answer to the planned w of session_messages(), with one message replaced."""
    pairs = dict([('intent/v', v_msg(P)), *plan()])
    pairs.update(changes)
    return outputs(list(pairs.items()))


def rotation_z(angle: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))
