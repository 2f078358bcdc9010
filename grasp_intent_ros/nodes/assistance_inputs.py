"""One planning chain's inputs of the assistance node: its grasp, posterior, features, v, clarification, model, pose.

A part of :mod:`.assistance` (no node of its own). :class:`ChainInputs` subscribes to one chain's ``grasp/pose``,
``grasp/posterior``, ``grasp/features``, ``intent/v``, ``intent/clarification``, ``object/pose`` and ``model/active``
(in the node's namespace for one object, in ``<object>/`` for each object of a scene: every rejection then names the
topic read, ``flashlight/intent/v: ...``), turns them into the assistance's inputs (the grasp's task set from the
model's demonstrations and the grasp's features, :func:`~grasp_intent_ros.shared_control.arbitration.grasp_task_set`;
the object's pose and body for the clearance) and hands them to a sink with
:class:`~grasp_intent_ros.shared_control.assistance.Assistance`'s setters: the assistance itself for one object, the
object's :class:`~grasp_intent_ros.shared_control.scene_assistance.ObjectChannel` in a scene.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np
from geometry_msgs.msg import PoseStamped
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import String

from ..errors import GraspIntentError
from ..method.body import ObjectBody
from ..method.features import MICO_3F
from ..method.model import ModelRequirements
from ..mico.kinematics import BASE_FRAME
from ..mico.parameters import object_pose
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.model_follower import ModelFollower
from ..ros.qos import input_qos
from ..shared_control.arbitration import grasp_task_set
from ..wire import topics
from ..wire.arrays import msg_labels, msg_to_array, read_features, read_posterior
from ..wire.model_document import ModelDocument
from ..wire.robot_state import object_pose_msg, pose_msg_to_matrix

__all__ = ['AssistanceSink', 'ChainInputs']


class AssistanceSink(Protocol):
    """What takes one chain's inputs: :class:`~grasp_intent_ros.shared_control.assistance.Assistance`'s setters."""

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None: ...  # noqa: D102
    def set_posterior(self, posterior: NDArray[np.float64], zone_labels: Sequence[str],  # noqa: D102
                      task_names: Sequence[str]) -> None: ...
    def set_v(self, v: NDArray[np.float64], labels: Sequence[str]) -> None: ...  # noqa: D102
    def set_task_set(self, task_set: int | None) -> None: ...  # noqa: D102
    def clarification(self) -> None: ...  # noqa: D102
    def set_object(self, base_T_obj: NDArray[np.float64] | None, body: ObjectBody | None) -> None: ...  # noqa: D102


class ChainInputs:
    """One chain's inputs into ``sink`` (module docstring).

    ``node``, ``diagnostics`` and ``params`` are the node's (its ``ASSISTANCE`` values: ``object_position`` and
    ``object_orientation`` are the object's pose until one arrives, ``workspace_radius`` bounds one).
    ``namespace``: '' for the node's own topics, else the object's relative namespace (``'cup'``).
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, params: Mapping[str, Any], sink: AssistanceSink, *,
                 namespace: str = '') -> None:
        self._params, self._sink = params, sink
        self.base_T_obj = object_pose(params)
        self.body: ObjectBody | None = None
        self._demos: tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]] | None = None
        self._features: NDArray[np.float64] | None = None
        latest, ns = input_qos(depth=1), namespace
        subscribe_input(node, topics.GRASP_POSE, self._on_grasp, latest, diagnostics, namespace=ns)
        subscribe_input(node, topics.GRASP_POSTERIOR, self._on_posterior, latest, diagnostics, namespace=ns)
        subscribe_input(node, topics.INTENT_V, self._on_v, latest, diagnostics, namespace=ns)
        subscribe_input(node, topics.INTENT_CLARIFICATION, self._on_clarification, input_qos(), diagnostics,
                        namespace=ns)
        subscribe_input(node, topics.GRASP_FEATURES, self._on_features, latest, diagnostics, namespace=ns)
        subscribe_input(node, topics.OBJECT_POSE, self._on_object_pose, latest, diagnostics, namespace=ns)
        thread = node.get_name() + (f'_{namespace}' if namespace else '')
        self.models = ModelFollower(node, diagnostics, self._use_model, name=f'{thread}_model', namespace=namespace,
                                    requires=lambda: ModelRequirements(feature_names=MICO_3F.names))

    def configure(self, changed: Mapping[str, Any]) -> None:
        """The node's parameters changed (``changed`` by name): the object set again (the clearance's margin).

        A new ``object_position`` or ``object_orientation`` is the object's pose.
        """
        if {'object_position', 'object_orientation'} & set(changed):
            self.base_T_obj = object_pose(self._params)
        self._sink.set_object(self.base_T_obj, self.body)

    def _use_model(self, document: ModelDocument | None) -> None:
        if document is not None:
            model = document.model
            self._demos = (model.demo_x, model.demo_sets, model.feature_scale)
            self._update_task_set()
            self.body = model.body
            self._sink.set_object(self.base_T_obj, self.body)

    def _on_features(self, msg: Any) -> None:
        self._features = read_features(msg)[0]
        self._update_task_set()

    def _update_task_set(self) -> None:
        demos, x = self._demos, self._features
        self._sink.set_task_set(None if demos is None or x is None else grasp_task_set(x, *demos))

    def _on_object_pose(self, msg: PoseStamped) -> None:
        self.base_T_obj = object_pose_msg(msg, self._params['workspace_radius'])
        self._sink.set_object(self.base_T_obj, self.body)

    def _on_grasp(self, msg: PoseStamped) -> None:
        self._sink.set_grasp(pose_msg_to_matrix(msg, frame_id=BASE_FRAME))

    def _on_posterior(self, msg: Any) -> None:
        posterior = read_posterior(msg)
        self._sink.set_posterior(posterior.p, posterior.zone_labels, posterior.task_names)

    def _on_v(self, msg: Any) -> None:
        v = msg_to_array(msg, what='v')
        labels = msg_labels(msg)
        if not labels or len(labels[0]) != v.size or np.any(v < 0.0):
            raise GraspIntentError(f'v must be non-negative and labelled with its {v.size} zones')
        self._sink.set_v(v, labels[0])

    def _on_clarification(self, msg: String) -> None:
        self._sink.clarification()
