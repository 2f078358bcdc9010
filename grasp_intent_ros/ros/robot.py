"""Robot-side messages written from core types: poses, twists, joint states, joint trajectories.

Poses
-----
4x4 transforms ``a_T_b`` -> geometry_msgs/PoseStamped through
:func:`~grasp_intent_ros.mico.frames.matrix_to_pose`. There is no TF here: a pose is published in the frame
it is given in. The readers of these messages (:func:`~grasp_intent_ros.wire.robot_state.pose_msg_to_matrix`,
:func:`~grasp_intent_ros.wire.robot_state.joint_positions`) are ROS-free, in
:mod:`grasp_intent_ros.wire.robot_state`, so that the session analysis reads recorded messages with them.
"""

from __future__ import annotations

import array
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, TwistStamped
from numpy.typing import ArrayLike
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from ..mico.frames import matrix_to_pose

__all__ = [
    'matrix_to_pose_msg',
    'twist_msg',
    'joint_state_msg',
    'joint_trajectory_msg',
]


def matrix_to_pose_msg(frame_T_pose: ArrayLike, *, frame_id: str, stamp: Time) -> PoseStamped:
    """PoseStamped of a 4x4 rigid transform (unit quaternion with w >= 0). Raises KinematicsError."""
    position, xyzw = matrix_to_pose(frame_T_pose)
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    point, quaternion = msg.pose.position, msg.pose.orientation  # filled in place: no objects built to copy
    point.x, point.y, point.z = position.tolist()
    quaternion.x, quaternion.y, quaternion.z, quaternion.w = xyzw.tolist()
    return msg


def twist_msg(twist: ArrayLike, *, frame_id: str, stamp: Time) -> TwistStamped:
    """TwistStamped of ``twist``, shape (6,): linear (m/s) then angular (rad/s) in ``frame_id`` (unchecked)."""
    msg = TwistStamped()
    msg.header.frame_id, msg.header.stamp = frame_id, stamp
    t = msg.twist
    t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z = np.asarray(twist, float).tolist()
    return msg


def joint_state_msg(names: Sequence[str], positions: ArrayLike, *, stamp: Time) -> JointState:
    """A JointState with names and positions (rad) only."""
    msg = JointState(name=list(names), position=_float64_array(names, positions))
    msg.header.stamp = stamp
    return msg


def _float64_array(names: Sequence[str], positions: ArrayLike) -> array.array[float]:
    """``positions`` (one per name) as the ``array.array('d')`` a message stores (taken as it is, unchecked)."""
    values = np.ascontiguousarray(positions, dtype=np.float64)
    if values.shape != (len(names),):
        raise ValueError(f'{len(names)} names but positions of shape {values.shape}')
    data = array.array('d')
    data.frombytes(values.tobytes())
    return data


def joint_trajectory_msg(names: Sequence[str], positions: ArrayLike, duration: float, *,
                         stamp: Time | None = None, frame_id: str = '') -> JointTrajectory:
    """A JointTrajectory with one point: ``positions`` (rad), zero velocities, after ``duration`` s.

    ``stamp`` defaults to zero, which trajectory controllers (trajectory_msgs convention) read as
    "start now"; a plan stamp, milliseconds in the past on arrival, would make them skip ahead.
    """
    msg = JointTrajectory(joint_names=list(names))
    msg.header.stamp = Time() if stamp is None else stamp
    msg.header.frame_id = frame_id
    point = JointTrajectoryPoint(positions=_float64_array(names, positions),
                                 velocities=array.array('d', bytes(8 * len(names))))
    sec, nanosec = divmod(int(float(duration) * 1e9), 10**9)  # as rclpy's Duration(seconds=...).to_msg()
    point.time_from_start = DurationMsg(sec=sec, nanosec=nanosec)
    msg.points = [point]
    return msg
