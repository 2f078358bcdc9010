"""Robot-side messages read as values: a PoseStamped as a transform, a JointState's positions by name, a twist.

ROS-free (attribute access only, so rosbags' message classes are read too): the nodes read their inputs and
the session analysis reads recorded messages with the same checks. Writers of these messages need rclpy and
live in :mod:`grasp_intent_ros.ros.robot`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import KinematicsError
from ..mico.frames import QUATERNION_NORM_TOL, check_unit_quaternion, pose_to_matrix
from ..mico.grasp import check_workspace
from ..mico.kinematics import BASE_FRAME
from ..mico.mock_arm import TwistCommand, check_twist
from .topics import MAX_JOINTS, MAX_NAME_LENGTH, check_names

__all__ = ['QUATERNION_NORM_TOL', 'check_unit_quaternion', 'pose_msg_to_matrix', 'named_positions', 'joint_positions',
           'twist_command', 'seconds', 'stamp_seconds', 'stamp_nanoseconds', 'object_pose_msg', 'trajectory_time']


def pose_msg_to_matrix(msg: Any, *, frame_id: str,
                       quat_tol: float = QUATERNION_NORM_TOL) -> NDArray[np.float64]:
    """``frame_T_pose``, shape (4, 4), of a geometry_msgs/PoseStamped given in ``frame_id`` (no TF lookup).

    Raises
    ------
    KinematicsError
        If the header names another frame, the position is not finite, or the quaternion is not a
        unit quaternion (see :func:`check_unit_quaternion`).
    """
    if msg.header.frame_id != frame_id:
        raise KinematicsError(f'pose must be given in frame {frame_id!r} (no TF lookup), '
                              f'got frame_id {msg.header.frame_id[:MAX_NAME_LENGTH]!r}')
    p, o = msg.pose.position, msg.pose.orientation
    position = np.array([p.x, p.y, p.z], dtype=np.float64)
    if not np.all(np.isfinite(position)):
        raise KinematicsError(f'pose position must be finite, got {position.tolist()}')
    return pose_to_matrix(position, check_unit_quaternion([o.x, o.y, o.z, o.w], tol=quat_tol))


def named_positions(msg: Any, names: Sequence[str]) -> dict[str, float]:
    """The positions (rad) of those of ``names`` that a sensor_msgs/JointState names, by name, in ``names``' order.

    The message's names may come in any order, with others besides (not read); its velocities and efforts are
    never read.

    Raises
    ------
    KinematicsError
        If the message has duplicate names, a different number of names and positions, or a position of one of
        ``names`` that is NaN or infinite.
    GraspIntentError
        For more than :data:`~grasp_intent_ros.wire.topics.MAX_JOINTS` names or a name longer than
        :data:`~grasp_intent_ros.wire.topics.MAX_NAME_LENGTH`.
    """
    check_names(msg.name, max_count=MAX_JOINTS, what='joint state')
    if len(msg.position) != len(msg.name):
        raise KinematicsError(f'joint state has {len(msg.name)} names but {len(msg.position)} positions')
    index = {name: i for i, name in enumerate(msg.name)}
    if len(index) != len(msg.name):
        duplicates = sorted(name for name, count in Counter(msg.name).items() if count > 1)
        raise KinematicsError(f'joint state has duplicate names: {duplicates}')
    positions = {name: float(msg.position[index[name]]) for name in names if name in index}
    bad = [name for name, value in positions.items() if not math.isfinite(value)]
    if bad:
        raise KinematicsError(f'joint state positions must be finite; NaN or infinity for {bad}')
    return positions


def joint_positions(msg: Any, names: Sequence[str]) -> NDArray[np.float64] | None:
    """Positions of ``names`` (in that order) from one sensor_msgs/JointState whose names may come in any order.

    For one message alone (e.g. ``grasp/joint_targets``); a ``joint_states`` stream, whose joints may come in
    several messages, is read by :class:`~grasp_intent_ros.wire.joint_states.JointStates`.

    Returns
    -------
    ndarray, shape (len(names),), or None when the message lacks one of ``names``.

    Raises
    ------
    KinematicsError, GraspIntentError
        As :func:`named_positions`.
    """
    positions = named_positions(msg, names)
    if len(positions) < len(names):
        return None
    return np.array([positions[name] for name in names], dtype=np.float64)


def twist_command(msg: Any, *, default_frame: str = BASE_FRAME) -> TwistCommand:
    """A geometry_msgs/TwistStamped, or a plain Twist (no header: frame ''), as a checked twist command.

    An empty frame means ``default_frame``.

    Raises
    ------
    CommandError
        As :func:`grasp_intent_ros.mico.mock_arm.check_twist`: a NaN or infinity, a frame but the base or the EE.
    """
    stamped = hasattr(msg, 'header')
    twist, frame = (msg.twist, msg.header.frame_id) if stamped else (msg, '')
    return check_twist([twist.linear.x, twist.linear.y, twist.linear.z],
                       [twist.angular.x, twist.angular.y, twist.angular.z], frame, default_frame=default_frame)


def seconds(t: Any) -> float:
    """A builtin_interfaces Time or Duration (``sec``, ``nanosec``) in seconds."""
    return int(t.sec) + 1e-9 * int(t.nanosec)


def stamp_seconds(msg: Any) -> float | None:
    """A message's header stamp in seconds; None for a message without a header or with an unset (zero) stamp."""
    if not hasattr(msg, 'header'):
        return None
    return seconds(msg.header.stamp) or None


def stamp_nanoseconds(msg: Any) -> int | None:
    """A message's header stamp in integer nanoseconds (exact, for ordering); None as :func:`stamp_seconds`."""
    if not hasattr(msg, 'header'):
        return None
    return (int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)) or None


def trajectory_time(msg: Any) -> float | None:
    """A trajectory_msgs/JointTrajectory's last ``time_from_start`` (s): how long it runs; None without points."""
    return seconds(msg.points[-1].time_from_start) if msg.points else None


def object_pose_msg(msg: Any, workspace_radius: float) -> NDArray[np.float64]:
    """``base_T_obj``, shape (4, 4), of an ``object/pose`` PoseStamped: in the base frame, within the workspace.

    Raises
    ------
    KinematicsError
        As :func:`pose_msg_to_matrix` (frame ``m1n6s300_link_base``), or for a position farther than
        ``workspace_radius`` (m) from the base origin (:func:`grasp_intent_ros.mico.grasp.check_workspace`).
    """
    base_T_obj = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
    check_workspace(base_T_obj[:3, 3], workspace_radius)
    return base_T_obj
