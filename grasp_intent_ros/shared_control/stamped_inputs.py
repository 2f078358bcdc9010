"""The intent estimator's inputs paired by their header stamps, not by their arrival order (ROS-free).

An operator twist stamped ``t`` is taken with the hand's pose of the newest joint state stamped at or before
``t`` and the newest shown grasp stamped at or before ``t`` (:class:`StampedInputs`). So the estimate is a
function of the stamped streams: delivery delays, a loaded machine or a replay's timing do not change which
hand and which grasp a twist is taken with, as long as the joint state stamped at or after the twist arrives
within ``wait`` of it (it then shows that every joint state stamped before it has arrived: one publisher's
messages arrive in order) and each grasp arrives before the joint state that follows its stamp.

Rules, in this order:

- A stamped twist waits (in arrival order, behind the twists before it) until a joint state stamped at or
  after it has arrived, or ``wait`` seconds after its arrival; then its hand is the newest joint state stamped
  at or before it (the oldest one kept when all are later; None without any joint state).
- A twist without a stamp, or while the newest joint state has none, is taken as it comes: with the newest
  hand and the newest grasp received.
- A grasp without a stamp replaces every kept grasp (it is shown from now on, to every twist).
- At most ``history`` joint states and grasps are kept; the grasp shown before the oldest one kept is kept too.

Several grasps may be shown at once, one per stream (e.g. one per object of a scene, each shown by its own
planner: :meth:`StampedInputs.proposal`'s ``stream``); the rules hold for each stream on its own, and a twist is
taken with every stream's grasp at its stamp (:attr:`Paired.proposals`).
"""

from __future__ import annotations

import bisect
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import InvalidIntentError

__all__ = ['Paired', 'StampedInputs']

C = TypeVar('C')
"""The operator's command, carried through unchanged."""


@dataclass(frozen=True)
class Paired(Generic[C]):
    """One operator twist with what it is taken with.

    Attributes
    ----------
    command
        The twist as given to :meth:`StampedInputs.twist`.
    arrival : float
        Its arrival time (s).
    hand : ndarray, shape (4, 4), or None
        The hand's pose at its stamp (module docstring); None before any joint state.
    proposals : mapping str -> ndarray, shape (4, 4), or None
        The grasp shown at its stamp in each stream given (:meth:`StampedInputs.proposal`); None for none. The same
        object as given while it is shown.
    """

    command: C
    arrival: float
    hand: NDArray[np.float64] | None
    proposals: Mapping[str, NDArray[np.float64] | None]

    @property
    def proposal(self) -> NDArray[np.float64] | None:
        """The grasp shown at its stamp in the default stream ``''`` (one grasp shown at a time)."""
        return self.proposals.get('')


class StampedInputs(Generic[C]):
    """Queues operator twists until the hand at their stamp is known (module docstring).

    Parameters
    ----------
    wait : float
        Longest time (s) a twist waits for the joint state that follows its stamp; > 0.
    history : int
        Joint states and grasps kept (>= 1).

    Raises
    ------
    InvalidIntentError
        For a ``wait`` that is not finite and > 0, or ``history`` < 1.
    """

    def __init__(self, wait: float, history: int = 256) -> None:
        if not (np.isfinite(wait) and wait > 0.0) or history < 1:
            raise InvalidIntentError(f'need a finite wait > 0 and a history >= 1, got {wait!r} and {history!r}')
        self.wait = float(wait)
        self._history = history
        self._hand_stamps: deque[int] = deque()
        self._hands: deque[NDArray[np.float64]] = deque()
        self._newest_hand: NDArray[np.float64] | None = None
        self._newest_hand_stamped = False
        self._shown: dict[str, _Shown] = {}  # per stream
        self._queue: deque[tuple[int | None, float, C]] = deque()

    def __len__(self) -> int:
        """Twists waiting."""
        return len(self._queue)

    def hand(self, stamp_ns: int | None, base_T_ee: NDArray[np.float64]) -> None:
        """A joint state's hand pose (4x4, checked by the caller) stamped ``stamp_ns`` (None: unstamped)."""
        self._newest_hand, self._newest_hand_stamped = base_T_ee, stamp_ns is not None
        if stamp_ns is None:
            return
        _insert(self._hand_stamps, self._hands, stamp_ns, base_T_ee)
        while len(self._hands) > self._history:
            self._hand_stamps.popleft()
            self._hands.popleft()

    def proposal(self, stamp_ns: int | None, base_T_grasp: NDArray[np.float64] | None, *, stream: str = '') -> None:
        """The grasp shown in ``stream`` from ``stamp_ns`` on (None: unstamped, shown from now to every twist)."""
        self._shown.setdefault(stream, _Shown()).add(stamp_ns, base_T_grasp, self._history)

    def twist(self, stamp_ns: int | None, arrival: float, command: C) -> None:
        """An operator twist stamped ``stamp_ns`` (None: unstamped) that arrived at ``arrival`` (s)."""
        self._queue.append((stamp_ns, arrival, command))

    def due(self, now: float) -> list[Paired[C]]:
        """The twists that can be taken at ``now`` (s, the arrival clock), in arrival order, with their inputs."""
        out = []
        while self._queue:
            stamp, arrival, command = self._queue[0]
            if stamp is None or not self._newest_hand_stamped:
                out.append(Paired(command, arrival, self._newest_hand,
                                  {name: shown.newest for name, shown in self._shown.items()}))
            elif self._hand_stamps[-1] >= stamp or now - arrival >= self.wait:
                out.append(Paired(command, arrival, _at(self._hand_stamps, self._hands, stamp, self._hands[0]),
                                  {name: shown.at(stamp) for name, shown in self._shown.items()}))
            else:
                break
            self._queue.popleft()
        return out


class _Shown:
    """One stream of shown grasps: those kept by stamp, the one shown before them, the newest received."""

    def __init__(self) -> None:
        self.stamps: deque[int] = deque()
        self.grasps: deque[NDArray[np.float64] | None] = deque()
        self.before: NDArray[np.float64] | None = None  # shown before the oldest kept one
        self.newest: NDArray[np.float64] | None = None

    def add(self, stamp_ns: int | None, base_T_grasp: NDArray[np.float64] | None, history: int) -> None:
        """As :meth:`StampedInputs.proposal`, keeping at most ``history`` grasps."""
        self.newest = base_T_grasp
        if stamp_ns is None:
            self.stamps.clear()
            self.grasps.clear()
            self.before = base_T_grasp
            return
        _insert(self.stamps, self.grasps, stamp_ns, base_T_grasp)
        while len(self.grasps) > history:
            self.stamps.popleft()
            self.before = self.grasps.popleft()

    def at(self, stamp_ns: int) -> NDArray[np.float64] | None:
        """The grasp shown at ``stamp_ns``."""
        return _at(self.stamps, self.grasps, stamp_ns, self.before)


T = TypeVar('T')


def _insert(stamps: deque[int], values: deque[T], stamp: int, value: T) -> None:
    """Insert ``value`` at ``stamp`` keeping ``stamps`` sorted (an equal stamp goes after: the newer arrival)."""
    if not stamps or stamp >= stamps[-1]:
        stamps.append(stamp)
        values.append(value)
        return
    index = bisect.bisect_right(stamps, stamp)
    stamps.insert(index, stamp)
    values.insert(index, value)


def _at(stamps: deque[int], values: deque[T], stamp: int, before: T) -> T:
    """The value of the newest entry stamped at or before ``stamp``; ``before`` when every entry is later."""
    index = bisect.bisect_right(stamps, stamp)
    return values[index - 1] if index > 0 else before
