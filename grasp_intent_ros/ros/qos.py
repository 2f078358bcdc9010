"""QoS profiles shared by the nodes.

Input topics must accept ``ros2 topic pub`` with its defaults (reliable, volatile, keep-last, no
deadline, infinite liveliness lease): a subscription that asks for a deadline or a finite lease is
incompatible with such a publisher and receives nothing, so staleness is detected in application code.
Each function returns a new profile (profiles are mutable; no module-level shared instance).

A node's output publishers are created by :func:`output_publisher` (without rclpy's default QoS event
handlers), its input subscriptions with the incompatible-QoS warning only (:func:`input_events`).
"""

from __future__ import annotations

from typing import Any

from rclpy.event_handler import PublisherEventCallbacks, QoSRequestedIncompatibleQoSInfo, SubscriptionEventCallbacks
from rclpy.impl.rcutils_logger import RcutilsLogger
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_policy_name_from_kind,
)

__all__ = ['input_qos', 'output_qos', 'latched_qos', 'output_publisher', 'input_events', 'DEFAULT_DEPTH',
           'STREAM_DEPTH']

DEFAULT_DEPTH = 10
"""Queue depth of input and output topics (messages)."""
STREAM_DEPTH = 100
"""Queue depth of a 100 Hz stream whose every message counts (one second), so a busy node catches up instead of
losing messages: the intent estimator's operator twists and joint states, a replay's inputs."""


def input_qos(depth: int = DEFAULT_DEPTH) -> QoSProfile:
    """Reliable, volatile, keep-last ``depth``; no deadline, no lifespan, automatic infinite liveliness.

    A latest-only consumer passes ``depth=1``.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                      liveliness=LivelinessPolicy.AUTOMATIC)


def output_qos(depth: int = DEFAULT_DEPTH) -> QoSProfile:
    """The :func:`input_qos` profile, offered by publishers.

    A reliable, volatile publisher matches both reliable and best-effort subscribers, so inputs and outputs
    share one profile; the two names say which side of a topic a profile is for.
    """
    return input_qos(depth)


def latched_qos() -> QoSProfile:
    """Reliable, transient local, keep-last 1: a late subscriber receives the last message.

    Subscribers must request transient local durability too to get the stored message.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL,
                      liveliness=LivelinessPolicy.AUTOMATIC)


def output_publisher(node: Node, msg_type: Any, topic: str, qos: QoSProfile | None = None) -> Publisher:
    """A publisher of one of the node's outputs: ``qos`` (default :func:`output_qos`), no QoS event handlers.

    rclpy gives every publisher two default event handlers (incompatible QoS, incompatible type) that
    only log a warning, and its executor walks each one in Python at every wake-up, whatever woke it: in
    the planner, with its eight output publishers, they would be more than half of its waitables and about
    half of the executor's CPU per wake-up.
    A subscriber with an incompatible request still gets the event on its side (rclpy and rclcpp log it
    there), which is where its missing messages show; the nodes' input subscriptions keep that warning
    (:func:`input_events`).
    """
    return node.create_publisher(msg_type, topic, output_qos() if qos is None else qos,
                                 event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))


def input_events(logger: RcutilsLogger, topic: str) -> SubscriptionEventCallbacks:
    """The ``event_callbacks`` of an input subscription: rclpy's incompatible-QoS warning only.

    The warning (logged by the node, as rclpy's default handler words it) says why a publisher's messages
    never arrive. rclpy's second default handler, for a publisher of another message type, is left out:
    each handler is one more entity the executor walks in Python at every wake-up (:func:`output_publisher`).
    """
    def warn(event: QoSRequestedIncompatibleQoSInfo) -> None:
        logger.warning(f"New publisher discovered on topic '{topic}', offering incompatible QoS. No messages "
                       f'will be received from it. Last incompatible policy: '
                       f'{qos_policy_name_from_kind(event.last_policy_kind)}')
    return SubscriptionEventCallbacks(incompatible_qos=warn, use_default_callbacks=False)
