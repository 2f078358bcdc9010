"""The recorder's rclpy plumbing: its topics, their QoS, the subscriptions feeding its bag, its command line.

A topic selection is a set of names and prefixes resolved against the recorder node
(:class:`TopicSelection`); what each publisher offers is read from discovery into the bag's
:class:`~grasp_intent_ros.sessions.bag.QosSpec` (:func:`offered_qos`), as ``ros2 bag record`` stores it;
:class:`TopicRecorder` subscribes to the selected topics and puts their messages, serialized, into a
:class:`~grasp_intent_ros.sessions.bag.Recording`.

When a topic is subscribed
    The package's own topics (:data:`~grasp_intent_ros.wire.topics.MSGTYPES`, resolved against the recorder:
    its namespace and remaps, and in every namespace the selection names, e.g. each chain of a scene that
    ``--topics cup/ flashlight/`` selects, :meth:`TopicSelection.namespaces`) that the selection holds are
    subscribed when the recorder starts, before any publisher is seen (:func:`known_topics`), so a one-shot
    publisher is heard, in a chain that starts after the recorder too: a message published on one
    of them after the recorder is ready reaches the bag if the publisher has matched the recorder's
    subscription (DDS discovery of a new participant takes ms to a second) and stays until the message is
    delivered: ``ros2 topic pub -w 2 --once intent/w ...`` and ``send_intent -w 2`` wait for two matched
    subscriptions, the interpreter's and the recorder's. Any other selected topic is subscribed when a look
    at the graph (every discovery period) first shows a publisher of it: what it sends before is lost.
The QoS they are subscribed with
    A known topic: what the suite's publishers of it offer (:func:`declared_qos`): reliable, transient local
    for the latched model topics (their last message is recorded however early it was published), volatile
    for the others (matching what ``send_intent``, ``replay`` and ``ros2 topic pub`` offer; a reliable subscription
    loses nothing a reliable publisher sends). When every live publisher of a known topic offers less (only
    best-effort ones, or only volatile ones on a latched topic), the topic is subscribed again as any other
    topic is: best effort / volatile if its publishers' offers differ, else what they offer
    (:func:`~grasp_intent_ros.sessions.bag.request_qos`), keep-last ``depth`` in every case. A publisher
    joining later with a weaker offer than the subscription requests, beside one it hears, is connected to
    nothing: a WARN names the topic.
The offered QoS in the bag
    As ``ros2 bag record`` does, the bag's ``offered_qos_profiles`` hold each publisher's QoS as discovery
    shows it (:func:`offered_qos_spec`: history unknown, the durations and liveliness the publisher offers),
    for the publishers seen when the topic enters the bag: at the first look that shows a publisher of it, or
    at its first message if earlier. A topic nobody published is not in the bag; one whose only publisher was
    gone by the time its first message was taken is recorded with :func:`declared_qos`, what discovery shows
    of the suite's publishers of it.
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from rclpy.event_handler import QoSMessageLostInfo, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rclpy.utilities import remove_ros_args

from ..sessions.bag import DEFAULT_FLUSH_PERIOD, BagWriteError, QosSpec, Recording, misses_offers, request_qos
from ..wire.diagnostics import WARN
from ..wire.topics import LATCHED_TOPICS, MSGTYPES, TOPIC_FOLDERS
from .compat import waiting_messages
from .conversions import type_class
from .diagnostics import NodeDiagnostics
from .qos import latched_qos, output_qos

__all__ = ['TopicSelection', 'DEFAULT_TOPICS', 'DEFAULT_DEPTH', 'DEFAULT_DISCOVERY_PERIOD', 'offered_qos_spec',
           'offered_qos', 'declared_qos', 'known_topics', 'subscription_qos', 'TopicRecorder', 'command_line']

DEFAULT_TOPICS = ('intent/', 'model/', 'grasp/', 'object/', 'joint_states', 'operator/', 'assistance/', '/diagnostics')
"""Recorded by default: relative to the recorder's namespace; a trailing '/' selects a whole subtree."""

DEFAULT_DEPTH = 1000
"""Keep-last depth of the recorder's subscriptions (messages): absorbs bursts while a write blocks; what a longer lag
drops is counted and reported (:meth:`TopicRecorder._check_queue`)."""

DEFAULT_DISCOVERY_PERIOD = 0.5
"""Seconds between the recorder's looks at the ROS graph for new topics."""


@dataclass(frozen=True)
class TopicSelection:
    """Fully qualified topic names and prefixes (ending in '/') to record."""

    names: frozenset[str]
    prefixes: tuple[str, ...]

    @classmethod
    def resolve(cls, node: Node, patterns: Iterable[str]) -> TopicSelection:
        """Resolve ``patterns`` (relative names are expanded and remapped against ``node``).

        Raises
        ------
        ValueError
            A pattern is empty or not a valid topic name.
        """
        names, prefixes = set(), []
        for pattern in patterns:
            subtree = pattern.endswith('/')
            stem = pattern.rstrip('/')
            if not stem:
                raise ValueError(f'not a topic name or prefix: {pattern!r}')
            try:
                full = node.resolve_topic_name(stem)
            except Exception as exc:  # rclpy raises its own (Invalid*NameException) types
                raise ValueError(f'not a topic name or prefix: {pattern!r}: {exc}') from None
            if subtree:
                prefixes.append(full + '/')
            else:
                names.add(full)
        return cls(frozenset(names), tuple(prefixes))

    def matches(self, topic: str) -> bool:
        """Whether a fully qualified topic name is selected."""
        return topic in self.names or topic.startswith(self.prefixes)

    def namespaces(self) -> tuple[str, ...]:
        """The namespaces the selection names, fully qualified ('' for the root), sorted.

        A prefix that ends in a folder of the package's topics (:data:`~grasp_intent_ros.wire.topics.TOPIC_FOLDERS`:
        ``/robot1/intent/``, ``/model/ambiguity/``) lies in the namespace before that folder (``/robot1``, '');
        any other prefix is a namespace itself (a chain of a scene: ``/cup/``). A name that ends in one of the
        package's topics (``/cup/intent/w``) lies in the namespace before it.
        """
        found = set()
        for prefix in self.prefixes:
            stem = prefix.rstrip('/')
            folders = [stem[:-len(f) - 1] for f in TOPIC_FOLDERS if stem.endswith(f'/{f}')]
            found.update(folders or [stem])
        found.update(name[:-len(t) - 1] for name in self.names for t in MSGTYPES
                     if not t.startswith('/') and name.endswith(f'/{t}'))
        return tuple(sorted(found))


_LIVELINESS = {LivelinessPolicy.AUTOMATIC: 'automatic', LivelinessPolicy.MANUAL_BY_TOPIC: 'manual_by_topic'}
_INFINITE_NS = 2**63 - 1


def _duration_ns(duration: object) -> int | None:
    """Nanoseconds of a QoS duration; None for infinite (RMW_DURATION_INFINITE) or unspecified (0: default)."""
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


def offered_qos(publishers: Sequence[TopicEndpointInfo]) -> tuple[QosSpec, ...]:
    """The QoS each of a topic's publishers offers, as recorded.

    ``ros2 bag record``'s ``offered_qos_profiles``: one profile per publisher.
    """
    return tuple(offered_qos_spec(p.qos_profile) for p in publishers)


def declared_qos(topic: str) -> QosSpec:
    """What the suite's publishers of ``topic`` (a relative name of :data:`MSGTYPES`) offer, as discovery shows it.

    The reliability and durability of the profile they publish with (:func:`~grasp_intent_ros.ros.qos.latched_qos`
    for :data:`~grasp_intent_ros.wire.topics.LATCHED_TOPICS`, :func:`~grasp_intent_ros.ros.qos.output_qos`
    otherwise: reliable, transient local or volatile); history unknown, the other policies :class:`QosSpec`'s
    defaults.
    """
    published = offered_qos_spec(latched_qos() if topic in LATCHED_TOPICS else output_qos())
    return QosSpec(published.reliability, published.durability, 0)


def known_topics(node: Node, selection: TopicSelection) -> dict[str, tuple[str, QosSpec]]:
    """The package's topics ``selection`` holds: fully qualified name -> (message type, :func:`declared_qos`).

    Each name of :data:`MSGTYPES` is resolved against ``node`` (namespace and remaps), as the suite's nodes
    started with the same namespace and remaps resolve it, and placed in every namespace the selection names
    (:meth:`TopicSelection.namespaces`: each chain of a scene, ``--topics cup/ flashlight/``).
    """
    known: dict[str, tuple[str, QosSpec]] = {}
    namespaces = selection.namespaces()
    for topic, msgtype in MSGTYPES.items():
        placed = [topic, *(f'{ns}/{topic}' for ns in namespaces if not topic.startswith('/'))]
        for name in map(node.resolve_topic_name, placed):
            if selection.matches(name):
                known.setdefault(name, (msgtype, declared_qos(topic)))
    return known


def subscription_qos(spec: QosSpec, depth: int) -> QoSProfile:
    """The profile to subscribe with: ``spec``'s reliability and durability, keep-last ``depth`` (messages)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=(ReliabilityPolicy.RELIABLE if spec.reliability == 'reliable'
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if spec.durability == 'transient_local'
                    else DurabilityPolicy.VOLATILE))


class TopicRecorder:
    """Subscribes ``node`` to the selected topics and puts their messages into ``bag``.

    A topic of the package (:func:`known_topics`) is subscribed at once, with :func:`declared_qos` (or its
    override), before any publisher of it is seen; any other selected topic when a look at the graph
    (:meth:`discover`) first shows a publisher of it, with :func:`request_qos` of their offers (or its
    override). A known topic whose live publishers the subscription all misses (e.g. only best-effort ones)
    is subscribed again with :func:`request_qos` of their offers; it misses nobody then, so nothing is lost or
    taken twice. A topic enters the bag, with the offers of the publishers seen then, at the first look
    that shows a publisher of it or at its first message, whichever comes first; when that first message's
    publisher is gone already (a one-shot one), its offer is taken to be :func:`declared_qos`.

    Parameters
    ----------
    node
        The recorder node: its graph is searched, its subscriptions created and destroyed here.
    bag
        Where the messages go, serialized (``raw=True``, never decoded), stamped with the middleware's
        receive time (ns).
    selection
        The topics to record.
    overrides
        Fully qualified topic -> QoS to subscribe with and record, instead of the discovered offered QoS.
    depth
        Keep-last depth of each subscription (messages), >= 1.
    diagnostics
        The node's diagnostics: a value per topic, a WARN for lost messages and late publishers.
    on_error
        Called with a :class:`BagWriteError` the bag raised while adding a topic.
    """

    def __init__(self, node: Node, bag: Recording, selection: TopicSelection, overrides: Mapping[str, QosSpec],
                 depth: int, diagnostics: NodeDiagnostics, on_error: Callable[[BagWriteError], object]) -> None:
        self._node, self._bag, self._selection, self._overrides = node, bag, selection, overrides
        self._depth, self._diagnostics, self._on_error = depth, diagnostics, on_error
        self._subscriptions: dict[str, Subscription] = {}
        self._subscribed: dict[str, tuple[str, QosSpec]] = {}  # topic -> (message type, QoS subscribed with)
        self._unrecorded: dict[str, QosSpec] = {}  # subscribed, not in the bag yet -> the offer assumed
        self._skipped: set[str] = set()
        self._qos_warned: set[str] = set()
        self._publishers: dict[str, int] = {}  # topic -> its publishers at the last look at the graph
        self._sequence: dict[str, int] = {}  # topic -> the publication sequence number of its last message taken
        for topic, (msgtype, declared) in known_topics(node, selection).items():
            override = overrides.get(topic)
            if self._subscribe(topic, msgtype, override or declared):
                self._unrecorded[topic] = override or declared

    def discover(self) -> None:
        """Look at the graph: subscribe to new selected topics with a publisher, put topics seen into the bag.

        A topic with several message types, or of a type the bag or this process does not know, is skipped
        with a warning; a topic seen only through its subscribers waits for a publisher.
        """
        log = self._node.get_logger()
        try:
            graph = self._node.get_topic_names_and_types()
        except Exception as exc:  # noqa: BLE001 - e.g. the context is shutting down; never raise in a timer
            log.warning(f'topic discovery failed: {exc}')
            return
        for topic, types in graph:
            if topic in self._skipped or (topic not in self._subscriptions and not self._selection.matches(topic)):
                continue
            if topic not in self._subscriptions and len(types) != 1:
                self._skip(topic, f'it has {len(types)} message types {types}; one is needed')
                continue
            try:
                publishers = self._node.get_publishers_info_by_topic(topic)
            except Exception as exc:  # noqa: BLE001
                log.warning(f'cannot query the publishers of {topic}: {exc}')
                continue
            if len(publishers) != self._publishers.get(topic, 0):  # another publisher's numbers: start again
                self._sequence.pop(topic, None)
            self._publishers[topic] = len(publishers)
            if not publishers:
                continue
            offered = offered_qos(publishers)
            override = self._overrides.get(topic)
            if topic not in self._subscriptions:
                if self._subscribe(topic, types[0], override or request_qos(offered)):
                    self._record(topic, (override,) if override is not None else offered)
                continue
            if topic in self._unrecorded and not self._record(topic, (override,) if override is not None else offered):
                return
            if override is None and all(misses_offers(self._subscribed[topic][1], q) for q in offered):
                self._resubscribe(topic, request_qos(offered))
            else:
                self._check_late_publishers(topic, offered)

    def stop(self, exc: BagWriteError) -> None:
        """After the write error ``exc``: destroy every subscription and close the bag (a failure logged)."""
        for subscription in self._subscriptions.values():
            self._node.destroy_subscription(subscription)
        close_failure = self._bag.close()
        if close_failure is not None and close_failure is not exc:
            self._node.get_logger().error(f'closing the bag after the error failed too: {close_failure}')

    def _check_late_publishers(self, topic: str, offered: Sequence[QosSpec]) -> None:
        """Warn (once per topic) about a publisher offering a weaker QoS than the subscription requests.

        Best effort or volatile beside publishers the subscription hears: DDS connects nothing to it, its
        messages are lost.
        """
        subscribed = self._subscribed[topic][1]
        weaker = request_qos(offered)
        if topic in self._qos_warned or not misses_offers(subscribed, weaker):
            return
        self._qos_warned.add(topic)
        message = (f'{topic}: a publisher offers {weaker.reliability}/{weaker.durability} but the recorder '
                   f'subscribed {subscribed.reliability}/{subscribed.durability}; its messages are NOT '
                   'recorded (restart the recorder to record it)')
        self._node.get_logger().warning(message)
        self._diagnostics.set_state(WARN, message)

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped.add(topic)
        self._node.get_logger().warning(f'not recording {topic}: {reason}')

    def _subscribe(self, topic: str, msgtype: str, qos: QosSpec) -> bool:
        """Subscribe to ``topic`` with ``qos`` (not yet in the bag); False (and skipped) for an unknown type."""
        if not self._bag.knows(msgtype):
            self._skip(topic, f'type {msgtype} is not a ROS 2 Jazzy standard type known to the bag writer')
            return False
        try:
            msg_class = type_class(msgtype)
        except (ImportError, AttributeError, ValueError) as exc:
            self._skip(topic, f'type {msgtype} cannot be imported: {exc}')
            return False
        on_message = self._diagnostics.guard(functools.partial(self._on_message, topic))
        self._subscriptions[topic] = self._node.create_subscription(  # two parameters: rclpy passes MessageInfo
            msg_class, topic, lambda data, info: on_message((data, info)),  # type: ignore[arg-type,misc]
            subscription_qos(qos, self._depth), raw=True,
            event_callbacks=SubscriptionEventCallbacks(message_lost=functools.partial(self._on_lost, topic)))
        self._subscribed[topic] = (msgtype, qos)
        return True

    def _resubscribe(self, topic: str, qos: QosSpec) -> None:
        """Subscribe ``topic`` (in the bag) again with ``qos``.

        The old subscription, which hears no live publisher, is emptied into the bag and destroyed.
        """
        old = self._subscriptions[topic]
        msgtype, before = self._subscribed[topic]
        if not self._subscribe(topic, msgtype, qos):
            return
        self._bag.count_received(len(self._take_waiting(old, topic, self._depth)))
        self._node.destroy_subscription(old)
        self._bag.resubscribe(topic, qos)
        self._node.get_logger().info(f'{topic}: no publisher offers {before.reliability}/{before.durability}; '
                                     f'subscribed again {qos.reliability}/{qos.durability}')

    def _record(self, topic: str, offered: Sequence[QosSpec]) -> bool:
        """Put a subscribed topic into the bag, recorded with the QoS ``offered``; False after a write error."""
        msgtype, qos = self._subscribed[topic]
        try:
            self._bag.add_topic(topic, msgtype, qos, offered)
        except BagWriteError as exc:
            self._on_error(exc)
            return False
        self._unrecorded.pop(topic, None)
        self._diagnostics.set_value(f'topic {topic}', 0)
        self._node.get_logger().info(f'recording {topic} ({msgtype}, {qos.reliability}, {qos.durability})')
        return True

    def _offers_now(self, topic: str) -> tuple[QosSpec, ...]:
        """The offers to record for a topic whose first message came before a look at the graph showed it.

        Its publishers' offers (the override if any), or the assumed offer once they are gone.
        """
        assumed = self._unrecorded[topic]
        if topic in self._overrides:
            return (assumed,)
        try:
            publishers = self._node.get_publishers_info_by_topic(topic)
        except Exception:  # noqa: BLE001 - shutting down: the assumed offer
            publishers = []
        return offered_qos(publishers) if publishers else (assumed,)

    def _on_message(self, topic: str, received: tuple[bytes, Mapping[str, int]]) -> None:
        """The whole work on the executor thread: stamp and enqueue, then drain the subscription's queue.

        rclpy's executor builds a wait set and a task for every message it hands over, which at
        a few kHz costs more than a loaded machine's share of a core; so the callback takes the
        messages already waiting on the same subscription itself (at most ``depth``, so other topics
        keep their turn), as rclpy's executor does (``handle.take_message``). A take of ``depth`` messages
        found the queue full: :meth:`_check_queue` counts what it dropped.
        """
        if topic in self._unrecorded and not self._record(topic, self._offers_now(topic)):
            return
        data, info = received
        # the middleware's receive time, not the callback's: an input and a fast answer taken in one
        # executor wait keep their order of arrival; and the publisher's send time, which orders a cause before
        # its effect whatever order the recorder received them in
        self._bag.put(topic, info.get('received_timestamp', 0) or self._node.get_clock().now().nanoseconds, data,
                      info.get('source_timestamp', 0) or None)
        subscription = self._subscriptions.get(topic)
        taken = [] if subscription is None else self._take_waiting(subscription, topic, self._depth - 1)
        self._bag.count_received(1 + len(taken))
        self._check_queue(topic, [info.get('publication_sequence_number'), *taken])

    def _take_waiting(self, subscription: Subscription, topic: str, limit: int) -> list[int | None]:
        """Put up to ``limit`` messages waiting on ``subscription`` (of ``topic``, in the bag) into the bag.

        Returns their publication sequence numbers (None where the middleware gives none), in order.
        """
        put, now = self._bag.put, self._node.get_clock().now
        taken: list[int | None] = []
        for data, info in waiting_messages(subscription, limit):
            put(topic, info.get('received_timestamp', 0) or now().nanoseconds, data,
                info.get('source_timestamp', 0) or None)
            taken.append(info.get('publication_sequence_number'))
        return taken

    def _check_queue(self, topic: str, sequence: Sequence[int | None]) -> None:
        """Count what ``topic``'s keep-last queue dropped, from one take's publication sequence numbers, in order.

        The queue drops its oldest message, silently (no middleware event), when a message arrives while it holds
        ``depth``; the next take then finds it full and takes ``depth`` messages. Only then is a jump in the
        sequence numbers (from the previous message taken, and within the take) counted as lost: while the last
        look at the graph showed one publisher, the numbers it skipped; with several (their numbers interleave),
        a full queue is counted as an overflow without a count. A number not above the one before (another
        publisher, or a new one) starts the sequence again.
        """
        previous, skipped = self._sequence.get(topic), 0
        for number in sequence:
            if number is not None and previous is not None and number > previous + 1:
                skipped += number - previous - 1
            previous = number
        if previous is None:
            self._sequence.pop(topic, None)
        else:
            self._sequence[topic] = previous
        if len(sequence) < self._depth:
            return
        if self._publishers.get(topic) == 1 and all(n is not None for n in sequence):
            if skipped:
                self._report_lost(self._bag.count_lost(topic, skipped), f'{topic}: its queue dropped {skipped}')
        else:
            self._report_lost(self._bag.count_overflow(topic), f'{topic}: its queue was full')

    def _on_lost(self, topic: str, info: QoSMessageLostInfo) -> None:
        """The middleware reports messages that never reached the subscription: count them, WARN."""
        lost = int(info.total_count_change)
        self._report_lost(self._bag.count_lost(topic, lost), f'{topic}: {lost} never reached it')

    def _report_lost(self, every: str, what: str) -> None:
        """WARN (the log at most every 5 s) with what was just lost and every topic's losses so far (``every``)."""
        message = f'messages lost, the bag misses them (raise --depth if a queue dropped them): {every}'
        self._node.get_logger().warning(f'{what}; {message}', throttle_duration_sec=5.0)
        self._diagnostics.set_state(WARN, message)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description='Record the node suite\'s topics into a rosbag2 MCAP bag until SIGINT/SIGTERM.')
    parser.add_argument('out_dir', type=Path, help='bag directory to create (must not exist)')
    parser.add_argument('--topics', nargs='+', metavar='T', default=list(DEFAULT_TOPICS),
                        help='topics to record, relative to the node namespace; a trailing "/" selects '
                             'a subtree, and one that is not a folder of the suite\'s topics names a namespace whose '
                             'suite topics are heard from the start (a chain of a scene: cup/) '
                             f'(default: {" ".join(DEFAULT_TOPICS)})')
    parser.add_argument('--depth', type=int, default=DEFAULT_DEPTH,
                        help=f'keep-last depth of each subscription (default {DEFAULT_DEPTH})')
    parser.add_argument('--discovery-period', type=float, default=DEFAULT_DISCOVERY_PERIOD,
                        help=f'seconds between looks for new topics (default {DEFAULT_DISCOVERY_PERIOD:g})')
    parser.add_argument('--flush-period', type=float, default=DEFAULT_FLUSH_PERIOD,
                        help='seconds after which a message is on disk, so that a killed recorder loses at '
                             f'most this much (default {DEFAULT_FLUSH_PERIOD:g}; repair with '
                             'python -m grasp_intent_ros reindex)')
    return parser


def command_line(argv: Sequence[str]) -> argparse.Namespace:
    """The recorder's options from a full command line (program name first; ROS arguments ignored).

    ``out_dir``, ``topics``, ``depth``, ``discovery_period``, ``flush_period``; exits with argparse's usage
    error (code 2) on a bad option or a depth below 1, a period not above 0.
    """
    parser = _parser()
    options = parser.parse_args(remove_ros_args(list(argv))[1:])
    if options.depth < 1 or not options.discovery_period > 0.0 or not options.flush_period > 0.0:
        parser.error('--depth must be >= 1, --discovery-period and --flush-period > 0')
    return options
