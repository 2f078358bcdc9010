"""Session recorder: the node suite's topics -> one rosbag2 MCAP bag (what ``ros2 bag record`` would write).

Run: ``python -m grasp_intent_ros recorder OUT_DIR [--topics T ...] [--ros-args -r __ns:=/robot1]``

Topics
    ``--topics`` takes topic names relative to the recorder's namespace (or absolute); a name ending
    in ``/`` selects every topic under it. Default: ``intent/ model/ grasp/ object/ joint_states
    operator/ assistance/ /diagnostics`` (the shared-control loop's twists and alpha included). Matching
    topics are discovered every ``--discovery-period`` seconds, so nodes may start before or after the
    recorder.
Recording
    Messages are taken serialized (``raw=True``, never decoded) and written unchanged with
    :class:`~grasp_intent_ros.sessions.bag.SessionWriter`, stamped with the middleware's receive time (ns). The
    executor thread only puts them on a queue; a writer thread (:class:`~grasp_intent_ros.sessions.bag.QueuedWriter`)
    writes and compresses, so a slow disk or a chunk being compressed never delays a subscription.
    Each topic is subscribed with the reliability and durability its publishers offer (best effort /
    volatile if they differ; transient local for latched topics, so the last ``model/active`` is
    recorded even when it was published before the recorder started), keep-last ``--depth``. As
    ``ros2 bag record`` does, the bag's ``offered_qos_profiles`` hold each publisher's QoS as discovery
    shows it (:func:`offered_qos_spec`: history unknown, the durations and
    liveliness the publisher offers).
Crash safety
    A chunk is closed and handed to the operating system once its first message is ``--flush-period``
    seconds old (default 1 s), also when no further message arrives: a SIGKILLed recorder loses at most
    that much. ``python -m grasp_intent_ros reindex BAG`` then rebuilds the MCAP summary and
    metadata.yaml from the complete chunks (the original file is kept as ``.mcap.broken``).
Diagnostics
    ``/diagnostics`` status ``<node>: recorder``: 'messages received', 'messages written' in total and
    per topic ('topic /intent/w': n), the 'writer queue' and its 'writer queue peak' (messages received,
    not yet written), 'messages lost' (the middleware's message-lost events: a reliable publisher whose
    history dropped messages before the recorder had them, a best-effort gap) with a WARN naming the
    topics, ERROR with the reason once a write failed.
Ending
    SIGINT/SIGTERM: the bag is closed (MCAP summary, metadata.yaml), a one-line summary printed, exit 0.
    A write error (e.g. disk full): an ERROR log naming the bag and the number of messages written,
    nothing more is recorded, exit code 1. A bag directory that exists already: exit code 1.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rclpy
from rclpy.event_handler import QoSMessageLostInfo, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rclpy.utilities import remove_ros_args

from ..ros.compat import waiting_messages
from ..ros.conversions import type_class
from ..ros.diagnostics import NodeDiagnostics
from ..ros.run import run_node
from ..sessions.bag import DEFAULT_FLUSH_PERIOD, BagWriteError, QosSpec, QueuedWriter, SessionWriter, jazzy_typestore
from ..wire.diagnostics import ERROR, WARN

__all__ = ['Recorder', 'TopicSelection', 'DEFAULT_TOPICS', 'DEFAULT_DEPTH', 'offered_qos_spec', 'offered_qos',
           'request_qos', 'main']

DEFAULT_TOPICS = ('intent/', 'model/', 'grasp/', 'object/', 'joint_states', 'operator/', 'assistance/', '/diagnostics')
"""Recorded by default: relative to the recorder's namespace; a trailing '/' selects a whole subtree."""

DEFAULT_DEPTH = 1000
"""Keep-last depth of the recorder's subscriptions (messages): absorbs bursts while a write blocks."""


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


def _subscription_qos(spec: QosSpec, depth: int) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=(ReliabilityPolicy.RELIABLE if spec.reliability == 'reliable'
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if spec.durability == 'transient_local'
                    else DurabilityPolicy.VOLATILE))


class Recorder(Node):
    """Records the selected topics, serialized, into a new rosbag2 MCAP bag at ``out_dir``.

    Parameters
    ----------
    out_dir
        Bag directory to create; it must not exist.
    topics
        Topic names/prefixes, see :data:`DEFAULT_TOPICS`.
    qos_overrides
        Topic (as in ``topics``, relative or absolute) -> QoS to subscribe with and
        record, instead of the discovered offered QoS.
    depth
        Keep-last depth of each subscription (messages).
    discovery_period
        Seconds between looks at the ROS graph for new topics.
    flush_period
        Seconds after which a received message is on disk (its chunk closed and flushed).
    on_failure
        Called once with the :class:`BagWriteError` after a write error stopped the
        recording (``main`` shuts the context down with it); default: nothing more.
    node_name
        Node name; ``kwargs`` go to ``rclpy.node.Node`` (e.g. ``context``, ``namespace``).

    Raises
    ------
    BagWriteError
        ``out_dir`` exists or cannot be created.
    ValueError
        A topic pattern is invalid, or depth/discovery_period/flush_period is not positive.

    The bag is finished by :meth:`close`, which :meth:`destroy_node` calls.
    """

    def __init__(self, out_dir: str | os.PathLike[str], *, topics: Iterable[str] = DEFAULT_TOPICS,
                 qos_overrides: Mapping[str, QosSpec] | None = None, depth: int = DEFAULT_DEPTH,
                 discovery_period: float = 0.5, flush_period: float = DEFAULT_FLUSH_PERIOD,
                 on_failure: Callable[[BagWriteError], object] | None = None,
                 node_name: str = 'recorder', **kwargs: Any) -> None:
        if depth < 1 or not discovery_period > 0.0 or not flush_period > 0.0:
            raise ValueError('depth must be >= 1, discovery_period and flush_period > 0, got '
                             f'{depth}, {discovery_period}, {flush_period}')
        super().__init__(node_name, **kwargs)
        self._typestore = jazzy_typestore()
        try:
            self._selection = TopicSelection.resolve(self, topics)
            self._overrides = {self.resolve_topic_name(t): q for t, q in (qos_overrides or {}).items()}
            self._bag = SessionWriter(out_dir, typestore=self._typestore,  # last: no empty bag left behind
                                      flush_period=flush_period)
        except BaseException:
            Node.destroy_node(self)
            raise
        self._writer = QueuedWriter(self._bag)  # its write errors are taken up by _report_counts
        self._depth = depth
        self._on_failure = on_failure
        self._topic_subs: dict[str, Subscription] = {}
        self._recorded: dict[str, tuple[str, QosSpec]] = {}  # topic -> (type, subscribed QoS)
        self._skipped: set[str] = set()
        self._qos_warned: set[str] = set()
        self._received = 0
        self._lost: dict[str, int] = {}
        self._error: BagWriteError | None = None
        self._diagnostics = NodeDiagnostics(self, 'recorder')
        self._diagnostics.set_value('bag', self._bag.path)
        self._report_counts()
        self._report_timer = self.create_timer(0.5, self._report_counts)
        self._timer = self.create_timer(discovery_period, self.discover)
        self.get_logger().info(f'recording to {self._bag.path}: '
                               f'{", ".join(sorted(self._selection.names | set(self._selection.prefixes)))}')
        self.discover()

    # ------------------------------------------------------------------ state
    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._bag.path

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per recorded topic (a new dict)."""
        written = self._writer.counts
        return {topic: written.get(topic, 0) for topic in self._recorded}

    @property
    def recorded_topics(self) -> dict[str, tuple[str, QosSpec]]:
        """A copy of the subscribed topics: name -> (message type, QoS subscribed with)."""
        return dict(self._recorded)

    @property
    def error(self) -> BagWriteError | None:
        """The write error that stopped the recording, if any."""
        return self._error

    def summary(self) -> str:
        """One line: messages per topic, and the error if the recording failed."""
        counts = self.counts
        per_topic = ', '.join(f'{t} {n}' for t, n in sorted(counts.items())) or 'no topics'
        line = (f'recorder: {sum(counts.values())} messages on {len(counts)} topics '
                f'in {self._bag.path} ({per_topic})')
        if self._error is not None:
            line += f'; FAILED: {self._error}'
            if self._writer.dropped:
                line += f'; {self._writer.dropped} messages received after the error not recorded'
        return line

    # ------------------------------------------------------------------ discovery
    def discover(self) -> None:
        """Subscribe to every selected topic that has appeared with a publisher since the last look."""
        if self._error is not None or self._bag.closed:
            return
        try:
            graph = self.get_topic_names_and_types()
        except Exception as exc:  # noqa: BLE001 - e.g. the context is shutting down; never raise in a timer
            self.get_logger().warning(f'topic discovery failed: {exc}')
            return
        for topic, types in graph:
            if topic in self._topic_subs:
                self._check_late_publishers(topic)
                continue
            if topic in self._skipped or not self._selection.matches(topic):
                continue
            if len(types) != 1:
                self._skip(topic, f'it has {len(types)} message types {types}; one is needed')
                continue
            try:
                publishers = self.get_publishers_info_by_topic(topic)
            except Exception as exc:  # noqa: BLE001
                self.get_logger().warning(f'cannot query the publishers of {topic}: {exc}')
                continue
            if publishers:  # a topic seen only through its subscribers waits for a publisher
                override = self._overrides.get(topic)
                offered = (override,) if override is not None else offered_qos(publishers)
                self._subscribe(topic, types[0], override or request_qos(offered), offered)

    def _check_late_publishers(self, topic: str) -> None:
        """Warn (once per topic) about a late publisher offering a weaker QoS than the subscription requests.

        Best effort or volatile: DDS connects nothing, its messages are lost.
        """
        if topic in self._qos_warned:
            return
        try:
            publishers = self.get_publishers_info_by_topic(topic)
        except Exception:  # noqa: BLE001 - shutting down; the next look will tell
            return
        if not publishers:
            return
        offered, subscribed = request_qos(offered_qos(publishers)), self._recorded[topic][1]
        if ((subscribed.reliability, offered.reliability) == ('reliable', 'best_effort')
                or (subscribed.durability, offered.durability) == ('transient_local', 'volatile')):
            self._qos_warned.add(topic)
            message = (f'{topic}: a publisher offers {offered.reliability}/{offered.durability} but the recorder '
                       f'subscribed {subscribed.reliability}/{subscribed.durability}; its messages are NOT '
                       'recorded (restart the recorder to record it)')
            self.get_logger().warning(message)
            self._diagnostics.set_state(WARN, message)

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped.add(topic)
        self.get_logger().warning(f'not recording {topic}: {reason}')

    def _subscribe(self, topic: str, msgtype: str, qos: QosSpec, offered: Sequence[QosSpec]) -> None:
        if msgtype not in self._typestore.fielddefs:
            self._skip(topic, f'type {msgtype} is not a ROS 2 Jazzy standard type known to the bag writer')
            return
        try:
            msg_class = type_class(msgtype)
        except (ImportError, AttributeError, ValueError) as exc:
            self._skip(topic, f'type {msgtype} cannot be imported: {exc}')
            return
        try:
            self._bag.add_topic(topic, msgtype, qos=offered)
        except BagWriteError as exc:
            self._fail(exc)
            return
        self._recorded[topic] = (msgtype, qos)
        self._diagnostics.set_value(f'topic {topic}', 0)
        on_message = self._diagnostics.guard(functools.partial(self._on_message, topic))
        self._topic_subs[topic] = self.create_subscription(  # two parameters: rclpy passes MessageInfo
            msg_class, topic, lambda data, info: on_message((data, info)),
            _subscription_qos(qos, self._depth), raw=True,
            event_callbacks=SubscriptionEventCallbacks(message_lost=functools.partial(self._on_lost, topic)))
        self.get_logger().info(f'recording {topic} ({msgtype}, {qos.reliability}, {qos.durability})')

    # ------------------------------------------------------------------ writing
    def _on_message(self, topic: str, received: tuple[bytes, Mapping[str, int]]) -> None:
        """The whole work on the executor thread: stamp and enqueue, then drain the subscription's queue.

        rclpy's executor builds a wait set and a task for every message it hands over, which at
        a few kHz costs more than a loaded machine's share of a core; so the callback takes the
        messages already waiting on the same subscription itself (at most ``depth``, so other topics
        keep their turn), as rclpy's executor does (``handle.take_message``).
        """
        data, info = received
        put, now = self._writer.put, self.get_clock().now
        # the middleware's receive time, not the callback's: an input and a fast answer taken in one
        # executor wait keep their order of arrival
        put(topic, info.get('received_timestamp', 0) or now().nanoseconds, data)
        taken = 1
        subscription = self._topic_subs.get(topic)
        if subscription is not None:
            for data, info in waiting_messages(subscription, self._depth - 1):
                put(topic, info.get('received_timestamp', 0) or now().nanoseconds, data)
                taken += 1
        self._received += taken

    def _on_lost(self, topic: str, info: QoSMessageLostInfo) -> None:
        """The middleware reports messages that never reached the subscription: count them, WARN."""
        self._lost[topic] = self._lost.get(topic, 0) + int(info.total_count_change)
        lost = ', '.join(f'{t} {n}' for t, n in sorted(self._lost.items()))
        self._diagnostics.set_state(WARN, f'messages lost before they reached the recorder: {lost}')

    def _report_counts(self) -> None:
        """Copy the writer's counts into the diagnostics (published every second); take up a write error."""
        if self._writer.error is not None and self._error is None:
            self._fail(self._writer.error)
        written = self._writer.counts
        self._diagnostics.set_values({
            'messages received': self._received, 'messages written': self._bag.message_count,
            'writer queue': self._writer.queued, 'writer queue peak': self._writer.peak,
            'messages lost': sum(self._lost.values()),
            **{f'topic {topic}': written.get(topic, 0) for topic in self._recorded}})

    def _fail(self, exc: BagWriteError) -> None:
        """Stop recording after a write error: report it, unsubscribe, call ``on_failure``."""
        if self._error is not None:
            return
        self._error = exc
        where = f' [bag {exc.path or self._bag.path}, {exc.messages_written} messages written before the error]'
        self.get_logger().error(f'recording stopped, nothing more is recorded: {exc}'
                                f'{"" if str(self._bag.path) in str(exc) else where}')
        self._diagnostics.set_state(ERROR, f'recording stopped: {exc}')
        self._diagnostics.publish()
        self._timer.cancel()
        for subscription in self._topic_subs.values():
            self.destroy_subscription(subscription)
        try:
            self._writer.close()
        except BagWriteError as close_exc:
            self.get_logger().error(f'closing the bag after the error failed too: {close_exc}')
        if self._on_failure is not None:
            try:
                self._on_failure(exc)
            except Exception as cb_exc:  # noqa: BLE001
                self.get_logger().error(f'on_failure callback raised {type(cb_exc).__name__}: {cb_exc}')

    def close(self) -> None:
        """Stop discovery, write what is queued and finish the bag (MCAP summary, metadata.yaml). Idempotent.

        A failure while finishing is logged and kept in :attr:`error`.
        """
        self._timer.cancel()
        self._report_timer.cancel()
        try:
            self._writer.close()
            failure = self._writer.error  # e.g. writing the last queued messages failed
        except BagWriteError as exc:
            failure = exc
        if failure is not None and self._error is None:
            self._error = failure
            self.get_logger().error(f'finishing bag {self._bag.path} failed: {failure}')

    def destroy_node(self) -> None:
        """Close the bag, then destroy the node."""
        self.close()
        super().destroy_node()


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description='Record the node suite\'s topics into a rosbag2 MCAP bag until SIGINT/SIGTERM.')
    parser.add_argument('out_dir', type=Path, help='bag directory to create (must not exist)')
    parser.add_argument('--topics', nargs='+', metavar='T', default=list(DEFAULT_TOPICS),
                        help='topics to record, relative to the node namespace; a trailing "/" selects '
                             f'a subtree (default: {" ".join(DEFAULT_TOPICS)})')
    parser.add_argument('--depth', type=int, default=DEFAULT_DEPTH,
                        help=f'keep-last depth of each subscription (default {DEFAULT_DEPTH})')
    parser.add_argument('--discovery-period', type=float, default=0.5,
                        help='seconds between looks for new topics (default 0.5)')
    parser.add_argument('--flush-period', type=float, default=DEFAULT_FLUSH_PERIOD,
                        help='seconds after which a message is on disk, so that a killed recorder loses at '
                             f'most this much (default {DEFAULT_FLUSH_PERIOD:g}; repair with '
                             'python -m grasp_intent_ros reindex)')
    return parser


def main(args: list[str] | None = None) -> None:
    """Entry point: record until SIGINT/SIGTERM (exit 0) or a write error (exit 1).

    ``args`` is a full command line (program name first), like ``sys.argv``, which it defaults to.
    """
    argv = list(sys.argv if args is None else args)
    options = _parser().parse_args(remove_ros_args(argv)[1:])
    if options.depth < 1 or not options.discovery_period > 0.0 or not options.flush_period > 0.0:
        _parser().error('--depth must be >= 1, --discovery-period and --flush-period > 0')
    built: list[Recorder] = []

    def build() -> Recorder:
        try:
            recorder = Recorder(options.out_dir, topics=options.topics, depth=options.depth,
                                discovery_period=options.discovery_period, flush_period=options.flush_period,
                                on_failure=lambda _exc: rclpy.try_shutdown())  # run_node's context
        except BagWriteError as exc:  # e.g. the bag directory exists already
            print(f'recorder: error: {exc}', file=sys.stderr)
            raise SystemExit(1) from None
        except ValueError as exc:  # a bad --topics entry
            print(f'recorder: error: {exc}', file=sys.stderr)
            raise SystemExit(2) from None
        built.append(recorder)
        return recorder

    run_node(build, argv, shutdown_grace=None)  # closing a bag may take longer: never cut short
    if built:
        recorder = built[0]
        print(recorder.summary(), flush=True)
        if recorder.error is not None:
            raise SystemExit(1)


if __name__ == '__main__':
    main()
