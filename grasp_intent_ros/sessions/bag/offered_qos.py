"""The offered QoS recorded per topic, and its conversion to and from rosbag2 metadata.

rosbag2 (Jazzy) records, for each topic, the QoS profile every publisher offered as seen through
discovery (``offered_qos_profiles``, one entry per publisher), and writes each profile as rosbag2_storage's
``qos.cpp`` encodes an rmw QoS profile for metadata version 9: policies as their rmw names
(``reliable``, ``transient_local``, ``automatic``; ``unknown`` for a history discovery cannot see) and
durations as the ``rmw_time_t`` they are, ``{sec, nsec}``, so an infinite duration (what a publisher
offers without a deadline, lifespan or lease) is ``RMW_DURATION_INFINITE`` = ``{sec: 9223372036, nsec:
854775807}``. :func:`encode_qos` writes exactly that; :func:`decode_qos` reads it back and, like
rosbag2, also reads the "infinite" values older rmw implementations reported (Foxy). :func:`request_qos` is
the QoS a recorder subscribes with to the publishers of a topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final, Literal

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from .errors import BagError, BagReadError

__all__ = ['QosSpec', 'Reliability', 'Durability', 'Liveliness', 'INFINITE', 'decode_qos', 'encode_qos', 'request_qos',
           'misses_offers']

Reliability = Literal['reliable', 'best_effort']
Durability = Literal['volatile', 'transient_local']
Liveliness = Literal['automatic', 'manual_by_topic', 'system_default']

_RELIABILITY: Final[dict[Reliability, QosReliability]] = {
    'reliable': QosReliability.RELIABLE,
    'best_effort': QosReliability.BEST_EFFORT,
}
_DURABILITY: Final[dict[Durability, QosDurability]] = {
    'volatile': QosDurability.VOLATILE,
    'transient_local': QosDurability.TRANSIENT_LOCAL,
}
_LIVELINESS: Final[dict[Liveliness, QosLiveliness]] = {
    'automatic': QosLiveliness.AUTOMATIC,
    'manual_by_topic': QosLiveliness.MANUAL_BY_TOPIC,
    'system_default': QosLiveliness.SYSTEM_DEFAULT,
}
_NS_PER_S: Final = 1_000_000_000
INFINITE: Final = QosTime(9_223_372_036, 854_775_807)
"""RMW_DURATION_INFINITE as rosbag2 writes it (``rmw_time_t``: 2**63 - 1 ns)."""
_INFINITE_NS: Final = 2**63 - 1
_LEGACY_INFINITE: Final = (
    QosTime(0x7FFFFFFF, 0xFFFFFFFF),  # Fast DDS, Foxy
    QosTime(0x7FFFFFFF, 0x7FFFFFFF),  # Connext, Foxy
    QosTime(_INFINITE_NS // _NS_PER_S, _INFINITE_NS % _NS_PER_S),  # Cyclone DDS, Foxy (same as INFINITE)
)


@dataclass(frozen=True)
class QosSpec:
    """The QoS one publisher offered on a topic, as discovery shows it and rosbag2 records it.

    Reliability and durability decide whether a subscriber connects; ``ros2 bag play`` offers the
    recorded ones and its own history. A publisher that sets no deadline, lifespan or liveliness lease
    offers them infinite (None here) with automatic liveliness: what rclpy's default profiles and every
    node of this package offer.

    Attributes
    ----------
    reliability
        'reliable' or 'best_effort'.
    durability
        'volatile' or 'transient_local'.
    depth
        Keep-last history depth (messages), >= 1; 0 means history not known, which is what
        ``ros2 bag record`` stores (publisher history is not visible through discovery).
    liveliness
        'automatic', 'manual_by_topic' or 'system_default'.
    deadline_ns, lifespan_ns, liveliness_lease_ns
        Durations in ns, > 0; None means infinite.

    Raises
    ------
    BagError
        A field is outside the values above.
    """

    reliability: Reliability = 'reliable'
    durability: Durability = 'volatile'
    depth: int = 10
    liveliness: Liveliness = 'automatic'
    deadline_ns: int | None = None
    lifespan_ns: int | None = None
    liveliness_lease_ns: int | None = None

    def __post_init__(self) -> None:
        if self.reliability not in _RELIABILITY:
            msg = f"QosSpec.reliability must be 'reliable' or 'best_effort', got {self.reliability!r}"
            raise BagError(msg)
        if self.durability not in _DURABILITY:
            msg = f"QosSpec.durability must be 'volatile' or 'transient_local', got {self.durability!r}"
            raise BagError(msg)
        if self.liveliness not in _LIVELINESS:
            msg = f'QosSpec.liveliness must be one of {", ".join(_LIVELINESS)}, got {self.liveliness!r}'
            raise BagError(msg)
        if isinstance(self.depth, bool) or not isinstance(self.depth, int) or self.depth < 0:
            msg = f'QosSpec.depth must be an int >= 0 (0: history not known), got {self.depth!r}'
            raise BagError(msg)
        for name in ('deadline_ns', 'lifespan_ns', 'liveliness_lease_ns'):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                      or not 0 < value < _INFINITE_NS):
                msg = f'QosSpec.{name} must be None (infinite) or an int of ns in (0, 2**63 - 1), got {value!r}'
                raise BagError(msg)


def _encode_time(ns: int | None) -> QosTime:
    return INFINITE if ns is None else QosTime(ns // _NS_PER_S, ns % _NS_PER_S)


def _decode_time(time: QosTime) -> int | None:
    """ns, or None for infinite; RMW_DURATION_UNSPECIFIED (0) is the rmw default, i.e. infinite too."""
    if time in _LEGACY_INFINITE or time == QosTime(0, 0):
        return None
    ns = time.sec * _NS_PER_S + time.nsec
    return None if ns >= _INFINITE_NS else ns


def encode_qos(spec: QosSpec) -> Qos:
    """Convert a :class:`QosSpec` into the rosbags profile written to ``offered_qos_profiles``.

    Depth 0 is written as history 'unknown', depth 0 (as ``ros2 bag record`` does); otherwise
    history 'keep_last' with the depth. Infinite durations are written as :data:`INFINITE`.
    """
    history = QosHistory.KEEP_LAST if spec.depth > 0 else QosHistory.UNKNOWN
    return Qos(
        history=history,
        depth=spec.depth,
        reliability=_RELIABILITY[spec.reliability],
        durability=_DURABILITY[spec.durability],
        deadline=_encode_time(spec.deadline_ns),
        lifespan=_encode_time(spec.lifespan_ns),
        liveliness=_LIVELINESS[spec.liveliness],
        liveliness_lease_duration=_encode_time(spec.liveliness_lease_ns),
        avoid_ros_namespace_conventions=False,
    )


def decode_qos(qos: Qos) -> QosSpec:
    """Convert one rosbags offered-QoS profile (from a bag's metadata) into a :class:`QosSpec`.

    History other than keep_last (unknown, system_default, keep_all) gives depth 0: history does not
    affect compatibility and ``ros2 bag play`` replaces it. Durations of 0 (unspecified: the rmw
    default) and the infinities of older rmw implementations read as infinite (None).

    Raises
    ------
    BagReadError
        Reliability, durability or liveliness is not one a publisher can offer on a live
        topic (e.g. best_available, unknown).
    """
    reliability = next((k for k, v in _RELIABILITY.items() if v == qos.reliability), None)
    durability = next((k for k, v in _DURABILITY.items() if v == qos.durability), None)
    liveliness = next((k for k, v in _LIVELINESS.items() if v == qos.liveliness), None)
    if reliability is None or durability is None or liveliness is None:
        msg = (
            f'offered QoS has reliability {qos.reliability.name.lower()!r}, durability '
            f'{qos.durability.name.lower()!r} and liveliness {qos.liveliness.name.lower()!r}; expected '
            'reliable|best_effort, volatile|transient_local and automatic|manual_by_topic|system_default'
        )
        raise BagReadError(msg)
    depth = qos.depth if qos.history == QosHistory.KEEP_LAST and qos.depth > 0 else 0
    return QosSpec(reliability, durability, depth, liveliness, _decode_time(qos.deadline),
                   _decode_time(qos.lifespan), _decode_time(qos.liveliness_lease_duration))


def request_qos(offered: Sequence[QosSpec]) -> QosSpec:
    """The QoS to subscribe with to publishers offering ``offered`` (rosbag2's adapt_request_to_offers).

    Reliable / transient local only if every publisher offers it, so the subscription matches all of them.

    Raises
    ------
    ValueError
        ``offered`` is empty.
    """
    if not offered:
        raise ValueError('a topic without publishers has no offered QoS')
    reliable = all(q.reliability == 'reliable' for q in offered)
    latched = all(q.durability == 'transient_local' for q in offered)
    return QosSpec('reliable' if reliable else 'best_effort', 'transient_local' if latched else 'volatile', 0)


def misses_offers(subscribed: QosSpec, offered: QosSpec) -> bool:
    """Whether a subscription with ``subscribed`` receives nothing from a publisher offering ``offered``.

    DDS connects no reliable subscription to a best-effort publisher, no transient-local one to a volatile one.
    """
    return ((subscribed.reliability, offered.reliability) == ('reliable', 'best_effort')
            or (subscribed.durability, offered.durability) == ('transient_local', 'volatile'))
