"""Input subscriptions that reject oversized messages before decoding them.

Every input of the suite is read serialized (``create_subscription(..., raw=True)`` hands the callback the
CDR bytes): a message larger than its topic's cap (:data:`grasp_intent_ros.protocol.MAX_MESSAGE_BYTES`) is
rejected by its size alone and never becomes Python objects; the rest is decoded with
``rclpy.serialization.deserialize_message`` and handed to the node's callback. Both go through the node's
:meth:`~grasp_intent_ros.ros.diagnostics.NodeDiagnostics.guard`, so an oversized message is one counted
rejection (a WARN with the size and the cap) like any other bad input.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

from ..core.errors import GraspIntentError
from ..protocol import MAX_MESSAGE_BYTES, check_message_size
from .conversions import message_class
from .diagnostics import NodeDiagnostics

__all__ = ['subscribe_input']


def subscribe_input(node: Node, topic: str, callback: Callable[[Any], object], qos: QoSProfile,
                    diagnostics: NodeDiagnostics, *, count_dropped: bool = False) -> Subscription:
    """Subscribe ``callback`` to the suite input ``topic``, size-checked before decoding and guarded.

    Parameters
    ----------
    node : Node
    topic : str
        A topic of :data:`~grasp_intent_ros.protocol.MAX_MESSAGE_BYTES` (relative name).
    callback : callable
        Called with the decoded message (the topic's type, :data:`~grasp_intent_ros.protocol.MSGTYPES`).
    qos : QoSProfile
    diagnostics : NodeDiagnostics
        Counts every message received and every rejection (:meth:`NodeDiagnostics.guard`).
    count_dropped : bool
        Also count the messages the node never took (:meth:`NodeDiagnostics.count_dropped`).

    Raises
    ------
    KeyError
        For a topic without a cap.
    """
    msg_type = message_class(topic)
    if topic not in MAX_MESSAGE_BYTES:
        raise KeyError(f'{topic!r} is not an input topic with a size cap')

    def on_serialized(data: bytes) -> None:
        check_message_size(topic, len(data))
        try:
            msg = deserialize_message(data, msg_type)
        except Exception as exc:  # noqa: BLE001 - a message rclpy cannot decode is bad input
            raise GraspIntentError(f'{topic}: undecodable message: {type(exc).__name__}: {exc}') from None
        callback(msg)

    on_serialized.__name__ = getattr(callback, '__name__', 'on_message')
    guarded = diagnostics.guard(on_serialized)
    return node.create_subscription(msg_type, topic, diagnostics.count_dropped(guarded) if count_dropped else guarded,
                                    qos, raw=True)
