"""Robot-side messages <-> core types: poses, joint states, joint trajectories.

Poses
-----
geometry_msgs/PoseStamped <-> 4x4 transforms ``a_T_b`` through :func:`~grasp_intent_ros.core.frames.
pose_to_matrix` / :func:`~grasp_intent_ros.core.frames.matrix_to_pose`. There is no TF here: a pose
must already be in the expected frame. Incoming quaternions must have unit norm within
:data:`QUATERNION_NORM_TOL` (they are then normalised); anything else is a malformed message.
"""

from __future__ import annotations

import array
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from numpy.typing import ArrayLike, NDArray
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from ..core.errors import KinematicsError
from ..core.frames import matrix_to_pose, pose_to_matrix
from ..protocol import MAX_JOINTS, MAX_NAME_LENGTH, check_names

__all__ = [
    'QUATERNION_NORM_TOL',
    'check_unit_quaternion',
    'pose_msg_to_matrix',
    'matrix_to_pose_msg',
    'joint_positions',
    'joint_state_msg',
    'joint_trajectory_msg',
]

QUATERNION_NORM_TOL = 1e-3
"""Largest accepted deviation of an incoming quaternion's norm from 1."""


def check_unit_quaternion(xyzw: ArrayLike, *, tol: float = QUATERNION_NORM_TOL) -> NDArray[np.float64]:
    """A finite quaternion (x, y, z, w) of unit norm within ``tol``, as an array of shape (4,).

    Raises
    ------
    KinematicsError
        For a wrong shape, a NaN or infinity, or a norm further than ``tol`` from 1.
    """
    try:
        q = np.asarray(xyzw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'quaternion must be numeric: {exc}') from None
    if q.shape != (4,):
        raise KinematicsError(f'quaternion must have 4 entries (x, y, z, w), got shape {q.shape}')
    if not np.all(np.isfinite(q)):
        raise KinematicsError(f'quaternion must be finite, got {q.tolist()}')
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > tol:
        raise KinematicsError(f'quaternion must have unit norm (within {tol:g}), got norm {norm:.6g} '
                              f'for (x, y, z, w) = {q.tolist()}')
    return q


def pose_msg_to_matrix(msg: PoseStamped, *, frame_id: str,
                       quat_tol: float = QUATERNION_NORM_TOL) -> NDArray[np.float64]:
    """``frame_T_pose``, shape (4, 4), of a PoseStamped given in ``frame_id``.

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


def joint_positions(msg: JointState, names: Sequence[str]) -> NDArray[np.float64] | None:
    """Positions of ``names`` (in that order) from a JointState whose names may come in any order.

    Returns
    -------
    ndarray, shape (len(names),), or None when the message lacks one of ``names`` (e.g. a
    finger-only message from another publisher).

    Raises
    ------
    KinematicsError
        If the message has duplicate names, a different number of names and positions, or a wanted
        position that is NaN or infinite.
    GraspIntentError
        For more than :data:`~grasp_intent_ros.protocol.MAX_JOINTS` names or a name longer than
        :data:`~grasp_intent_ros.protocol.MAX_NAME_LENGTH`.
    """
    check_names(msg.name, max_count=MAX_JOINTS, what='joint state')
    if len(msg.position) != len(msg.name):
        raise KinematicsError(f'joint state has {len(msg.name)} names but {len(msg.position)} positions')
    index = {name: i for i, name in enumerate(msg.name)}
    if len(index) != len(msg.name):
        duplicates = sorted(name for name, count in Counter(msg.name).items() if count > 1)
        raise KinematicsError(f'joint state has duplicate names: {duplicates}')
    if any(name not in index for name in names):
        return None
    q = np.array([msg.position[index[name]] for name in names], dtype=np.float64)
    if not np.all(np.isfinite(q)):
        bad = [name for name, value in zip(names, q) if not math.isfinite(value)]
        raise KinematicsError(f'joint state positions must be finite; NaN or infinity for {bad}')
    return q


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
