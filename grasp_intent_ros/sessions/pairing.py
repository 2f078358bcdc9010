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

:func:`pair_messages` splits the messages in send order (:func:`send_order`) into :class:`Step` s: one per input
(or model switch), holding the outputs sent after it and before the next input. That pairing is exact when
the session was recorded one input at a time, each sent once the previous one was answered (what
``scripts/record_sessions.py`` does and ``replay --check`` reproduces), and its publishers' clocks agree (one
machine). The send order, not the receive order: a recorder may receive an input after the outputs it caused
(its publisher delivered it to the chain first; a one-shot w of ``send_intent -w 2`` was received a few ms after
its v in 4 of 30 recordings on a loaded 2-core machine), never send it after them. :mod:`.compare` compares a
step's recorded outputs with live ones.

A chain of a scene of several objects (:mod:`.scenes`) is paired by its namespace: its own inputs and the
arm's ``joint_states`` in the scene's namespace, its outputs, the rejections of its own nodes
(:func:`pair_messages` with ``arm_namespace``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

from ..wire.model_document import ModelHeader
from ..wire.topics import DIAGNOSTICS, INPUT_TOPICS, JOINT_STATES, MODEL_ACTIVE, OUTPUT_TOPICS
from .bag.offered_qos import QosSpec
from .bag.reader import BagMessage, read_messages, topics_info
from .bag.writer import SessionWriter
from .outputs import Output, RawMessage, RejectionTracker, SessionError, decode, model_header, output_of

__all__ = [
    'Step',
    'PairedSession',
    'session_topics',
    'detect_namespace',
    'ModelSwitches',
    'ChainPairing',
    'send_order',
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
    arm_namespace
        None for a one-chain session; for a chain of a scene, the scene's namespace, where the arm's
        ``joint_states`` is (:func:`~.scenes.detect_scene`).
    """

    path: Path
    namespace: str
    initial_model: ModelHeader | None
    steps: tuple[Step, ...]
    unpaired: tuple[Output, ...] = field(default=())
    arm_namespace: str | None = None

    @property
    def joint_states(self) -> str:
        """The topic the session's ``joint_states`` steps were received on and are sent to again.

        Relative (``joint_states``, in :attr:`namespace`) for a one-chain session, else the arm's, fully qualified.
        """
        return JOINT_STATES if self.arm_namespace is None else f'{self.arm_namespace}/{JOINT_STATES}'

    @property
    def name(self) -> str:
        """The chain's name in its scene ('cup' for '/cup' in the root's scene); '' for a one-chain session."""
        return '' if self.arm_namespace is None else self.namespace[len(self.arm_namespace) + 1:]

    @property
    def n_outputs(self) -> int:
        """Number of outputs paired with an input."""
        return sum(len(s.expected) for s in self.steps)

    @property
    def duration_s(self) -> float:
        """Time from the first to the last input (s)."""
        return 1e-9 * (self.steps[-1].t_ns - self.steps[0].t_ns) if self.steps else 0.0


_KNOWN_RELATIVE: Final = (*INPUT_TOPICS, MODEL_ACTIVE, *OUTPUT_TOPICS)


def session_topics(topics: Iterable[str]) -> dict[str, list[str]]:
    """Namespace ('' for root) -> the session topics among ``topics`` in it, fully qualified, sorted.

    Raises
    ------
    SessionError
        No session topic.
    """
    topics = sorted(topics)
    found: dict[str, list[str]] = {}
    for topic in topics:
        for rel in _KNOWN_RELATIVE:
            if topic.endswith(f'/{rel}'):
                found.setdefault(topic[:-len(rel) - 1], []).append(topic)
    if not found:
        raise SessionError(f'no session topic ({", ".join(_KNOWN_RELATIVE)}) in {topics}')
    return found


def detect_namespace(topics: Iterable[str]) -> str:
    """The namespace of the session topics among ``topics`` ('' for root, e.g. '/robot1').

    Raises
    ------
    SessionError
        No session topic, or session topics in several namespaces.
    """
    found = session_topics(topics)
    if len(found) > 1:
        raise SessionError(f'session topics in several namespaces: {sorted(found)}')
    return next(iter(found))


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


class ChainPairing:
    """Pairs one chain's messages into steps as they come (:func:`pair_messages` says how; its arguments)."""

    def __init__(self, namespace: str, arm_namespace: str | None) -> None:
        self._prefix = f'{namespace}/'
        self._joint_states = f'{namespace if arm_namespace is None else arm_namespace}/{JOINT_STATES}'
        self._label = '' if arm_namespace is None else f'{namespace[len(arm_namespace) + 1:]}: '
        self._tracker = RejectionTracker(nodes_in=None if arm_namespace is None else namespace)
        self._models = ModelSwitches()
        self._steps: list[Step] = []
        self._pending: Step | None = None
        self._outputs: list[Output] = []
        self._unpaired: list[Output] = []

    def take(self, msg: RawMessage) -> Step | None:
        """Take the next message; the (pending) step it opens when it is an input of this chain, else None."""
        if msg.topic == DIAGNOSTICS:
            events = [Output(DIAGNOSTICS, msg.timestamp_ns, r) for r in self._tracker.update_cdr(msg.cdr)]
            (self._outputs if self._pending is not None else self._unpaired).extend(events)
            return None
        if msg.topic == self._joint_states:
            rel = JOINT_STATES
        elif msg.topic.startswith(self._prefix):
            rel = msg.topic[len(self._prefix):]
        else:
            return None
        if rel in INPUT_TOPICS or rel == MODEL_ACTIVE:
            header = self._models.take(msg) if rel == MODEL_ACTIVE else None
            if rel == MODEL_ACTIVE and header is None:
                return None
            self._close()
            label = '' if msg.topic == self._joint_states else self._label
            self._pending = Step(len(self._steps) + 1, rel, msg.timestamp_ns, msg.msgtype, bytes(msg.cdr), (),
                                 label + _describe_input(rel, msg.msgtype, msg.cdr))
            if header is not None:
                self._outputs.append(Output(rel, msg.timestamp_ns, header))
            return self._pending
        if rel in OUTPUT_TOPICS:
            (self._outputs if self._pending is not None else self._unpaired).append(
                output_of(rel, msg.timestamp_ns, msg.cdr))
        return None

    def _close(self) -> None:
        if self._pending is not None:
            p = self._pending
            self._steps.append(Step(p.index, p.topic, p.t_ns, p.msgtype, p.cdr, tuple(self._outputs), p.description))
        self._outputs.clear()

    def finish(self) -> tuple[ModelHeader | None, tuple[Step, ...], tuple[Output, ...]]:
        """(initial model, steps, outputs before the first input), the last step closed."""
        self._close()
        self._pending = None
        return self._models.initial, tuple(self._steps), tuple(self._unpaired)


def send_order(messages: Iterable[BagMessage]) -> list[BagMessage]:
    """``messages`` (receive-time order, :func:`~grasp_intent_ros.sessions.bag.read_messages`) in send order.

    By publish time (the publisher's send time), equal ones in receive order: a bag whose messages have no send
    time of their own (their publish time is their receive time, as rosbags writes) keeps its receive order.
    """
    return sorted(messages, key=lambda message: message.publish_ns)


def pair_messages(messages: Iterable[RawMessage], *, namespace: str = '', arm_namespace: str | None = None) -> tuple[
        ModelHeader | None, tuple[Step, ...], tuple[Output, ...]]:
    """Split time-ordered messages into (initial model, steps, outputs before the first input).

    Parameters
    ----------
    messages
        Messages in send order (:func:`send_order` of :func:`~grasp_intent_ros.sessions.bag.read_messages`);
        topics outside the session's (in ``namespace``) are ignored.
    namespace
        '' or e.g. '/robot1'.
    arm_namespace
        None: a one-chain session (``joint_states`` in ``namespace``, every node's rejections). For a chain of
        a scene (``namespace`` '/cup'), the scene's namespace: the arm's ``joint_states`` there is an input of
        the chain, only the rejections of nodes in ``namespace`` are its outputs, and each description but the
        joint states' starts with the chain's name ('cup: intent/w [...]').

    Raises
    ------
    SessionError
        An input or model document cannot be decoded.
    """
    chain = ChainPairing(namespace, arm_namespace)
    for msg in messages:
        chain.take(msg)
    return chain.finish()


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
    initial, steps, unpaired = pair_messages(send_order(read_messages(bag)), namespace=ns)
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
            writer.write(msg.topic, msg.timestamp_ns, msg.cdr, msg.publish_ns)
            counts[msg.topic] += 1
    return counts

