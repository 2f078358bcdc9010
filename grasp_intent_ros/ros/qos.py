"""QoS profiles shared by the nodes.

Input topics must accept ``ros2 topic pub`` with its defaults (reliable, volatile, keep-last, no
deadline, infinite liveliness lease): a subscription that asks for a deadline or a finite lease is
incompatible with such a publisher and receives nothing, so staleness is detected in application code.
Each function returns a new profile (profiles are mutable; no module-level shared instance).
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['input_qos', 'output_qos', 'latched_qos', 'DEFAULT_DEPTH']

DEFAULT_DEPTH = 10
"""Queue depth of input and output topics (messages)."""


def input_qos(depth: int = DEFAULT_DEPTH) -> QoSProfile:
    """Reliable, volatile, keep-last ``depth``; no deadline, no lifespan, automatic infinite liveliness.

    A latest-only consumer passes ``depth=1``.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                      liveliness=LivelinessPolicy.AUTOMATIC)


def output_qos(depth: int = DEFAULT_DEPTH) -> QoSProfile:
    """Reliable, volatile, keep-last ``depth``: matches both reliable and best-effort subscribers."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                      liveliness=LivelinessPolicy.AUTOMATIC)


def latched_qos() -> QoSProfile:
    """Reliable, transient local, keep-last 1: a late subscriber receives the last message.

    Subscribers must request transient local durability too to get the stored message.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL,
                      liveliness=LivelinessPolicy.AUTOMATIC)
