"""Repair of a session bag whose recorder was killed: what ``ros2 bag reindex`` does, for MCAP.

A recorder that is SIGKILLed (or loses power) leaves an .mcap file without its summary and footer, possibly
ending inside a record, and no metadata.yaml: no reader opens it. :func:`reindex` reads the file's records
in order with mcap's ``StreamReader`` (which reads a cut file up to the cut), keeps every complete chunk
(decompressed and CRC-checked whole before any of its messages is kept) and every complete record outside
chunks, stops at the first truncated or corrupt one, and writes the recovered schemas, channels (topic,
type, offered QoS) and messages, in file order with their log times, as a complete bag with
:class:`SessionWriter`: MCAP with summary and footer, metadata.yaml with the true counts, start and duration.

Files: the repaired bag replaces ``<bag>/<name>.mcap`` (``<name>`` is the directory's name, as the writer
names it) and ``<bag>/metadata.yaml``; the original file is never deleted: it is renamed to
``<original file name>.broken`` in the same directory (readers look at metadata.yaml or ``*.mcap`` only).
The repaired bag is written first into ``<bag>/.reindex/<name>/`` and moved in place only when complete,
so an interrupted repair leaves the original readable by a second repair.
"""

from __future__ import annotations

import io
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Final

from mcap.exceptions import EndOfFile, InvalidMagic, McapError
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.interfaces import MessageDefinitionFormat
from rosbags.rosbag2.metadata import parse_qos

from .errors import BagReadError, BagWriteError
from .offered_qos import decode_qos
from .reader import register_type
from .types import jazzy_typestore
from .writer import SessionWriter

if TYPE_CHECKING:
    from collections.abc import Iterator

    from rosbags.typesys.store import Typestore

__all__ = ['ReindexResult', 'reindex', 'BROKEN_SUFFIX']

MAGIC: Final = b'\x89MCAP0\r\n'
BROKEN_SUFFIX: Final = '.broken'
"""Appended to the name of the original .mcap file that :func:`reindex` replaced (kept next to it)."""
_WORK_DIR: Final = '.reindex'
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
    """A complete record whose contents cannot be used."""


class _WholeReads(io.BufferedReader):
    """A file whose ``read(n)`` returns n bytes or raises mcap's EndOfFile.

    mcap's record readers raise EndOfFile only when a read returns nothing: a field cut by the end of a
    killed recording would come back short and pass for a whole one.
    """

    def read(self, size: int | None = -1) -> bytes:
        if size is None or size < 0:
            raise _Corrupt('a record shorter than its own fields')
        data = super().read(size)
        if len(data) < size:
            raise EndOfFile
        return data


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
        self.schemas: dict[int, Schema] = {}
        self.topics: dict[int, str] = {}  # channel id -> topic written
        self.counts: dict[str, int] = {}

    def apply(self, record: McapRecord) -> None:
        """Write a schema, channel or message to the new bag (other records carry nothing to keep).

        Raises _Corrupt for a record that contradicts the file.
        """
        if isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            self._add_channel(record)
        elif isinstance(record, Message):
            topic = self.topics.get(record.channel_id)
            if topic is None:
                raise _Corrupt(f'message on channel {record.channel_id}, which no earlier record defines')
            self.writer.write(topic, record.log_time, record.data, record.publish_time)
            self.counts[topic] += 1

    def _add_channel(self, channel: Channel) -> None:
        if channel.id in self.topics:
            return
        schema = self.schemas.get(channel.schema_id)
        if schema is None:
            raise _Corrupt(f'channel {channel.topic!r} refers to schema {channel.schema_id}, which is not defined')
        if schema.name not in self.typestore.fielddefs:
            fmt = _SCHEMA_FORMATS.get(schema.encoding, MessageDefinitionFormat.NONE)
            register_type(self.typestore, schema.name, fmt, schema.data.decode(), self.bag)
        try:
            qos = [decode_qos(q) for q in parse_qos(channel.metadata.get('offered_qos_profiles', '[]'))]
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
    store = typestore if typestore is not None else jazzy_typestore()
    size = mcap.stat().st_size
    with _WholeReads(io.FileIO(mcap, 'rb')) as stream:
        # the file's own size bounds a record's length: a corrupt length is not read as 4 GiB
        records = StreamReader(stream, emit_chunks=True, record_size_limit=size).records
        try:
            header = next(records)
        except InvalidMagic:
            raise BagReadError(f'cannot reindex {bag}: {mcap.name} does not start with the MCAP magic') from None
        except (McapError, _Corrupt, ValueError):
            header = None
        if stream.tell() < len(MAGIC):
            raise BagReadError(f'cannot reindex {bag}: {mcap.name} does not start with the MCAP magic')
        if not isinstance(header, Header):
            raise BagReadError(f'cannot reindex {bag}: {mcap.name} has no complete MCAP header record')
        shutil.rmtree(work, ignore_errors=True)  # an interrupted earlier repair's leftovers: ours
        try:
            with SessionWriter(work / bag.name, typestore=store, flush_period=None) as writer:
                rebuilder = _Rebuilder(writer, store, bag)
                chunks, stopped, discarded = _rebuild(records, stream, rebuilder, size)
        except BagWriteError:
            shutil.rmtree(work, ignore_errors=True)
            raise
    repaired_dir = work / bag.name
    mcap.rename(broken)
    (repaired_dir / f'{bag.name}.mcap').replace(bag / f'{bag.name}.mcap')
    (repaired_dir / 'metadata.yaml').replace(metadata)
    shutil.rmtree(work, ignore_errors=True)
    return ReindexResult(bag, True, dict(rebuilder.counts), chunks, discarded, stopped, broken)


def _rebuild(records: Iterator[McapRecord], stream: io.BufferedReader, rebuilder: _Rebuilder,
             size: int) -> tuple[int, str, int]:
    """Apply every complete record after the header: (complete chunks, why it stopped, bytes discarded)."""
    chunks = 0
    while True:
        offset = stream.tell()
        try:
            record = next(records)
        except EndOfFile:  # cut inside this record, or at its start
            return chunks, 'end of file' if offset == size else f'record cut short at byte {offset}', size - offset
        except (McapError, _Corrupt, ValueError) as exc:  # ValueError: e.g. a string that is not UTF-8
            return chunks, f'corrupt record at byte {offset}: {exc}', size - offset
        if isinstance(record, (DataEnd, Footer)):  # the rest is the summary section and footer
            return chunks, 'end of data', 0
        try:
            if isinstance(record, Chunk):
                try:  # all of a chunk's records or none: decompressed and checked before any is applied
                    inner = breakup_chunk(record, validate_crc=True)
                except Exception as exc:  # noqa: BLE001 - mcap's errors, or the zstd/lz4 library's own type
                    raise _Corrupt(f'chunk unreadable: {type(exc).__name__}: {exc}') from None
            else:
                inner = [record]
            for each in inner:
                rebuilder.apply(each)
        except (_Corrupt, UnicodeDecodeError) as exc:  # a schema's definition that is not UTF-8
            return chunks, f'corrupt record at byte {offset}: {exc}', size - offset
        chunks += isinstance(record, Chunk)
