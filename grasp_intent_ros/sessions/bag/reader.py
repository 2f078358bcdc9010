"""Reading session bags with rosbags (metadata.yaml, topics, types), their MCAP messages with mcap (both times)."""

from __future__ import annotations

import heapq
import os
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import TYPE_CHECKING

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from rosbags.interfaces import ConnectionExtRosbag2, MessageDefinitionFormat
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.serde import SerdeError
from rosbags.typesys import TypesysError, get_types_from_msg

from .errors import BagReadError
from .offered_qos import QosSpec, decode_qos
from .types import jazzy_typestore

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.typesys.store import Typestore

__all__ = [
    'BagMessage',
    'TopicInfo',
    'read_messages',
    'register_type',
    'topics_info',
]


@dataclass(frozen=True)
class BagMessage:
    """One message as stored: its topic, type, receive time and CDR bytes.

    Attributes
    ----------
    topic
        Topic name.
    msgtype
        Message type, e.g. 'geometry_msgs/msg/PoseStamped'.
    timestamp_ns
        Receive (log) time, ns since the epoch.
    cdr
        Serialized message, CDR with encapsulation header.
    publish_ns
        Send time (the MCAP record's publish time: the publisher's source timestamp in a bag the recorder or
        ``ros2 bag record`` on Jazzy wrote; the receive time where the recorder had none), ns since the epoch.
    """

    topic: str
    msgtype: str
    timestamp_ns: int
    cdr: bytes
    _typestore: Typestore = field(repr=False, compare=False)
    publish_ns: int

    def decode(self) -> object:
        """Deserialize :attr:`cdr` into a rosbags message object (decoded anew on each call).

        Raises
        ------
        BagReadError
            The bytes are not a valid ``msgtype`` message.
        """
        try:
            return self._typestore.deserialize_cdr(self.cdr, self.msgtype)
        except (SerdeError, TypesysError, KeyError) as exc:
            msg = f'cannot decode {self.msgtype!r} on {self.topic!r} at {self.timestamp_ns} ns: {exc}'
            raise BagReadError(msg) from exc


@dataclass(frozen=True)
class TopicInfo:
    """What a bag holds on one topic.

    Its message type ``msgtype``, the ``count`` of messages, and the offered ``qos`` profiles recorded for
    it (one per recorded publisher).
    """

    msgtype: str
    count: int
    qos: tuple[QosSpec, ...]


def read_messages(
    path: str | os.PathLike[str],
    *,
    topics: Collection[str] | None = None,
    typestore: Typestore | None = None,
) -> Iterator[BagMessage]:
    """Iterate over a rosbag2 bag's messages in receive-time order (ties in the file's order), with both times.

    The bag's topics and types are read with rosbags; the messages of the MCAP files its metadata.yaml lists with
    mcap (rosbags reads no publish time). Another storage's messages, or those of compressed files, are read with
    rosbags, their publish time the receive time.

    Parameters
    ----------
    path
        Bag directory (with metadata.yaml).
    topics
        Only these topics; None for all.
    typestore
        Types for :meth:`BagMessage.decode`; default ROS 2 Jazzy, extended with any type
        the bag defines that the store lacks.

    Yields
    ------
        :class:`BagMessage`, timestamps non-decreasing.

    Raises
    ------
    BagReadError
        On first iteration, if the bag is missing/malformed or a topic is not in it.
    """
    bag_path = Path(path)
    store = typestore if typestore is not None else jazzy_typestore()
    try:
        with Reader(bag_path) as reader:
            conns = _select(reader.connections, topics, bag_path)
            _register_missing_types(store, conns, bag_path)
            mcap_files = _mcap_files(bag_path)
            if mcap_files is None:
                for conn, stamp, data in reader.messages(connections=conns):
                    yield BagMessage(conn.topic, conn.msgtype, stamp, bytes(data), store, stamp)
                return
            types = {conn.topic: conn.msgtype for conn in conns}
            files = [_mcap_messages(file, types, store) for file in mcap_files]
            yield from heapq.merge(*files, key=lambda message: message.timestamp_ns)
    except (ReaderError, McapError, OSError) as exc:
        raise BagReadError(f'cannot read bag {bag_path}: {exc}') from exc


def _mcap_files(bag_path: Path) -> list[Path] | None:
    """The MCAP files of the bag directory ``bag_path``, in the order its metadata.yaml lists them.

    Each listed path is taken by its file name inside the bag directory (as rosbags opens them: older rosbag2
    listed paths with the bag's own directory in front). None when the messages are not in plain MCAP files:
    another storage (sqlite3), or compressed files (``compression_mode`` 'file' or 'message').

    Raises
    ------
    BagReadError
        metadata.yaml does not parse, lacks ``rosbag2_bagfile_information``'s ``storage_identifier`` or
        ``relative_file_paths``, or lists a file the directory does not hold.
    """
    metadata = bag_path / 'metadata.yaml'
    try:
        info = yaml.safe_load(metadata.read_text(encoding='utf-8'))['rosbag2_bagfile_information']
        storage, listed = info['storage_identifier'], info['relative_file_paths']
        compression = str(info.get('compression_mode') or 'none').lower()
        names = [PurePath(str(name)).name for name in listed]
    except (yaml.YAMLError, KeyError, TypeError, AttributeError, UnicodeDecodeError) as exc:
        raise BagReadError(f'bag {bag_path}: {metadata.name} lists no storage and files: {exc!r}') from exc
    if storage != 'mcap' or compression != 'none':
        return None
    files = [bag_path / name for name in names]
    if missing := [file.name for file in files if not file.is_file()]:
        raise BagReadError(f'bag {bag_path}: {metadata.name} lists {missing}, which the directory does not hold')
    return files


def _mcap_messages(path: Path, types: dict[str, str], store: Typestore) -> Iterator[BagMessage]:
    """The messages on the topics of ``types`` (topic -> message type) of one MCAP file, by log time, then position."""
    with path.open('rb') as stream:
        for _, channel, message in make_reader(stream).iter_messages(topics=list(types), log_time_order=True):
            yield BagMessage(channel.topic, types[channel.topic], message.log_time, bytes(message.data), store,
                             message.publish_time)


def topics_info(path: str | os.PathLike[str]) -> dict[str, TopicInfo]:
    """Summarise a rosbag2 bag per topic: type, message count, offered QoS.

    Raises
    ------
    BagReadError
        The bag is missing/malformed, a topic has two types, or a recorded QoS has a
        reliability/durability outside :class:`QosSpec`.
    """
    bag_path = Path(path)
    try:
        with Reader(bag_path) as reader:
            conns = list(reader.connections)
    except (ReaderError, OSError) as exc:
        raise BagReadError(f'cannot read bag {bag_path}: {exc}') from exc
    infos: dict[str, TopicInfo] = {}
    for conn in conns:
        qos = conn.ext.offered_qos_profiles if isinstance(conn.ext, ConnectionExtRosbag2) else []
        try:
            specs = tuple(decode_qos(q) for q in qos)
        except BagReadError as exc:
            raise BagReadError(f'bag {bag_path}, topic {conn.topic!r}: {exc}') from exc
        if (seen := infos.get(conn.topic)) is not None:
            if seen.msgtype != conn.msgtype:
                msg = (
                    f'bag {bag_path}: topic {conn.topic!r} has two types, '
                    f'{seen.msgtype!r} and {conn.msgtype!r}'
                )
                raise BagReadError(msg)
            infos[conn.topic] = TopicInfo(seen.msgtype, seen.count + conn.msgcount, seen.qos + specs)
        else:
            infos[conn.topic] = TopicInfo(conn.msgtype, conn.msgcount, specs)
    return infos


def _select(conns: list[Connection], topics: Collection[str] | None, bag_path: Path) -> list[Connection]:
    if topics is None:
        return list(conns)
    wanted = set(topics)
    if missing := wanted - {c.topic for c in conns}:
        raise BagReadError(f'bag {bag_path} has no topic(s) {sorted(missing)}')
    return [c for c in conns if c.topic in wanted]


def _register_missing_types(store: Typestore, conns: list[Connection], bag_path: Path) -> None:
    """Add to ``store`` the bag's own definitions of message types it lacks."""
    for conn in conns:
        if conn.msgtype not in store.fielddefs:
            register_type(store, conn.msgtype, conn.msgdef.format, conn.msgdef.data, bag_path)


def register_type(store: Typestore, msgtype: str, fmt: MessageDefinitionFormat, definition: str,
                  bag_path: Path) -> None:
    """Add ``msgtype`` to ``store`` from a bag's own definition of it (.msg format, dependencies included).

    Raises
    ------
    BagReadError
        The definition is not in .msg format or does not parse.
    """
    if fmt != MessageDefinitionFormat.MSG:
        raise BagReadError(f'bag {bag_path}: type {msgtype!r} is unknown and has no .msg definition')
    try:
        store.register(get_types_from_msg(definition, msgtype))
    except TypesysError as exc:
        raise BagReadError(f'bag {bag_path}: cannot register type {msgtype!r}: {exc}') from exc
