"""A :class:`SessionWriter` fed through a queue by its own thread: the producer never waits for the disk.

A recorder's executor thread only enqueues (:meth:`QueuedWriter.put`: one queue append); the writer thread
writes, compresses and flushes chunks (zstd releases the GIL while it compresses) and closes a chunk
when its first message is ``flush_period`` seconds old even when no further message arrives.
"""

from __future__ import annotations

import functools
import queue
import threading
from collections.abc import Callable
from typing import Final

from .errors import BagWriteError
from .writer import SessionWriter

__all__ = ['QueuedWriter']

_STOP: Final = None


class QueuedWriter:
    """Write messages to ``writer`` from a thread of its own, in the order they were put.

    Parameters
    ----------
    writer
        An open :class:`SessionWriter` whose topics are added (:meth:`SessionWriter.add_topic`, which
        may be called at any time) before messages of them are put. :meth:`close` closes it.
    on_error
        Called once, from the writer thread, with the :class:`BagWriteError` that stopped the writing
        (the writer is then closed and later messages are counted in :attr:`dropped`); it must not raise.

    The queue is unbounded (messages are never refused); :attr:`queued` and :attr:`peak` show how far the
    writer thread is behind.
    """

    def __init__(self, writer: SessionWriter, *,
                 on_error: Callable[[BagWriteError], object] | None = None) -> None:
        self._writer = writer
        self._on_error = on_error
        self._queue: queue.SimpleQueue[tuple[str, int, bytes | memoryview, int | None] | None] = queue.SimpleQueue()
        self._counts: dict[str, int] = {}
        self._error: BagWriteError | None = None
        self._dropped = 0
        self._peak = 0
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=f'bag writer {writer.path.name}', daemon=True)
        self._thread.start()

    @property
    def counts(self) -> dict[str, int]:
        """A copy of the messages written per topic (topics with a message written so far)."""
        return dict(self._counts)

    @property
    def error(self) -> BagWriteError | None:
        """The error that stopped the writing, if any."""
        return self._error

    @property
    def dropped(self) -> int:
        """Messages put (or still queued) after the error, not written."""
        return self._dropped

    @property
    def queued(self) -> int:
        """Messages waiting for the writer thread (approximate)."""
        return self._queue.qsize()

    @property
    def peak(self) -> int:
        """The largest :attr:`queued` seen by :meth:`put`."""
        return self._peak

    def put(self, topic: str, timestamp_ns: int, cdr: bytes | memoryview, publish_ns: int | None = None) -> None:
        """Queue one serialized message (see :meth:`SessionWriter.write`); never blocks, never raises.

        After an error or :meth:`close` the message is counted in :attr:`dropped` instead.
        """
        if self._error is not None or self._closed:
            self._dropped += 1
            return
        self._queue.put((topic, timestamp_ns, cdr, publish_ns))
        self._peak = max(self._peak, self._queue.qsize())

    def close(self) -> None:
        """Write everything queued, stop the thread and close the writer. Idempotent.

        Raises
        ------
        BagWriteError
            Closing the writer failed (e.g. ENOSPC while writing the summary).
        """
        if not self._closed:
            self._closed = True
            self._queue.put(_STOP)
        self._thread.join()
        self._writer.close()

    def _run(self) -> None:
        writer = self._writer
        while True:
            wait = writer.seconds_to_flush if self._error is None else None
            try:
                item = self._queue.get(timeout=None if wait is None else max(wait, 0.0))
            except queue.Empty:
                self._guarded(writer.flush_if_due)
                continue
            if item is _STOP:
                return
            if self._error is not None:
                self._dropped += 1
                continue
            topic, stamp, cdr, published = item
            if self._guarded(functools.partial(writer.write, topic, stamp, cdr, published)):
                self._counts[topic] = self._counts.get(topic, 0) + 1
            else:
                self._dropped += 1

    def _guarded(self, action: Callable[[], object]) -> bool:
        """Run a write or flush; on failure record the error (once) and call ``on_error``."""
        try:
            action()
        except BagWriteError as exc:
            self._fail(exc)
            return False
        except Exception as exc:  # noqa: BLE001 - a writer thread must not die silently
            self._fail(BagWriteError(f'writing bag {self._writer.path} failed: {type(exc).__name__}: {exc}',
                                     path=self._writer.path, messages_written=self._writer.message_count))
            return False
        return True

    def _fail(self, exc: BagWriteError) -> None:
        self._error = exc
        if self._on_error is not None:
            self._on_error(exc)
