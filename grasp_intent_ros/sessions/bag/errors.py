"""The bag layer's exception types.

A bag that cannot be read is bad input: :class:`BagReadError` is a
:class:`~grasp_intent_ros.errors.GraspIntentError` (a ValueError). A bag that cannot be written (the
directory exists, the disk is full) is not: :class:`BagWriteError` is no ValueError, so a handler of bad
arguments never takes it for one.
"""

from __future__ import annotations

from pathlib import Path

from grasp_intent_ros.errors import GraspIntentError

__all__ = [
    'BagError',
    'BagWriteError',
    'BagReadError',
]


class BagError(Exception):
    """Base class: a rosbag2 session cannot be written or read as asked (also: a malformed QosSpec)."""


class BagWriteError(BagError):
    """A session bag cannot be created or written (path exists, disk full, unknown topic, ...).

    Attributes
    ----------
    path
        The bag directory concerned, or None if there is none.
    messages_written
        How many messages the writer had accepted before the failure.
    """

    def __init__(self, message: str, *, path: Path | None = None, messages_written: int = 0) -> None:
        super().__init__(message)
        self.path = path
        self.messages_written = messages_written


class BagReadError(BagError, GraspIntentError):
    """A bag cannot be read: missing or malformed metadata/storage, unknown topic, undecodable message."""
