"""Robot-side messages <-> core types: poses, joint states, trajectories, markers, stamped arrays.

Poses
-----
geometry_msgs/PoseStamped <-> 4x4 transforms ``a_T_b`` through :func:`~grasp_intent_ros.core.kinematics.
pose_to_matrix` / :func:`~grasp_intent_ros.core.kinematics.matrix_to_pose`. There is no TF here: a pose
must already be in the expected frame. Incoming quaternions must have unit norm within
:data:`QUATERNION_NORM_TOL` (they are then normalised); anything else is a malformed message.

Stamped arrays and the grasp posterior
--------------------------------------
Both layouts are described in :mod:`grasp_intent_ros.ros.conversions`, which holds their one parser
(``stamped_values``, ``split_posterior``). :func:`stamped_array_to_msg` and :func:`posterior_to_msg`
write them; :func:`stamped_array_from_msg` and :func:`posterior_from_msg` read them, with the stamp as a
``builtin_interfaces/Time``.

Markers
-------
:func:`grasp_markers` draws the object as a cylinder standing on its frame origin, the planned gripper as
an arrow along the approach ending at the palm centre plus a schematic of the three fingers (base on a
circle around the approach axis, bent inwards by their closure; not the finger kinematics), and a text
with the most likely zones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion
from numpy.typing import ArrayLike, NDArray
from rclpy.duration import Duration
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from ..core.errors import KinematicsError
from ..core.kinematics import matrix_to_pose, pose_to_matrix
from .conversions import MAX_ARRAY_SIZE, array_to_msg, join_labels, split_posterior, stamped_values

__all__ = [
    'QUATERNION_NORM_TOL',
    'check_unit_quaternion',
    'pose_msg_to_matrix',
    'matrix_to_pose_msg',
    'joint_positions',
    'joint_state_msg',
    'trajectory_duration',
    'joint_trajectory_msg',
    'stamp_label',
    'stamped_array_to_msg',
    'stamped_array_from_msg',
    'GraspPosterior',
    'posterior_to_msg',
    'posterior_from_msg',
    'zone_summary',
    'grasp_markers',
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
                              f'got frame_id {msg.header.frame_id!r}')
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
    msg.pose = Pose(position=Point(x=float(position[0]), y=float(position[1]), z=float(position[2])),
                    orientation=Quaternion(x=float(xyzw[0]), y=float(xyzw[1]), z=float(xyzw[2]),
                                           w=float(xyzw[3])))
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
    """
    if len(msg.position) != len(msg.name):
        raise KinematicsError(f'joint state has {len(msg.name)} names but {len(msg.position)} positions')
    index = {name: i for i, name in enumerate(msg.name)}
    if len(index) != len(msg.name):
        raise KinematicsError(f'joint state has duplicate names: {list(msg.name)}')
    if any(name not in index for name in names):
        return None
    q = np.array([msg.position[index[name]] for name in names], dtype=np.float64)
    if not np.all(np.isfinite(q)):
        bad = [name for name, value in zip(names, q) if not math.isfinite(value)]
        raise KinematicsError(f'joint state positions must be finite; NaN or infinity for {bad}')
    return q


def joint_state_msg(names: Sequence[str], positions: ArrayLike, *, stamp: Time) -> JointState:
    """A JointState with names and positions (rad) only."""
    values = np.asarray(positions, dtype=np.float64)
    if values.shape != (len(names),):
        raise ValueError(f'{len(names)} names but positions of shape {values.shape}')
    msg = JointState(name=list(names), position=[float(v) for v in values])
    msg.header.stamp = stamp
    return msg


def trajectory_duration(q_from: ArrayLike, q_to: ArrayLike, velocity_limits: ArrayLike, *,
                        min_duration: float = 0.0) -> float:
    """Shortest time (s) to move every joint from ``q_from`` to ``q_to`` at its velocity limit (rad/s).

    max_i |q_to_i - q_from_i| / v_i, but at least ``min_duration``. All arrays shape (n,), limits > 0.
    """
    delta = np.abs(np.asarray(q_to, dtype=np.float64) - np.asarray(q_from, dtype=np.float64))
    limits = np.asarray(velocity_limits, dtype=np.float64)
    if delta.shape != limits.shape or not np.all(limits > 0.0):
        raise ValueError(f'need positive velocity limits of shape {delta.shape}, got {limits.tolist()}')
    return max(float(np.max(delta / limits)) if delta.size else 0.0, float(min_duration))


def joint_trajectory_msg(names: Sequence[str], positions: ArrayLike, duration: float, *,
                         stamp: Time | None = None, frame_id: str = '') -> JointTrajectory:
    """A JointTrajectory with one point: ``positions`` (rad), zero velocities, reached after
    ``duration`` seconds.

    ``stamp`` defaults to zero, which trajectory controllers (trajectory_msgs convention) read as
    "start now"; a plan stamp, milliseconds in the past on arrival, would make them skip ahead.
    """
    values = np.asarray(positions, dtype=np.float64)
    if values.shape != (len(names),):
        raise ValueError(f'{len(names)} names but positions of shape {values.shape}')
    msg = JointTrajectory(joint_names=list(names))
    msg.header.stamp = Time() if stamp is None else stamp
    msg.header.frame_id = frame_id
    msg.points = [JointTrajectoryPoint(positions=[float(v) for v in values], velocities=[0.0] * len(names),
                                       time_from_start=Duration(seconds=float(duration)).to_msg())]
    return msg


# ---------------------------------------------------------------------------------- stamped arrays
def stamp_label(stamp: Time) -> str:
    """``"stamp=<sec>.<nanosec>"`` with 9 nanosecond digits."""
    return f'stamp={int(stamp.sec)}.{int(stamp.nanosec):09d}'


def stamped_array_to_msg(values: ArrayLike, labels: str | Sequence[str], *, stamp: Time) -> Float64MultiArray:
    """A 1-D array as a stamped Float64MultiArray (layout in :mod:`grasp_intent_ros.ros.conversions`).

    ``labels``: the value names (one per value) or a ready label string.
    """
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f'values must be 1-D, got shape {arr.shape}')
    return array_to_msg(arr[None, :], [stamp_label(stamp), labels])


def stamped_array_from_msg(msg: Float64MultiArray, *, max_size: int = MAX_ARRAY_SIZE,
                           what: str = 'array') -> tuple[Time, str, NDArray[np.float64]]:
    """(stamp, values label, values of shape (n,)) of a stamped array.

    Raises
    ------
    GraspIntentError
        If the layout is not (stamp axis of size 1, values axis) or the values are malformed.
    """
    values, label, stamp = stamped_values(msg, max_size=max_size, what=what)
    assert stamp is not None  # require_stamp=True
    return Time(sec=stamp[0], nanosec=stamp[1]), label, values


@dataclass(frozen=True)
class GraspPosterior:
    """The content of ``grasp/posterior``.

    Attributes
    ----------
    stamp : builtin_interfaces/Time
        Stamp of the plan (equal to the header stamp of the plan's other outputs).
    zone_labels : tuple of str, length K
    p : ndarray, shape (K,)
        P(zone | x) of the planned grasp.
    task_names : tuple of str, length m
    w : ndarray, shape (m,)
        Principal-task probabilities reconstructed from p.
    """

    stamp: Time
    zone_labels: tuple[str, ...]
    p: NDArray[np.float64]
    task_names: tuple[str, ...]
    w: NDArray[np.float64]


def posterior_to_msg(p: ArrayLike, w: ArrayLike, zone_labels: Sequence[str], task_names: Sequence[str], *,
                     stamp: Time) -> Float64MultiArray:
    """The ``grasp/posterior`` message (layout in :mod:`grasp_intent_ros.ros.conversions`)."""
    p_arr, w_arr = np.asarray(p, dtype=np.float64), np.asarray(w, dtype=np.float64)
    if p_arr.shape != (len(zone_labels),) or w_arr.shape != (len(task_names),):
        raise ValueError(f'p {p_arr.shape} / w {w_arr.shape} do not match {len(zone_labels)} zones / '
                         f'{len(task_names)} tasks')
    label = f'{join_labels(zone_labels)}|{join_labels(task_names)}'
    return stamped_array_to_msg(np.concatenate([p_arr, w_arr]), label, stamp=stamp)


def posterior_from_msg(msg: Float64MultiArray) -> GraspPosterior:
    """Parse a ``grasp/posterior`` message. Raises GraspIntentError for another layout."""
    stamp, label, values = stamped_array_from_msg(msg, what='posterior')
    zones, p, tasks, w = split_posterior(values, label, what='posterior')
    return GraspPosterior(stamp=stamp, zone_labels=zones, p=p, task_names=tasks, w=w)


def zone_summary(zone_labels: Sequence[str], p: ArrayLike, *, top: int = 3) -> str:
    """The ``top`` most likely zones, one per line: ``"UT  0.62"``."""
    p_arr = np.asarray(p, dtype=np.float64)
    order = np.argsort(-p_arr, kind='stable')[:top]
    return '\n'.join(f'{zone_labels[int(k)]}  {p_arr[int(k)]:.2f}' for k in order)


# ---------------------------------------------------------------------------------- markers
_ARROW_LENGTH = 0.12
"""Length of the approach arrow (m), ending at the palm centre."""
_FINGER_BASE_RADIUS = 0.03
_FINGER_LENGTH = 0.08
_FINGER_ANGLES = (0.0, math.radians(140.6), -math.radians(140.6))
"""Azimuth of fingers 1 (thumb, +x of the EE frame), 2 and 3 around the approach axis (rad)."""
_FINGER_SPLAY = 0.35
"""Outward tilt of an open finger (rad); closure c tilts it inwards by c - splay."""


def _color(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _point(p: ArrayLike) -> Point:
    x, y, z = (float(v) for v in np.asarray(p, dtype=np.float64))
    return Point(x=x, y=y, z=z)


def _marker(kind: int, marker_id: int, ns: str, frame_id: str, stamp: Time, color: ColorRGBA,
            scale: tuple[float, float, float]) -> Marker:
    marker = Marker(type=kind, id=marker_id, ns=ns, action=Marker.ADD, color=color)
    marker.header.frame_id = frame_id
    marker.header.stamp = stamp
    marker.scale.x, marker.scale.y, marker.scale.z = scale
    marker.pose.orientation.w = 1.0
    return marker


def grasp_markers(base_T_obj: ArrayLike, base_T_ee: ArrayLike, fingers: ArrayLike, text: str, *,
                  frame_id: str, stamp: Time, object_size: tuple[float, float] = (0.08, 0.10),
                  ns: str = 'grasp') -> MarkerArray:
    """RViz markers of a planned grasp, all in ``frame_id`` (the frame of both transforms).

    Parameters
    ----------
    base_T_obj, base_T_ee : array_like, shape (4, 4)
        Object pose (origin at the centre of its base, +z up) and end-effector pose.
    fingers : array_like, shape (3,)
        Finger closures (rad), 0 open .. 1.51 closed.
    text : str
        Shown above the object.
    object_size : (diameter, height)
        Of the object's cylinder (m).

    Returns
    -------
    MarkerArray
        ids 0 object (CYLINDER), 1 approach (ARROW), 2 fingers (LINE_LIST), 3 text (TEXT_VIEW_FACING).
    """
    obj = np.asarray(base_T_obj, dtype=np.float64)
    ee = np.asarray(base_T_ee, dtype=np.float64)
    closures = np.asarray(fingers, dtype=np.float64)
    diameter, height = (float(v) for v in object_size)

    cylinder = _marker(Marker.CYLINDER, 0, ns, frame_id, stamp, _color(0.6, 0.6, 0.65, 0.6),
                       (diameter, diameter, height))
    centre = obj @ np.array([0.0, 0.0, 0.5 * height, 1.0])
    cylinder.pose = matrix_to_pose_msg(np.block([[obj[:3, :3], centre[:3, None]], [np.eye(4)[3:]]]),
                                       frame_id=frame_id, stamp=stamp).pose

    palm, approach = ee[:3, 3], ee[:3, 2]
    arrow = _marker(Marker.ARROW, 1, ns, frame_id, stamp, _color(0.1, 0.4, 0.9), (0.01, 0.02, 0.03))
    arrow.points = [_point(palm - _ARROW_LENGTH * approach), _point(palm)]

    lines = _marker(Marker.LINE_LIST, 2, ns, frame_id, stamp, _color(0.95, 0.55, 0.1), (0.006, 0.0, 0.0))
    for azimuth, closure in zip(_FINGER_ANGLES, closures):
        radial = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        tilt = float(closure) - _FINGER_SPLAY
        base_ee = _FINGER_BASE_RADIUS * radial
        tip_ee = base_ee + _FINGER_LENGTH * (math.cos(tilt) * np.array([0.0, 0.0, 1.0]) - math.sin(tilt) * radial)
        lines.points.extend(_point(ee[:3, :3] @ p + ee[:3, 3]) for p in (base_ee, tip_ee))

    label = _marker(Marker.TEXT_VIEW_FACING, 3, ns, frame_id, stamp, _color(1.0, 1.0, 1.0), (0.0, 0.0, 0.03))
    label.pose.position = _point(obj[:3, 3] + np.array([0.0, 0.0, height + 0.08]))
    label.text = text
    return MarkerArray(markers=[cylinder, arrow, lines, label])
