"""Clarification requests on ``intent/clarification``, reported in the requesting node's diagnostics.

When an intent cannot be served (the interpreter: P(no task) too high or no zone of the model possible;
the planner: v fits no zone of the model or no grasp is reachable), the operator is asked with the reason
as a std_msgs/String, and the node's status says so: a status value holds the last outcome, a count the
requests made, and the status message becomes ``clarification requested: <reason>`` at the level given.
"""

from __future__ import annotations

from collections.abc import Hashable

from rclpy.node import Node
from std_msgs.msg import String

from ..wire import topics
from ..wire.diagnostics import OK
from .diagnostics import NodeDiagnostics, cap_text
from .qos import output_publisher
from .run import publish_all

__all__ = ['ClarificationRequests']


class ClarificationRequests:
    """The clarification requests of one node.

    Parameters
    ----------
    node : Node
        Owner of the ``intent/clarification`` publisher.
    diagnostics : NodeDiagnostics
        The component whose status reports the requests.
    count_key, outcome_key : str
        Status values holding the number of requests and the last outcome.
    level : int
        Status level of a request (:data:`grasp_intent_ros.wire.diagnostics.OK` or ``WARN``).
    log : bool
        Also log each request as a warning.
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, *, count_key: str, outcome_key: str,
                 level: int = OK, log: bool = False) -> None:
        self._node, self._diagnostics = node, diagnostics
        self._count_key, self._outcome_key, self._level, self._log = count_key, outcome_key, level, log
        topic = topics.INTENT_CLARIFICATION
        self._publishers = {topic: output_publisher(node, String, topic)}
        self._asked: Hashable = None
        self.count = 0
        """Requests published so far."""
        diagnostics.set_value(count_key, 0)

    def request(self, reason: str, *, once_for: Hashable = None) -> None:
        """Ask with ``reason``; with ``once_for`` (e.g. intent and model) unless the last request had that key.

        The status reports the request either way.
        """
        message = f'clarification requested: {reason}'
        self._diagnostics.set_value(self._outcome_key, message)
        self._diagnostics.note(message, level=self._level)
        if once_for is not None and once_for == self._asked:
            return  # e.g. the object moved but the intent is the same: asked already
        self._asked = once_for
        self.count += 1
        self._diagnostics.set_value(self._count_key, self.count)
        if self._log:
            self._node.get_logger().warning(cap_text(message))
        publish_all(self._node, self._publishers, {topics.INTENT_CLARIFICATION: String(data=reason)})
