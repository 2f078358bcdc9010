"""Recorded sessions for replay: each input paired with the outputs it caused, and live-vs-recorded checks.

Pure functions over bag messages (rosbags and numpy only, never rclpy), used by
:mod:`grasp_intent_ros.replay` for recorded and live messages alike: the replay tool subscribes to the
live outputs serialized and decodes them with :func:`decode` too, so both sides go through the same code.

Sessions
--------
A session bag holds, besides anything else (ignored), the node suite's topics relative to one namespace:

inputs      ``intent/w``, ``object/pose``, ``joint_states`` (published again by a replay)
model       ``model/active``: the first document is the initial model; every later document with another
            (name, sha256) is a *model switch*, an input that a replay reproduces by setting the model
            server's ``model`` parameter; an exact repeat of the current document is ignored
outputs     ``intent/v``, ``intent/clarification``, ``grasp/pose``, ``grasp/joint_targets``,
            ``grasp/trajectory``, ``grasp/posterior``, ``grasp/features``
rejections  ``/diagnostics``: a status whose 'messages rejected' count grew since the previous status of
            the same name is one rejection, with the status level and its 'last error' as the reason;
            periodic repeats are not events (:class:`RejectionTracker`)

:func:`pair_messages` splits the time-ordered messages into :class:`Step` s: one per input (or model
switch), holding the outputs received after it and before the next input. That pairing is exact when
the session was recorded one input at a time, each sent once the previous one was answered (what
``scripts/record_sessions.py`` does and ``replay --check`` reproduces).

Comparison
----------
:func:`compare_step` compares one step's live outputs with the recorded ones topic by topic, the i-th live
message with the i-th recorded one, within :class:`Tolerances`: v 1e-9; P and reconstructed w 1e-4; end-
effector position 1 mm and orientation 0.01 rad; joint targets and trajectory positions 1e-3 rad;
clarifications, rejections (status, level, reason) and frame/joint/zone names identical. Stamps are
never compared. A model document whose content (sha256) differs under the same name is a note, not a
failure: the differing plans that follow are what fails.
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Final, Protocol

import numpy as np
from numpy.typing import NDArray
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, TypesysError, get_typestore

from ..core.errors import ModelFormatError
from ..core.model import ModelHeader, parse_model_document
from .errors import BagError
from .qos import QosSpec
from .reader import read_messages, topics_info
from .writer import SessionWriter

__all__ = [
    'INPUT_TOPICS',
    'MODEL_TOPIC',
    'OUTPUT_TOPICS',
    'PLAN_TOPICS',
    'DIAGNOSTICS_TOPIC',
    'MSGTYPES',
    'SessionError',
    'Vector',
    'Text',
    'Pose',
    'Joints',
    'Trajectory',
    'ModelHeader',
    'Rejection',
    'Undecodable',
    'Output',
    'Step',
    'Session',
    'Tolerances',
    'Difference',
    'RawMessage',
    'RejectionTracker',
    'decode',
    'model_header',
    'reduce_message',
    'summarize',
    'output_of',
    'detect_namespace',
    'pair_messages',
    'load_session',
    'compare_step',
    'answered',
    'diverged',
    'compact_session',
]

INPUT_TOPICS: Final = ('intent/w', 'object/pose', 'joint_states')
"""Inputs a replay publishes again (relative names)."""
MODEL_TOPIC: Final = 'model/active'
PLAN_TOPICS: Final = ('grasp/pose', 'grasp/joint_targets', 'grasp/trajectory', 'grasp/posterior',
                      'grasp/features')
"""The outputs of one plan (all carry the same stamp)."""
OUTPUT_TOPICS: Final = ('intent/v', 'intent/clarification', *PLAN_TOPICS)
"""Outputs compared by a replay (relative names), besides ``model/active`` and rejections."""
DIAGNOSTICS_TOPIC: Final = '/diagnostics'
MSGTYPES: Final[Mapping[str, str]] = {
    'intent/w': 'std_msgs/msg/Float64MultiArray',
    'object/pose': 'geometry_msgs/msg/PoseStamped',
    'joint_states': 'sensor_msgs/msg/JointState',
    'model/active': 'std_msgs/msg/String',
    'intent/v': 'std_msgs/msg/Float64MultiArray',
    'intent/clarification': 'std_msgs/msg/String',
    'grasp/pose': 'geometry_msgs/msg/PoseStamped',
    'grasp/joint_targets': 'sensor_msgs/msg/JointState',
    'grasp/trajectory': 'trajectory_msgs/msg/JointTrajectory',
    'grasp/posterior': 'std_msgs/msg/Float64MultiArray',
    'grasp/features': 'std_msgs/msg/Float64MultiArray',
    DIAGNOSTICS_TOPIC: 'diagnostic_msgs/msg/DiagnosticArray',
}
"""Message type of every topic a session uses, by relative name (``/diagnostics`` is absolute)."""

_WARN: Final = 1
_LEVELS: Final = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}


class SessionError(BagError):
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

    Attributes:
        topic: Relative topic name ('intent/v', 'model/active', ...) or '/diagnostics'.
        t_ns: Receive time, ns since the epoch.
        value: The reduced message.
    """

    topic: str
    t_ns: int
    value: Value


class RawMessage(Protocol):
    """What :func:`pair_messages` needs of a message; :class:`~grasp_intent_ros.bag.BagMessage` fits."""

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
    return get_typestore(Stores.ROS2_JAZZY)


def decode(msgtype: str, cdr: bytes) -> Any:
    """Deserialize CDR bytes (with encapsulation header) into a rosbags message of ``msgtype``.

    Raises:
        SessionError: The bytes are not a valid message of that type.
    """
    try:
        return _typestore().deserialize_cdr(cdr, msgtype)
    except (SerdeError, TypesysError, KeyError, ValueError, IndexError, UnicodeDecodeError) as exc:
        raise SessionError(f'cannot decode {msgtype}: {exc}') from exc


def _level(level: Any) -> int:
    return level[0] if isinstance(level, (bytes, bytearray)) else int(level)


def model_header(text: str) -> ModelHeader:
    """The header lines of a model document (:func:`~grasp_intent_ros.core.model.parse_model_document`);
    the body is neither hashed nor parsed.

    Raises:
        SessionError: The three header lines are missing or malformed.
    """
    try:
        return parse_model_document(text, check_sha256=False)[0]
    except ModelFormatError as exc:
        raise SessionError(str(exc)) from None


def reduce_message(topic: str, msg: Any) -> Value:
    """The comparable content of a decoded message on a session topic (relative name).

    Raises:
        SessionError: ``topic`` is not a session input/output topic, or the message is malformed
            (e.g. a model document without its header).
    """
    msgtype = MSGTYPES.get(topic)
    if msgtype is None or topic == DIAGNOSTICS_TOPIC:
        raise SessionError(f'{topic!r} is not a session input or output topic')
    kind = msgtype.rsplit('/', 1)[1]
    if kind == 'Float64MultiArray':
        return Vector(tuple(str(d.label) for d in msg.layout.dim),
                      np.asarray(msg.data, dtype=np.float64)[int(msg.layout.data_offset):].copy())
    if kind == 'String':
        return model_header(msg.data) if topic == MODEL_TOPIC else Text(str(msg.data))
    if kind == 'PoseStamped':
        p, q = msg.pose.position, msg.pose.orientation
        return Pose(str(msg.header.frame_id), np.array([p.x, p.y, p.z], dtype=np.float64),
                    np.array([q.x, q.y, q.z, q.w], dtype=np.float64))
    if kind == 'JointState':
        return Joints(tuple(str(n) for n in msg.name), np.asarray(msg.position, dtype=np.float64).copy())
    # JointTrajectory
    names = tuple(str(n) for n in msg.joint_names)
    positions = np.array([np.asarray(pt.positions, dtype=np.float64) for pt in msg.points], dtype=np.float64)
    times = np.array([pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec for pt in msg.points],
                     dtype=np.float64)
    return Trajectory(names, positions.reshape(len(msg.points), -1), times)


def output_of(topic: str, t_ns: int, cdr: bytes) -> Output:
    """An :class:`Output` from serialized bytes on a session topic (relative name, not /diagnostics);
    a message that cannot be decoded becomes an :class:`Undecodable` value (never raises)."""
    try:
        value: Value = reduce_message(topic, decode(MSGTYPES[topic], cdr))
    except (SessionError, KeyError, AttributeError, TypeError, ValueError) as exc:
        value = Undecodable(str(exc))
    return Output(topic, t_ns, value)


class RejectionTracker:
    """Turns ``/diagnostics`` arrays into rejection events (see the module docstring).

    Statuses without an integer 'messages rejected' value (not a node of this package) are ignored.
    Feed every DiagnosticArray in order; the tracker remembers the last count per status name.
    """

    def __init__(self) -> None:
        self._rejected: dict[str, int] = {}

    def update(self, msg: Any) -> list[Rejection]:
        """The rejections that ``msg`` (a decoded DiagnosticArray) reports for the first time."""
        events = []
        for status in msg.status:
            values = {str(kv.key): str(kv.value) for kv in status.values}
            try:
                count = int(values.get('messages rejected', ''))
            except ValueError:
                continue
            previous = self._rejected.get(status.name, 0)
            self._rejected[status.name] = count
            if count > previous:
                events.append(Rejection(str(status.name), _level(status.level), values.get('last error', '')))
        return events

    def update_cdr(self, cdr: bytes) -> list[Rejection]:
        """:meth:`update` for a serialized DiagnosticArray; an undecodable one reports nothing."""
        try:
            return self.update(decode(MSGTYPES[DIAGNOSTICS_TOPIC], cdr))
        except SessionError:
            return []


# ------------------------------------------------------------------------------ pairing
def _describe_input(topic: str, msgtype: str, cdr: bytes) -> str:
    try:
        msg = decode(msgtype, cdr)
        if topic == 'intent/w':
            data = [float(v) for v in msg.data]
            shown = ', '.join(f'{v:g}' for v in data[:8]) + (f', ... ({len(data)} values)' if len(data) > 8 else '')
            dims = [int(d.size) for d in msg.layout.dim]
            layout = '' if not dims or dims == [len(data)] else f' with layout sizes {dims}'
            return f'intent/w [{shown}]{layout}'
        if topic == 'object/pose':
            p, q = msg.pose.position, msg.pose.orientation
            return (f'object/pose ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) m, q ({q.x:.3g}, {q.y:.3g}, {q.z:.3g}, '
                    f'{q.w:.3g}) in {msg.header.frame_id!r}')
        if topic == 'joint_states':
            return f'joint_states ({len(msg.name)} names, {len(msg.position)} positions)'
        if topic == MODEL_TOPIC:
            return f'model switch to {model_header(msg.data).name}'
    except (SessionError, AttributeError, TypeError, ValueError) as exc:
        return f'{topic} <undecodable: {exc}>'
    return topic


@dataclass(frozen=True)
class Step:
    """One input of a session and the outputs recorded for it.

    Attributes:
        index: Input number, 1-based.
        topic: 'intent/w', 'object/pose', 'joint_states', or 'model/active' for a model switch.
        t_ns: Receive time of the input, ns.
        msgtype: Its message type.
        cdr: The serialized input, published again by a replay (for a model switch: the document).
        expected: The outputs received after it and before the next input; for a model switch the
            first is the new ``model/active`` document itself.
        description: One line for humans, e.g. 'intent/w [0.9, 0.1, 0.1]'.
    """

    index: int
    topic: str
    t_ns: int
    msgtype: str
    cdr: bytes
    expected: tuple[Output, ...]
    description: str

    @property
    def model(self) -> str | None:
        """The model a model-switch step activates; None for other steps."""
        if self.topic != MODEL_TOPIC or not self.expected:
            return None
        header = self.expected[0].value
        return header.name if isinstance(header, ModelHeader) else None


@dataclass(frozen=True)
class Session:
    """A session bag split into steps.

    Attributes:
        path: The bag directory.
        namespace: Namespace of the session topics ('' for the root namespace, else e.g. '/robot1').
        initial_model: The first model document of the session (None if it has none).
        steps: The inputs in order with their outputs.
        unpaired: Outputs received before the first input (not compared).
    """

    path: Path
    namespace: str
    initial_model: ModelHeader | None
    steps: tuple[Step, ...]
    unpaired: tuple[Output, ...] = field(default=())

    @property
    def n_outputs(self) -> int:
        """Number of outputs paired with an input."""
        return sum(len(s.expected) for s in self.steps)

    @property
    def duration_s(self) -> float:
        """Time from the first to the last input (s)."""
        return 1e-9 * (self.steps[-1].t_ns - self.steps[0].t_ns) if self.steps else 0.0


_KNOWN_RELATIVE: Final = (*INPUT_TOPICS, MODEL_TOPIC, *OUTPUT_TOPICS)


def detect_namespace(topics: Iterable[str]) -> str:
    """The namespace of the session topics among ``topics`` ('' for root, e.g. '/robot1').

    Raises:
        SessionError: No session topic, or session topics in several namespaces.
    """
    found = set()
    for topic in topics:
        for rel in _KNOWN_RELATIVE:
            if topic == f'/{rel}' or topic.endswith(f'/{rel}'):
                found.add(topic[:-len(rel) - 1])
    if not found:
        raise SessionError(f'no session topic ({", ".join(_KNOWN_RELATIVE)}) in {sorted(topics)}')
    if len(found) > 1:
        raise SessionError(f'session topics in several namespaces: {sorted(found)}')
    return found.pop()


def pair_messages(messages: Iterable[RawMessage], *, namespace: str = '') -> tuple[
        ModelHeader | None, tuple[Step, ...], tuple[Output, ...]]:
    """Split time-ordered messages into (initial model, steps, outputs before the first input).

    Args:
        messages: Messages in receive-time order (e.g. :func:`~grasp_intent_ros.bag.read_messages`);
            topics outside the session's (in ``namespace``) are ignored.
        namespace: '' or e.g. '/robot1'.

    Raises:
        SessionError: An input or model document cannot be decoded.
    """
    prefix = f'{namespace}/'
    tracker = RejectionTracker()
    initial: ModelHeader | None = None
    current: ModelHeader | None = None
    steps: list[Step] = []
    pending: Step | None = None
    outputs: list[Output] = []
    unpaired: list[Output] = []

    def close() -> None:
        if pending is not None:
            steps.append(Step(pending.index, pending.topic, pending.t_ns, pending.msgtype, pending.cdr,
                              tuple(outputs), pending.description))
        outputs.clear()

    for msg in messages:
        if msg.topic == DIAGNOSTICS_TOPIC:
            events = [Output(DIAGNOSTICS_TOPIC, msg.timestamp_ns, r) for r in tracker.update_cdr(msg.cdr)]
            (outputs if pending is not None else unpaired).extend(events)
            continue
        if not msg.topic.startswith(prefix):
            continue
        rel = msg.topic[len(prefix):]
        if rel in INPUT_TOPICS or rel == MODEL_TOPIC:
            if rel == MODEL_TOPIC:
                try:
                    header = model_header(decode(msg.msgtype, msg.cdr).data)
                except SessionError as exc:
                    raise SessionError(f'model document at {msg.timestamp_ns} ns: {exc}') from None
                if current is None:
                    initial = current = header
                    continue
                if (header.name, header.sha256) == (current.name, current.sha256):
                    continue
                current = header
            close()
            pending = Step(len(steps) + 1, rel, msg.timestamp_ns, msg.msgtype, bytes(msg.cdr), (),
                           _describe_input(rel, msg.msgtype, msg.cdr))
            if rel == MODEL_TOPIC:
                outputs.append(Output(rel, msg.timestamp_ns, header))
        elif rel in OUTPUT_TOPICS:
            (outputs if pending is not None else unpaired).append(output_of(rel, msg.timestamp_ns, msg.cdr))
    close()
    return initial, tuple(steps), tuple(unpaired)


def load_session(path: str | os.PathLike[str], *, namespace: str | None = None) -> Session:
    """Read a session bag and pair its inputs with their outputs.

    Args:
        path: The bag directory.
        namespace: Namespace of the session topics; None detects it from the bag's topics.

    Raises:
        BagReadError: The bag cannot be read.
        SessionError: The bag has no session topics or no inputs, or a model document is malformed.
    """
    bag = Path(path)
    infos = topics_info(bag)
    ns = detect_namespace(infos) if namespace is None else namespace.rstrip('/')
    initial, steps, unpaired = pair_messages(read_messages(bag), namespace=ns)
    if not steps:
        raise SessionError(f'bag {bag} holds no inputs ({", ".join(INPUT_TOPICS)} or model switches)')
    return Session(bag, ns, initial, steps, unpaired)


# ------------------------------------------------------------------------------ comparison
@dataclass(frozen=True)
class Tolerances:
    """Largest accepted |recorded - live| per quantity (absolute).

    Attributes:
        v: Target vector entries.
        posterior: P(zone | x) and reconstructed w entries.
        position_m: End-effector position (Euclidean distance, m); also palm features.
        angle_rad: End-effector orientation (rotation angle between the two, rad); also approach and
            roll features.
        joint_rad: Joint targets and trajectory positions (rad); also finger features.
        duration_s: Trajectory time from start (s).
    """

    v: float = 1e-9
    posterior: float = 1e-4
    position_m: float = 1e-3
    angle_rad: float = 0.01
    joint_rad: float = 1e-3
    duration_s: float = 0.01


@dataclass(frozen=True)
class Difference:
    """One difference between a recorded and a live output.

    Attributes:
        step: Input number (1-based) whose answer differs.
        input: The input's description.
        topic: Output topic (relative) or '/diagnostics'.
        field: What differs, e.g. 'P[UT]', 'position', 'message'.
        recorded: The recorded value, formatted.
        live: The live value, formatted.
        fatal: False for a note that does not fail a check (a model's content differs).
    """

    step: int
    input: str
    topic: str
    field: str
    recorded: str
    live: str
    fatal: bool = True

    def __str__(self) -> str:
        kind = '' if self.fatal else 'note: '
        return (f'{kind}input #{self.step} ({self.input}): {self.topic} {self.field}: '
                f'recorded {self.recorded}, live {self.live}')


def summarize(value: Value) -> str:
    """A short one-line rendering of an output value."""
    if isinstance(value, Vector):
        data = ', '.join(f'{v:.6g}' for v in value.data[:10]) + (', ...' if value.data.size > 10 else '')
        return f'[{data}]'
    if isinstance(value, Text):
        return repr(value.data)
    if isinstance(value, Pose):
        return f'position {_fmt(value.position, 4)} m, q {_fmt(value.orientation, 4)} in {value.frame_id!r}'
    if isinstance(value, Joints):
        return f'{len(value.names)} joints {_fmt(value.positions, 4)} rad'
    if isinstance(value, Trajectory):
        return f'{len(value.times_s)} point(s) over {len(value.joint_names)} joints'
    if isinstance(value, ModelHeader):
        return f'model {value.name!r} (sha256 {value.sha256[:12]})'
    if isinstance(value, Rejection):
        return f'{_LEVELS.get(value.level, value.level)} from {value.status!r}: {value.reason!r}'
    return f'<undecodable: {value.reason}>'


def _fmt(values: NDArray[np.float64], digits: int = 6) -> str:
    return '(' + ', '.join(f'{v:.{digits}g}' for v in values) + ')'


def _beyond(diff: float, tol: float) -> str:
    return f' (|diff| {diff:.3g} > {tol:g})'


def _value_labels(vector: Vector, n: int) -> tuple[str, ...]:
    """Names of a vector's entries: from the last dimension label (a leading stamp axis is skipped);
    a posterior's '<zones>|<tasks>' label gives 'P[zone]' and 'w[task]'."""
    labels = [label for label in vector.labels if not label.startswith('stamp=')]
    label = labels[-1] if labels else ''
    zones, bar, tasks = label.partition('|')
    if bar:
        names = [f'P[{z}]' for z in zones.split(',')] + [f'w[{t}]' for t in tasks.split(',')]
    else:
        names = [f'[{z}]' for z in label.split(',')] if label else []
    return tuple(names) if len(names) == n else tuple(f'[{i}]' for i in range(n))


def _feature_tolerance(name: str, tol: Tolerances) -> float:
    bare = name.strip('[]')
    if bare.startswith('palm'):
        return tol.position_m
    if bare.startswith(('approach', 'roll')):
        return tol.angle_rad
    return tol.joint_rad


def _stripped_labels(vector: Vector) -> tuple[str, ...]:
    return tuple(label for label in vector.labels if not label.startswith('stamp='))


def _compare_vectors(topic: str, rec: Vector, live: Vector, tol: Tolerances) -> list[tuple[str, str, str]]:
    if _stripped_labels(rec) != _stripped_labels(live) or rec.data.shape != live.data.shape:
        return [('layout', f'labels {list(_stripped_labels(rec))}, {rec.data.size} values',
                 f'labels {list(_stripped_labels(live))}, {live.data.size} values')]
    names = _value_labels(rec, rec.data.size)
    out = []
    for name, r, v in zip(names, rec.data, live.data):
        if topic == 'intent/v':
            limit = tol.v
        elif topic == 'grasp/posterior':
            limit = tol.posterior
        else:
            limit = _feature_tolerance(name, tol)
        diff = abs(float(r) - float(v))
        if not diff <= limit:  # NaN differs too
            field_name = name if topic != 'intent/v' else f'v{name}'
            out.append((field_name, f'{r:.10g}', f'{v:.10g}{_beyond(diff, limit)}'))
    return out


def _rotation_angle(q1: NDArray[np.float64], q2: NDArray[np.float64]) -> float:
    n1, n2 = float(np.linalg.norm(q1)), float(np.linalg.norm(q2))
    if not (n1 > 0.0 and n2 > 0.0):
        return math.inf
    dot = min(1.0, abs(float(np.dot(q1, q2))) / (n1 * n2))
    return 2.0 * math.acos(dot)


def _compare_joint_lists(names: Sequence[str], rec: NDArray[np.float64], live: NDArray[np.float64],
                         tol: float, what: str) -> list[tuple[str, str, str]]:
    out = []
    for i, (r, v) in enumerate(zip(rec, live)):
        diff = abs(float(r) - float(v))
        if not diff <= tol:
            name = names[i] if i < len(names) else str(i)
            out.append((f'{what}[{name}]', f'{r:.6f} rad', f'{v:.6f} rad{_beyond(diff, tol)}'))
    return out


def _compare_values(topic: str, rec: Value, live: Value, tol: Tolerances) -> list[tuple[str, str, str, bool]]:
    """(field, recorded, live, fatal) for every difference between two values of one topic."""
    if isinstance(live, Undecodable) or type(rec) is not type(live):
        return [('message', summarize(rec), summarize(live), True)]
    out: list[tuple[str, str, str]] = []
    if isinstance(rec, Vector) and isinstance(live, Vector):
        out = _compare_vectors(topic, rec, live, tol)
    elif isinstance(rec, Text) and isinstance(live, Text):
        if rec.data != live.data:
            out = [('text', repr(rec.data), repr(live.data))]
    elif isinstance(rec, Pose) and isinstance(live, Pose):
        if rec.frame_id != live.frame_id:
            out.append(('frame_id', repr(rec.frame_id), repr(live.frame_id)))
        dist = float(np.linalg.norm(rec.position - live.position))
        if not dist <= tol.position_m:
            out.append(('position', f'{_fmt(rec.position)} m',
                        f'{_fmt(live.position)} m (distance {1e3 * dist:.3g} mm > {1e3 * tol.position_m:g} mm)'))
        angle = _rotation_angle(rec.orientation, live.orientation)
        if not angle <= tol.angle_rad:
            out.append(('orientation', f'q {_fmt(rec.orientation)}',
                        f'q {_fmt(live.orientation)} (rotation {angle:.3g} rad > {tol.angle_rad:g} rad)'))
    elif isinstance(rec, Joints) and isinstance(live, Joints):
        if rec.names != live.names or rec.positions.shape != live.positions.shape:
            out = [('name', str(list(rec.names)), str(list(live.names)))]
        else:
            out = _compare_joint_lists(rec.names, rec.positions, live.positions, tol.joint_rad, 'position')
    elif isinstance(rec, Trajectory) and isinstance(live, Trajectory):
        if rec.joint_names != live.joint_names or rec.positions.shape != live.positions.shape:
            out = [('joint_names/points', f'{list(rec.joint_names)}, {len(rec.times_s)} point(s)',
                    f'{list(live.joint_names)}, {len(live.times_s)} point(s)')]
        else:
            for k in range(len(rec.times_s)):
                out += _compare_joint_lists(rec.joint_names, rec.positions[k], live.positions[k],
                                            tol.joint_rad, f'points[{k}].positions')
                diff = abs(float(rec.times_s[k] - live.times_s[k]))
                if not diff <= tol.duration_s:
                    out.append((f'points[{k}].time_from_start', f'{rec.times_s[k]:.4f} s',
                                f'{live.times_s[k]:.4f} s{_beyond(diff, tol.duration_s)}'))
    elif isinstance(rec, ModelHeader) and isinstance(live, ModelHeader):
        if rec.name != live.name:
            out = [('model name', repr(rec.name), repr(live.name))]
        elif rec.sha256 != live.sha256:
            return [('model content', f'sha256 {rec.sha256[:12]}', f'sha256 {live.sha256[:12]} '
                     '(same name, different model: the plans that follow may differ)', False)]
    elif isinstance(rec, Rejection) and isinstance(live, Rejection):
        if (rec.status, rec.level, rec.reason) != (live.status, live.level, live.reason):
            out = [('rejection', summarize(rec), summarize(live))]
    elif isinstance(rec, Undecodable) and isinstance(live, Undecodable):
        pass
    return [(f, r, v, True) for f, r, v in out]


def _by_topic(outputs: Iterable[Output]) -> dict[str, list[Output]]:
    groups: dict[str, list[Output]] = defaultdict(list)
    for out in outputs:
        groups[out.topic].append(out)
    if DIAGNOSTICS_TOPIC in groups:  # rejections from different nodes: order by node, then arrival
        groups[DIAGNOSTICS_TOPIC].sort(key=lambda o: o.value.status if isinstance(o.value, Rejection) else '')
    return groups


_TOPIC_ORDER: Final = {topic: k for k, topic in enumerate((
    MODEL_TOPIC, 'intent/v', 'intent/clarification', DIAGNOSTICS_TOPIC, 'grasp/posterior', 'grasp/pose',
    'grasp/joint_targets', 'grasp/trajectory', 'grasp/features'))}
"""Order in which a step's differences are listed: the cause first, the most telling outputs next."""


def compare_step(step: Step, live: Sequence[Output], tol: Tolerances = Tolerances()) -> list[Difference]:
    """The differences between a step's recorded outputs and the ``live`` outputs for the same input.

    Outputs are matched per topic in order (rejections per status name); a missing or extra message is
    a difference on field 'message'.
    """
    expected, got = _by_topic(step.expected), _by_topic(live)
    topics = sorted(set(expected) | set(got), key=lambda t: (_TOPIC_ORDER.get(t, len(_TOPIC_ORDER)), t))
    diffs = []
    for topic in topics:
        rec_list, live_list = expected.get(topic, []), got.get(topic, [])
        for i in range(max(len(rec_list), len(live_list))):
            if i >= len(live_list):
                diffs.append(Difference(step.index, step.description, topic, 'message',
                                        summarize(rec_list[i].value), 'nothing'))
            elif i >= len(rec_list):
                diffs.append(Difference(step.index, step.description, topic, 'message', 'nothing',
                                        summarize(live_list[i].value)))
            else:
                diffs += [Difference(step.index, step.description, topic, f, r, v, fatal)
                          for f, r, v, fatal in _compare_values(topic, rec_list[i].value, live_list[i].value, tol)]
    return diffs


def _counts(outputs: Iterable[Output]) -> dict[str, int]:
    counts: dict[str, int] = defaultdict(int)
    for out in outputs:
        counts[out.topic] += 1
    return counts


def answered(step: Step, live: Sequence[Output]) -> bool:
    """Whether ``live`` holds at least as many messages per topic as the step's recorded outputs."""
    have = _counts(live)
    return all(have[topic] >= n for topic, n in _counts(step.expected).items())


def diverged(step: Step, live: Sequence[Output]) -> bool:
    """Whether ``live`` holds a message the recording does not (a topic, or one message too many)."""
    want = _counts(step.expected)
    return any(n > want.get(topic, 0) for topic, n in _counts(live).items())


# ------------------------------------------------------------------------------ compaction
def compact_session(src: str | os.PathLike[str], dst: str | os.PathLike[str], *,
                    drop_topics: Iterable[str] = ()) -> dict[str, int]:
    """Copy a bag, keeping of ``/diagnostics`` only the messages that report a rejection.

    Periodic diagnostics make up most of a recorded session and add nothing a replay or a report
    needs; the rejections stay, at their receive times. Other messages are copied unchanged (bytes,
    timestamps, offered QoS); topics in ``drop_topics`` (absolute names) and topics left without
    messages are left out.

    Returns:
        Messages written per topic.

    Raises:
        BagReadError: ``src`` cannot be read.
        BagWriteError: ``dst`` exists or cannot be written.
    """
    infos = topics_info(src)
    dropped = set(drop_topics)
    tracker = RejectionTracker()
    counts: dict[str, int] = {}
    with SessionWriter(dst) as writer:
        for msg in read_messages(src):
            if msg.topic in dropped:
                continue
            if msg.topic == DIAGNOSTICS_TOPIC and not tracker.update_cdr(msg.cdr):
                continue
            if msg.topic not in counts:
                qos = infos[msg.topic].qos
                writer.add_topic(msg.topic, msg.msgtype, qos=qos or QosSpec())
                counts[msg.topic] = 0
            writer.write(msg.topic, msg.timestamp_ns, msg.cdr)
            counts[msg.topic] += 1
    return counts

