"""joint_states as a real arm's driver publishes them: each joint's latest position, staleness, the hand, the rest.

Hand-built message sequences: split (the arm and the fingers from two publishers), reordered with extra joints,
partial (some joints only), velocity-less, stamped or not, taken in a burst after a backlog; and the mock arm's own
close, read by the position rule and by the velocity rule the suite used before, and by stamps and by receipts.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from grasp_intent_ros.errors import DataError, GraspIntentError
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import FINGER_VELOCITY_LIMIT, MockArm
from grasp_intent_ros.wire.joint_states import (
    CLOSE_SETTLE,
    SETTLE_TOLERANCE,
    SETTLE_WINDOW,
    Hand,
    HandTracker,
    JointStates,
    RestRule,
    fingers_settled,
)

FINGERS = np.array([0.8, 0.75, 0.9])
TARGETS = (FINGERS, np.array([0.3, 1.2, 0.05]), np.zeros(3))
"""The mock arm's closes: the last to where the fingers are."""
JOINTS = (*ARM_JOINTS, *FINGER_JOINTS)
RATE = 100
DT = 1.0 / RATE


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def joint_state(names: Any, positions: Any, velocities: Any = (), stamp_ns: int = 0) -> SimpleNamespace:
    """A JointState as attributes (no velocities unless given); header stamp ``stamp_ns`` (0: unset)."""
    stamp = SimpleNamespace(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
    return SimpleNamespace(header=SimpleNamespace(stamp=stamp), name=list(names),
                           position=[float(p) for p in positions], velocity=list(velocities))


def arm_msg(q: Any = HOME_Q, **kwargs: Any) -> SimpleNamespace:
    """The arm's joints in reversed order, with a joint the suite does not know; no velocities."""
    return joint_state(['m1n6s300_joint_extra', *ARM_JOINTS[::-1]], [9.0, *np.asarray(q)[::-1]], **kwargs)


def finger_msg(fingers: Any = FINGERS, **kwargs: Any) -> SimpleNamespace:
    return joint_state(FINGER_JOINTS[::-1], np.asarray(fingers)[::-1], **kwargs)


# ------------------------------------------------------------------------------------------ JointStates
def test_each_joint_keeps_its_latest_position_from_whichever_message_named_it_last() -> None:
    joints = JointStates(JOINTS)
    assert joints.add(arm_msg(stamp_ns=2_000), 1.0) == ARM_JOINTS  # by name: order and the extra joint ignored
    assert joints.read() is None and joints.missing() == f'never named: {", ".join(FINGER_JOINTS)}'
    assert_array_equal(joints.read(ARM_JOINTS).positions, HOME_Q)
    assert joints.add(finger_msg(stamp_ns=1_000), 1.01) == FINGER_JOINTS
    reading = joints.read()
    assert reading is not None and joints.missing() == ''
    assert_array_equal(reading.positions, [*HOME_Q, *FINGERS])
    assert (reading.received, reading.stamp_ns) == (1.0, 1_000)  # the oldest receipt, the oldest stamp

    moved = HOME_Q + 0.1
    assert joints.add(joint_state(ARM_JOINTS[3:0:-1], moved[3:0:-1]), 1.02) == ARM_JOINTS[1:4]  # partial
    reading = joints.read()
    assert reading is not None
    assert_array_equal(reading.positions, [HOME_Q[0], *moved[1:4], *HOME_Q[4:], *FINGERS])
    assert (reading.received, reading.stamp_ns) == (1.0, None)  # joints 1-3's message had no stamp
    assert joints.add(joint_state(['m1n6s300_joint_extra'], [0.0]), 1.03) == ()  # names none: nothing new


def test_a_joint_not_named_for_stale_after_while_others_are_is_unknown_again() -> None:
    """Stale when the newest message is more than ``stale_after`` s newer: exactly ``stale_after`` is not stale."""
    joints = JointStates(JOINTS, stale_after=0.5)
    joints.add(arm_msg(), 0.0)
    joints.add(finger_msg(), 0.5)
    assert joints.read() is not None and joints.read().received == 0.0
    joints.add(finger_msg(), math.nextafter(0.5, 1.0))
    assert joints.read() is None and joints.read(FINGER_JOINTS) is not None
    assert joints.missing() == ('stale (not named for more than 0.5 s while other joints were): '
                                + ', '.join(ARM_JOINTS))
    joints.add(arm_msg(), 0.6)
    assert joints.read() is not None
    with pytest.raises(DataError, match='stale_after'):
        JointStates(JOINTS, stale_after=0.0)


def test_one_publisher_that_falls_silent_leaves_its_joints_known() -> None:
    """Staleness is relative to the newest message: the silence of every publisher is the reader's to judge."""
    joints = JointStates(JOINTS)
    joints.add(joint_state(JOINTS, [*HOME_Q, *FINGERS]), 0.0)
    assert joints.read() is not None and joints.read().received == 0.0


@pytest.mark.parametrize(('msg', 'match'), [
    (joint_state([*FINGER_JOINTS, FINGER_JOINTS[0]], [0.1, 0.2, 0.3, 0.4]), 'duplicate names'),
    (SimpleNamespace(name=list(FINGER_JOINTS), position=[0.1, 0.2], velocity=[]), '3 names but 2 positions'),
    (joint_state(FINGER_JOINTS, [0.1, math.nan, 0.3]), 'finite'),
    (joint_state([f'j{i}' for i in range(65)], [0.0] * 65), 'limit'),
])
def test_a_malformed_message_raises_and_changes_nothing(msg: Any, match: str) -> None:
    joints = JointStates(JOINTS)
    joints.add(joint_state(JOINTS, [*HOME_Q, *FINGERS]), 0.0)
    with pytest.raises(GraspIntentError, match=match):
        joints.add(msg, 0.1)
    reading = joints.read()
    assert reading is not None and reading.received == 0.0 and joints.newest == 0.0
    assert_array_equal(reading.positions, [*HOME_Q, *FINGERS])


def test_a_nan_in_a_joint_not_kept_is_not_read() -> None:
    joints = JointStates(ARM_JOINTS)
    assert joints.add(joint_state([*ARM_JOINTS, 'gripper'], [*HOME_Q, math.nan]), 0.0) == ARM_JOINTS


# ------------------------------------------------------------------------------------------ the hand
def closing(kin: MicoKinematics, speed: float = 1.0, split: bool = False) -> list[tuple[float, list[Any]]]:
    """1 s at rest open, a close to FINGERS at ``speed`` rad/s, 1 s at rest: (t, messages) every DT, no velocities.

    ``split``: the fingers' message, then the arm's (another publisher), at each t; else one message of both.
    """
    fingers, out, k = np.zeros(3), [], 0
    while True:
        t = k * DT
        if t > 1.0:
            fingers = np.minimum(fingers + speed * DT, FINGERS)
        msgs = [finger_msg(fingers), arm_msg()] if split else [joint_state(JOINTS, [*HOME_Q, *fingers])]
        out.append((t, msgs))
        if np.array_equal(fingers, FINGERS) and t > 1.0 + np.max(FINGERS) / speed + 1.0:
            return out
        k += 1


def settled_at(kin: MicoKinematics, sequence: list[tuple[float, list[Any]]], closed: float) -> tuple[float, Hand]:
    """The first time fingers_settled holds for a close at ``closed`` s, and the hand there."""
    tracker = HandTracker(kin)
    for t, msgs in sequence:
        for msg in msgs:
            tracker.add(msg, t)
        hand = tracker.hand()
        if fingers_settled(hand, closed):
            assert hand is not None
            return t, hand
    raise AssertionError('never settled')


def test_the_hand_of_split_reordered_velocity_less_messages_is_that_of_one_message(kin: MicoKinematics) -> None:
    one, split = closing(kin), closing(kin, split=True)
    t_one, hand_one = settled_at(kin, one, 1.0)
    t_split, hand_split = settled_at(kin, split, 1.0)
    assert t_one == t_split and hand_one.received == hand_split.received == t_one
    assert_array_equal(hand_one.fingers, FINGERS)
    assert_array_equal(hand_split.fingers, FINGERS)
    assert_allclose(hand_split.base_T_ee, kin.fk(HOME_Q), rtol=0.0, atol=0.0)


def test_velocity_less_fingers_are_not_at_rest_while_they_close(kin: MicoKinematics) -> None:
    """Without velocities the fingers are at rest by their positions only, once still for SETTLE_WINDOW s.

    The rule before (every finger velocity zero, a missing one counting as zero) had them at rest the moment the
    close was read: here while they still close, CLOSE_SETTLE s after the close. Still means within
    SETTLE_TOLERANCE: up to SETTLE_TOLERANCE / speed s before the window has passed since they reached FINGERS.
    """
    speed = 0.2  # 4.5 s to close: still closing at the close + CLOSE_SETTLE
    sequence = closing(kin, speed=speed)
    reached = next(t for t, (msg,) in sequence if msg.position[6:] == FINGERS.tolist())
    t, hand = settled_at(kin, sequence, 1.0)
    assert_array_equal(hand.fingers, FINGERS)
    assert reached + SETTLE_WINDOW - SETTLE_TOLERANCE / speed - 1e-9 <= t <= reached + SETTLE_WINDOW + 1e-9


def test_no_hand_while_the_arm_or_the_fingers_are_unknown_or_stale(kin: MicoKinematics) -> None:
    tracker = HandTracker(kin, stale_after=0.5)
    assert tracker.add(finger_msg(), 0.0) == FINGER_JOINTS and tracker.hand() is None
    assert tracker.add(arm_msg(), 0.1) == ARM_JOINTS
    hand = tracker.hand()
    assert hand is not None and hand.received == 0.0 and not hand.fingers_at_rest  # one reading: no window yet
    tracker.add(arm_msg(), 0.6)
    assert tracker.hand() is None  # the fingers' publisher stopped while the arm's goes on
    tracker.add(finger_msg(), 0.7)
    assert tracker.hand() is not None


def test_the_mock_arms_close_gives_the_velocity_rules_fingers_a_window_later(kin: MicoKinematics) -> None:
    """On the mock arm (exact velocities, zero at rest) the velocity rule before and the position rule agree.

    Both read the same fingers, the executed closures; the position rule SETTLE_WINDOW s later, less up to
    SETTLE_TOLERANCE / FINGER_VELOCITY_LIMIT and a step (the close's last steps within the tolerance); as soon, for
    a close to where the fingers are.
    """
    for target in TARGETS:
        arm, tracker = MockArm(kin, [*HOME_Q, 0.0, 0.0, 0.0]), HandTracker(kin)
        t, closed, by_velocity, by_position = 0.0, 1.0, None, None
        while by_position is None:
            t = round(t + DT, 9)
            if t == closed:
                executed = arm.close_fingers(target)
            arm.step(t, DT)
            tracker.add(joint_state(JOINTS, arm.q, arm.qd), t)
            if by_velocity is None and t >= closed + CLOSE_SETTLE and not np.any(arm.qd[6:]):
                by_velocity = (t, arm.q[6:].copy())
            if fingers_settled(hand := tracker.hand(), closed) and hand is not None:
                by_position = (t, hand.fingers)
        assert by_velocity is not None
        assert_array_equal(by_position[1], by_velocity[1])
        assert_array_equal(by_position[1], executed)
        delay = by_position[0] - by_velocity[0]
        if np.any(target):
            assert SETTLE_WINDOW - SETTLE_TOLERANCE / FINGER_VELOCITY_LIMIT - DT - 1e-9 <= delay <= SETTLE_WINDOW
        else:
            assert delay == 0.0


# ------------------------------------------------------------------------------------------ the rest's clock
STAMP0 = 1_764_500_000_000_000_000
"""A driver's clock (ns) at t = 0: stamps on another clock than the receipts."""
STALL = (1.3, 1.9)
"""The subscriber's stall (s): what is published in [1.3, 1.9) is taken at 1.9, in a burst, 1 us apart."""


def stamped(t: float, msg: SimpleNamespace) -> SimpleNamespace:
    """``msg`` stamped at ``t`` s on the driver's clock."""
    return joint_state(msg.name, msg.position, stamp_ns=STAMP0 + round(t * 1e9))


def backlogged(kin: MicoKinematics, stamps: bool) -> list[tuple[float, list[Any]]]:
    """closing() at 1 rad/s as a stalled subscriber takes it: (receipt, messages), stamped at publication or not.

    Received 1 ms after publication but for those published during :data:`STALL`, taken at its end in a burst.
    """
    out, held = [], 0
    for t, (msg,) in closing(kin):
        stalled = STALL[0] <= t < STALL[1]
        out.append((STALL[1] + held * 1e-6 if stalled else t + 1e-3, [stamped(t, msg) if stamps else msg]))
        held += stalled
    return out


def test_a_backlog_taken_in_a_burst_is_judged_by_the_stamps_not_the_receipts(kin: MicoKinematics) -> None:
    """A burst's first reading, published 0.6 s before its receipt, has the reading before the stall in its window.

    By receipts (unstamped) it is still over that window, 10 ms of motion: the fingers, still closing, are called at
    rest and settled (the rule's limit without stamps). By stamps they settle where they stop, as without a stall.
    """
    t, hand = settled_at(kin, backlogged(kin, stamps=False), 1.0)
    assert t == STALL[1] and np.all(hand.fingers < FINGERS - 0.4)  # mid-close
    sequence = backlogged(kin, stamps=True)
    t, hand = settled_at(kin, sequence, 1.0)
    assert_array_equal(hand.fingers, FINGERS)
    reached = next(t for t, (msg,) in sequence if msg.position[6:] == FINGERS.tolist())
    assert reached + SETTLE_WINDOW - SETTLE_TOLERANCE - 1e-9 <= t <= reached + SETTLE_WINDOW + 1e-9


def rest_flags(kin: MicoKinematics, sequence: list[tuple[float, list[Any]]]) -> tuple[list[bool], HandTracker]:
    """Whether the fingers are at rest after each message of ``sequence`` (a hand throughout), and the tracker."""
    tracker, flags = HandTracker(kin), []
    for t, msgs in sequence:
        for msg in msgs:
            tracker.add(msg, t)
            hand = tracker.hand()
            assert hand is not None
            flags.append(hand.fingers_at_rest)
    return flags, tracker


@pytest.mark.parametrize('stamp', ['zero', 'the same', 'earlier'])
def test_a_reading_unstamped_or_not_later_than_the_one_before_times_the_rest_by_receipts_for_good(
        kin: MicoKinematics, stamp: str) -> None:
    """From there the readings are timed by receipts, stamped or not; never at rest sooner than by receipts alone.

    The break comes in the burst (where receipts and stamps differ most), the stamps after it advance again.
    """
    sequence = backlogged(kin, stamps=True)
    k = next(k for k, (t, _) in enumerate(sequence) if t == STALL[1])  # the burst's first reading
    ((_, (before,)), (t, (msg,))) = sequence[k - 1:k + 1]
    stamp_ns = {'zero': 0, 'the same': STAMP0 + round(1.29 * 1e9), 'earlier': STAMP0}[stamp]
    sequence[k] = (t, [joint_state(msg.name, msg.position, stamp_ns=stamp_ns)])
    flags, tracker = rest_flags(kin, sequence)
    by_receipts, _ = rest_flags(kin, backlogged(kin, stamps=False))
    assert rest_flags(kin, sequence[:k])[1].rest.by_stamps and not tracker.rest.by_stamps
    assert flags[:k] == rest_flags(kin, backlogged(kin, stamps=True)[:k])[0]  # by stamps up to the break
    assert all(by_receipts[i] for i in range(k, len(flags)) if flags[i])
    assert flags[-1]  # and they settle


def test_a_stamp_that_never_advances_does_not_keep_the_fingers_from_settling(kin: MicoKinematics) -> None:
    """A driver that stamps every message alike: by those stamps no time passes; by receipts the fingers settle."""
    sequence = [(t, [joint_state(msg.name, msg.position, stamp_ns=STAMP0)]) for t, (msg,) in closing(kin)]
    t, hand = settled_at(kin, sequence, 1.0)
    assert_array_equal(hand.fingers, FINGERS)


def test_the_mock_arms_close_stamped_gets_the_decisions_of_its_receipts(kin: MicoKinematics) -> None:
    """The mock arm's stream stamped at publication, received a constant 3 ms later: decided as by receipts alone.

    At every message the rest and fingers_settled decide as by receipts alone (the rule before stamps), for each
    close. Only differences of times are read, and here they are the same on both clocks, to the nanosecond.
    """
    for target in TARGETS:
        arm, tracker, receipts = MockArm(kin, [*HOME_Q, 0.0, 0.0, 0.0]), HandTracker(kin), HandTracker(kin)
        t, closed, decisions = 0.0, 1.0, []
        while t < closed + 2.0:
            t = round(t + DT, 9)
            if t == closed:
                arm.close_fingers(target)
            arm.step(t, DT)
            received = (round(t * 1e9) + 3_000_000) / 1e9  # receipt_ns gives back these whole nanoseconds
            tracker.add(joint_state(JOINTS, arm.q, arm.qd, stamp_ns=STAMP0 + round(t * 1e9)), received)
            receipts.add(joint_state(JOINTS, arm.q, arm.qd), received)
            hand, before = tracker.hand(), receipts.hand()
            assert hand is not None and before is not None
            decisions.append((hand.fingers_at_rest, before.fingers_at_rest, fingers_settled(hand, closed),
                              fingers_settled(before, closed)))
        assert tracker.rest.by_stamps and not receipts.rest.by_stamps
        assert all(d[0] == d[1] and d[2] == d[3] for d in decisions)
        assert any(d[2] for d in decisions) and not all(d[0] for d in decisions)


CLOSE_STALL = (0.9, 1.5)
"""A stall around the close at 1.0 s: what is published in [0.9, 1.5) is taken at 1.5 (> 1.0 + CLOSE_SETTLE)."""


def test_a_backlog_sampled_before_the_close_and_taken_after_it_is_not_the_settled_hand(kin: MicoKinematics) -> None:
    """The live benchmark's close read from a keep-100 queue that a stall left 0.6 s behind, taken in a burst.

    The burst's first joint state, sampled at 0.9 s with the fingers open and still for 0.9 s, is received 0.5 s
    after the close: by receipts it passes for a hand seen after the close, settled with open fingers. Judged by its
    stamp against the close's on the same clock, it was sampled before the close: the fingers settle where the
    close ends, as without a stall.
    """
    sequence, held = [], 0
    for t, (msg,) in closing(kin):
        stalled = CLOSE_STALL[0] <= t < CLOSE_STALL[1]
        sequence.append((CLOSE_STALL[1] + held * 1e-6 if stalled else t + 1e-3, stamped(t, msg)))
        held += stalled
    closed, closed_ns = 1.0, STAMP0 + 1_000_000_000
    by_receipts = by_stamps = None
    tracker = HandTracker(kin)
    for received, msg in sequence:
        tracker.add(msg, received)
        hand = tracker.hand()
        assert hand is not None and hand.stamp_ns == msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if by_receipts is None and fingers_settled(hand, closed):
            by_receipts = hand
        if by_stamps is None and fingers_settled(hand, closed, closed_ns=closed_ns):
            by_stamps, t_stamps = hand, received
    assert by_receipts is not None and by_stamps is not None
    assert by_receipts.received == CLOSE_STALL[1] and not np.any(by_receipts.fingers)  # open: the defect receipts allow
    assert_array_equal(by_stamps.fingers, FINGERS)
    assert t_stamps == settled_at(kin, [(t + 1e-3, [stamped(t, msg)]) for t, (msg,) in closing(kin)], 1.0)[0]


def test_a_hand_has_a_stamp_only_while_the_rest_goes_by_stamps(kin: MicoKinematics) -> None:
    """Unstamped, or once a stamp did not advance: no stamp, and fingers_settled goes by the receipts."""
    tracker = HandTracker(kin)
    tracker.add(arm_msg(stamp_ns=STAMP0 + 5), 0.0)
    tracker.add(finger_msg(stamp_ns=STAMP0 + 7), 0.0)
    assert tracker.hand().stamp_ns == STAMP0 + 5  # the oldest of the arm's and the fingers'
    tracker.add(arm_msg(), 0.01)
    assert tracker.hand().stamp_ns is None  # the arm's message is unstamped
    tracker.add(arm_msg(stamp_ns=STAMP0 + 9), 0.02)
    assert tracker.hand().stamp_ns == STAMP0 + 7
    tracker.add(finger_msg(stamp_ns=STAMP0 + 7), 0.03)  # does not advance: by receipts for good
    assert not tracker.rest.by_stamps and tracker.hand().stamp_ns is None
    hand = Hand(10.5, np.eye(4), FINGERS, True)
    assert fingers_settled(hand, 10.0, 0.5, closed_ns=STAMP0)  # no stamp: the receipt


def test_fingers_settled_needs_every_joint_received_settle_seconds_after_the_close_and_at_rest() -> None:
    def hand(received: float, at_rest: bool) -> Hand:
        return Hand(received, np.eye(4), FINGERS, at_rest)

    assert not fingers_settled(None, 10.0, 0.5)
    assert not fingers_settled(hand(math.nextafter(10.5, 0.0), True), 10.0, 0.5)  # perhaps before the close
    assert not fingers_settled(hand(10.75, False), 10.0, 0.5)  # still closing
    assert fingers_settled(hand(10.5, True), 10.0, 0.5)


def test_fingers_settled_given_the_close_on_the_stamps_clock_needs_every_joint_sampled_settle_seconds_after() -> None:
    def hand(received: float, stamp_ns: int, at_rest: bool = True) -> Hand:
        return Hand(received, np.eye(4), FINGERS, at_rest, stamp_ns)

    closed_ns = STAMP0 + 10_000_000_000
    assert fingers_settled(hand(10.5, closed_ns + 500_000_000), 10.0, 0.5, closed_ns=closed_ns)
    assert not fingers_settled(hand(99.0, closed_ns + 499_999_999), 10.0, 0.5, closed_ns=closed_ns)  # a backlog
    assert fingers_settled(hand(10.0, closed_ns + 500_000_000), 10.0, 0.5, closed_ns=closed_ns)  # the stamp decides
    assert not fingers_settled(hand(10.5, closed_ns + 500_000_000, at_rest=False), 10.0, 0.5, closed_ns=closed_ns)


def test_the_rest_rule_checks_its_amounts() -> None:
    for tolerance, window in ((-0.01, 0.5), (0.02, 0.0), (math.inf, 0.5), (0.02, math.inf), (math.nan, 0.5)):
        with pytest.raises(DataError, match='rest rule'):
            RestRule(tolerance, window)
