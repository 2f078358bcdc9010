"""The offered QoS recorded per topic, and its conversion to and from rosbag2 metadata."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from .errors import BagError, BagReadError

__all__ = ['QosSpec', 'Reliability', 'Durability', 'decode_qos', 'encode_qos']

Reliability = Literal['reliable', 'best_effort']
Durability = Literal['volatile', 'transient_local']

_RELIABILITY: Final[dict[Reliability, QosReliability]] = {
    'reliable': QosReliability.RELIABLE,
    'best_effort': QosReliability.BEST_EFFORT,
}
_DURABILITY: Final[dict[Durability, QosDurability]] = {
    'volatile': QosDurability.VOLATILE,
    'transient_local': QosDurability.TRANSIENT_LOCAL,
}
# RMW_DURATION_UNSPECIFIED: the rmw default (infinite deadline/lifespan/lease).
_UNSPECIFIED: Final = QosTime(0, 0)


@dataclass(frozen=True)
class QosSpec:
    """The QoS a publisher offered on a topic, as far as it matters for replay.

    Only reliability and durability decide whether a subscriber connects; ``ros2 bag play`` offers the
    recorded reliability/durability and uses its own history. Deadline, lifespan and liveliness are
    written as unspecified (the rmw defaults) and not read back.

    Attributes
    ----------
    reliability
        'reliable' or 'best_effort'.
    durability
        'volatile' or 'transient_local'.
    depth
        Keep-last history depth (messages), >= 1; 0 means history not known, which is what
        ``ros2 bag record`` stores (publisher history is not visible through discovery).

    Raises
    ------
    BagError
        A field is outside the values above.
    """

    reliability: Reliability = 'reliable'
    durability: Durability = 'volatile'
    depth: int = 10

    def __post_init__(self) -> None:
        if self.reliability not in _RELIABILITY:
            msg = f"QosSpec.reliability must be 'reliable' or 'best_effort', got {self.reliability!r}"
            raise BagError(msg)
        if self.durability not in _DURABILITY:
            msg = f"QosSpec.durability must be 'volatile' or 'transient_local', got {self.durability!r}"
            raise BagError(msg)
        if isinstance(self.depth, bool) or not isinstance(self.depth, int) or self.depth < 0:
            msg = f'QosSpec.depth must be an int >= 0 (0: history not known), got {self.depth!r}'
            raise BagError(msg)


def encode_qos(spec: QosSpec) -> Qos:
    """Convert a :class:`QosSpec` into the rosbags profile written to ``offered_qos_profiles``.

    Depth 0 is written as history 'unknown', depth 0 (as ``ros2 bag record`` does); otherwise
    history 'keep_last' with the depth.
    """
    history = QosHistory.KEEP_LAST if spec.depth > 0 else QosHistory.UNKNOWN
    return Qos(
        history=history,
        depth=spec.depth,
        reliability=_RELIABILITY[spec.reliability],
        durability=_DURABILITY[spec.durability],
        deadline=_UNSPECIFIED,
        lifespan=_UNSPECIFIED,
        liveliness=QosLiveliness.SYSTEM_DEFAULT,
        liveliness_lease_duration=_UNSPECIFIED,
        avoid_ros_namespace_conventions=False,
    )


def decode_qos(qos: Qos) -> QosSpec:
    """Convert one rosbags offered-QoS profile (from a bag's metadata) into a :class:`QosSpec`.

    History other than keep_last (unknown, system_default, keep_all) gives depth 0: history does not
    affect compatibility and ``ros2 bag play`` replaces it.

    Raises
    ------
    BagReadError
        Reliability or durability is not one a publisher can offer on a live topic
        (system_default, best_available, unknown).
    """
    reliability = next((k for k, v in _RELIABILITY.items() if v == qos.reliability), None)
    durability = next((k for k, v in _DURABILITY.items() if v == qos.durability), None)
    if reliability is None or durability is None:
        msg = (
            f'offered QoS has reliability {qos.reliability.name.lower()!r} and durability '
            f'{qos.durability.name.lower()!r}; expected reliable|best_effort and volatile|transient_local'
        )
        raise BagReadError(msg)
    depth = qos.depth if qos.history == QosHistory.KEEP_LAST and qos.depth > 0 else 0
    return QosSpec(reliability, durability, depth)
