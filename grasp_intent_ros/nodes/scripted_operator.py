"""Scripted operator node: one scripted operator drives the live loop without a device (docs/shared_control.md).

Run: ``python -m grasp_intent_ros scripted_operator [--ros-args --params-file config/scripted_operator.yaml]``
(in the suite: ``python -m grasp_intent_ros suite --shared-control --with scripted_operator``)

The operator (:class:`~grasp_intent_ros.shared_control.operators.ScriptedOperator`, the benchmarks' stated model,
blind to the task rules) in the episodes of :class:`~grasp_intent_ros.shared_control.operator_loop.OperatorEpisodes`;
its own grasp (:func:`~grasp_intent_ros.shared_control.operator_loop.own_grasp`) is planned in a thread of its own
when the model, the object pose or ``task_set`` changes (a task the model lacks: ERROR, and it waits).

Topics and services (relative)
    in   ``joint_states``, ``grasp/pose`` (the grasp shown), ``grasp/trajectory`` (its last ``time_from_start``:
         how long an executed grasp takes), ``object/pose``, ``model/active``
    out  ``operator/twist`` (TwistStamped, base frame, every ``publish_period`` s; zero unless reaching),
         ``intent/w`` (``intent: held``), ``/diagnostics`` (``scripted operator``: state, episode, times to grasp,
         the last execute's answer)
    With ``object`` (a scene, docs/several_objects.md): that chain's ``<object>/grasp/pose``, ``grasp/trajectory``,
    ``object/pose``, ``model/active``, ``intent/w`` instead; the arm's ``joint_states``, twist and services as above.
    call ``grasp/execute`` then ``grasp/close`` (std_srvs/Trigger, with ``close_on_reach``; the execute only on the
         shown grasp, with ``execute_shown``), ``mock_arm/reset`` (between episodes)

The grasp command (with ``close_on_reach``) and the reset, in sequence:
:mod:`~grasp_intent_ros.shared_control.operator_calls`. ``hold`` counts from the fingers' close.

Parameters: :data:`grasp_intent_ros.shared_control.parameters.SCRIPTED_OPERATOR`, ``config/scripted_operator.yaml``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, TwistStamped
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from ..errors import GraspIntentError
from ..method.features import MICO_3F
from ..method.model import ModelRequirements
from ..mico.grasp import check_mico_model
from ..mico.kinematics import BASE_FRAME, JOINT_LIMIT_MARGIN, MicoKinematics
from ..mico.parameters import object_pose
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_arm, subscribe_input
from ..ros.model_follower import ModelFollower
from ..ros.params import declare_parameters
from ..ros.qos import STREAM_DEPTH, input_qos, output_publisher
from ..ros.robot import twist_msg
from ..ros.run import guard_exit, publish_all, run_node
from ..ros.worker import LatestOnlyWorker
from ..shared_control.operator_calls import OperatorCalls
from ..shared_control.operator_loop import OperatorEpisodes, own_grasp
from ..shared_control.operators import OperatorConstants, PersistentIntent, ScriptedOperator
from ..shared_control.parameters import SCRIPTED_OPERATOR, check_scripted_operator, episodes_settings
from ..wire import topics
from ..wire.diagnostics import ERROR, KEY_EXECUTE, KEY_TIMES_TO_GRASP, OK, OPERATOR_COMPONENT, WARN
from ..wire.joint_states import JointReading
from ..wire.model_document import ModelDocument
from ..wire.robot_state import object_pose_msg, pose_msg_to_matrix, trajectory_time
from .mock_arm import GRASP_CLOSE, GRASP_EXECUTE

__all__ = ['ScriptedOperatorNode', 'ARM_RESET', 'main']

ARM_RESET = 'mock_arm/reset'  # the mock arm's reset to its initial joints (std_srvs/Trigger)


@dataclass(frozen=True)
class _Scene:  # what the own grasp is planned from
    model: ModelDocument | None
    base_T_obj: NDArray[np.float64]
    task_names: tuple[str, ...]


class ScriptedOperatorNode(Node):
    """Plays one scripted operator against the live suite. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'scripted_operator', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, OPERATOR_COMPONENT)
        p = self._params = declare_parameters(self, SCRIPTED_OPERATOR, on_change=self._configure, check=_check)
        chain = p['object']  # '' or the object's chain namespace (relative)
        self._kin = p.build('urdf_path', lambda path: MicoKinematics(path or None))
        self._loop = OperatorEpisodes(ScriptedOperator(p['device'], OperatorConstants(), np.random.default_rng(
            [p['seed'], 0]), p['publish_period']), **episodes_settings(p))
        self._w_rng = np.random.default_rng([p['seed'], 1])
        self._task_set: int | None = None  # the task set over the model's tasks, once validated
        self._problem = ''  # why there is no own grasp ('' while there is one, or none was tried)
        self._twist_pub = output_publisher(self, TwistStamped, topics.OPERATOR_TWIST)
        self._w_topic = f'{chain}/{topics.INTENT_W}' if chain else topics.INTENT_W
        self._w_pub = output_publisher(self, Float64MultiArray, self._w_topic)
        clients = {name: self.create_client(Trigger, name) for name in (GRASP_EXECUTE, GRASP_CLOSE, ARM_RESET)}
        self._calls = OperatorCalls(self._loop, execute=GRASP_EXECUTE, close=GRASP_CLOSE, reset=ARM_RESET,
                                    clients=clients, request=Trigger.Request, logger=self.get_logger(),
                                    report=lambda text: self._diag.set_values({KEY_EXECUTE: text}))
        self._scenes = LatestOnlyWorker(_Scene(None, object_pose(p), p['task_set']),
                                        self._diag.guard(self._prepare, counts_received=False),
                                        ready=lambda scene: scene.model is not None, name=f'{node_name}_goal')
        self.context.on_shutdown(self._scenes.stop_soon)
        self._models = ModelFollower(self, self._diag, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: ModelRequirements(feature_names=MICO_3F.names),
                                     namespace=chain)
        subscribe_arm(self, self._on_arm, input_qos(STREAM_DEPTH), self._diag)
        subscribe_input(self, topics.GRASP_POSE, self._on_grasp, input_qos(), self._diag, namespace=chain)
        subscribe_input(self, topics.GRASP_TRAJECTORY, self._on_trajectory, input_qos(), self._diag, namespace=chain)
        subscribe_input(self, topics.OBJECT_POSE, self._on_object_pose, input_qos(depth=1), self._diag,
                        namespace=chain)
        self.create_timer(p['publish_period'], self._diag.guard_timer(self._on_tick))
        self.create_timer(p['w_period'], self._diag.guard_timer(self._on_w))

    def destroy_node(self) -> None:  # an own grasp being planned is not waited for beyond FINISH_WAIT (latest_only)
        self._models.stop()
        self._scenes.stop()
        super().destroy_node()

    def _configure(self, changed: Mapping[str, Any]) -> None:
        p = self._params
        for name, value in episodes_settings(p).items():
            setattr(self._loop, name, value)
        if {'object_position', 'object_orientation'} & set(changed):
            self._scenes.update(lambda scene: replace(scene, base_T_obj=object_pose(p)))
        if {'task_set', 'w', 'intent'} & set(changed):  # planned again: a w that fits the model is checked there
            self._scenes.update(lambda scene: replace(scene, task_names=p['task_set']))

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread
        if doc is not None:
            check_mico_model(doc.model, doc.name)
        self._scenes.update(lambda scene: replace(scene, model=doc))

    def _prepare(self, scene: _Scene) -> None:
        assert scene.model is not None
        self._loop.own = self._task_set = None
        held = self._params['w'] if self._params['intent'] == 'held' else None
        try:
            self._task_set, own = own_grasp(scene.model.model, scene.task_names, scene.base_T_obj, self._kin, held)
        except GraspIntentError as exc:
            self._problem = f'model {scene.model.name}: {exc}'
            raise GraspIntentError(self._problem) from None
        self._problem, self._loop.own = '', own.base_T_ee
        self._diag.set_values({'model': scene.model.name, 'task set': ', '.join(scene.task_names),
                               'own grasp (m)': ', '.join(f'{v:.3f}' for v in own.base_T_ee[:3, 3])})

    def _on_arm(self, arm: JointReading) -> None:
        self._kin.check_limits(arm.positions, margin=JOINT_LIMIT_MARGIN, what='joint state')
        self._loop.hand(arm.received, self._kin.fk(arm.positions))

    def _on_grasp(self, msg: PoseStamped) -> None:
        self._loop.shown(time.monotonic(), pose_msg_to_matrix(msg, frame_id=BASE_FRAME))

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        self._calls.trajectory_time = trajectory_time(msg)

    def _on_object_pose(self, msg: PoseStamped) -> None:
        base_T_obj = object_pose_msg(msg, self._params['workspace_radius'])
        self._scenes.update(lambda scene: replace(scene, base_T_obj=base_T_obj))

    def _on_w(self) -> None:
        if self._params['intent'] == 'held' and (task_set := self._task_set) is not None:
            w = PersistentIntent(tuple(self._params['w']), task_set, self._params['w_noise']).w(0.0, self._w_rng)
            publish_all(self, {self._w_topic: self._w_pub}, {self._w_topic: Float64MultiArray(data=w.tolist())})

    def _on_tick(self) -> None:
        now = time.monotonic()
        step = self._loop.step(now)
        self._calls.tick(step, self._params['close_on_reach'])
        publish_all(self, {topics.OPERATOR_TWIST: self._twist_pub}, {topics.OPERATOR_TWIST: twist_msg(
            np.zeros(6) if step is None else step.twist, frame_id=BASE_FRAME, stamp=self.get_clock().now().to_msg())})
        self._show(now)

    def _show(self, now: float) -> None:
        loop = self._loop
        text = loop.status(now) if self._scenes.latest.model is not None else f'waiting for {self._models.topic}'
        self._diag.set_state(*((ERROR, self._problem) if self._problem else (WARN, self._calls.unavailable)
                               if self._calls.unavailable else (OK, text)))
        self._diag.set_values({'state': loop.state, 'episode': loop.episode,
                               KEY_TIMES_TO_GRASP: ', '.join(f'{c.time_to_grasp:.2f}' for c in loop.closed)})


def _check(values: Mapping[str, Any]) -> None:  # check_scripted_operator's rules; object '' or a chain's name
    check_scripted_operator(values)
    topics.check_object_names([values['object']] if values['object'] else [])


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(ScriptedOperatorNode, args)
    guard_exit()


if __name__ == '__main__':
    main()
