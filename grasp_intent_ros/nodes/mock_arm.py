"""Mock MICO node: joint states from commanded trajectories and twists, without hardware.

A stand-in for ros2_control's mock hardware (commands mirrored into states) with a joint_trajectory_controller
and a servo in front of it: the motion rules are :mod:`grasp_intent_ros.mico.mock_arm`.

Run: ``python -m grasp_intent_ros mock_arm [--ros-args --params-file config/mock_arm.yaml]``
(the suite connects ``-r arm_controller/joint_trajectory:=grasp/trajectory
-r servo/delta_twist_cmds:=assistance/twist``)

Topics and services (relative)
    in   ``arm_controller/joint_trajectory`` (trajectory_msgs/JointTrajectory),
         ``servo/delta_twist_cmds`` (geometry_msgs/TwistStamped in ``m1n6s300_link_base`` or
         ``m1n6s300_end_effector``; '' = the base)
    out  ``joint_states`` (the 6 arm joints and 3 fingers: positions and velocities, every ``period`` s),
         ``/diagnostics`` (``arm``: commands received and rejected with the reason, mode, trajectories
         ignored, the trajectory kept)
    in   ``grasp/joint_targets`` (sensor_msgs/JointState: the plan's finger closures, the latest kept); with the
         ``objects`` parameter each ``<object>/grasp/joint_targets``, each ``<object>/grasp/trajectory`` and
         ``assistance/object`` instead of it and of ``arm_controller/joint_trajectory`` (:mod:`.arm_plans`: the plan
         of the object the assistance follows; ``trajectory_execution`` must then be ``on_request``)
    srv  ``~/reset`` (std_srvs/Trigger): back to ``initial_positions``, at rest, commands dropped
    srv  ``grasp/close`` (std_srvs/Trigger): close the fingers to the latest plan's closures plus the hand's own
         closure error (each finger N(0, ``closure_error``^2), one draw per close from a stream seeded by
         ``closure_seed``, which a set of that parameter restarts); the answer's message gives the executed
         closures; refused (success false) before any plan
         (with ``objects``: before a plan of the object followed)
    srv  ``grasp/execute`` (std_srvs/Trigger): with ``trajectory_execution: on_request``, follow the latest
         trajectory received (with ``objects``: the object followed's), from now (its stamp
         ignored); refused (success false) before any, or under ``on_arrival``

``trajectory_execution`` says who owns the arm:

- ``on_arrival`` (the default, a joint_trajectory_controller): the newest command wins, as a servo writing
  to a trajectory controller: a twist ends a trajectory in progress; a trajectory replaces the twist control
  unless a twist is still live (newer than ``command_timeout``), in which case it is ignored and counted (a
  controller manager would not let a second controller claim the joints).
- ``on_request`` (shared control, the suite's ``config/mock_arm.yaml``): the twist stream owns the arm. A
  trajectory is checked and kept, never executed on arrival (so a gap in the twists never lets the planner's
  trajectory move the arm by itself: the assistance's zero-input rule holds end to end); ``grasp/execute``
  runs the kept one. While it runs, a zero twist leaves it alone (a servo halts on zero commands; the
  assistance sends zeros while the operator gives no input), and a non-zero twist ends it: the operator
  takes over.

Parameters: :data:`grasp_intent_ros.mico.parameters.MOCK_ARM`, ``config/mock_arm.yaml``.
"""

from __future__ import annotations

import array
import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from ..errors import GraspIntentError
from ..mico.grasp import JOINT_NAMES
from ..mico.kinematics import MicoKinematics
from ..mico.mock_arm import MockArm
from ..mico.parameters import MOCK_ARM
from ..mico.trajectory import TrajectoryCommand, check_trajectory
from ..ros.clock import now_seconds
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.params import declare_parameters
from ..ros.qos import input_qos, output_publisher
from ..ros.robot import joint_state_msg
from ..ros.run import guard_exit, publish_all, run_node
from ..wire import topics
from ..wire.robot_state import twist_command
from .arm_plans import ArmPlans, check_objects, trajectory_command

__all__ = ['MockArmNode', 'GRASP_CLOSE', 'GRASP_EXECUTE', 'main']

GRASP_CLOSE = 'grasp/close'
"""The hand's grasp command (std_srvs/Trigger): close the fingers to the plan's closures."""
GRASP_EXECUTE = 'grasp/execute'
"""The request to follow the latest trajectory (std_srvs/Trigger), under ``trajectory_execution: on_request``."""


class MockArmNode(Node):
    """Publishes the mock MICO's joint states and executes its commands. ``kwargs`` go to ``Node``."""

    def __init__(self, node_name: str = 'mock_arm', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, 'arm')
        self._closure_rng: np.random.Generator  # made by _configure from closure_seed
        self._params = declare_parameters(self, MOCK_ARM, on_change=self._configure, check=check_objects)
        kin = self._params.build('urdf_path', lambda path: MicoKinematics(path or None))
        self._arm = self._params.build('initial_positions', lambda q0: MockArm(
            kin, q0, finger_velocity_limit=self._params['finger_velocity_limit'],
            twist_joint_limit=self._params['twist_joint_limit']))
        self._configure(self._params)
        self._ignored = 0
        self._pubs = {topics.JOINT_STATES: output_publisher(self, JointState, topics.JOINT_STATES)}
        if not self._params['objects']:  # with objects the chains' trajectories (arm_plans)
            subscribe_input(self, topics.ARM_TRAJECTORY_COMMAND, self._on_trajectory, input_qos(), self._diag)
        subscribe_input(self, topics.ARM_TWIST_COMMAND, self._on_twist, input_qos(depth=1), self._diag)
        self._plans = ArmPlans(self, self._diag, self._params['objects'], check=self._check_trajectory)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(Trigger, GRASP_CLOSE, self._on_close)
        self.create_service(Trigger, GRASP_EXECUTE, self._on_execute)
        self._last = now_seconds(self)
        self.create_timer(self._params['period'], self._diag.guard_timer(self._on_timer))

    def _configure(self, changed: Mapping[str, Any]) -> None:
        self._arm.damping, self._arm.singular_threshold = self._params['ik_damping'], self._params['singular_threshold']
        self._arm.command_timeout = self._params['command_timeout']
        self._arm.twist_joint_limit = self._params['twist_joint_limit']
        self._arm.velocity_limits[6:] = self._params['finger_velocity_limit']
        if 'closure_seed' in changed:  # set, even to its value: the errors' sequence starts again
            self._closure_rng = np.random.default_rng(self._params['closure_seed'])

    def _check_trajectory(self, cmd: TrajectoryCommand) -> None:  # as grasp/execute would run it, from now
        arm = self._arm
        check_trajectory(dataclasses.replace(cmd, start=None), arm.joint_names, arm.lower, arm.upper,
                         now=now_seconds(self), allow_partial=self._params['allow_partial_joints_goal'])

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        cmd = trajectory_command(msg)
        if self._params['trajectory_execution'] == 'on_request':
            self._plans.keep(cmd)
            return
        now, arm = now_seconds(self), self._arm
        if arm.twist_live(now):
            self._ignored += 1
            self._diag.set_value('trajectories ignored while a twist is live', self._ignored)
            return
        arm.command_trajectory(cmd, now, allow_partial=self._params['allow_partial_joints_goal'])

    def _on_twist(self, msg: TwistStamped) -> None:
        twist = twist_command(msg)
        if (self._params['trajectory_execution'] == 'on_request' and self._arm.mode == 'trajectory'
                and not (np.any(twist.linear) or np.any(twist.angular))):
            return  # a requested trajectory runs on through the zero twists of an operator at rest
        self._arm.command_twist(twist, now_seconds(self))

    def _on_execute(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        kept, plan = self._plans.trajectory()
        if self._params['trajectory_execution'] != 'on_request':
            response.success, response.message = False, 'trajectory_execution is on_arrival: nothing is kept'
        elif kept is None:
            response.success, response.message = False, plan
        else:
            try:
                self._arm.command_trajectory(dataclasses.replace(kept, start=None), now_seconds(self),
                                             allow_partial=self._params['allow_partial_joints_goal'])
            except GraspIntentError as exc:  # allow_partial_joints_goal changed since it was kept
                response.success, response.message = False, str(exc)
            else:
                response.success = True
                response.message = 'following the latest trajectory' + (f' ({plan}\'s plan)' if plan else '') + \
                    ' from now'
        return response

    def _on_close(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        closures, plan = self._plans.closures()
        if closures is None:
            response.success, response.message = False, plan
            return response
        error = self._closure_rng.normal(0.0, self._params['closure_error'], 3)
        executed = self._arm.close_fingers(closures + error)
        response.success = True
        response.message = 'closing to ' + ', '.join(f'{c:.4f}' for c in executed.tolist()) + ' rad' + (
            f' ({plan}\'s plan)' if plan else '')
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            self._arm.reset(self._params['initial_positions'])
        except GraspIntentError as exc:  # initial_positions set outside the limits since the start
            response.success, response.message = False, str(exc)
        else:
            response.success, response.message = True, 'at initial_positions'
        return response

    def _on_timer(self) -> None:
        now = now_seconds(self)
        self._arm.step(now, now - self._last)
        self._last = now
        msg = joint_state_msg(JOINT_NAMES, self._arm.q, stamp=self.get_clock().now().to_msg())
        msg.velocity = array.array('d', self._arm.qd.tolist())
        publish_all(self, self._pubs, {topics.JOINT_STATES: msg})  # dropped once a signal ended the context
        self._diag.set_value('mode', self._arm.mode)


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(MockArmNode, args)
    guard_exit()


if __name__ == '__main__':
    main()
