"""Recorded sessions for replay: each input paired with the outputs it caused, and live-vs-recorded checks.

Pure functions over bag messages (rosbags and numpy only, never rclpy); the messages are read into
comparable values by :mod:`.outputs`, for recorded and live messages alike.

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
            periodic repeats are not events (:class:`~.outputs.RejectionTracker`)

:func:`pair_messages` splits the time-ordered messages into :class:`Step` s: one per input (or model
switch), holding the outputs received after it and before the next input. That pairing is exact when
the session was recorded one input at a time, each sent once the previous one was answered (what
``scripts/record_sessions.py`` does and ``replay --check`` reproduces). :mod:`.compare` compares a step's
recorded outputs with live ones.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

from ..wire.model_document import ModelHeader
from ..wire.topics import DIAGNOSTICS, INPUT_TOPICS, MODEL_ACTIVE, OUTPUT_TOPICS
from .bag.offered_qos import QosSpec
from .bag.reader import read_messages, topics_info
from .bag.writer import SessionWriter
from .outputs import Output, RawMessage, RejectionTracker, SessionError, decode, model_header, output_of

__all__ = [
    'Step',
    'PairedSession',
    'detect_namespace',
    'ModelSwitches',
    'pair_messages',
    'load_paired_session',
    'compact_session',
]

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
        if topic == MODEL_ACTIVE:
            return f'model switch to {model_header(msg.data).name}'
    except (SessionError, AttributeError, TypeError, ValueError) as exc:
        return f'{topic} <undecodable: {exc}>'
    return topic


@dataclass(frozen=True)
class Step:
    """One input of a session and the outputs recorded for it.

    Attributes
    ----------
    index
        Input number, 1-based.
    topic
        'intent/w', 'object/pose', 'joint_states', or 'model/active' for a model switch.
    t_ns
        Receive time of the input, ns.
    msgtype
        Its message type.
    cdr
        The serialized input, published again by a replay (for a model switch: the document).
    expected
        The outputs received after it and before the next input; for a model switch the
        first is the new ``model/active`` document itself.
    description
        One line for humans, e.g. 'intent/w [0.9, 0.1, 0.1]'.
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
        if self.topic != MODEL_ACTIVE or not self.expected:
            return None
        header = self.expected[0].value
        return header.name if isinstance(header, ModelHeader) else None


@dataclass(frozen=True)
class PairedSession:
    """A session bag split into steps.

    Attributes
    ----------
    path
        The bag directory.
    namespace
        Namespace of the session topics ('' for the root namespace, else e.g. '/robot1').
    initial_model
        The first model document of the session (None if it has none).
    steps
        The inputs in order with their outputs.
    unpaired
        Outputs received before the first input (not compared).
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


_KNOWN_RELATIVE: Final = (*INPUT_TOPICS, MODEL_ACTIVE, *OUTPUT_TOPICS)


def detect_namespace(topics: Iterable[str]) -> str:
    """The namespace of the session topics among ``topics`` ('' for root, e.g. '/robot1').

    Raises
    ------
    SessionError
        No session topic, or session topics in several namespaces.
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


class ModelSwitches:
    """Follows a session's ``model/active`` documents (module docstring: the first is the initial model)."""

    def __init__(self) -> None:
        self.initial: ModelHeader | None = None
        """The first document's header."""
        self._current: ModelHeader | None = None

    def take(self, msg: RawMessage) -> ModelHeader | None:
        """The document's header when it switches the model; None for the first document or an exact repeat.

        Raises SessionError for a malformed document.
        """
        try:
            header = model_header(decode(msg.msgtype, msg.cdr).data)
        except SessionError as exc:
            raise SessionError(f'model document at {msg.timestamp_ns} ns: {exc}') from None
        if self._current is None:
            self.initial = self._current = header
            return None
        if (header.name, header.sha256) == (self._current.name, self._current.sha256):
            return None
        self._current = header
        return header


def pair_messages(messages: Iterable[RawMessage], *, namespace: str = '') -> tuple[
        ModelHeader | None, tuple[Step, ...], tuple[Output, ...]]:
    """Split time-ordered messages into (initial model, steps, outputs before the first input).

    Parameters
    ----------
    messages
        Messages in receive-time order (e.g. :func:`~grasp_intent_ros.sessions.bag.read_messages`);
        topics outside the session's (in ``namespace``) are ignored.
    namespace
        '' or e.g. '/robot1'.

    Raises
    ------
    SessionError
        An input or model document cannot be decoded.
    """
    prefix = f'{namespace}/'
    tracker = RejectionTracker()
    models = ModelSwitches()
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
        if msg.topic == DIAGNOSTICS:
            events = [Output(DIAGNOSTICS, msg.timestamp_ns, r) for r in tracker.update_cdr(msg.cdr)]
            (outputs if pending is not None else unpaired).extend(events)
            continue
        if not msg.topic.startswith(prefix):
            continue
        rel = msg.topic[len(prefix):]
        if rel in INPUT_TOPICS or rel == MODEL_ACTIVE:
            header = models.take(msg) if rel == MODEL_ACTIVE else None
            if rel == MODEL_ACTIVE and header is None:
                continue
            close()
            pending = Step(len(steps) + 1, rel, msg.timestamp_ns, msg.msgtype, bytes(msg.cdr), (),
                           _describe_input(rel, msg.msgtype, msg.cdr))
            if header is not None:
                outputs.append(Output(rel, msg.timestamp_ns, header))
        elif rel in OUTPUT_TOPICS:
            (outputs if pending is not None else unpaired).append(output_of(rel, msg.timestamp_ns, msg.cdr))
    close()
    return models.initial, tuple(steps), tuple(unpaired)


def load_paired_session(path: str | os.PathLike[str], *, namespace: str | None = None) -> PairedSession:
    """Read a session bag and pair its inputs with their outputs.

    Parameters
    ----------
    path
        The bag directory.
    namespace
        Namespace of the session topics; None detects it from the bag's topics.

    Raises
    ------
    BagReadError
        The bag cannot be read.
    SessionError
        The bag has no session topics or no inputs, or a model document is malformed.
    """
    bag = Path(path)
    infos = topics_info(bag)
    ns = detect_namespace(infos) if namespace is None else namespace.rstrip('/')
    initial, steps, unpaired = pair_messages(read_messages(bag), namespace=ns)
    if not steps:
        raise SessionError(f'bag {bag} holds no inputs ({", ".join(INPUT_TOPICS)} or model switches)')
    return PairedSession(bag, ns, initial, steps, unpaired)


# ------------------------------------------------------------------------------ compaction
def _statuses_ending(msg: RawMessage, suffixes: set[str]) -> set[str]:
    """Which of ``suffixes`` end a status name of the DiagnosticArray ``msg`` (none when undecodable)."""
    try:
        names = [str(status.name) for status in decode(msg.msgtype, msg.cdr).status]
    except SessionError:
        return set()
    return {suffix for suffix in suffixes if any(name.endswith(suffix) for name in names)}


def compact_session(src: str | os.PathLike[str], dst: str | os.PathLike[str], *,
                    drop_topics: Iterable[str] = (), keep_components: Iterable[str] = ()) -> dict[str, int]:
    """Copy a bag, keeping of ``/diagnostics`` only the messages that report a rejection.

    Periodic diagnostics make up most of a recorded session and add nothing a replay or a report
    needs; the rejections stay, at their receive times, and so does the first message holding a status of
    each component in ``keep_components`` (e.g. the intent estimator's: it tells a replay which node
    produced w). Other messages are copied unchanged (bytes, timestamps, offered QoS); topics in
    ``drop_topics`` (absolute names) and topics left without messages are left out.

    Returns
    -------
        Messages written per topic.

    Raises
    ------
    BagReadError
        ``src`` cannot be read.
    BagWriteError
        ``dst`` exists or cannot be written.
    """
    infos = topics_info(src)
    dropped = set(drop_topics)
    tracker = RejectionTracker()
    wanted = {f': {component}' for component in keep_components}
    counts: dict[str, int] = {}
    with SessionWriter(dst) as writer:
        for msg in read_messages(src):
            if msg.topic in dropped:
                continue
            if msg.topic == DIAGNOSTICS and not tracker.update_cdr(msg.cdr):
                found = _statuses_ending(msg, wanted) if wanted else set()
                if not found:
                    continue
                wanted -= found
            if msg.topic not in counts:
                qos = infos[msg.topic].qos
                writer.add_topic(msg.topic, msg.msgtype, qos=qos or QosSpec())
                counts[msg.topic] = 0
            writer.write(msg.topic, msg.timestamp_ns, msg.cdr)
            counts[msg.topic] += 1
    return counts

