"""The assistance node over several objects: each chain's inputs, P(o), the object followed on ``assistance/object``.

A part of :mod:`.assistance` (no node of its own). docs/several_objects.md ("The assistance: one arm, the goals of
every object") gives the design, :mod:`grasp_intent_ros.shared_control.scene_assistance` and
:mod:`grasp_intent_ros.shared_control.scene_target` the rules. :class:`SceneInputs` is what the node does with its
``objects`` parameter: one :class:`~.assistance_inputs.ChainInputs` per object in the object's namespace
(``cup/grasp/pose``, ``cup/intent/v``, ...) into that object's channel of one
:class:`~grasp_intent_ros.shared_control.scene_assistance.SceneAssistance`, ``intent/objects`` (P(o)) at the node's
namespace, and the outputs beside the node's ``assistance/twist`` and ``assistance/alpha``:

- ``assistance/object`` (std_msgs/String, latched): the name of the object followed, at each change (nothing before
  an object has a grasp). Latched because it is a state, not a stream: the mock arm's ``grasp/close`` and a viewer
  started late need the object followed now, not at the next switch.
- the node's status values: ``following`` and, per object, ``<object>: s`` (P(o) P(grasp serves T | w^o)) and
  ``<object>: score`` (s times the operator's agreement), as at the last output.

Bad input on one object's topic is a WARN rejection naming the topic (``flashlight/intent/v: ...``); the other objects
are served on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from rclpy.node import Node
from std_msgs.msg import String

from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.qos import input_qos, latched_qos, output_publisher
from ..ros.run import publish_all
from ..shared_control.assistance import Assistance, Command
from ..shared_control.scene_assistance import SceneAssistance
from ..shared_control.scene_target import FollowRule
from ..wire.arrays import read_object_probabilities
from ..wire.topics import ASSISTANCE_OBJECT, INTENT_OBJECTS
from .assistance_inputs import ChainInputs

__all__ = ['SceneInputs']


def follow_rule(params: Mapping[str, Any]) -> FollowRule:
    """The hysteresis from the node's ``follow_margin`` and ``follow_hold_time``."""
    return FollowRule(margin=float(params['follow_margin']), hold_time=float(params['follow_hold_time']))


class SceneInputs:
    """The assistance over the objects ``names`` (module docstring); ``node``, ``diagnostics``, ``params`` are its."""

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, params: Mapping[str, Any], assistance: Assistance,
                 names: Sequence[str]) -> None:
        self._node, self._diag, self._params = node, diagnostics, params
        self.scene = SceneAssistance(assistance, names, follow_rule(params))
        self.chains = [ChainInputs(node, diagnostics, params, self.scene.channel(name), namespace=name)
                       for name in self.scene.names]
        subscribe_input(node, INTENT_OBJECTS, self._on_objects, input_qos(depth=1), diagnostics)
        self._pubs = {ASSISTANCE_OBJECT: output_publisher(node, String, ASSISTANCE_OBJECT, latched_qos())}
        self._announced: str | None = None

    def configure(self, changed: Mapping[str, Any]) -> None:
        """The node's parameters changed: the hysteresis, and each chain's (:meth:`.ChainInputs.configure`)."""
        self.scene.follower.rule = follow_rule(self._params)
        for chain in self.chains:
            chain.configure(changed)

    def _on_objects(self, msg: Any) -> None:
        self.scene.set_probabilities(read_object_probabilities(msg, self.scene.names))

    def command(self, now: float) -> Command:
        """The scene's command at ``now``; the object followed published when it changed, the status values set."""
        command = self.scene.command(now)
        followed = self.scene.followed
        if followed is not None and followed != self._announced:
            publish_all(self._node, self._pubs, {ASSISTANCE_OBJECT: String(data=followed)})
            self._announced = followed
        scores, serving = self.scene.scores, self.scene.serving
        self._diag.set_values({'following': followed or 'none (no grasp yet)',
                               **{f'{name}: s': f'{serving[name]:.3f}' if name in serving else 'no grasp'
                                  for name in self.scene.names},
                               **{f'{name}: score': f'{scores[name]:.3f}' for name in scores}})
        return command
