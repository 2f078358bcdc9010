"""Messages of the suite read into comparable values (ROS-free).

Decoded CDR, reduced per topic, rejections told apart from periodic diagnostics. A replay reads the recorded and
the live messages through the same code (:func:`output_of`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from rosbags.serde import SerdeError
from rosbags.typesys import TypesysError

from ..errors import ModelFormatError
from ..wire.diagnostics import KEY_LAST_ERROR, KEY_REJECTED, level_value, status_values
from ..wire.model_document import ModelHeader, parse_model_document
from ..wire.robot_state import seconds
from ..wire.topics import DIAGNOSTICS, MODEL_ACTIVE, MSGTYPES
from .bag.errors import BagReadError
from .bag.types import jazzy_typestore

__all__ = [
    'SessionError',
    'Vector',
    'Text',
    'Pose',
    'Joints',
    'Trajectory',
    'Rejection',
    'Undecodable',
    'Output',
    'RawMessage',
    'RejectionTracker',
    'status_namespace',
    'decode',
    'model_header',
    'reduce_message',
    'output_of',
]


class SessionError(BagReadError):
    """A bag is not a usable session (no inputs, a malformed model document, mixed namespaces, ...)."""


# ------------------------------------------------------------------------------ reduced values
@dataclass(frozen=True, eq=False)
class Vector:
    """A Float64MultiArray: its dimension labels and values (flattened, shape (n,))."""

    labels: tuple[str, ...]
    data: NDArray[np.float64]


@dataclass(frozen=True)
class Text:
    """A std_msgs/String (e.g. a clarification request)."""

    data: str


@dataclass(frozen=True, eq=False)
class Pose:
    """A PoseStamped without its stamp: frame, position (3,) in m, unit quaternion (x, y, z, w)."""

    frame_id: str
    position: NDArray[np.float64]
    orientation: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Joints:
    """A JointState's names and positions (rad), shape (n,)."""

    names: tuple[str, ...]
    positions: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A JointTrajectory: joint names, point positions, shape (n_points, n), and times from start (s)."""

    joint_names: tuple[str, ...]
    positions: NDArray[np.float64]
    times_s: NDArray[np.float64]


@dataclass(frozen=True)
class Rejection:
    """An input rejected by a node: the diagnostic status name, its level (1 WARN, 2 ERROR), the reason."""

    status: str
    level: int
    reason: str


@dataclass(frozen=True)
class Undecodable:
    """A message that could not be decoded or reduced, with the reason."""

    reason: str


Value = Vector | Text | Pose | Joints | Trajectory | ModelHeader | Rejection | Undecodable


@dataclass(frozen=True)
class Output:
    """One output message (or rejection) of the system.

    Attributes
    ----------
    topic
        Relative topic name ('intent/v', 'model/active', ...) or '/diagnostics'.
    t_ns
        Receive time, ns since the epoch.
    value
        The reduced message.
    """

    topic: str
    t_ns: int
    value: Value


class RawMessage(Protocol):
    """What :func:`pair_messages` needs of a message; :class:`~grasp_intent_ros.sessions.bag.BagMessage` fits."""

    @property
    def topic(self) -> str: ...
    @property
    def msgtype(self) -> str: ...
    @property
    def timestamp_ns(self) -> int: ...
    @property
    def cdr(self) -> bytes: ...


# ------------------------------------------------------------------------------ decoding
@lru_cache(maxsize=1)
def _typestore() -> Any:
    return jazzy_typestore()


def decode(msgtype: str, cdr: bytes) -> Any:
    """Deserialize CDR bytes (with encapsulation header) into a rosbags message of ``msgtype``.

    Raises
    ------
    SessionError
        The bytes are not a valid message of that type.
    """
    try:
        return _typestore().deserialize_cdr(cdr, msgtype)
    except (SerdeError, TypesysError, KeyError, ValueError, IndexError, UnicodeDecodeError) as exc:
        raise SessionError(f'cannot decode {msgtype}: {exc}') from exc


def model_header(text: str) -> ModelHeader:
    """The header lines of a model document (:func:`~grasp_intent_ros.wire.model_document.parse_model_document`).

    The body is neither hashed nor parsed.

    Raises
    ------
    SessionError
        The three header lines are missing or malformed.
    """
    try:
        return parse_model_document(text, check_sha256=False)[0]
    except ModelFormatError as exc:
        raise SessionError(str(exc)) from None


def reduce_message(topic: str, msg: Any) -> Value:
    """The comparable content of a decoded message on a session topic (relative name).

    Raises
    ------
    SessionError
        ``topic`` is not a session input/output topic, or the message is malformed
        (e.g. a model document without its header).
    """
    msgtype = MSGTYPES.get(topic)
    if msgtype is None or topic == DIAGNOSTICS:
        raise SessionError(f'{topic!r} is not a session input or output topic')
    kind = msgtype.rsplit('/', 1)[1]
    if kind == 'Float64MultiArray':
        return Vector(tuple(str(d.label) for d in msg.layout.dim),
                      np.asarray(msg.data, dtype=np.float64)[int(msg.layout.data_offset):].copy())
    if kind == 'String':
        return model_header(msg.data) if topic == MODEL_ACTIVE else Text(str(msg.data))
    if kind == 'PoseStamped':
        p, q = msg.pose.position, msg.pose.orientation
        return Pose(str(msg.header.frame_id), np.array([p.x, p.y, p.z], dtype=np.float64),
                    np.array([q.x, q.y, q.z, q.w], dtype=np.float64))
    if kind == 'JointState':
        return Joints(tuple(str(n) for n in msg.name), np.asarray(msg.position, dtype=np.float64).copy())
    # JointTrajectory
    names = tuple(str(n) for n in msg.joint_names)
    positions = np.array([np.asarray(pt.positions, dtype=np.float64) for pt in msg.points], dtype=np.float64)
    times = np.array([seconds(pt.time_from_start) for pt in msg.points], dtype=np.float64)
    return Trajectory(names, positions.reshape(len(msg.points), -1), times)


def output_of(topic: str, t_ns: int, cdr: bytes) -> Output:
    """An :class:`Output` from serialized bytes on a session topic (relative name, not /diagnostics).

    A message that cannot be decoded becomes an :class:`Undecodable` value (never raises).
    """
    try:
        value: Value = reduce_message(topic, decode(MSGTYPES[topic], cdr))
    except (SessionError, KeyError, AttributeError, TypeError, ValueError) as exc:
        value = Undecodable(str(exc))
    return Output(topic, t_ns, value)


def status_namespace(name: str) -> str:
    """The namespace of the node a package status names, '' for the root (``/cup/grasp_planner: planning``: /cup)."""
    return name.partition(': ')[0].rpartition('/')[0]


class RejectionTracker:
    """Turns ``/diagnostics`` arrays into rejection events (see the module docstring).

    Statuses without an integer 'messages rejected' value (not a node of this package) are ignored.
    Feed every DiagnosticArray in order; the tracker remembers the last count per status name.

    Parameters
    ----------
    nodes_in
        None: every node's statuses. A namespace ('' for the root, else e.g. '/cup'): only the statuses of
        nodes directly in it (``/cup/grasp_planner: planning``, not ``/flashlight/grasp_planner: planning``),
        the rejections of one chain of a scene.
    """

    def __init__(self, *, nodes_in: str | None = None) -> None:
        self._rejected: dict[str, int] = {}
        self._nodes_in = nodes_in

    def update(self, msg: Any) -> list[Rejection]:
        """The rejections that ``msg`` (a decoded DiagnosticArray) reports for the first time."""
        events = []
        for status in msg.status:
            if self._nodes_in is not None and status_namespace(str(status.name)) != self._nodes_in:
                continue
            values = status_values(status)
            try:
                count = int(values.get(KEY_REJECTED, ''))
            except ValueError:
                continue
            previous = self._rejected.get(status.name, 0)
            self._rejected[status.name] = count
            if count > previous:
                events.append(Rejection(str(status.name), level_value(status.level), values.get(KEY_LAST_ERROR, '')))
        return events

    def update_cdr(self, cdr: bytes) -> list[Rejection]:
        """:meth:`update` for a serialized DiagnosticArray; an undecodable one reports nothing."""
        try:
            return self.update(decode(MSGTYPES[DIAGNOSTICS], cdr))
        except SessionError:
            return []
