"""Session recorder: the node suite's topics -> one rosbag2 MCAP bag (what ``ros2 bag record`` would write).

Run: ``python -m grasp_intent_ros recorder OUT_DIR [--topics T ...] [--ros-args -r __ns:=/robot1]``

Topics
    ``--topics`` takes topic names relative to the recorder's namespace (or absolute); a name ending in ``/``
    selects every topic under it. Default: :data:`~grasp_intent_ros.ros.recording.DEFAULT_TOPICS` (the
    shared-control loop's twists and alpha included). The package's own topics among them, also in each
    namespace a prefix names (a scene's chains: ``--topics cup/ flashlight/ joint_states /diagnostics``), are
    subscribed at start, others once a look at the graph (every ``--discovery-period`` s) shows a publisher;
    what reaches the bag once it logs ``recording to BAG``, with which QoS: :mod:`grasp_intent_ros.ros.recording`.
Recording
    Messages are taken serialized and written unchanged, stamped with the middleware's receive time (ns), and
    recorded with each publisher's offered QoS, as ``ros2 bag record`` does. The executor thread only queues
    them; a writer thread (:class:`~grasp_intent_ros.sessions.bag.Recording`) writes and compresses, so a slow
    disk or a chunk being compressed never delays a subscription.
Crash safety
    A chunk is on disk once its first message is ``--flush-period`` seconds old (default 1 s): a SIGKILLed
    recorder loses at most that much; ``python -m grasp_intent_ros reindex BAG`` repairs the bag.
Diagnostics
    Status ``<node>: recorder``: counts and losses per topic (:class:`~grasp_intent_ros.sessions.bag.Recording`), a
    WARN naming the topics that lost messages (:class:`~grasp_intent_ros.ros.recording.TopicRecorder`), ERROR
    with the reason once a write failed.
Ending
    SIGINT/SIGTERM: the bag is closed, a summary printed (messages, losses per topic), exit 0. A write error (a
    full disk): an ERROR log naming the bag and the messages written, exit 1 (also when the bag exists already).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import rclpy
from rclpy.node import Node

from ..ros import recording
from ..ros.diagnostics import NodeDiagnostics
from ..ros.run import run_node
from ..sessions.bag import DEFAULT_FLUSH_PERIOD, BagWriteError, QosSpec, Recording
from ..wire.diagnostics import ERROR

__all__ = ['Recorder', 'main']


class Recorder(Node):
    """Records the selected topics, serialized, into a new rosbag2 MCAP bag at ``out_dir``, finished by :meth:`close`.

    Parameters
    ----------
    out_dir
        Bag directory to create; it must not exist.
    topics
        Topic names/prefixes, see :data:`~grasp_intent_ros.ros.recording.DEFAULT_TOPICS`.
    qos_overrides
        Topic (as in ``topics``) -> QoS to subscribe with and record, instead of the discovered offered QoS.
    depth, discovery_period, flush_period
        Keep-last depth of each subscription (messages); seconds between looks at the ROS graph for new
        topics; seconds after which a received message is on disk (its chunk closed and flushed).
    on_failure
        Called once with the :class:`BagWriteError` that stopped the recording (``main`` shuts the context
        down with it); default: nothing more.
    node_name
        Node name; ``kwargs`` go to ``rclpy.node.Node`` (e.g. ``context``, ``namespace``).

    Raises
    ------
    BagWriteError
        ``out_dir`` exists or cannot be created.
    ValueError
        A topic pattern is invalid, or depth/discovery_period/flush_period is not positive.
    """

    def __init__(self, out_dir: str | os.PathLike[str], *, topics: Iterable[str] = recording.DEFAULT_TOPICS,
                 qos_overrides: Mapping[str, QosSpec] | None = None, depth: int = recording.DEFAULT_DEPTH,
                 discovery_period: float = recording.DEFAULT_DISCOVERY_PERIOD,
                 flush_period: float = DEFAULT_FLUSH_PERIOD,
                 on_failure: Callable[[BagWriteError], object] | None = None,
                 node_name: str = 'recorder', **kwargs: Any) -> None:
        if depth < 1 or not discovery_period > 0.0 or not flush_period > 0.0:
            raise ValueError('depth must be >= 1, discovery_period and flush_period > 0, got '
                             f'{depth}, {discovery_period}, {flush_period}')
        super().__init__(node_name, **kwargs)
        try:
            selection = recording.TopicSelection.resolve(self, topics)
            overrides = {self.resolve_topic_name(t): q for t, q in (qos_overrides or {}).items()}
            self._bag = Recording(out_dir, flush_period=flush_period)  # last: no empty bag left behind
        except BaseException:
            Node.destroy_node(self)
            raise
        self._on_failure = on_failure
        self._diagnostics = NodeDiagnostics(self, 'recorder')
        self._topics = recording.TopicRecorder(self, self._bag, selection, overrides, depth, self._diagnostics,
                                               self._fail)
        self._diagnostics.set_value('bag', self._bag.path)
        self._report_counts()
        self._report_timer = self.create_timer(0.5, self._report_counts)
        self._timer = self.create_timer(discovery_period, self.discover)
        self.get_logger().info(f'recording to {self._bag.path}: '
                               f'{", ".join(sorted(selection.names | set(selection.prefixes)))}')
        self.discover()

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._bag.path

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per recorded topic (a new dict)."""
        return self._bag.counts

    @property
    def recorded_topics(self) -> dict[str, tuple[str, QosSpec]]:
        """A copy of the topics in the bag: name -> (message type, QoS subscribed with)."""
        return self._bag.recorded_topics

    @property
    def error(self) -> BagWriteError | None:
        """The write error that stopped the recording, if any."""
        return self._bag.error

    def summary(self) -> str:
        """One line: messages per topic, and the error if the recording failed."""
        return self._bag.summary()

    def discover(self) -> None:
        """Look at the graph: subscribe to new selected topics with a publisher, put topics seen into the bag."""
        if self._bag.error is None and not self._bag.closed:
            self._topics.discover()

    def _report_counts(self) -> None:
        """Copy the writer's counts into the diagnostics (published every second); take up a write error."""
        if self._bag.writer_error is not None and self._bag.error is None:
            self._fail(self._bag.writer_error)
        self._diagnostics.set_values(self._bag.values())

    def _fail(self, exc: BagWriteError) -> None:
        """Stop recording after a write error: report it, unsubscribe, call ``on_failure``."""
        if not self._bag.stop(exc):
            return
        self.get_logger().error(f'recording stopped, nothing more is recorded: {self._bag.located(exc)}')
        self._diagnostics.set_state(ERROR, f'recording stopped: {exc}')
        self._diagnostics.publish()
        self._timer.cancel()
        self._topics.stop(exc)
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
        earlier = self._bag.error
        failure = self._bag.close()
        if failure is not None and earlier is None:
            self.get_logger().error(f'finishing bag {self._bag.path} failed: {failure}')

    def destroy_node(self) -> None:
        """Close the bag, then destroy the node."""
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point: record until SIGINT/SIGTERM (exit 0) or a write error (exit 1).

    ``args`` is a full command line (program name first), like ``sys.argv``, which it defaults to.
    """
    argv = list(sys.argv if args is None else args)
    options = recording.command_line(argv)
    built: list[Recorder] = []

    def build() -> Recorder:
        try:
            recorder = Recorder(**vars(options), on_failure=lambda _exc: rclpy.try_shutdown())  # run_node's context
        except (BagWriteError, ValueError) as exc:  # the bag directory exists already (1), a bad --topics entry (2)
            print(f'recorder: error: {exc}', file=sys.stderr)
            raise SystemExit(1 if isinstance(exc, BagWriteError) else 2) from None
        built.append(recorder)
        return recorder

    run_node(build, argv, shutdown_grace=None)  # closing a bag may take longer: never cut short
    if built:
        print(built[0].summary(), flush=True)
        if built[0].error is not None:
            raise SystemExit(1)


if __name__ == '__main__':
    main()
