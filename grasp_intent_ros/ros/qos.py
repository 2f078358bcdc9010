"""QoS profiles shared by the nodes, and a discovered publisher's QoS as a bag records it.

Input topics must accept ``ros2 topic pub`` with its defaults (reliable, volatile, keep-last, no
deadline, infinite liveliness lease): a subscription that asks for a deadline or a finite lease is
incompatible with such a publisher and receives nothing, so staleness is detected in application code.
Each function returns a new profile (profiles are mutable; no module-level shared instance).
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy

from ..bag.qos import QosSpec

__all__ = ['input_qos', 'output_qos', 'latched_qos', 'DEFAULT_DEPTH', 'offered_qos_spec']

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


_LIVELINESS = {LivelinessPolicy.AUTOMATIC: 'automatic', LivelinessPolicy.MANUAL_BY_TOPIC: 'manual_by_topic'}
_INFINITE_NS = 2**63 - 1


def _duration_ns(duration: object) -> int | None:
    """ns of a QoS duration; None for infinite (RMW_DURATION_INFINITE) or unspecified (0: the default)."""
    ns = int(getattr(duration, 'nanoseconds'))
    return None if ns <= 0 or ns >= _INFINITE_NS else ns


def offered_qos_spec(profile: QoSProfile) -> QosSpec:
    """What a publisher offers (``TopicEndpointInfo.qos_profile`` from discovery) as a bag records it.

    ``ros2 bag record`` stores exactly this profile per publisher: discovery shows no history (history
    unknown, depth 0) and the durations the middleware resolved (infinite for a publisher that sets
    none, with automatic liveliness). Reliability or durability that no live publisher offers
    (system default, best available, unknown) are recorded as best effort / volatile, the offers every
    subscriber can match.
    """
    depth = int(profile.depth) if profile.history == HistoryPolicy.KEEP_LAST and profile.depth > 0 else 0
    return QosSpec(
        'reliable' if profile.reliability == ReliabilityPolicy.RELIABLE else 'best_effort',
        'transient_local' if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL else 'volatile',
        depth,
        _LIVELINESS.get(profile.liveliness, 'system_default'),  # type: ignore[arg-type]
        _duration_ns(profile.deadline), _duration_ns(profile.lifespan),
        _duration_ns(profile.liveliness_lease_duration))
