"""RViz markers of a planned grasp (visualization_msgs/MarkerArray).

:func:`grasp_markers` draws the object as a cylinder standing on its frame origin, the planned gripper as
an arrow along the approach ending at the palm centre plus the schematic of the three fingers of
:func:`grasp_intent_ros.mico.frames.finger_segments`, and a text with the most likely zones
(:func:`zone_summary`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from numpy.typing import ArrayLike
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..mico.frames import finger_segments
from .robot import matrix_to_pose_msg

__all__ = ['zone_summary', 'grasp_markers']


def zone_summary(zone_labels: Sequence[str], p: ArrayLike, *, top: int = 3) -> str:
    """The ``top`` most likely zones, one per line: ``"UT  0.62"``."""
    p_arr = np.asarray(p, dtype=np.float64)
    order = np.argsort(-p_arr, kind='stable')[:top]
    return '\n'.join(f'{zone_labels[int(k)]}  {p_arr[int(k)]:.2f}' for k in order)


_ARROW_LENGTH = 0.12
"""Length of the approach arrow (m), ending at the palm centre."""


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
    for base_ee, tip_ee in finger_segments(closures):
        lines.points.extend(_point(ee[:3, :3] @ p + ee[:3, 3]) for p in (base_ee, tip_ee))

    label = _marker(Marker.TEXT_VIEW_FACING, 3, ns, frame_id, stamp, _color(1.0, 1.0, 1.0), (0.0, 0.0, 0.03))
    label.pose.position = _point(obj[:3, 3] + np.array([0.0, 0.0, height + 0.08]))
    label.text = text
    return MarkerArray(markers=[cylinder, arrow, lines, label])
