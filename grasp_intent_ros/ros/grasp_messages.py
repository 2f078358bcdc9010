"""A plan's way out: the messages one planned grasp becomes, their publishers, its diagnostics.

Read top to bottom, the way a plan leaves the planner node, which calls :meth:`GraspOutputs.send` with what
:func:`grasp_intent_ros.mico.grasp.plan_grasp` returned:

1. No grasp (:class:`~grasp_intent_ros.mico.grasp.NoModelZone`,
   :class:`~grasp_intent_ros.mico.grasp.NoReachableGrasp`): a clarification request, nothing published.
2. A grasp is checked against the arm (:func:`~grasp_intent_ros.mico.grasp.check_grasp`), then every message
   is built (:func:`grasp_messages`, in :data:`~grasp_intent_ros.wire.topics.PLAN_TOPICS` order): the pose
   (``grasp/pose``), the joint targets and the one-point trajectory (``grasp/joint_targets``,
   ``grasp/trajectory``), the posterior with w (``grasp/posterior``), the features (``grasp/features``), and
   when due the RViz markers (``grasp/markers``, :func:`grasp_markers`). A check or a message that fails
   (NaN, a bad pose) asks for clarification instead: a plan's messages are published all or none.
3. The plan is reported on the planning diagnostics (counts of plans and reachability outcomes, planning
   and IK times, the last status), and a fallback to a lower-ranked candidate is logged.

The generic writers (poses and joint states in :mod:`.robot`, labelled arrays in :mod:`.conversions`)
serve other nodes too; the markers are the plan's alone and are drawn here. All carry the plan's stamp but
the trajectory, stamped zero ("start now", the trajectory_msgs convention) and ordered right after the
joint targets of its plan.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from numpy.typing import ArrayLike, NDArray
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..method.features import FINGERS
from ..mico.frames import finger_segments
from ..mico.grasp import JOINT_NAMES, OUTCOMES, Grasp, NoModelZone, NoReachableGrasp, check_grasp
from ..mico.kinematics import BASE_FRAME, MicoKinematics
from ..wire import topics
from ..wire.diagnostics import KEY_PLAN_STATUS, KEY_PLANNING_TIME, KEY_PLANS
from ..wire.model_document import ModelDocument
from .clarification import ClarificationRequests
from .conversions import message_class, posterior_to_msg, stamped_array_to_msg
from .diagnostics import NodeDiagnostics
from .qos import output_publisher
from .robot import joint_state_msg, joint_trajectory_msg, matrix_to_pose_msg
from .run import publish_all

__all__ = ['grasp_messages', 'GraspOutputs', 'grasp_markers', 'zone_summary']


class GraspOutputs:
    """A planner's outputs for each plan: the grasp's messages, all or none, or a clarification request.

    Every message of a plan is built and checked before the first is published; the plan is then reported
    on the planning diagnostics (counts of plans and reachability outcomes, planning and IK times, the last
    status) and a fallback to a lower-ranked candidate is logged.

    Parameters
    ----------
    node : Node
        Owner of the publishers (:data:`~grasp_intent_ros.wire.topics.PLAN_TOPICS` and ``grasp/markers``).
    kin : MicoKinematics
        The arm a grasp is checked against (:func:`~grasp_intent_ros.mico.grasp.check_grasp`).
    diagnostics : NodeDiagnostics
        The planning component.
    clarifications : ClarificationRequests
        Asks the operator when a plan has no grasp to publish.
    object_size : callable
        The object marker's (diameter, height), m; read for each plan.
    markers_period : callable
        Least time between two ``grasp/markers`` messages, s (0: with every plan); read as a plan is sent.
    """

    def __init__(self, node: Node, kin: MicoKinematics, diagnostics: NodeDiagnostics,
                 clarifications: ClarificationRequests, *, object_size: Callable[[], tuple[float, float]],
                 markers_period: Callable[[], float]) -> None:
        self._node, self._kin, self._diagnostics, self._clarifications = node, kin, diagnostics, clarifications
        self._object_size, self._markers_period = object_size, markers_period
        self._publishers = {topic: output_publisher(node, message_class(topic), topic)
                            for topic in (*topics.PLAN_TOPICS, topics.GRASP_MARKERS)}
        self._markers_due = -math.inf  # time.monotonic() from which the next plan publishes markers
        self._counts = dict.fromkeys((KEY_PLANS, *OUTCOMES), 0)

    def send(self, grasp: Grasp | NoReachableGrasp | NoModelZone, doc: ModelDocument,
             base_T_obj: NDArray[np.float64], *, stamp: Time, once_for: Hashable,
             stopping: Callable[[], bool]) -> Grasp | None:
        """Publish a plan's outputs (unless ``stopping()``) or ask for clarification, then report the plan.

        Parameters
        ----------
        grasp : Grasp, NoReachableGrasp or NoModelZone
            What :func:`~grasp_intent_ros.mico.grasp.plan_grasp` returned.
        doc : ModelDocument
            The model planned on.
        base_T_obj : ndarray, shape (4, 4)
            Object pose in :data:`~grasp_intent_ros.mico.kinematics.BASE_FRAME`.
        stamp : builtin_interfaces/Time
            Of every output but the trajectory.
        once_for : hashable
            Clarification is asked once for each value (e.g. the intent and the model).
        stopping : callable
            True when the node stops: then nothing is published.

        Returns
        -------
        Grasp or None
            The grasp when it passed its checks (a warm start for the next plan), else None.
        """
        status = None
        try:
            if isinstance(grasp, (NoModelZone, NoReachableGrasp)):
                self._clarifications.request(grasp.reason, once_for=once_for)
                return None
            try:
                check_grasp(grasp, self._kin)
                markers = time.monotonic() >= self._markers_due
                messages = grasp_messages(grasp, doc, base_T_obj, stamp=stamp, object_size=self._object_size(),
                                          markers=markers)
            except (ValueError, OverflowError) as exc:
                self._clarifications.request(f'no grasp published: {exc}', once_for=once_for)
                return None
            if not stopping():
                if markers:
                    self._markers_due = time.monotonic() + float(self._markers_period())
                publish_all(self._node, self._publishers, messages)
                status = f'grasp published ({grasp.result.message})'
            return grasp
        finally:  # the diagnostics after the outputs, off their path
            self._report(grasp, status)

    def _report(self, grasp: Grasp | NoReachableGrasp | NoModelZone, status: str | None) -> None:
        if not isinstance(grasp, NoModelZone):
            self._counts[KEY_PLANS] += 1
            self._counts[grasp.outcome] += 1
            self._diagnostics.set_values({KEY_PLANNING_TIME: f'{1e3 * grasp.result.wall_time_s:.3f}',
                                          'last IK time [ms]': f'{1e3 * grasp.ik_seconds:.3f}',
                                          'last plan reachability': grasp.note, **self._counts})
            if isinstance(grasp, Grasp) and grasp.clearance is not None:
                self._diagnostics.set_value('last grasp clearance', grasp.clearance.summary())
        if status is not None:
            self._diagnostics.set_value(KEY_PLAN_STATUS, status)
        if isinstance(grasp, Grasp) and grasp.fallback:
            self._node.get_logger().warning(grasp.note, throttle_duration_sec=5.0)


def grasp_messages(grasp: Grasp, doc: ModelDocument, base_T_obj: NDArray[np.float64], *, stamp: Time,
                   object_size: tuple[float, float], markers: bool = True) -> dict[str, Any]:
    """The plan's outputs by topic (:data:`grasp_intent_ros.wire.topics.PLAN_TOPICS`, and ``grasp/markers``).

    Parameters
    ----------
    grasp : Grasp
    doc : ModelDocument
        The model planned on (zone labels, task and feature names, marker text).
    base_T_obj : ndarray, shape (4, 4)
        Object pose in :data:`~grasp_intent_ros.mico.kinematics.BASE_FRAME`.
    stamp : builtin_interfaces/Time
        The stamp of every output but the trajectory.
    object_size : (diameter, height)
        Of the object marker (m).
    markers : bool
        Whether to build ``grasp/markers`` too.
    """
    model, x = doc.model, grasp.result.x
    messages: dict[str, Any] = {  # PLAN_TOPICS order: the pose (what teleoperation waits on) first
        topics.GRASP_POSE: matrix_to_pose_msg(grasp.base_T_ee, frame_id=BASE_FRAME, stamp=stamp),
        topics.GRASP_JOINT_TARGETS: joint_state_msg(JOINT_NAMES, grasp.positions, stamp=stamp),
        topics.GRASP_TRAJECTORY: joint_trajectory_msg(JOINT_NAMES, grasp.positions, grasp.duration_s),
        topics.GRASP_POSTERIOR: posterior_to_msg(grasp.result.posterior, grasp.result.w, model.zone_labels,
                                                 model.task_names, stamp=stamp),
        topics.GRASP_FEATURES: stamped_array_to_msg(x, model.feature_names, stamp=stamp),
    }
    if markers:
        text = f'{doc.name}\n{zone_summary(model.zone_labels, grasp.result.posterior)}'
        messages[topics.GRASP_MARKERS] = grasp_markers(base_T_obj, grasp.base_T_ee, x[FINGERS], text,
                                                       frame_id=BASE_FRAME, stamp=stamp, object_size=object_size)
    return messages


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
