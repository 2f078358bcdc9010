"""Model server node: hosts the trained grasp models and publishes the active one, latched.

Run: ``python -m grasp_intent_ros.nodes.model_server``
     ``[--ros-args --params-file config/model_server.yaml]``

Topics (relative; ``-r __ns:=/robot1`` moves them)
    out, latched  ``model/active``               std_msgs/String: the versioned model document
                                                 (see :mod:`grasp_intent_ros.ros.conversions`)
    out, latched  ``model/ambiguity``            std_msgs/Float64MultiArray, KL matrix (m, m), nats;
                                                 [i, j] = KL(task i || task j); both dims labelled
                                                 with the task names
    out, latched  ``model/ambiguity/symmetric``  same layout: KL + KL^T
    out, latched  ``model/ambiguity/pinsker``    same layout: Pinsker bounds min(sqrt(KL / 2), 1)
    in            ``model/query``                std_msgs/Float64MultiArray, a feature vector x, shape (d,)
    out           ``model/posterior``            std_msgs/Float64MultiArray, P(zone | x) over the active
                                                 model's zones, dim labelled with the zone labels
    out           ``/diagnostics``

Parameters: :data:`grasp_intent_ros.method.parameters.MODEL_SERVER`, ``config/model_server.yaml``.
    ``model`` (string, default cup_7zone): active model, the stem of a YAML file in the models
    directory; changeable at run time; an unknown or malformed model is rejected with the reason.
    Its descriptor's ``additional_constraints`` (``ros2 param describe /model_server model``) list the
    models in the directory, read anew at every describe, so a model trained into it appears at once.
    ``models_dir`` (string, read-only, default '' = <config_dir()>/models).
    ``task_names`` (string[], default usage, transfer, handover): the suite's tasks. Only a model the suite
    serves is published (:func:`~grasp_intent_ros.ros.model_follower.served_models`: these tasks, the MICO
    3-finger features); another is refused like a malformed one, with the reason, and a change of
    ``task_names`` that the active model does not fit is refused too.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..errors import InvalidFeaturesError
from ..method import ambiguity
from ..method.parameters import MODEL_SERVER
from ..method.registry import ModelFiles
from ..ros.conversions import array_to_msg, message_class, model_to_msg
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.model_follower import served_models
from ..ros.params import declare_parameters
from ..ros.qos import input_qos, latched_qos, output_publisher
from ..ros.run import guard_exit, publish_all, release_free_memory, run_node
from ..wire import topics
from ..wire.arrays import msg_to_array
from ..wire.diagnostics import KEY_MODEL
from ..wire.topics import MAX_FEATURES

__all__ = ['ModelServer', 'MAX_FEATURES', 'main']

class ModelServer(Node):
    """Publishes the active model and its ambiguity (latched) and answers posterior queries."""

    def __init__(self, node_name: str = 'model_server', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diagnostics = NodeDiagnostics(self, 'model')
        self._files: ModelFiles | None = None
        self._version = 0
        self._pubs = {topic: output_publisher(self, message_class(topic), topic, latched_qos())
                      for topic in topics.MODEL_LATCHED_TOPICS}
        self._pubs[topics.MODEL_POSTERIOR] = output_publisher(self, Float64MultiArray, topics.MODEL_POSTERIOR)
        self._params = declare_parameters(self, MODEL_SERVER, check=self._check, on_change=self._activate)
        self._activate(self._params)
        self._query_sub = subscribe_input(self, topics.MODEL_QUERY, self._on_query, input_qos(), self._diagnostics)

    def _model_files(self, models_dir: str) -> ModelFiles:
        if self._files is None:
            self._files = ModelFiles.at(models_dir)
        return self._files

    def describe_parameter(self, name: str) -> ParameterDescriptor:
        """The declared descriptor; for ``model`` with the models available now as its constraints."""
        descriptor = super().describe_parameter(name)
        if name != 'model' or self._files is None:
            return descriptor
        described = copy.copy(descriptor)
        described.additional_constraints = (f'one of {", ".join(self._files.names()) or "(none)"}: the *.yaml '
                                            f'files in {self._files.directory}')
        return described

    def _check(self, values: Mapping[str, Any]) -> None:
        self._model_files(values['models_dir']).load(values['model'], requires=served_models(values['task_names']))

    def _activate(self, changed: Mapping[str, Any]) -> None:
        if set(changed) == {'task_names'}:
            return  # the active model fits them (_check): nothing to publish again
        name = self._params['model']
        model = self._model_files(self._params['models_dir']).load(name,
                                                                   requires=served_models(self._params['task_names']))
        report = ambiguity.report(model)
        self._version += 1
        self._model = model
        tasks = [model.task_names, model.task_names]
        publish_all(self, self._pubs, {topics.MODEL_ACTIVE: model_to_msg(model, name=name, version=self._version),
                                       topics.MODEL_AMBIGUITY: array_to_msg(report.kl, tasks),
                                       topics.MODEL_AMBIGUITY_SYMMETRIC: array_to_msg(report.symmetric, tasks),
                                       topics.MODEL_AMBIGUITY_PINSKER: array_to_msg(report.pinsker, tasks)})
        self._diagnostics.set_value(KEY_MODEL, name)
        self._diagnostics.set_value('model version', self._version)
        self._diagnostics.set_value('zones', ','.join(model.zone_labels))
        self.get_logger().info(f'active model {name!r} (version {self._version}, '
                               f'zones {",".join(model.zone_labels)})')
        release_free_memory()  # what the loading and the document's writing freed

    def _on_query(self, msg: Float64MultiArray) -> None:
        x = msg_to_array(msg, max_size=MAX_FEATURES, error=InvalidFeaturesError, what='x')
        posterior = self._model.posterior(x)  # raises for an x too far out for a finite posterior
        publish_all(self, self._pubs, {topics.MODEL_POSTERIOR: array_to_msg(posterior, [self._model.zone_labels])})


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(ModelServer, args)
    guard_exit()  # the interpreter's exit too must end, or leave the stacks


if __name__ == '__main__':
    main()
