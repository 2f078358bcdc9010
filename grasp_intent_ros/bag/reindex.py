"""Repair of a session bag whose recorder was killed: what ``ros2 bag reindex`` does, for MCAP.

A recorder that is SIGKILLed (or loses power) leaves an .mcap file without its summary and footer, possibly
ending inside a record, and no metadata.yaml: no reader opens it. :func:`reindex` reads the file's records
in order, keeps every complete chunk (and every complete record outside chunks), stops at the first
truncated or corrupt one, and writes the recovered schemas, channels (topic, type, offered QoS) and
messages, in file order with their log times, as a complete bag with :class:`SessionWriter`: MCAP with
summary and footer, metadata.yaml with the true counts, start and duration.

Files: the repaired bag replaces ``<bag>/<name>.mcap`` (``<name>`` is the directory's name, as the writer
names it) and ``<bag>/metadata.yaml``; the original file is never deleted: it is renamed to
``<original file name>.broken`` in the same directory (readers look at metadata.yaml or ``*.mcap`` only).
The repaired bag is written first into ``<bag>/.reindex/<name>/`` and moved in place only when complete,
so an interrupted repair leaves the original readable by a second repair.
"""

from __future__ import annotations

import os
import shutil
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO, Final

from rosbags.interfaces import MessageDefinitionFormat
from rosbags.rosbag2 import storage_mcap
from rosbags.typesys import Stores, get_typestore

from .errors import BagReadError, BagWriteError
from .qos import decode_qos
from .reader import register_type
from .writer import SessionWriter

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ['ReindexResult', 'reindex', 'BROKEN_SUFFIX']

MAGIC: Final = b'\x89MCAP0\r\n'
BROKEN_SUFFIX: Final = '.broken'
"""Appended to the name of the original .mcap file that :func:`reindex` replaced (kept next to it)."""
_WORK_DIR: Final = '.reindex'
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END = (
    0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F)
_RECORD_HEAD: Final = struct.Struct('<BQ')
_MESSAGE_HEAD: Final = struct.Struct('<HIQQ')  # channel id, sequence, log time, publish time
_CHUNK_HEAD: Final = struct.Struct('<QQQI')  # start, end, uncompressed size, crc
_SCHEMA_FORMATS: Final = {'ros2msg': MessageDefinitionFormat.MSG, 'ros2idl': MessageDefinitionFormat.IDL}


@dataclass(frozen=True)
class ReindexResult:
    """What :func:`reindex` did to one bag.

    Attributes
    ----------
    path
        The bag directory.
    repaired
        False if the bag was complete already (nothing was changed).
    topics
        Messages recovered per topic (every topic recovered, also those with 0 messages).
    chunks
        Complete chunks read.
    discarded_bytes
        Bytes after the last complete record (an unfinished chunk, a cut record): lost.
    stopped
        Why the scan ended: 'end of data', or what was truncated or corrupt and where.
    broken
        Where the original file was kept; None if nothing was repaired.
    """

    path: Path
    repaired: bool
    topics: dict[str, int] = field(default_factory=dict)
    chunks: int = 0
    discarded_bytes: int = 0
    stopped: str = 'end of data'
    broken: Path | None = None

    @property
    def messages(self) -> int:
        """Messages recovered on all topics."""
        return sum(self.topics.values())

    def summary(self) -> str:
        """One line for a user."""
        if not self.repaired:
            return f'{self.path}: complete (MCAP footer and metadata.yaml present), nothing to do'
        return (f'{self.path}: {self.messages} messages on {len(self.topics)} topics recovered from '
                f'{self.chunks} complete chunks; {self.discarded_bytes} bytes discarded ({self.stopped}); '
                f'the original is kept as {self.broken}')


class _Corrupt(Exception):
    """A complete record whose contents cannot be parsed."""


@dataclass(frozen=True)
class _Schema:
    id: int
    name: str
    encoding: str
    data: str


@dataclass(frozen=True)
class _Channel:
    id: int
    topic: str
    schema_id: int
    metadata: bytes


@dataclass(frozen=True)
class _Message:
    channel_id: int
    log_time: int
    data: bytes


_Record = tuple[int, bytes]  # opcode, content


def _string(bio: BytesIO) -> str:
    return _sized(bio, 4).decode()


def _sized(bio: BytesIO, width: int) -> bytes:
    raw = bio.read(width)
    if len(raw) != width:
        raise _Corrupt('field cut short')
    size = int.from_bytes(raw, 'little')
    data = bio.read(size)
    if len(data) != size:
        raise _Corrupt('field longer than its record')
    return data


def _records(stream: BinaryIO | BytesIO, end: int | None = None) -> Iterator[tuple[int, int, bytes]]:
    """(offset, opcode, content) of each complete record until ``end`` or the end of the data.

    Stops silently at a truncated record (the caller compares offsets to know).
    """
    while end is None or stream.tell() < end:
        offset = stream.tell()
        head = stream.read(_RECORD_HEAD.size)
        if len(head) < _RECORD_HEAD.size:
            stream.seek(offset)
            return
        opcode, length = _RECORD_HEAD.unpack(head)
        content = stream.read(length) if length <= 1 << 40 else b''
        if len(content) != length:
            stream.seek(offset)
            return
        yield offset, opcode, content


def _chunk_records(content: bytes) -> list[_Record]:
    """The records inside a chunk record's content. Raises _Corrupt."""
    if len(content) < _CHUNK_HEAD.size:
        raise _Corrupt('chunk header cut short')
    bio = BytesIO(content)
    _, _, size, crc = _CHUNK_HEAD.unpack(bio.read(_CHUNK_HEAD.size))
    compression = _string(bio)
    compressed = _sized(bio, 8)
    try:
        raw = storage_mcap.decompress(compressed, compression, size, crc)
    except Exception as exc:  # noqa: BLE001 - ReaderError, or the zstd/lz4 library's own error type
        raise _Corrupt(f'chunk cannot be decompressed: {type(exc).__name__}: {exc}') from None
    inner = BytesIO(raw)
    records = [(opcode, data) for _, opcode, data in _records(inner, len(raw))]
    if inner.tell() != len(raw):
        raise _Corrupt('chunk ends inside a record')
    return records


def _is_complete(mcap: Path, metadata: Path) -> bool:
    if not metadata.is_file():
        return False
    with mcap.open('rb') as stream:
        stream.seek(0, os.SEEK_END)
        if stream.tell() < 2 * len(MAGIC):
            return False
        stream.seek(-len(MAGIC), os.SEEK_END)
        return stream.read() == MAGIC


def _storage_file(bag: Path) -> Path:
    if not bag.is_dir():
        raise BagReadError(f'cannot reindex {bag}: not a directory')
    files = sorted(p for p in bag.glob('*.mcap') if p.is_file())
    if len(files) != 1:
        found = ', '.join(p.name for p in files) or 'none'
        originals = sorted(p.name for p in bag.glob(f'*.mcap{BROKEN_SUFFIX}'))
        hint = (f' ({", ".join(originals)}: the original of an interrupted repair? rename it back to '
                'repair again)' if originals and not files else '')
        raise BagReadError(f'cannot reindex {bag}: expected one .mcap file, found {found}{hint}')
    return files[0]


class _Rebuilder:
    """Feeds the records of the broken file to a new SessionWriter."""

    def __init__(self, writer: SessionWriter, typestore: Typestore, bag: Path) -> None:
        self.writer = writer
        self.typestore = typestore
        self.bag = bag
        self.schemas: dict[int, _Schema] = {}
        self.topics: dict[int, str] = {}  # channel id -> topic written
        self.counts: dict[str, int] = {}

    @staticmethod
    def parse(opcode: int, content: bytes) -> _Schema | _Channel | _Message | None:
        """A schema, channel or message record, parsed (not yet applied); None for other records."""
        bio = BytesIO(content)
        if opcode in (_OP_SCHEMA, _OP_CHANNEL):
            head = bio.read(2)
            if len(head) != 2:
                raise _Corrupt('record cut short')
            record_id = int.from_bytes(head, 'little')
            if opcode == _OP_SCHEMA:
                return _Schema(record_id, _string(bio), _string(bio), _sized(bio, 4).decode())
            schema_id = int.from_bytes(bio.read(2), 'little')
            topic, _encoding = _string(bio), _string(bio)
            return _Channel(record_id, topic, schema_id, _sized(bio, 4))
        if opcode == _OP_MESSAGE:
            if len(content) < _MESSAGE_HEAD.size:
                raise _Corrupt('message record cut short')
            channel_id, _, log_time, _ = _MESSAGE_HEAD.unpack_from(content)
            return _Message(channel_id, log_time, content[_MESSAGE_HEAD.size:])
        return None

    def apply(self, record: _Schema | _Channel | _Message) -> None:
        """Write a parsed record to the new bag. Raises _Corrupt for a record that contradicts the file."""
        if isinstance(record, _Schema):
            self.schemas[record.id] = record
        elif isinstance(record, _Channel):
            self._add_channel(record)
        else:
            topic = self.topics.get(record.channel_id)
            if topic is None:
                raise _Corrupt(f'message on channel {record.channel_id}, which no earlier record defines')
            self.writer.write(topic, record.log_time, record.data)
            self.counts[topic] += 1

    def _add_channel(self, channel: _Channel) -> None:
        if channel.id in self.topics:
            return
        schema = self.schemas.get(channel.schema_id)
        if schema is None:
            raise _Corrupt(f'channel {channel.topic!r} refers to schema {channel.schema_id}, which is not defined')
        if schema.name not in self.typestore.fielddefs:
            fmt = _SCHEMA_FORMATS.get(schema.encoding, MessageDefinitionFormat.NONE)
            register_type(self.typestore, schema.name, fmt, schema.data, self.bag)
        try:
            qos = [decode_qos(q) for q in storage_mcap.get_qos(channel.metadata)]
        except (BagReadError, ValueError, KeyError, TypeError) as exc:
            raise _Corrupt(f'offered QoS of {channel.topic!r} unreadable: {exc}') from None
        self.writer.add_topic(channel.topic, schema.name, qos=qos)
        self.topics[channel.id] = channel.topic
        self.counts[channel.topic] = 0


def reindex(path: str | os.PathLike[str], *, typestore: Typestore | None = None) -> ReindexResult:
    """Make a bag left by a killed recorder complete again; see the module docstring.

    Parameters
    ----------
    path
        Bag directory holding one .mcap file (metadata.yaml may be missing).
    typestore
        Message types (default ROS 2 Jazzy); a type it lacks is taken from the file's ros2msg schema.

    Returns
    -------
        :class:`ReindexResult`; ``repaired`` is False (and nothing changed) when the .mcap file ends with
        the MCAP magic and metadata.yaml exists.

    Raises
    ------
    BagReadError
        Not a directory with exactly one .mcap file; the file does not start with the MCAP magic and
        a complete header; ``<file>.broken`` exists already (a previous repair's original: move it first).
    BagWriteError
        The repaired bag cannot be written (e.g. disk full); the original is then left untouched.
    """
    bag = Path(path)
    mcap = _storage_file(bag)
    metadata = bag / 'metadata.yaml'
    if _is_complete(mcap, metadata):
        return ReindexResult(bag, repaired=False)
    broken = mcap.with_name(mcap.name + BROKEN_SUFFIX)
    if broken.exists():
        raise BagReadError(f'cannot reindex {bag}: {broken} exists (the original of an earlier repair?); '
                           'move it away first')
    work = bag / _WORK_DIR
    store = typestore if typestore is not None else get_typestore(Stores.ROS2_JAZZY)
    with mcap.open('rb') as stream:
        if stream.read(len(MAGIC)) != MAGIC:
            raise BagReadError(f'cannot reindex {bag}: {mcap.name} does not start with the MCAP magic')
        first = next(_records(stream), None)
        if first is None or first[1] != _OP_HEADER:
            raise BagReadError(f'cannot reindex {bag}: {mcap.name} has no complete MCAP header record')
        shutil.rmtree(work, ignore_errors=True)  # an interrupted earlier repair's leftovers: ours
        try:
            with SessionWriter(work / bag.name, typestore=store, flush_period=None) as writer:
                result = _rebuild(stream, _Rebuilder(writer, store, bag), bag)
        except BagWriteError:
            shutil.rmtree(work, ignore_errors=True)
            raise
    repaired_dir = work / bag.name
    mcap.rename(broken)
    (repaired_dir / f'{bag.name}.mcap').replace(bag / f'{bag.name}.mcap')
    (repaired_dir / 'metadata.yaml').replace(metadata)
    shutil.rmtree(work, ignore_errors=True)
    return ReindexResult(bag, True, result.topics, result.chunks, result.discarded_bytes, result.stopped, broken)


def _rebuild(stream: BinaryIO, rebuilder: _Rebuilder, bag: Path) -> ReindexResult:
    """Apply every complete record after the header; the counts and why it stopped."""
    chunks, stopped = 0, ''
    for offset, opcode, content in _records(stream):
        if opcode in (_OP_DATA_END, _OP_FOOTER):
            stopped = 'end of data'
            break
        try:
            if opcode == _OP_CHUNK:
                parsed = [rebuilder.parse(op, data) for op, data in _chunk_records(content)]
            else:
                parsed = [rebuilder.parse(opcode, content)]
            for record in parsed:
                if record is not None:
                    rebuilder.apply(record)
        except _Corrupt as exc:
            stream.seek(offset)
            stopped = f'corrupt record (opcode 0x{opcode:02x}) at byte {offset}: {exc}'
            break
        except UnicodeDecodeError:
            stream.seek(offset)
            stopped = f'corrupt record (opcode 0x{opcode:02x}) at byte {offset}: a string is not UTF-8'
            break
        chunks += opcode == _OP_CHUNK
    end = stream.tell()
    stream.seek(0, os.SEEK_END)
    size = stream.tell()
    if stopped == 'end of data':  # the rest is the summary section and footer: no data lost
        return ReindexResult(bag, True, dict(rebuilder.counts), chunks, 0, stopped)
    if not stopped:
        stopped = 'end of file' if end == size else f'record cut short at byte {end}'
    return ReindexResult(bag, True, dict(rebuilder.counts), chunks, size - end, stopped)
