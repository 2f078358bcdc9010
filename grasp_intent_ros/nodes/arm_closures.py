"""The finger closures the mock arm's ``grasp/close`` closes to: one plan's, or the plan of the object followed.

A part of :mod:`.mock_arm` (no node of its own). :class:`PlanClosures` keeps the newest ``grasp/joint_targets``
finger closures: for one object, the node's own; with the node's ``objects`` parameter (a scene of several objects,
``suite --object ... --shared-control``), each ``<object>/grasp/joint_targets`` and the assistance's
``assistance/object`` (latched: the object whose grasp it follows), and a close is to the newest plan of the object
followed then. The rule: the hand closes on what the assistance steers it to; a close before any object is followed,
or before a plan of the object followed, is refused, naming why (a plan of another object is never used).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np
from numpy.typing import NDArray
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from ..errors import GraspIntentError
from ..mico.kinematics import FINGER_JOINTS
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.qos import input_qos, latched_qos
from ..wire import topics
from ..wire.robot_state import joint_positions

__all__ = ['PlanClosures']


class PlanClosures:
    """The closures of the plan to close to (module docstring); ``objects`` empty: the node's own plan."""

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, objects: Sequence[str] = ()) -> None:
        self.objects = tuple(objects)
        self._closures: dict[str, NDArray[np.float64]] = {}
        self.followed: str | None = None
        """The object the assistance follows (``assistance/object``), None before one."""
        for name in self.objects or ('',):
            subscribe_input(node, topics.GRASP_JOINT_TARGETS, partial(self._on_targets, name), input_qos(depth=1),
                            diagnostics, namespace=name)
        if self.objects:
            subscribe_input(node, topics.ASSISTANCE_OBJECT, self._on_followed, latched_qos(), diagnostics)

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

    def closures(self) -> tuple[NDArray[np.float64] | None, str]:
        """The finger closures (rad, shape (3,)) to close to and the object whose plan they are ('': one object's).

        None and the reason when there is nothing to close to.
        """
        if not self.objects:
            plan = self._closures.get('')
            return (plan, '') if plan is not None else (None, 'no grasp planned: nothing to close to')
        if self.followed is None:
            return None, f'no object followed yet ({topics.ASSISTANCE_OBJECT}): nothing to close to'
        plan = self._closures.get(self.followed)
        if plan is None:
            return None, f'no grasp planned for {self.followed}, the object followed: nothing to close to'
        return plan, self.followed
