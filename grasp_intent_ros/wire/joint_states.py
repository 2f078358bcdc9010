"""The arm's ``joint_states`` read as a real arm's driver publishes them: each joint's latest position, the hand.

ROS-free (attribute access only, so rosbags' message classes are read too): the nodes, the demo's loop and the
session analysis read the stream with the same rules.

What a driver may send, and what is read
    One message with every joint (the mock arm), or the arm and the fingers in separate messages (two
    controllers, two publishers), in any order, with other joints besides, at 10 Hz or 100 Hz, with exact, noisy
    or no velocities (a position-only ros2_control interface publishes an empty ``velocity``). Only ``name`` and
    ``position`` (and the header's stamp) are read: velocities and efforts never are.
The contract (:class:`JointStates`)
    The latest position of each joint, from whichever message named it last; a joint no message named yet is
    unknown. Stale: a joint whose latest position was received more than ``stale_after`` s
    (:data:`STALE_AFTER`) before the newest message is unknown again (its publisher stopped while another goes
    on); with one publisher no joint is ever stale. A reading of several joints exists once each is known and not
    stale; its receipt is the oldest of theirs (every joint in it was seen at least then). The silence of every
    publisher is not judged here: a reading keeps its receipt, and its reader judges its age.
Bad input
    A malformed message (as :func:`~grasp_intent_ros.wire.robot_state.named_positions`: too many or too long
    names, duplicates, names and positions of different counts, a kept joint's position NaN or infinite) raises
    and changes nothing; the joints it would have updated keep their previous positions.
The fingers at rest (:class:`RestRule`, :class:`FingerRest`: from positions alone)
    A *finger reading* is a message that names a finger while the three fingers are known; its *time* is its
    message's header stamp while every finger reading so far has had a non-zero stamp later than the one before
    (the driver's clock: when each sample was taken), else its receipt (a position-only driver may stamp zero).
    At a finger reading of time ``t`` the fingers are *at rest* when, over the finger readings from the latest
    one of time at or before ``t - window`` up to it, every finger's positions span (max - min) at most
    ``tolerance`` rad: still for ``window`` s at least. ``<=`` for the span and the window, times in integer
    nanoseconds. A finger slower than ``tolerance / window`` rad/s is at rest.
The rule's clock
    Receipts misjudge a backlog: messages held up and taken in a burst get receipts close together, so a burst's
    first reading, a sample long before its receipt, has the reading before the backlog within the window and is
    judged still over what was a few milliseconds of the fingers' motion. Stamps time each sample where it was
    taken. The first finger reading unstamped, or stamped at or before the one before (a stamp that does not
    advance, a clock that went back), ends the stamps' use for good: the rule goes on by receipts, over the
    readings the stamps' window kept, so in the window after the change it may call the fingers at rest later
    than receipts alone would, never sooner. Only differences of times are read, so a constant offset between
    the stamps and the receipts changes no decision. A hand's receipt (:class:`Hand`) stays on its reader's clock;
    its stamp is given while the rule goes by stamps, and :func:`fingers_settled` judges "after the close" by it when
    told the close's time on the stamps' clock (else by the receipt).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from ..errors import DataError
from ..mico.kinematics import ARM_JOINTS, FINGER_JOINTS, MicoKinematics
from .robot_state import named_positions, stamp_nanoseconds

__all__ = ['STALE_AFTER', 'FINGER_SET', 'SETTLE_TOLERANCE', 'SETTLE_WINDOW', 'JointReading', 'JointStates', 'RestRule',
           'FingerRest', 'receipt_ns', 'Hand', 'HandTracker', 'CLOSE_SETTLE', 'fingers_settled']

STALE_AFTER: Final = 1.0
"""Seconds a joint's latest position may lag the newest ``joint_states`` message before it is unknown again.

Ten periods of a 10 Hz driver (a hundred of the mock arm's): two publishers at 10 Hz each lag the other by at most
one period and their jitter, so only a publisher that stopped while another goes on is stale."""

SETTLE_TOLERANCE: Final = 0.02
"""Default span (rad) within which every finger's positions must stay over :data:`SETTLE_WINDOW` to be at rest.

Ten standard deviations of an encoder's noise of 0.002 rad: the span of 51 samples of such noise (the window at
100 Hz) exceeds it with a probability below 1e-8 per window, so noise at rest does not keep the fingers from
settling."""

SETTLE_WINDOW: Final = 0.5
"""Default time (s) the fingers must stay within :data:`SETTLE_TOLERANCE` to be at rest.

51 joint states at 100 Hz (the mock arm's rate; 6 from a driver at 10 Hz), shorter than a demonstrator holds a
grasp; a finger moving faster than ``SETTLE_TOLERANCE / SETTLE_WINDOW`` (0.04 rad/s: 25 s from open to
1 rad) is never at rest, and a slower one cannot be told from a rest."""


@dataclass(frozen=True)
class JointReading:
    """Some joints' latest positions, when they were received, and their messages' stamps.

    ``positions`` shape (n,) rad, in the order asked; ``received`` s, the oldest receipt among them; ``stamp_ns``
    the oldest of their messages' header stamps (integer ns), None when one of those messages had no stamp.
    """

    positions: NDArray[np.float64]
    received: float
    stamp_ns: int | None


class JointStates:
    """The latest position of each of ``names``, from whichever ``joint_states`` message named it last.

    The module docstring's contract; ``stale_after`` s (> 0, may be inf). Times are the caller's receipt times in s
    on one clock (a monotonic clock, or a bag's receive times).
    """

    def __init__(self, names: Sequence[str], *, stale_after: float = STALE_AFTER) -> None:
        if not stale_after > 0.0:
            raise DataError(f'stale_after must be > 0 s (or inf), got {stale_after}')
        self.names, self.stale_after = tuple(names), stale_after
        self._latest: dict[str, tuple[float, float, int | None]] = {}  # name: (position, received, stamp ns)
        self.newest = -math.inf  # the newest message's receipt

    def add(self, msg: Any, received: float) -> tuple[str, ...]:
        """Take a sensor_msgs/JointState received at ``received`` s; the kept joints it named (in ``names``' order).

        Raises as :func:`~grasp_intent_ros.wire.robot_state.named_positions`, and then changes nothing.
        """
        positions = named_positions(msg, self.names)
        stamp = stamp_nanoseconds(msg)
        for name, position in positions.items():
            self._latest[name] = (position, received, stamp)
        self.newest = max(self.newest, received)
        return tuple(positions)

    def read(self, names: Sequence[str] | None = None) -> JointReading | None:
        """The reading of ``names`` (default: every kept joint); None while one is unknown or stale."""
        entries = [self._latest.get(name) for name in (self.names if names is None else names)]
        known = [entry for entry in entries if entry is not None and self.newest - entry[1] <= self.stale_after]
        if len(known) < len(entries):
            return None
        stamps = [stamp for _, _, stamp in known]
        return JointReading(np.array([position for position, _, _ in known], dtype=np.float64),
                            min(received for _, received, _ in known),
                            None if None in stamps else min(s for s in stamps if s is not None))

    def missing(self, names: Sequence[str] | None = None) -> str:
        """Why :meth:`read` gives None for ``names``, in words ('' when it does not)."""
        names = self.names if names is None else names
        never = [name for name in names if name not in self._latest]
        stale = [name for name in names if name in self._latest
                 and self.newest - self._latest[name][1] > self.stale_after]
        parts = ([f'never named: {", ".join(never)}'] if never else []) + (
            [f'stale (not named for more than {self.stale_after:g} s while other joints were): {", ".join(stale)}']
            if stale else [])
        return '; '.join(parts)


def receipt_ns(t: float) -> int:
    """A receipt time in s as integer nanoseconds (exact for a bag's receive times, which are whole nanoseconds)."""
    return round(t * 1e9)


@dataclass(frozen=True)
class RestRule:
    """The rest rule's amounts (module docstring): ``tolerance`` rad, ``window`` s.

    Raises
    ------
    DataError
        Unless ``0 <= tolerance`` and ``0 < window``, both finite.
    """

    tolerance: float = SETTLE_TOLERANCE
    window: float = SETTLE_WINDOW

    def __post_init__(self) -> None:
        if not (0.0 <= self.tolerance < math.inf and 0.0 < self.window < math.inf):
            raise DataError(f'the rest rule needs a finite settle tolerance >= 0 and a finite settle window > 0; got '
                            f'tolerance {self.tolerance} rad, window {self.window} s')


class FingerRest:
    """Whether the fingers are at rest, finger reading by finger reading (module docstring: the rule, its clock).

    ``by_stamps``: whether the readings so far are timed by their stamps (True until one is unstamped or not later
    than the one before).
    """

    def __init__(self, rule: RestRule = RestRule()) -> None:
        self.rule, self.window_ns = rule, receipt_ns(rule.window)
        self.by_stamps = True
        # (receipt ns, stamp ns, fingers) from the latest of time at or before the newest's less the window
        self.recent: deque[tuple[int, int | None, NDArray[np.float64]]] = deque()

    def step(self, received: float, stamp_ns: int | None, fingers: NDArray[np.float64]) -> bool:
        """Whether the fingers are at rest at their reading ``fingers`` (shape (3,), rad).

        ``received``: its receipt (s, non-decreasing from call to call); ``stamp_ns``: its message's header stamp
        (integer ns; None when unset).
        """
        if self.by_stamps and (stamp_ns is None or (self.recent and stamp_ns <= self._time(-1))):
            self.by_stamps = False
        self.recent.append((receipt_ns(received), stamp_ns, fingers))
        since = self._time(-1) - self.window_ns
        while len(self.recent) >= 2 and self._time(1) <= since:
            self.recent.popleft()
        positions = np.array([f for _, _, f in self.recent])
        return self._time(0) <= since and bool(
            np.all(positions.max(axis=0) - positions.min(axis=0) <= self.rule.tolerance))

    def _time(self, index: int) -> int:
        """The time (ns) of the reading kept at ``index``: its stamp while :attr:`by_stamps`, else its receipt."""
        received, stamp, _ = self.recent[index]
        if not self.by_stamps:
            return received
        assert stamp is not None  # every reading kept while by_stamps has a stamp
        return stamp


@dataclass(frozen=True)
class Hand:
    """The MICO's hand as the joint states give it: where the hand is, and its fingers.

    ``received``: s (the oldest receipt of the joints it is read from: each was seen at least then); ``base_T_ee``:
    shape (4, 4), base frame (forward kinematics of the arm joints); ``fingers``: shape (3,), rad (the executed
    closures: a mock arm's closure error included); ``fingers_at_rest``: at the latest finger reading, by the rest
    rule (:class:`FingerRest`: positions only, timed by stamps or receipts as the module docstring says);
    ``stamp_ns``: the oldest header stamp of the joints it is read from (integer ns: each was sampled at least
    then) while the rest rule times the finger readings by their stamps, None when it goes by receipts or a joint's
    message had no stamp.
    """

    received: float
    base_T_ee: NDArray[np.float64]
    fingers: NDArray[np.float64]
    fingers_at_rest: bool
    stamp_ns: int | None = None


FINGER_SET: Final = frozenset(FINGER_JOINTS)


class HandTracker:
    """The :class:`Hand` of a ``joint_states`` stream: arm and fingers by :class:`JointStates`, the rest by positions.

    Each message (:meth:`add`) that names a finger, with the three fingers known, is a finger reading: the rest rule
    (:attr:`rest`) steps on it, at the message's stamp or receipt (the module docstring's clock). :meth:`hand` is the
    hand after the latest message; safe to call from another thread than :meth:`add`'s (it reads one snapshot).
    """

    def __init__(self, kin: MicoKinematics, rule: RestRule = RestRule(), *, stale_after: float = STALE_AFTER) -> None:
        self.kin = kin
        self.joints = JointStates((*ARM_JOINTS, *FINGER_JOINTS), stale_after=stale_after)
        self.rest = FingerRest(rule)
        # the latest finger reading, at rest there, by stamps there
        self._fingers: tuple[JointReading, bool, bool] | None = None
        self._state: tuple[JointReading | None, tuple[JointReading, bool, bool] | None] = (None, None)

    def add(self, msg: Any, received: float) -> tuple[str, ...]:
        """Take a sensor_msgs/JointState received at ``received`` s (non-decreasing); the arm and finger joints named.

        Raises as :meth:`JointStates.add` (nothing changes).
        """
        named = self.joints.add(msg, received)
        fingers = self.joints.read(FINGER_JOINTS)
        if fingers is not None and not FINGER_SET.isdisjoint(named):
            at_rest = self.rest.step(received, stamp_nanoseconds(msg), fingers.positions)
            self._fingers = (fingers, at_rest, self.rest.by_stamps)
        self._state = (self.joints.read(ARM_JOINTS), self._fingers if fingers is not None else None)
        return named

    def hand(self) -> Hand | None:
        """The hand after the latest message; None while an arm or finger joint is unknown or stale."""
        arm, fingers = self._state
        if arm is None or fingers is None:
            return None
        reading, at_rest, by_stamps = fingers
        stamp = (min(arm.stamp_ns, reading.stamp_ns) if by_stamps and arm.stamp_ns is not None
                 and reading.stamp_ns is not None else None)
        return Hand(min(arm.received, reading.received), self.kin.fk(arm.positions), reading.positions, at_rest, stamp)


CLOSE_SETTLE = 0.3
"""Seconds from a close (its answer, or a status that reports it) to the first joint state read for the fingers:
the close request is served within milliseconds, and the fingers must be seen moving or at rest after it."""


def fingers_settled(hand: Hand | None, closed: float, settle: float = CLOSE_SETTLE, *,
                    closed_ns: int | None = None) -> bool:
    """Whether ``hand`` shows the fingers at rest after a close at ``closed`` s (the clock of its receipts).

    True when the fingers are at rest by the rest rule (:class:`FingerRest`, from positions: velocities are never
    read), so at least the rule's window after they last moved, and every joint of the hand was seen ``settle`` s
    after the close or later (the fingers seen moving or at rest after the close, not before it); its ``fingers``
    are then the executed closures. "After the close" is judged on the rest rule's clock: given ``closed_ns``, the
    close on the stamps' clock (integer ns, the clock the arm stamps its joint states with: one machine's system
    clock for the mock arm and its caller), and a hand timed by stamps (:attr:`Hand.stamp_ns`), by the stamps:
    every joint's message sampled at least ``settle`` s after the close, however late it was received (a backlog of
    joint states sampled before the close, taken in a burst after it, never passes). Otherwise by receipts: every
    joint received at least ``settle`` s after ``closed``; receipts say when a joint state was taken, not when it
    was sampled, so a backlog of more than ``settle`` s taken after the close passes for joint states sampled
    after it (a reader that keeps only the newest joint state, as the demo's loop does, has no backlog).
    """
    if hand is None or not hand.fingers_at_rest:
        return False
    if closed_ns is not None and hand.stamp_ns is not None:
        return hand.stamp_ns >= closed_ns + receipt_ns(settle)
    return hand.received >= closed + settle
