"""A planned grasp judged and placed without ROS: the tasks it serves and the object pose it implies.

Shared by the viewer (:mod:`grasp_intent_ros.scene.state`) and the session report, which reads bags without
ROS message packages.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..method.features import MICO_3F
from ..method.model import GraspModel
from ..mico.frames import features_to_obj_T_ee
from ..objects.demos import object_of

__all__ = ['served_tasks', 'plan_object_pose']


def served_tasks(model: GraspModel, x: NDArray[np.float64]) -> tuple[str, ...] | None:
    """The tasks whose rule grasp ``x`` satisfies, by the rules of the model's object; None if not known.

    The object is the one the model document names (:func:`~grasp_intent_ros.objects.demos.object_of`), with the
    model's task names.
    """
    rules = object_of(model)
    task_names = model.task_names
    if rules is None or rules.task_names != task_names or x.size != MICO_3F.dim:
        return None
    mask = rules.label(x)
    return tuple(name for i, name in enumerate(task_names) if mask >> i & 1)


def plan_object_pose(base_T_ee: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``base_T_obj`` (4x4) of a plan: its end-effector pose composed with the inverse of its grasp ``x``.

    ``x`` is the plan's grasp in the object frame (:data:`~grasp_intent_ros.method.features.MICO_3F` order),
    so the result is the object pose the planner planned for. Raises KinematicsError for a malformed ``x``.
    """
    return base_T_ee @ np.linalg.inv(features_to_obj_T_ee(x))
