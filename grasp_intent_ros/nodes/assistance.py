"""Assistance node: the operator's twist blended with a twist toward the planned grasp (shared control).

Run: ``python -m grasp_intent_ros assistance [--ros-args --params-file config/assistance.yaml]``
(for MoveIt Servo: ``-r assistance/twist:=/servo_node/delta_twist_cmds``)

Topics (relative)
    in   ``operator/twist`` (geometry_msgs/TwistStamped, or Twist with ``operator_message_type``; frame
         ``m1n6s300_link_base`` or ``m1n6s300_end_effector``, '' = ``operator_frame``), ``joint_states``,
         ``grasp/pose``, ``grasp/posterior``, ``grasp/features``, ``intent/v``, ``intent/clarification``,
         ``model/active`` (latched: the demonstrations, whose labels give the planned grasp's task set, and the
         object's body), ``object/pose`` (the tracked object, as the planner's; ``object_position`` and
         ``object_orientation`` until one arrives)
    out  ``assistance/twist`` (TwistStamped in ``m1n6s300_link_base``), ``assistance/alpha``
         (std_msgs/Float64, the arbitration weight of that twist), ``/diagnostics`` (``assistance``)
    srv  ``assistance/enable`` (std_srvs/SetBool): the operator's switch; off, the output is the operator's
         twist exactly

Behaviour
    One blended twist per ``publish_period``: at the operator's cadence while its source streams, else by the
    timer (a stale operator source: the zero twist); the rule and why:
    :mod:`grasp_intent_ros.shared_control.output_cadence`. The kinematics, the maths and the path search's process
    run once at start (warm-up), before the first output. The maths, alpha's definition and the rules are
    :mod:`grasp_intent_ros.shared_control.assistance`. Inputs are keep-last 1 (latest only) but ``joint_states`` (the
    arm and the fingers may come from separate publishers) and ``intent/clarification``, keep-last 10; staleness is
    judged by arrival time on the node's clock. With a model that has a body, the robot's joint path keeps the open
    hand clear of it at the object's pose (:mod:`grasp_intent_ros.shared_control.clearance`); without one, unchecked.

Threads and processes
    The executor's thread runs every callback and owns the ``Assistance``; the joint path is sought in a process of
    its own (:class:`~grasp_intent_ros.shared_control.path_search.PathWorker`), again for every grasp and object
    pose; meanwhile a bit-identical grasp and object keep the path in use, else the output is the operator's twist
    alone (alpha 0, ``seeking a path``); a search that raises or ends: ERROR. The process (``main``) is tuned as
    the planner's (:mod:`grasp_intent_ros.ros.startup`: the start's objects frozen once warmed up); then
    ``thread_priority`` 1-99 sets its threads to ``SCHED_FIFO``, reset on fork (:mod:`grasp_intent_ros.ros.realtime`).

Several objects
    With the ``objects`` parameter (``suite --object ... --shared-control``) it serves from the suite's namespace
    each ``<object>/`` chain's inputs above, ``intent/objects`` (P(o)), and publishes ``assistance/object`` (the object
    followed, latched) beside its twist and alpha (:mod:`.assistance_scene`, docs/several_objects.md); the operator,
    the joints, the switch and the output are the arm's, as for one object. Each chain's inputs:
    :mod:`.assistance_inputs`.

Parameters: :data:`grasp_intent_ros.shared_control.parameters.ASSISTANCE`, ``config/assistance.yaml``.
"""

from __future__ import annotations

from ..ros import startup

if __name__ == '__main__':  # a node process: before the imports below (grasp_intent_ros.ros.startup)
    startup.begin()

from collections.abc import Mapping
from typing import Any

import numpy as np
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from std_msgs.msg import Float64
from std_srvs.srv import SetBool

from ..method.features import MICO_3F
from ..mico.collision import HandCollision
from ..mico.kinematics import BASE_FRAME, MicoKinematics
from ..mico.parameters import check_object_pose
from ..parameters import config_from
from ..ros.clock import now_seconds
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_arm, subscribe_operator
from ..ros.params import declare_parameters
from ..ros.qos import input_qos, output_publisher
from ..ros.realtime import apply_thread_priority
from ..ros.robot import twist_msg
from ..ros.run import publish_all
from ..shared_control.arbitration import grasp_task_set
from ..shared_control.assistance import Assistance, warm_up
from ..shared_control.assistance_config import AssistanceConfig
from ..shared_control.limits import TwistLimiter
from ..shared_control.output_cadence import OutputCadence
from ..shared_control.parameters import ASSISTANCE
from ..shared_control.path_search import PathWorker
from ..wire import topics
from ..wire.diagnostics import ERROR, WARN
from ..wire.joint_states import JointReading
from ..wire.robot_state import twist_command
from .assistance_inputs import ChainInputs
from .assistance_scene import SceneInputs

__all__ = ['AssistanceNode', 'ENABLE_SERVICE', 'main']

ENABLE_SERVICE = topics.ASSISTANCE_ENABLE
"""The operator's switch (std_srvs/SetBool)."""


def _check(values: Mapping[str, Any]) -> None:
    """The rules over the parameters: the object pose's, and the object names a namespace each."""
    check_object_pose(values)
    topics.check_object_names(values['objects'])


class AssistanceNode(Node):
    """Blends the operator's twist with the robot's toward the planned grasp. ``kwargs`` go to ``Node``."""

    def __init__(self, node_name: str = 'assistance', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, 'assistance')
        self._params = declare_parameters(self, ASSISTANCE, check=_check, on_change=self._configure)
        self._kin = self._params.build('urdf_path', lambda path: MicoKinematics(path or None))
        hand = self._params.build('urdf_path', lambda path: HandCollision(path or None))
        self._paths = PathWorker(self._params['urdf_path'] or None, name=f'{node_name}_paths', on_error=lambda text:
                                 self._diag.rejected('internal error: path search', level=ERROR, detail=text))
        self._assist = Assistance(AssistanceConfig(), TwistLimiter(1.0, 1.0, 1.0, 1.0), self._kin, hand)
        self._scene: SceneInputs | None = None
        self._chains: list[ChainInputs] = []
        self._configure(self._params)
        warm_up(self._assist)
        grasp_task_set(np.zeros(MICO_3F.dim), np.zeros((1, MICO_3F.dim)), np.ones(1, dtype=np.int64),
                       np.ones(MICO_3F.dim))
        self._paths.wait_ready(60.0)  # its start (a fresh install's compile) overlaps the warm-up above
        self._assist.paths = self._paths
        self._outputs = 0
        self._pubs = {topics.ASSISTANCE_TWIST: output_publisher(self, TwistStamped, topics.ASSISTANCE_TWIST),
                      topics.ASSISTANCE_ALPHA: output_publisher(self, Float64, topics.ASSISTANCE_ALPHA)}
        latest, diag = input_qos(depth=1), self._diag
        subscribe_operator(self, self._on_operator, latest, diag, self._params['operator_message_type'])
        subscribe_arm(self, self._on_arm, input_qos(), diag)
        if self._params['objects']:
            self._scene = SceneInputs(self, diag, self._params, self._assist, self._params['objects'])
            self._chains = self._scene.chains
        else:
            self._chains = [ChainInputs(self, diag, self._params, self._assist)]
        self._configure({})  # each chain's object set
        self.create_service(SetBool, ENABLE_SERVICE, self._on_enable)
        period = float(self._params['publish_period'])
        timer = self.create_timer(period, self._diag.guard_timer(self._on_timer))
        self._cadence = OutputCadence(period, timer, self._publish)
        startup.end()  # warmed up, the path search's process started: the start's objects frozen, the collector on
        apply_thread_priority(int(self._params['thread_priority']), report=self._diag.set_value, warn=self._warn)

    def _warn(self, text: str) -> None:
        """A standing WARN status and its log line (a ``thread_priority`` refused)."""
        self._diag.set_state(WARN, text)
        self.get_logger().warning(text)

    def destroy_node(self) -> None:
        """Stop the path search's process (after its search), then destroy the node."""
        self._paths.stop()
        super().destroy_node()

    def _on_enable(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self._assist.enabled = bool(request.data)
        response.success, response.message = True, f'assistance {"on" if request.data else "off"}'
        self._diag.set_value('enabled', self._assist.enabled)
        return response

    def _configure(self, changed: Mapping[str, Any]) -> None:
        p = self._params
        self._assist.config = config_from(AssistanceConfig, p)
        limiter = self._assist.limiter
        limiter.max_linear, limiter.max_angular = p['max_linear'], p['max_angular']
        limiter.max_linear_acceleration = p['max_linear_acceleration']
        limiter.max_angular_acceleration = p['max_angular_acceleration']
        limiter.max_dt = 2.0 * p['publish_period']
        if self._scene is not None:
            self._scene.configure(changed)  # the hysteresis and every chain
        else:
            for chain in self._chains:
                chain.configure(changed)  # the object, or the clearance's margin, changed

    def _on_operator(self, msg: Any) -> None:
        xi = twist_command(msg, default_frame=self._params['operator_frame']).in_base(self._assist.base_T_ee)
        (self._assist if self._scene is None else self._scene.scene).set_operator(xi, now_seconds(self))
        self._cadence.on_operator()

    def _on_timer(self) -> None:
        self._cadence.on_timer()

    def _on_arm(self, arm: JointReading) -> None:
        self._assist.set_joints(arm.positions)

    def _publish(self) -> None:
        stamp = self.get_clock().now()
        now = stamp.nanoseconds * 1e-9
        command = self._assist.command(now) if self._scene is None else self._scene.command(now)
        out = twist_msg(command.twist, frame_id=BASE_FRAME, stamp=stamp.to_msg())
        publish_all(self, self._pubs, {topics.ASSISTANCE_TWIST: out,
                                       topics.ASSISTANCE_ALPHA: Float64(data=command.alpha)})
        self._outputs += 1
        self._diag.set_values({'alpha': f'{command.alpha:.3f}', 'state': command.phase, 'outputs': self._outputs})


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM, in a process tuned by :func:`.ros.startup.run`."""
    startup.run(AssistanceNode, args)


if __name__ == '__main__':
    main()

