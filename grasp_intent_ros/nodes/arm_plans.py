"""The plans the mock arm's grasp commands use: one plan's, or the plans of the object the assistance follows.

A part of :mod:`.mock_arm` (no node of its own). :class:`ArmPlans` keeps the newest plan's finger closures
(``grasp/joint_targets``, what ``grasp/close`` closes to) and the newest trajectory kept for ``grasp/execute``
(checked when kept: :meth:`ArmPlans.keep`). For one object, the node's own: the closures on ``grasp/joint_targets``,
the trajectories the node keeps from its ``arm_controller/joint_trajectory`` under ``trajectory_execution:
on_request``. With the node's ``objects`` parameter (a scene of several objects, ``suite --object ...
--shared-control``), each chain's ``<object>/grasp/joint_targets`` and ``<object>/grasp/trajectory`` (the planners'
own topics) and the assistance's ``assistance/object`` (latched: the object whose grasp it follows), and a close or
an execute uses the newest plan of the object followed then. The rule: the hand goes where the assistance steers
it; a command before any object is followed, or before a plan of the object followed, is refused, naming why (a plan
of another object is never used).
"""

from __future__ import annotations

import array
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from ..errors import GraspIntentError
from ..mico.kinematics import FINGER_JOINTS
from ..mico.trajectory import TrajectoryCommand
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.qos import input_qos, latched_qos
from ..wire import topics
from ..wire.robot_state import joint_positions, seconds

__all__ = ['ArmPlans', 'check_objects', 'trajectory_command']

_Plan = TypeVar('_Plan')


def check_objects(values: Mapping[str, Any]) -> None:
    """The mock arm's ``objects``: valid names; with any, ``trajectory_execution`` ``on_request``.

    A chain's trajectory run on arrival would move the arm to a grasp of an object the assistance may not follow.

    Raises
    ------
    GraspIntentError
        Naming the problem.
    """
    topics.check_object_names(values['objects'])
    if values['objects'] and values['trajectory_execution'] != 'on_request':
        raise GraspIntentError('with objects, trajectory_execution must be on_request: a chain\'s grasp/trajectory '
                               'runs only on grasp/execute, and only the object followed\'s')


def trajectory_command(msg: JointTrajectory) -> TrajectoryCommand:
    """The trajectory as received (unchecked); a zero header stamp is ``start=None`` ("start now")."""
    points = msg.points
    return TrajectoryCommand(tuple(msg.joint_names), array.array('d', (seconds(p.time_from_start) for p in points)),
                             [p.positions for p in points], [p.velocities for p in points],
                             [p.accelerations for p in points], start=seconds(msg.header.stamp) or None)


class ArmPlans:
    """The plans the grasp commands use (module docstring); ``objects`` empty: the node's own plan.

    Parameters
    ----------
    node, diagnostics
        The mock arm and its status (each input's receipts and rejections).
    objects
        The scene's object names (their chains' namespaces, relative), or empty.
    check
        Raises GraspIntentError for a trajectory the arm would refuse to run (:meth:`keep` keeps none such).
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, objects: Sequence[str] = (), *,
                 check: Callable[[TrajectoryCommand], object]) -> None:
        self.objects = tuple(objects)
        self._check = check
        self._diag = diagnostics
        self._closures: dict[str, NDArray[np.float64]] = {}
        self._trajectories: dict[str, TrajectoryCommand] = {}
        self.followed: str | None = None
        """The object the assistance follows (``assistance/object``), None before one."""
        for name in self.objects or ('',):
            subscribe_input(node, topics.GRASP_JOINT_TARGETS, partial(self._on_targets, name), input_qos(depth=1),
                            diagnostics, namespace=name)
        for name in self.objects:
            subscribe_input(node, topics.GRASP_TRAJECTORY, partial(self._on_trajectory, name), input_qos(depth=1),
                            diagnostics, namespace=name)
        if self.objects:
            subscribe_input(node, topics.ASSISTANCE_OBJECT, self._on_followed, latched_qos(), diagnostics)

    def keep(self, cmd: TrajectoryCommand, name: str = '') -> None:
        """Keep ``cmd`` as the newest trajectory of object ``name`` ('' for one object) once ``check`` passes it."""
        self._check(cmd)
        self._trajectories[name] = cmd
        self._diag.set_value(f'{name}: trajectory kept for grasp/execute' if name else
                             'trajectory kept for grasp/execute', f'{len(cmd.times)} points')

    def _on_trajectory(self, name: str, msg: JointTrajectory) -> None:
        self.keep(trajectory_command(msg), name)

    def _on_targets(self, name: str, msg: JointState) -> None:
        closures = joint_positions(msg, FINGER_JOINTS)
        if closures is None:
            raise GraspIntentError(f'grasp/joint_targets must name the fingers {list(FINGER_JOINTS)}')
        self._closures[name] = closures

    def _on_followed(self, msg: String) -> None:
        if msg.data not in self.objects:
            raise GraspIntentError(f'{topics.ASSISTANCE_OBJECT}: {msg.data!r} is not one of the objects '
                                   f'{list(self.objects)}')
        self.followed = msg.data

    def _newest(self, plans: Mapping[str, _Plan], none: str, verb: str) -> tuple[_Plan | None, str]:
        if not self.objects:
            plan = plans.get('')
            return (plan, '') if plan is not None else (None, f'no {none}: nothing to {verb}')
        if self.followed is None:
            return None, f'no object followed yet ({topics.ASSISTANCE_OBJECT}): nothing to {verb}'
        plan = plans.get(self.followed)
        if plan is None:
            return None, f'no {none} for {self.followed}, the object followed: nothing to {verb}'
        return plan, self.followed

    def closures(self) -> tuple[NDArray[np.float64] | None, str]:
        """The finger closures (rad, shape (3,)) to close to and the object whose plan they are ('': one object's).

        None and the reason when there is nothing to close to.
        """
        return self._newest(self._closures, 'grasp planned', 'close to')

    def trajectory(self) -> tuple[TrajectoryCommand | None, str]:
        """The trajectory to execute (as kept) and the object whose plan it is ('': one object's).

        None and the reason when there is nothing to execute.
        """
        return self._newest(self._trajectories, 'trajectory received', 'execute')
