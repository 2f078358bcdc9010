"""Robot-side messages read as values: a PoseStamped as a transform, a JointState's positions by name.

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
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from ..mico.frames import pose_to_matrix
from .topics import MAX_JOINTS, MAX_NAME_LENGTH, check_names

__all__ = ['QUATERNION_NORM_TOL', 'check_unit_quaternion', 'pose_msg_to_matrix', 'joint_positions']

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


def joint_positions(msg: Any, names: Sequence[str]) -> NDArray[np.float64] | None:
    """Positions of ``names`` (in that order) from a sensor_msgs/JointState whose names may come in any order.

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
    if any(name not in index for name in names):
        return None
    q = np.array([msg.position[index[name]] for name in names], dtype=np.float64)
    if not np.all(np.isfinite(q)):
        bad = [name for name, value in zip(names, q) if not math.isfinite(value)]
        raise KinematicsError(f'joint state positions must be finite; NaN or infinity for {bad}')
    return q
