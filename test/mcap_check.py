"""The tests' second, independent bag reader: the ``mcap`` + ``mcap_ros2`` libraries.

Without rosbags and without metadata.yaml (what a tool that opens only the .mcap file sees). Test-only: the runtime
never needs mcap (package.xml declares mcap-ros2-support as a test dependency).
"""

from __future__ import annotations

import heapq
from collections.abc import Collection, Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from grasp_intent_ros.sessions.bag import BagReadError

__all__ = ['McapMessage', 'read_messages_mcap']


@dataclass(frozen=True)
class McapMessage:
    """One message as read by the ``mcap`` library, independently of rosbags.

    The fields of :class:`grasp_intent_ros.sessions.bag.BagMessage` under the mcap library's names: the channel
    ``topic``, the ``schema_name`` (the message type, e.g. 'std_msgs/msg/String'), the log (receive) time
    ``log_time_ns`` in ns since the epoch, and instead of the bytes the ``mcap_ros2`` dynamic message object
    ``decoded`` (fields as attributes); the publish (send) time ``publish_time_ns``.
    """

    topic: str
    schema_name: str
    log_time_ns: int
    decoded: Any
    publish_time_ns: int


def read_messages_mcap(
    path: str | Path,
    *,
    topics: Collection[str] | None = None,
) -> Iterator[McapMessage]:
    """Iterate over the messages of a bag's .mcap file(s) in log-time order, with ``mcap``/``mcap_ros2``.

    Independent of rosbags and metadata.yaml: decodes with the schemas stored in the MCAP files.

    Parameters
    ----------
    path
        Bag directory (all ``*.mcap`` in it, merged by log time) or one .mcap file.
    topics
        Only these topics; None for all.

    Yields
    ------
        :class:`McapMessage`, log times non-decreasing.

    Raises
    ------
    BagReadError
        On first iteration, if there is no .mcap file or a file cannot be read/decoded.
    """
    bag_path = Path(path)
    files = sorted(bag_path.glob('*.mcap')) if bag_path.is_dir() else [bag_path]
    if not files or not all(f.is_file() for f in files):
        raise BagReadError(f'no .mcap file at {bag_path}')
    wanted = None if topics is None else list(topics)
    try:
        with ExitStack() as stack:
            streams = [
                _mcap_file_messages(stack.enter_context(f.open('rb')), wanted) for f in files
            ]
            yield from heapq.merge(*streams, key=lambda m: m.log_time_ns)
    except (McapError, OSError) as exc:
        raise BagReadError(f'cannot read MCAP in {bag_path}: {exc}') from exc


def _mcap_file_messages(stream: Any, topics: list[str] | None) -> Iterator[McapMessage]:
    reader = make_reader(stream, decoder_factories=[DecoderFactory()])
    for schema, channel, message, decoded in reader.iter_decoded_messages(topics=topics, log_time_order=True):
        yield McapMessage(channel.topic, schema.name if schema else '', message.log_time, decoded, message.publish_time)
