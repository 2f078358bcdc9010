"""Writing a session to a rosbag2 directory as rosbag2 in ROS 2 Jazzy writes one.

metadata.yaml v9, MCAP storage, CDR messages.

rosbags writes the rosbag2 layout; two details differ from what ``ros2 bag record`` on Jazzy writes and
are set here as rosbag2 does (ros2/rosbag2, jazzy):

- ``ros_distro``: rosbag2 stores ``$ROS_DISTRO`` in metadata.yaml and in the MCAP ``rosbag2`` metadata
  record; rosbags stores 'rosbags'. These bags hold ROS 2 Jazzy types: ``jazzy``.
- MCAP channel metadata: rosbag2_storage_mcap's ``create_topic`` writes two entries per channel,
  ``offered_qos_profiles`` (the YAML list of profiles) and ``topic_type_hash`` (the RIHS01 type hash), so
  a reader of the .mcap alone sees the type hashes; rosbags writes only the first.
- A message's two times: rosbag2 (Jazzy) writes the receive time as the MCAP record's ``log_time`` and the
  publisher's send time (the middleware's source timestamp, its ``send_timestamp``) as its ``publish_time``, the
  receive time when the middleware gives none; rosbags writes the receive time in both.

Crash safety, as rosbag2's MCAP storage has it: rosbags closes a chunk only when it exceeds 1 MiB and keeps
even the file header in Python's buffer. Here the header is flushed when the bag is created, every closed
chunk is pushed to the operating system at once, and a chunk is closed when its first message is
``flush_period`` seconds old (:meth:`SessionWriter.write`, :meth:`SessionWriter.flush_if_due`). A killed
process then loses at most the last ``flush_period`` seconds; :func:`~grasp_intent_ros.sessions.bag.reindex` makes
the rest a complete bag again.
"""

from __future__ import annotations

import operator
import os
import re
import struct
import threading
import time
from collections.abc import Sequence
from contextlib import suppress
from io import BytesIO
from pathlib import Path
from typing import TYPE_CHECKING, Final, Literal, cast

from rosbags.interfaces import ConnectionExtRosbag2
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError, storage_mcap
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.serde import SerdeError
from rosbags.typesys import TypesysError

from .errors import BagWriteError
from .offered_qos import QosSpec, encode_qos
from .types import jazzy_typestore

if TYPE_CHECKING:
    from collections.abc import Mapping
    from types import TracebackType

    from rosbags.interfaces import Connection
    from rosbags.typesys.store import Typestore

__all__ = ['SessionWriter', 'ROS_DISTRO', 'DEFAULT_FLUSH_PERIOD']

_MAX_TIMESTAMP_NS: Final = 2**63 - 1
ROS_DISTRO: Final = 'jazzy'
"""``ros_distro`` of the bags written here (their message types are ROS 2 Jazzy's)."""
DEFAULT_FLUSH_PERIOD: Final = 1.0
"""Seconds after which a recorded message is on disk (its chunk closed and handed to the operating system)."""
_ROSBAGS_DISTRO_LINE: Final = re.compile(r'^(\s*ros_distro:) rosbags$', re.MULTILINE)


def _set_ros_distro(metadata_yaml: str) -> str:
    """The metadata YAML with ``ros_distro: jazzy`` in place of rosbags' ``ros_distro: rosbags``."""
    text, count = _ROSBAGS_DISTRO_LINE.subn(rf'\1 {ROS_DISTRO}', metadata_yaml)
    if count != 1:
        msg = f'expected one "ros_distro: rosbags" line in the metadata rosbags wrote, found {count}'
        raise WriterError(msg)
    return text


class _McapStorage(storage_mcap.McapWriter):
    """rosbags' MCAP storage with the channel metadata and ros_distro of rosbag2's (Jazzy), flushed.

    The header is in the file once the storage exists, and every closed chunk is handed to the operating
    system at once (a SIGKILL then loses no closed chunk). :attr:`open_since` is the monotonic time (s) of
    the first message of the open chunk, None while it holds none.
    """

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        super().__init__(path, compression)
        self.open_since: float | None = None
        self.publish_time: int | None = None
        """The next message's publish time (ns), set by its writer just before; None: its log time."""
        self.bio.flush()

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        """Write as rosbags' ``McapWriter.write`` does (the index by log time), with :attr:`publish_time`."""
        if self.open_since is None:
            self.open_since = time.monotonic()
        self.message_start_time = min(timestamp, self.message_start_time)
        self.message_end_time = max(timestamp, self.message_end_time)
        self.channel_stats[connection.id] += 1
        self.chunk.message_start_time = min(timestamp, self.chunk.message_start_time)
        self.chunk.message_end_time = max(timestamp, self.chunk.message_end_time)
        self.chunk.msgs[connection.id].append((timestamp, self.chunk.bio.tell()))
        rec = BytesIO()
        storage_mcap.write_uint16(rec, connection.id)
        storage_mcap.write_uint32(rec, 0)
        storage_mcap.write_uint64(rec, timestamp)
        storage_mcap.write_uint64(rec, timestamp if self.publish_time is None else self.publish_time)
        rec.write(data)
        storage_mcap.write_record(self.chunk.bio, 0x05, rec)
        if self.chunk.bio.tell() > 2**20:
            self.close_chunk()

    def close_chunk(self) -> None:
        super().close_chunk()
        self.open_since = None
        self.bio.flush()

    def flush(self) -> None:
        """Close the open chunk if it holds a message, and hand the file's buffer to the operating system."""
        if self.open_since is not None:
            self.close_chunk()
        self.bio.flush()

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        metadata = BytesIO()
        for key, value in (('offered_qos_profiles', offered_qos_profiles), ('topic_type_hash', connection.digest)):
            storage_mcap.write_string(metadata, key)
            storage_mcap.write_string(metadata, value)
        ext = cast('ConnectionExtRosbag2', connection.ext)
        self.channels.append(storage_mcap.Channel(connection.id, connection.msgtype, connection.topic,
                                                  ext.serialization_format, metadata.getvalue()))
        self.channel_stats[connection.id] = 0
        storage_mcap.write_channel(self.chunk.bio, self.channels[-1], self.schemas)

    def close(self, version: int, metadata: str) -> None:
        super().close(version, _set_ros_distro(metadata))


class _Writer(Writer):
    """rosbags' rosbag2 writer with :class:`_McapStorage` and ``ros_distro: jazzy`` in metadata.yaml."""

    STORAGE_PLUGINS: Mapping[StoragePlugin, type[storage_mcap.McapWriter]] = {
        StoragePlugin.MCAP: _McapStorage,
    }

    def close(self) -> None:
        super().close()
        self.metapath.write_text(_set_ros_distro(self.metapath.read_text('utf8')), 'utf8')


class SessionWriter:
    """Write one recording session as a rosbag2 directory that ``ros2 bag info/play`` (Jazzy) reads.

    The bag is created when the writer is constructed and finished (MCAP summary, then metadata.yaml)
    by :meth:`close`, which the context manager always calls, also when the ``with`` body raises, so
    that what was recorded before an error stays readable. Writes are serialised by a lock, so one
    writer can be fed from several executor threads.

    Parameters
    ----------
    path
        Bag directory to create; it must not exist. Its parent directories are created.
    typestore
        Message types used for schemas and :meth:`write_message`; default: ROS 2 Jazzy.
    compress
        Compress the MCAP chunks with zstd (MCAP's own storage-level compression, which
        ``ros2 bag`` and the ``mcap`` reader decode transparently); default True.
    flush_period
        Seconds after which a chunk's first message is on disk: :meth:`write` and
        :meth:`flush_if_due` close the open chunk (and hand it to the operating system) once its
        first message is that old. Default 1.0; None closes chunks by size (1 MiB) only.

    Raises
    ------
    BagWriteError
        ``path`` exists, or the directory/storage file cannot be created.
    ValueError
        ``flush_period`` is not None and not positive.

    Example:
        >>> with SessionWriter(tmp / 'session') as bag:  # doctest: +SKIP
        ...     bag.add_topic('/intent', 'std_msgs/msg/Float64MultiArray', qos=QosSpec())
        ...     bag.write('/intent', stamp_ns, cdr_bytes)
    """

    def __init__(self, path: str | os.PathLike[str], *, typestore: Typestore | None = None,
                 compress: bool = True, flush_period: float | None = DEFAULT_FLUSH_PERIOD) -> None:
        if flush_period is not None and not flush_period > 0.0:
            raise ValueError(f'flush_period must be None or > 0 s, got {flush_period!r}')
        self._flush_period = flush_period
        self._path = Path(path)
        self._typestore = typestore if typestore is not None else jazzy_typestore()
        self._lock = threading.Lock()
        self._connections: dict[str, Connection] = {}
        self._count = 0
        self._closed = True
        if self._path.exists():
            msg = f'cannot write bag {self._path}: it exists already (a session bag is never overwritten)'
            raise BagWriteError(msg, path=self._path)
        try:
            self._writer = _Writer(self._path, version=9, storage_plugin=StoragePlugin.MCAP)
            if compress:
                self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
            self._writer.open()
        except WriterError as exc:
            raise BagWriteError(f'cannot write bag {self._path}: {exc}', path=self._path) from exc
        except OSError as exc:
            msg = f'cannot create bag {self._path}: {exc.strerror or exc}'
            raise BagWriteError(msg, path=self._path) from exc
        self._closed = False

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._path

    @property
    def message_count(self) -> int:
        """Messages written so far (all topics)."""
        return self._count

    @property
    def closed(self) -> bool:
        """True once :meth:`close` ran or a write failed."""
        return self._closed

    @property
    def seconds_to_flush(self) -> float | None:
        """Seconds until the open chunk is due (<= 0: due now); None if it holds no message or no period."""
        storage = self._storage
        if self._flush_period is None or storage is None or storage.open_since is None:
            return None
        return storage.open_since + self._flush_period - time.monotonic()

    @property
    def topics(self) -> dict[str, str]:
        """A copy of the added topics: topic name -> message type."""
        return {topic: conn.msgtype for topic, conn in self._connections.items()}

    def add_topic(self, topic: str, msgtype: str, *, qos: QosSpec | Sequence[QosSpec]) -> None:
        """Declare a topic before writing to it.

        Parameters
        ----------
        topic
            Fully qualified topic name, e.g. '/grasp_intent/intent'.
        msgtype
            Message type in the typestore, e.g. 'std_msgs/msg/Float64MultiArray'.
        qos
            The QoS each publisher offered (one spec, or one per publisher, as ``ros2 bag
            record`` stores them); stored as the topic's ``offered_qos_profiles``.

        Raises
        ------
        BagWriteError
            Writer closed, topic malformed or already added, msgtype unknown.
        """
        with self._lock:
            self._check_open()
            if not isinstance(topic, str) or not topic.startswith('/'):
                raise self._error(f'topic must be a fully qualified name starting with "/", got {topic!r}')
            if topic in self._connections:
                raise self._error(f'topic {topic!r} was already added')
            if msgtype not in self._typestore.fielddefs:
                raise self._error(f'message type {msgtype!r} of topic {topic!r} is not in the typestore')
            profiles = (qos,) if isinstance(qos, QosSpec) else tuple(qos)
            if not all(isinstance(q, QosSpec) for q in profiles):
                raise self._error(f'qos must be a QosSpec or a sequence of them, got {qos!r}')
            try:
                conn = self._writer.add_connection(
                    topic,
                    msgtype,
                    typestore=self._typestore,
                    offered_qos_profiles=[encode_qos(q) for q in profiles],
                )
            except (WriterError, TypesysError) as exc:
                raise self._error(f'cannot add topic {topic!r}: {exc}') from exc
            self._connections[topic] = conn

    def write(self, topic: str, timestamp_ns: int, cdr: bytes | memoryview, publish_ns: int | None = None) -> None:
        """Write one already serialized message (CDR with its 4-byte encapsulation header).

        Parameters
        ----------
        topic
            A topic given to :meth:`add_topic`.
        timestamp_ns
            Receive time, ns since the epoch, in [0, 2**63).
        cdr
            The serialized message, e.g. from an rclpy subscription with ``raw=True``.
        publish_ns
            Send time (the publisher's source timestamp), ns since the epoch, in [0, 2**63); None: the receive
            time (the module docstring: a message's two times).

        Raises
        ------
        BagWriteError
            Writer closed, topic unknown, bad timestamp or data, or an OS error
            (e.g. ENOSPC); after an OS error the writer is closed and the bag is incomplete.
        """
        with self._lock:
            self._write_locked(topic, timestamp_ns, cdr, publish_ns)

    def write_message(self, topic: str, timestamp_ns: int, msg: object) -> None:
        """Serialize a rosbags message object of the topic's type to CDR and write it.

        Raises
        ------
        BagWriteError
            As :meth:`write`, or the message is not of the topic's type or cannot be
            serialized (e.g. a primitive array that is not a numpy array).
        """
        with self._lock:
            self._check_open()
            conn = self._connection(topic)
            msgtype = getattr(msg, '__msgtype__', None)
            if msgtype != conn.msgtype:
                raise self._error(
                    f'topic {topic!r} carries {conn.msgtype!r}, got a message of type {msgtype!r}'
                )
            try:
                cdr = self._typestore.serialize_cdr(msg, conn.msgtype, little_endian=True)
            except (SerdeError, TypesysError, struct.error, AttributeError, TypeError, ValueError) as exc:
                raise self._error(f'cannot serialize {conn.msgtype!r} for topic {topic!r}: {exc}') from exc
            self._write_locked(topic, timestamp_ns, cdr)

    def flush(self) -> None:
        """Close the open chunk (if it holds a message) and hand everything written to the operating system.

        What was flushed survives a SIGKILL of this process (not a power loss: no fsync); a bag left
        without its summary by a kill is made whole by :func:`~grasp_intent_ros.sessions.bag.reindex`.

        Raises
        ------
        BagWriteError
            The writer is closed, or an OS error (e.g. ENOSPC); after an OS error the writer is closed.
        """
        with self._lock:
            self._flush_locked()

    def flush_if_due(self) -> bool:
        """:meth:`flush` if the open chunk's first message is ``flush_period`` s old; whether it flushed.

        Raises
        ------
        BagWriteError
            As :meth:`flush`.
        """
        with self._lock:
            due = self.seconds_to_flush
            if due is None or due > 0.0:
                return False
            self._flush_locked()
            return True

    def close(self) -> None:
        """Finish the bag: write the MCAP summary and metadata.yaml. Idempotent.

        Raises
        ------
        BagWriteError
            An OS error while finishing (e.g. ENOSPC); the bag is then incomplete.
        """
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._writer.close()
            except OSError as exc:
                raise self._failed('closing', exc) from exc
            except WriterError as exc:
                raise self._error(f'closing bag {self._path} failed: {exc}') from exc

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc_val: BaseException | None,
        exc_tb: TracebackType | None,
    ) -> Literal[False]:
        self.close()
        return False

    def __repr__(self) -> str:
        state = 'closed' if self._closed else 'open'
        return (
            f'SessionWriter({str(self._path)!r}, {state}, '
            f'{len(self._connections)} topics, {self._count} messages)'
        )

    def _write_locked(self, topic: str, timestamp_ns: int, cdr: bytes | memoryview,
                      publish_ns: int | None = None) -> None:
        self._check_open()
        conn = self._connection(topic)
        stamp = self._nanoseconds('timestamp_ns', timestamp_ns)
        published = None if publish_ns is None else self._nanoseconds('publish_ns', publish_ns)
        if not isinstance(cdr, (bytes, memoryview)) or len(cdr) < 4:
            raise self._error(f'cdr must be serialized bytes with a 4-byte encapsulation header on {topic!r}')
        storage = self._storage
        try:
            if storage is not None:
                storage.publish_time = published
            self._writer.write(conn, stamp, cdr)
        except OSError as exc:
            raise self._failed('writing', exc) from exc
        finally:
            if storage is not None:
                storage.publish_time = None
        self._count += 1
        due = self.seconds_to_flush
        if due is not None and due <= 0.0:
            self._flush_locked()

    def _nanoseconds(self, name: str, value: object) -> int:
        """``value`` as an integer time in [0, 2**63) ns; a :class:`BagWriteError` naming ``name`` otherwise."""
        try:
            stamp = operator.index(value)  # type: ignore[arg-type]
        except TypeError:
            raise self._error(f'{name} must be an integer (ns), got {value!r}') from None
        if not 0 <= stamp <= _MAX_TIMESTAMP_NS:
            raise self._error(f'{name} must be in [0, 2**63), got {stamp}')
        return stamp

    def _flush_locked(self) -> None:
        self._check_open()
        storage = self._storage
        assert storage is not None  # open
        try:
            storage.flush()
        except OSError as exc:
            raise self._failed('flushing', exc) from exc

    @property
    def _storage(self) -> _McapStorage | None:
        return cast('_McapStorage | None', self._writer.storage)

    def _connection(self, topic: str) -> Connection:
        try:
            return self._connections[topic]
        except KeyError:
            raise self._error(f'topic {topic!r} was not added (call add_topic first)') from None

    def _check_open(self) -> None:
        if self._closed:
            raise self._error(f'writer for bag {self._path} is closed')

    def _error(self, msg: str) -> BagWriteError:
        return BagWriteError(msg, path=self._path, messages_written=self._count)

    def _failed(self, action: str, exc: OSError) -> BagWriteError:
        """Abort the storage after an OS error and describe what was lost."""
        self._closed = True
        with suppress(Exception):
            self._writer.abort()
        msg = (
            f'{action} bag {self._path} failed: {exc.strerror or exc} (errno {exc.errno}); '
            f'{self._count} messages had been written; the bag is incomplete (no MCAP summary, '
            'no metadata.yaml) and messages still buffered in the open chunk are lost'
        )
        return self._error(msg)
