"""The messages of one planned grasp (:class:`grasp_intent_ros.mico.grasp.Grasp`), and their publishers.

All carry the plan's stamp but the trajectory, stamped zero ("start now", the trajectory_msgs convention)
and ordered right after the joint targets of its plan. :class:`GraspOutputs` is the planner's output
stage: a plan's messages all or none, or a clarification request.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import NDArray
from rclpy.node import Node

from ..method.features import FINGERS
from ..mico.grasp import JOINT_NAMES, OUTCOMES, Grasp, NoModelZone, NoReachableGrasp, check_grasp
from ..mico.kinematics import BASE_FRAME, MicoKinematics
from ..wire import topics
from ..wire.diagnostics import KEY_PLAN_STATUS, KEY_PLANNING_TIME, KEY_PLANS
from ..wire.model_document import ModelDocument
from .clarification import ClarificationRequests
from .conversions import message_class, posterior_to_msg, stamped_array_to_msg
from .diagnostics import NodeDiagnostics
from .markers import grasp_markers, zone_summary
from .qos import output_publisher
from .robot import joint_state_msg, joint_trajectory_msg, matrix_to_pose_msg
from .run import publish_all

__all__ = ['grasp_messages', 'GraspOutputs']


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
