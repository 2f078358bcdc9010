"""A recording in progress: a new bag written off the caller's thread, what it holds and how it ended.

What a recorder keeps about its bag, ROS-free: the topics added with the QoS they are subscribed with,
the messages received, written and lost, the first write error, and the one-line summary. Messages go
through a :class:`~.queued.QueuedWriter`, so :meth:`Recording.put` never waits for the disk.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from .errors import BagWriteError
from .offered_qos import QosSpec
from .queued import QueuedWriter
from .types import jazzy_typestore
from .writer import DEFAULT_FLUSH_PERIOD, SessionWriter

__all__ = ['Recording']


class Recording:
    """A new rosbag2 MCAP bag at ``out_dir``, fed from a queue (see :class:`~.writer.SessionWriter`).

    Parameters
    ----------
    out_dir
        Bag directory to create; it must not exist.
    flush_period
        Seconds after which a received message is on disk (its chunk closed and flushed).

    Raises
    ------
    BagWriteError
        ``out_dir`` exists or cannot be created.
    """

    def __init__(self, out_dir: str | os.PathLike[str], *, flush_period: float = DEFAULT_FLUSH_PERIOD) -> None:
        self._typestore = jazzy_typestore()
        self._bag = SessionWriter(out_dir, typestore=self._typestore, flush_period=flush_period)
        self._writer = QueuedWriter(self._bag)
        self.put = self._writer.put
        """Queue one serialized message: ``put(topic, receive time in ns, CDR bytes, send time in ns or None)``;
        never blocks or raises."""
        self._recorded: dict[str, tuple[str, QosSpec]] = {}  # topic -> (type, subscribed QoS)
        self._received = 0
        self._lost: dict[str, int] = {}
        self._overflows: dict[str, int] = {}
        self._error: BagWriteError | None = None

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._bag.path

    @property
    def closed(self) -> bool:
        """Whether the bag is finished (closed after an error or by :meth:`close`)."""
        return self._bag.closed

    @property
    def recorded_topics(self) -> dict[str, tuple[str, QosSpec]]:
        """A copy of the added topics: name -> (message type, QoS subscribed with)."""
        return dict(self._recorded)

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per added topic (a new dict)."""
        written = self._writer.counts
        return {topic: written.get(topic, 0) for topic in self._recorded}

    @property
    def error(self) -> BagWriteError | None:
        """The write error that stopped the recording, if any (see :meth:`stop`)."""
        return self._error

    @property
    def writer_error(self) -> BagWriteError | None:
        """The writer thread's write error, which stops the recording once taken up by :meth:`stop`."""
        return self._writer.error

    def knows(self, msgtype: str) -> bool:
        """Whether the bag can store messages of ``msgtype`` (a ROS 2 Jazzy standard type: 'std_msgs/msg/String')."""
        return msgtype in self._typestore.fielddefs

    def add_topic(self, topic: str, msgtype: str, subscribed: QosSpec, offered: Sequence[QosSpec]) -> None:
        """Add a topic recorded with the QoS its publishers ``offered``, subscribed with ``subscribed``.

        Raises
        ------
        BagWriteError
            The bag cannot take the topic (e.g. it is closed).
        """
        self._bag.add_topic(topic, msgtype, qos=offered)
        self._recorded[topic] = (msgtype, subscribed)

    def resubscribe(self, topic: str, subscribed: QosSpec) -> None:
        """Note that an added topic is now subscribed with ``subscribed``; its offered QoS in the bag stay.

        Raises
        ------
        KeyError
            ``topic`` was not added.
        """
        self._recorded[topic] = (self._recorded[topic][0], subscribed)

    def count_received(self, messages: int) -> None:
        """Count messages received (put or about to be)."""
        self._received += messages

    def count_lost(self, topic: str, messages: int) -> str:
        """Count messages lost before they reached the bag; return every topic's losses (:meth:`losses`)."""
        self._lost[topic] = self._lost.get(topic, 0) + messages
        return self.losses()

    def count_overflow(self, topic: str) -> str:
        """Count a full queue whose losses are not known; return every topic's losses (:meth:`losses`)."""
        self._overflows[topic] = self._overflows.get(topic, 0) + 1
        return self.losses()

    def losses(self) -> str:
        """Every topic's losses in words: 'LOST 5: /a 2, /b 3', then '; queue full, losses not counted: /c 1 time'.

        '' when nothing was lost.
        """
        parts = []
        if self._lost:
            parts.append(f'LOST {sum(self._lost.values())}: '
                         + ', '.join(f'{t} {n}' for t, n in sorted(self._lost.items())))
        if self._overflows:
            parts.append('queue full, losses not counted: '
                         + ', '.join(f'{t} {n} time{"s" if n > 1 else ""}' for t, n in sorted(self._overflows.items())))
        return '; '.join(parts)

    def values(self) -> dict[str, int]:
        """The counts a recorder reports, by key.

        'messages received', 'messages written' in total and per topic ('topic /intent/w': n), the 'writer
        queue' and its 'writer queue peak' (messages received, not yet written), 'messages lost' in total and per
        topic that lost any ('lost /intent/w': n: the middleware's message-lost events, a reliable publisher whose
        history dropped messages before the recorder had them, a best-effort gap; and what a subscription's
        keep-last queue dropped, counted by the recorder), 'queue full' per topic whose full queue's losses are
        not known ('queue full /diagnostics': times).
        """
        written = self._writer.counts
        return {
            'messages received': self._received, 'messages written': self._bag.message_count,
            'writer queue': self._writer.queued, 'writer queue peak': self._writer.peak,
            'messages lost': sum(self._lost.values()),
            **{f'topic {topic}': written.get(topic, 0) for topic in self._recorded},
            **{f'lost {topic}': n for topic, n in self._lost.items()},
            **{f'queue full {topic}': n for topic, n in self._overflows.items()}}

    def located(self, exc: BagWriteError) -> str:
        """``exc`` with the bag and the messages written before it, unless its text names the bag already."""
        where = f' [bag {exc.path or self.path}, {exc.messages_written} messages written before the error]'
        return f'{exc}{"" if str(self.path) in str(exc) else where}'

    def stop(self, exc: BagWriteError) -> bool:
        """Keep ``exc`` as the error that stopped the recording; False if one was kept already."""
        if self._error is not None:
            return False
        self._error = exc
        return True

    def close(self) -> BagWriteError | None:
        """Write what is queued and finish the bag (MCAP summary, metadata.yaml). Idempotent.

        Returns the failure, never raises it: the error finishing raised, else the writer thread's (also
        kept as :attr:`error` when no earlier error stopped the recording).
        """
        try:
            self._writer.close()
            failure = self._writer.error  # e.g. writing the last queued messages failed
        except BagWriteError as exc:
            failure = exc
        if failure is not None and self._error is None:
            self._error = failure
        return failure

    def summary(self) -> str:
        """One line: messages per topic, the losses (:meth:`losses`), and the error if the recording failed."""
        counts = self.counts
        per_topic = ', '.join(f'{t} {n}' for t, n in sorted(counts.items())) or 'no topics'
        line = (f'recorder: {sum(counts.values())} messages on {len(counts)} topics '
                f'in {self._bag.path} ({per_topic})')
        if losses := self.losses():
            line += f'; {losses}'
        if self._error is not None:
            line += f'; FAILED: {self._error}'
            if self._writer.dropped:
                line += f'; {self._writer.dropped} messages received after the error not recorded'
        return line
