"""The messages of one planned grasp (:class:`grasp_intent_ros.core.grasp.Grasp`).

All carry the plan's stamp but the trajectory, stamped zero ("start now", the trajectory_msgs convention)
and ordered right after the joint targets of its plan.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import NDArray

from .. import protocol as topics
from ..core.features import FINGERS
from ..core.grasp import JOINT_NAMES, Grasp
from ..core.kinematics import BASE_FRAME
from ..protocol import ModelDocument
from .conversions import posterior_to_msg, stamped_array_to_msg
from .markers import grasp_markers, zone_summary
from .robot import joint_state_msg, joint_trajectory_msg, matrix_to_pose_msg

__all__ = ['grasp_messages']


def grasp_messages(grasp: Grasp, doc: ModelDocument, base_T_obj: NDArray[np.float64], *, stamp: Time,
                   object_size: tuple[float, float], markers: bool = True) -> dict[str, Any]:
    """The plan's outputs by topic (:data:`grasp_intent_ros.protocol.PLAN_TOPICS`, and ``grasp/markers``).

    Parameters
    ----------
    grasp : Grasp
    doc : ModelDocument
        The model planned on (zone labels, task and feature names, marker text).
    base_T_obj : ndarray, shape (4, 4)
        Object pose in :data:`~grasp_intent_ros.core.kinematics.BASE_FRAME`.
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
