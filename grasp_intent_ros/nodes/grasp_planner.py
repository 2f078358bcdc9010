"""Grasp planner node: target vector v + active model + object pose -> MICO grasp (docs/planner.md).

Run: ``python -m grasp_intent_ros.nodes.grasp_planner [--ros-args --params-file config/grasp_planner.yaml]``

Topics (relative; formats in :mod:`grasp_intent_ros.wire`; each in docs/nodes.md)
    in   ``intent/v``, ``model/active`` (latched), ``object/pose`` (default: the ``object_*`` parameters),
         ``joint_states`` (IK seed)
    out  ``grasp/*`` (:class:`~grasp_intent_ros.ros.grasp_messages.GraspOutputs`: all or none), else
         ``intent/clarification`` with the reason; ``/diagnostics`` (``inputs``, ``planning``)

A :class:`~grasp_intent_ros.ros.worker.LatestOnlyWorker` plans the newest inputs, never a backlog, with
:func:`grasp_intent_ros.mico.grasp.plan_grasp` for v as ``plan_for`` says (:func:`~.mico.parameters.planned_target`),
warm-started from the last plan of the same model and ``plan_for``; its thread takes ``intent/v`` itself. A
:class:`~grasp_intent_ros.ros.model_follower.ModelFollower` reads each new ``model/active`` in a thread of its own;
:mod:`grasp_intent_ros.ros.startup` tunes the process and loads every compiled kernel before the node logs ready.
Parameters: :data:`grasp_intent_ros.mico.parameters.GRASP_PLANNER`, ``config/grasp_planner.yaml``.
"""

from __future__ import annotations

from ..ros import startup

if __name__ == '__main__':  # a node process: before the imports below (grasp_intent_ros.ros.startup)
    startup.begin()

import functools
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped
from numpy.typing import NDArray
from rclpy.node import Node
from rclpy.time import Time

from ..method.intent import match_zones
from ..mico.collision import HandCollision
from ..mico.grasp import plan_grasp
from ..mico.kinematics import HOME_Q, JOINT_LIMIT_MARGIN, MicoKinematics
from ..mico.parameters import GRASP_PLANNER, check_object_pose, object_pose, planned_target
from ..planning.options import node_options, noise_from
from ..planning.task import precompute
from ..ros.clarification import ClarificationRequests
from ..ros.conversions import SerializedTargets
from ..ros.diagnostics import NodeDiagnostics
from ..ros.grasp_messages import GraspOutputs
from ..ros.inputs import decode_input, subscribe_arm, subscribe_input
from ..ros.model_follower import ModelFollower, served_models
from ..ros.params import declare_parameters
from ..ros.qos import input_qos
from ..ros.worker import LatestOnlyWorker
from ..wire import topics
from ..wire.diagnostics import KEY_CLARIFICATIONS, KEY_KERNELS_LOADED_LATE, KEY_MODEL, KEY_PLAN_STATUS, OK, WARN
from ..wire.joint_states import JointReading
from ..wire.model_document import ModelDocument
from ..wire.robot_state import object_pose_msg

__all__ = ['GraspPlanner', 'main']


@dataclass(frozen=True)
class _Inputs:
    """The newest inputs; ``stamp`` is the node-clock time the newest planning input arrived."""

    model: ModelDocument | None = None
    v: NDArray[np.float64] | None = None
    v_labels: tuple[str, ...] | None = None
    v_seq: int = 0
    base_T_obj: NDArray[np.float64] | None = None
    q_arm: NDArray[np.float64] | None = None
    stamp: Time | None = None
    plan_for: str = 'v'


class GraspPlanner(Node):
    """Plans a MICO grasp for the newest v, model and object pose. ``kwargs`` go to ``rclpy.node.Node``."""

    announces_ready = True
    """It logs that it is ready once its compiled kernels are loaded (:mod:`grasp_intent_ros.ros.startup`)."""

    def __init__(self, node_name: str = 'grasp_planner', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._inputs_diag, self._plan_diag = NodeDiagnostics(self, 'inputs'), NodeDiagnostics(self, 'planning')
        self._params = declare_parameters(self, GRASP_PLANNER, on_change=self._on_parameters, check=self._check)
        self._kin = self._params.build('urdf_path', lambda path: MicoKinematics(path or None))
        self._hand = self._params.build('urdf_path', lambda path: HandCollision(path or None))
        self._warm: tuple[tuple[str, str, str], NDArray[np.float64]] | None = None
        self._clarifications = ClarificationRequests(self, self._plan_diag, count_key=KEY_CLARIFICATIONS,
                                                     outcome_key=KEY_PLAN_STATUS, level=WARN, log=True)
        self._plan_diag.set_state(OK, f'waiting for {topics.MODEL_ACTIVE} and {topics.INTENT_V}')
        self._outputs = GraspOutputs(self, self._kin, self._plan_diag, self._clarifications,
                                     object_size=lambda: self._params['object_marker_size'],
                                     markers_period=lambda: float(self._params['markers_period']))
        self._kernels = startup.KernelWarmUp(lambda: self._kin.ik(self._kin.fk(HOME_Q), HOME_Q, restarts=0),
                                             report=self._plan_diag.set_value, warn=self.get_logger().warning,
                                             ready=functools.partial(startup.announce_ready, self.get_logger().info))
        first = _Inputs(base_T_obj=object_pose(self._params), plan_for=self._params['plan_for'])
        self._worker = LatestOnlyWorker(first, self._plan_diag.guard(self._plan), ready=self._ready,
                                        name=f'{node_name}_planning',
                                        min_period=lambda: float(self._params['min_replan_period']),
                                        prepare=self._kernels.at_start,
                                        context=self.context)
        # SIGINT/SIGTERM shut the context down before destroy_node runs: stop planning at once
        self.context.on_shutdown(self._worker.stop_soon)
        diag, latest = self._inputs_diag, input_qos(depth=1)
        self._targets = SerializedTargets(functools.partial(decode_input, topics.INTENT_V))
        # v is taken in the planning thread: no hand-over, and the executor thread sleeps through the v stream
        self._worker.take(subscribe_input(self, topics.INTENT_V, self._on_v, latest, diag, count_dropped=True,
                                          serialized=True, callback_group=self._worker.callback_group))
        self._models = ModelFollower(self, self._inputs_diag, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: served_models(self._params['task_names']))
        subscribe_input(self, topics.OBJECT_POSE, self._on_object_pose, latest, diag)
        # not keep-last 1: arm and finger states may come from different publishers
        subscribe_arm(self, self._on_arm, input_qos(), diag)  # the IK seed, whatever its age

    def destroy_node(self) -> None:
        """Stop the planning and model threads (their current work waited for at most FINISH_WAIT s), then destroy."""
        self._models.stop()
        self._worker.stop()
        super().destroy_node()

    def _update(self, trigger: bool = True, **changes: Any) -> None:
        if trigger:
            changes['stamp'] = self.get_clock().now()
        self._worker.update(lambda inputs: replace(inputs, **changes), trigger=trigger)

    def _on_v(self, data: bytes) -> None:  # in the planning thread (LatestOnlyWorker.take)
        v, labels = self._targets(data)
        if (model := self._worker.latest.model) is not None:
            match_zones(v.size, labels, model.model.task_names)
        self._update(v=v, v_labels=labels, v_seq=self._worker.latest.v_seq + 1)
        if model is None and (refused := self._models.refused):  # no model, and the newest was refused
            self._clarifications.request(f'cannot serve: {refused}')

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread: planning goes on
        previous = self._worker.latest.model
        new = doc is not None and (previous is None or (previous.name, previous.sha256) != (doc.name, doc.sha256))
        if doc is not None and self._params['method'] == 'task':  # off the plan path (a model sent again: a new object)
            precompute(doc.model, noise_from(self._params['execution_noise']))
        self._update(trigger=new, model=doc)  # None: recheck() refused the model; nothing to plan with
        self._plan_diag.set_value(KEY_MODEL, 'none' if doc is None else f'{doc.name} (version {doc.version}, '
                                  f'zones {",".join(doc.model.zone_labels)})')

    def _on_object_pose(self, msg: PoseStamped) -> None:
        self._update(base_T_obj=object_pose_msg(msg, self._params['workspace_radius']))

    def _on_arm(self, arm: JointReading) -> None:
        self._kin.check_limits(arm.positions, margin=JOINT_LIMIT_MARGIN, what='joint state')
        self._update(trigger=False, q_arm=arm.positions)

    def _check(self, values: Mapping[str, Any]) -> None:
        """The object within the workspace, and task_names that the active model has.

        No model is active while the parameters are declared.
        """
        check_object_pose(values)
        if hasattr(self, '_models'):
            self._models.check(served_models(values['task_names']))

    def _on_parameters(self, changed: Mapping[str, Any]) -> None:
        if 'task_names' in changed:
            self._models.recheck()  # the model is served for other tasks, or now one refused is
        if {'object_position', 'object_orientation', 'plan_for'} & set(changed):  # replan the newest inputs
            self._update(base_T_obj=object_pose(self._params), plan_for=self._params['plan_for'])

    def _ready(self, inputs: _Inputs) -> bool:
        missing = [t for t, x in ((topics.MODEL_ACTIVE, inputs.model), (topics.INTENT_V, inputs.v)) if x is None]
        self._plan_diag.set_state(OK, f'waiting for {" and ".join(missing)}' if missing else '')
        return not missing

    def _plan(self, inputs: _Inputs) -> None:
        assert inputs.model and inputs.v is not None and inputs.base_T_obj is not None and inputs.stamp
        doc, key = inputs.model, (inputs.model.name, inputs.model.sha256, inputs.plan_for)
        warm = self._warm[1] if self._warm is not None and self._warm[0] == key else None
        v, zones = planned_target(inputs.plan_for, inputs.v, inputs.v_labels, doc.model.task_names)
        grasp = plan_grasp(doc.model, v, zones, inputs.base_T_obj, self._kin, name=doc.name, q_arm=inputs.q_arm,
                           warm_start=warm, method=self._params['method'],
                           options=node_options(self._params['method'], self._params['n_starts'],
                                                self._params['execution_noise']),
                           ik_restarts=self._params['ik_restarts'],
                           hand=self._hand if self._params['collision_check'] else None,
                           margin=self._params['object_margin'],
                           table_plane=self._params['table_plane'] if any(self._params['table_plane']) else None)
        try:
            if (checked := self._outputs.send(grasp, doc, inputs.base_T_obj, stamp=inputs.stamp.to_msg(),
                                              once_for=(inputs.v_seq, key), stopping=lambda: self._worker.stopping)):
                self._warm = (key, checked.result.x)
        finally:  # the diagnostics after the outputs, off their path
            self._plan_diag.set_value('inputs superseded', self._worker.superseded)
            self._plan_diag.set_value(KEY_KERNELS_LOADED_LATE, self._kernels.loaded_late())


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM, in a process tuned by :func:`.ros.startup.run`."""
    startup.run(GraspPlanner, args)


if __name__ == '__main__':
    main()
