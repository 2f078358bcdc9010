"""Per-node diagnostics on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray), without diagnostic_updater.

One :class:`NodeDiagnostics` per node component counts the messages received and rejected, keeps the
last error and the last processing time, and publishes one DiagnosticStatus named
``<node fully-qualified name>: <component>`` every ``period`` seconds and at once when an input is
rejected. Levels: OK while the last input was processed (message 'ok', or what the callback reported with
:meth:`NodeDiagnostics.note`, e.g. a clarification request, at the level it gave); WARN after a rejected
input (message = the reason) until an input is processed again; ERROR after an unexpected exception, or whatever
:meth:`NodeDiagnostics.set_state` asks for (the worse of the two wins).

:meth:`NodeDiagnostics.guard` wraps a subscription callback so that no exception escapes it: a
:class:`~grasp_intent_ros.errors.GraspIntentError` (bad input) is a rejection, anything else an
internal error logged with its traceback; either way the node keeps serving.
:meth:`NodeDiagnostics.count_dropped` wraps one so that the messages the node never took (replaced in a
full keep-last input queue, or lost) are counted, from the gaps in the publisher's sequence numbers.

Every text a status or a log line takes from outside (a reason, a value, a traceback) is capped at
:data:`MAX_TEXT` characters (:func:`cap_text`), so a rejected 500 kB message is never echoed whole.
"""

from __future__ import annotations

import functools
import math
import threading
import time
import traceback
import typing
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from ..errors import GraspIntentError
from ..wire.diagnostics import (
    ERROR,
    KEY_DROPPED,
    KEY_LAST_ERROR,
    KEY_PROCESSING_TIME,
    KEY_RECEIVED,
    KEY_REJECTED,
    OK,
    WARN,
    level_value,
    status_name,
)
from ..wire.topics import DIAGNOSTICS
from .qos import output_publisher

__all__ = ['NodeDiagnostics', 'MAX_TEXT', 'LOG_PERIOD', 'cap_text']

M = TypeVar('M')

MAX_TEXT = 1024
"""Longest text (characters) a status message, a status value or a diagnostics log line carries."""

LOG_PERIOD = 1.0
"""Seconds: at most one log line of rejected input per level (WARN, ERROR) and node component in this
time; a flood of bad messages does not flood the log (every rejection is still counted on /diagnostics)."""


def cap_text(text: str, limit: int = MAX_TEXT) -> str:
    """``text`` if at most ``limit`` characters, else its start and end around ``[... n characters ...]``."""
    if len(text) <= limit:
        return text
    marker = f' [... {len(text)} characters in all ...] '
    keep = max(limit - len(marker), 0)
    head = keep - keep // 4
    return f'{text[:head]}{marker}{text[len(text) - (keep - head):]}'


class NodeDiagnostics:
    """Counters, last error and timing of one node component, published on ``/diagnostics``.

    Parameters
    ----------
    node : Node
        Owner: creates the publisher and the timer on it.
    component : str
        Second half of the status name, e.g. 'intent'.
    period : float
        Seconds between periodic publications.
    hardware_id : str
    """

    def __init__(self, node: Node, component: str, *, period: float = 1.0, hardware_id: str = '') -> None:
        self._node = node
        self.name = status_name(node.get_fully_qualified_name(), component)
        self._hardware_id = hardware_id
        self._lock = threading.Lock()
        self._received = 0
        self._rejected = 0
        self._dropped: int | None = None  # None until an input is tracked (count_dropped)
        self._last_error = ''
        self._last_seconds: float | None = None
        self._outcome_level: int = level_value(OK)
        self._outcome_message = 'waiting for input'
        self._note: tuple[int, str] | None = None
        self._logged: dict[bool, tuple[float, int]] = {False: (-math.inf, 0), True: (-math.inf, 0)}
        """Per level (error or not): when a rejection was last logged, and how many were not logged since."""
        self._state_level: int = level_value(OK)
        self._state_message = ''
        self._values: dict[str, str] = {}
        self._publisher = output_publisher(node, DiagnosticArray, DIAGNOSTICS)
        self._timer = node.create_timer(period, self.publish)

    # ---------------------------------------------------------------- recording
    def set_state(self, level: bytes | int, message: str) -> None:
        """A standing condition of the node (e.g. ERROR 'no model'); OK with '' clears it."""
        with self._lock:
            self._state_level, self._state_message = level_value(level), cap_text(message)

    def set_value(self, key: str, value: object) -> None:
        """An extra key/value shown in every status (e.g. the active model)."""
        self.set_values({key: value})

    def set_values(self, values: Mapping[str, object]) -> None:
        """Several extra key/values at once (:meth:`set_value`)."""
        with self._lock:
            self._values.update((key, cap_text(str(value))) for key, value in values.items())

    def note(self, message: str, *, level: bytes | int = OK) -> None:
        """What the input being processed led to, when it is more than 'ok'.

        E.g. 'clarification requested: <reason>': the status message, at ``level``, published at once when
        :meth:`processed` is called.
        """
        with self._lock:
            self._note = (level_value(level), cap_text(message))

    def processed(self, seconds: float) -> None:
        """An input was processed in ``seconds`` (wall time); the status shows 'ok' or the last note."""
        with self._lock:
            note, self._note = self._note, None
            self._last_seconds = seconds
            self._outcome_level, self._outcome_message = note or (level_value(OK), 'ok')
            status = self._status() if note is not None else None
        if status is not None:
            self._publish(status)  # at once, as for a rejection

    def rejected(self, reason: str, *, level: bytes | int = WARN, detail: str = '') -> None:
        """An input was rejected: count it, log it and publish a WARN (or ``level``) status now.

        ``detail`` (e.g. a traceback) follows the log line. Log lines are throttled (:data:`LOG_PERIOD`).
        """
        reason = cap_text(reason)
        with self._lock:
            self._rejected += 1
            self._last_error = reason
            self._outcome_level, self._outcome_message = level_value(level), f'rejected input: {reason}'
            status = self._status()  # as of this rejection: another thread may process an input meanwhile
        error = level_value(level) >= level_value(ERROR)
        line = self._log_line(error, f'{self.name}: {reason}' if error else f'rejected input: {reason}')
        if line is not None and error:  # one call site per severity (rclpy's logger requires it)
            self._node.get_logger().error(f'{line}\n{detail}' if detail else line)
        elif line is not None:
            self._node.get_logger().warning(f'{line}\n{detail}' if detail else line)
        self._publish(status)

    def _log_line(self, error: bool, text: str) -> str | None:
        """``text`` when a line of its level may be logged now (one per :data:`LOG_PERIOD` s), else None.

        The rejections a throttled level did not log are counted into its next line; /diagnostics counts
        every one.
        """
        now = time.monotonic()
        with self._lock:
            last, skipped = self._logged[error]
            if now - last < LOG_PERIOD:
                self._logged[error] = (last, skipped + 1)
                return None
            self._logged[error] = (now, 0)
        return text if not skipped else f'{text} ({skipped} more since the last such line, not logged)'

    def guard(self, callback: Callable[[M], object], *, counts_received: bool = True) -> Callable[[M], None]:
        """Wrap a subscription callback: count, time, and turn every exception into a rejection.

        A GraspIntentError (the core's bad-input errors, or raised by the conversions) is a WARN
        rejection with its message as the reason; any other exception is an ERROR rejection with its
        traceback logged. Nothing escapes. ``counts_received=False`` is for the second stage of an input
        that its subscription's guard has counted already (e.g. a model document read on a thread).
        """
        @functools.wraps(callback)
        def guarded(msg: M) -> None:
            start = time.perf_counter()
            with self._lock:
                self._received += counts_received
                self._note = None
            try:
                callback(msg)
            except GraspIntentError as exc:
                self.rejected(str(exc))
            except Exception as exc:  # noqa: BLE001 - an exception escaping a callback kills the node
                self.rejected(f'internal error: {type(exc).__name__}: {exc}', level=ERROR,
                              detail=cap_text(traceback.format_exc(), 4 * MAX_TEXT))
            else:
                self.processed(time.perf_counter() - start)
        return guarded

    def guard_timer(self, callback: Callable[[], object]) -> Callable[[], None]:
        """Wrap a timer callback: any exception is an ERROR rejection ('internal error: ...'); nothing escapes.

        An exception escaping a timer callback would kill the node; the timer's own work is not counted.
        """
        @functools.wraps(callback)
        def guarded() -> None:
            try:
                callback()
            except Exception as exc:  # noqa: BLE001 - an exception escaping a timer kills the node
                self.rejected(f'internal error: {type(exc).__name__}: {exc}', level=ERROR)
        return guarded

    def count_dropped(self, callback: Callable[[M], object]) -> Callable[[M], None]:
        """Wrap a subscription callback so that the messages it never got are counted (``messages dropped``).

        The wrapped callback takes the message info too (rclpy passes it to a two-argument callback): a jump
        in its ``publication_sequence_number`` is the number of messages of that publisher that were
        replaced in the full keep-last input queue or lost before the node took them. One publisher per
        topic is assumed: a sequence number at or below the last one (a restarted or another publisher)
        starts counting afresh, so a topic with several interleaved publishers overcounts. Middlewares
        without sequence numbers (0 or None) count nothing.
        """
        last = 0
        with self._lock:
            self._dropped = self._dropped or 0

        def counted(msg: M, info: Mapping[str, Any]) -> None:
            nonlocal last
            seq = info.get('publication_sequence_number')
            if isinstance(seq, int) and seq > 0:
                if last and seq > last + 1:
                    with self._lock:
                        self._dropped = (self._dropped or 0) + seq - last - 1
                last = seq
            callback(msg)
        # rclpy inspects the signature and passes the message info; its annotation names only Callable[[M], None]
        return typing.cast(Callable[[M], None], counted)

    # ---------------------------------------------------------------- reporting
    def status(self) -> DiagnosticStatus:
        """The current DiagnosticStatus."""
        with self._lock:
            return self._status()

    def _status(self) -> DiagnosticStatus:  # with the lock held
        if self._state_level > self._outcome_level and self._state_message:
            level, message = self._state_level, self._state_message
        else:
            level, message = self._outcome_level, self._outcome_message
            if self._state_message:
                message = f'{message}; {self._state_message}'
        values = {
            KEY_RECEIVED: str(self._received),
            KEY_REJECTED: str(self._rejected),
            KEY_LAST_ERROR: self._last_error,
            KEY_PROCESSING_TIME: '' if self._last_seconds is None else f'{1e3 * self._last_seconds:.3f}',
            **({} if self._dropped is None else {KEY_DROPPED: str(self._dropped)}),
            **self._values,
        }
        return DiagnosticStatus(level=bytes([level]), name=self.name, message=message,
                                hardware_id=self._hardware_id,
                                values=[KeyValue(key=k, value=v) for k, v in values.items()])

    def publish(self) -> None:
        """Publish the current status now."""
        self._publish(None)

    def _publish(self, status: DiagnosticStatus | None) -> None:
        """Publish ``status`` (None: the current one)."""
        try:
            msg = DiagnosticArray(status=[self.status() if status is None else status])
            msg.header.stamp = self._node.get_clock().now().to_msg()
            self._publisher.publish(msg)
        except Exception as exc:  # noqa: BLE001 - e.g. during shutdown; never raise from a timer
            self._node.get_logger().warning(f'diagnostics not published: {exc}')
