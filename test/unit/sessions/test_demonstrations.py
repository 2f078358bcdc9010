"""The demonstrations command: closes found in joint states, labels, rejections, and a mock-arm session end to end.

The rules (grasp_intent_ros.sessions.demonstrations' docstring) on hand-built message sequences, the joint states
as three kinds of driver publish them (exact velocities, none, noisy positions and velocities), then the proof:
the mock arm's dynamics driven to demonstrations of config/data/cup.csv at the default object pose, closed,
recorded with the session bag writer, read back by the command, and trained on.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import DataError
from grasp_intent_ros.method.data import load_csv
from grasp_intent_ros.method.intent import DEFAULT_TASKS
from grasp_intent_ros.mico.frames import (
    default_base_T_obj,
    features_to_obj_T_ee,
    matrix_to_pose,
    obj_T_ee_to_features,
    rotation_angle,
)
from grasp_intent_ros.mico.grasp import JOINT_NAMES
from grasp_intent_ros.mico.ik import IK_POS_TOL, IK_ROT_TOL
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm
from grasp_intent_ros.mico.parameters import MOCK_ARM
from grasp_intent_ros.mico.trajectory import TrajectoryCommand
from grasp_intent_ros.objects.train import train
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter
from grasp_intent_ros.sessions.demonstrations import (
    SETTLE_TOLERANCE,
    SETTLE_WINDOW,
    CloseRule,
    extract,
    main,
    parse_tasks,
)
from grasp_intent_ros.wire.topics import JOINT_STATES, OBJECT_POSE, OPERATOR_GRASP_TASKS

from ..session_bags import T, header, text

KIN = MicoKinematics()
BASE_T_OBJ = default_base_T_obj()
USAGE, TRANSFER, HANDOVER = 1, 2, 4
RATE = 100
"""The mock arm's joint_states rate (Hz), its node's default."""
DT = 1.0 / RATE


def joint_state(q: Any, qd: Any = None, names: Any = JOINT_NAMES) -> Any:
    """A rosbags JointState of ``names`` (default: the 6 arm joints and 3 fingers), positions and velocities.

    The velocities are zero by default.
    """
    q = np.asarray(q, dtype=np.float64)
    qd = np.zeros(q.size) if qd is None else np.asarray(qd, dtype=np.float64)
    return T['sensor_msgs/msg/JointState'](header=header(), name=list(names), position=q, velocity=qd,
                                           effort=np.array([], dtype=np.float64))


def pose(base_T_obj: Any = BASE_T_OBJ, frame: str = 'm1n6s300_link_base') -> Any:
    position, quaternion = matrix_to_pose(base_T_obj)
    point = T['geometry_msgs/msg/Point'](x=position[0], y=position[1], z=position[2])
    orientation = T['geometry_msgs/msg/Quaternion'](x=quaternion[0], y=quaternion[1], z=quaternion[2],
                                                    w=quaternion[3])
    return T['geometry_msgs/msg/PoseStamped'](header=header(frame), pose=T['geometry_msgs/msg/Pose'](
        position=point, orientation=orientation))


# ------------------------------------------------------------------ hand-built sequences
GRASP_X = np.array([0.13, -0.02, 0.07, -0.89, 0.17, -0.42, 4.54, 0.0, 0.0, 0.0])
GRASP_X[3:6] /= np.linalg.norm(GRASP_X[3:6])
Q_GRASP = KIN.ik(BASE_T_OBJ @ features_to_obj_T_ee(GRASP_X), HOME_Q).q
OPEN, CLOSED = np.zeros(3), np.array([1.0, 1.1, 0.9])  # CLOSED: mean closure 1 rad
POSITION_NOISE, VELOCITY_NOISE = 0.002, 0.01
"""A real driver's noise (standard deviations, rad and rad/s) on every joint, at rest and moving."""
DRIVERS = ('exact', 'positions only', 'noisy', 'split', 'partial')
"""How a driver publishes: the mock arm's exact positions and velocities (zero at rest), a ros2_control interface
with position state interfaces only (an empty ``velocity``), measured positions and velocities with noise, the
arm and the fingers in two messages (in reversed order, an extra joint with the arm, no velocities), or the
arm's joints over two messages, the second with the fingers, in other orders (noisy positions, no velocities)."""
EXTRA_JOINT = 'm1n6s300_joint_extra'


class Fingers:
    """The arm held at Q_GRASP while the fingers move and rest in turn, sampled every DT s at times k / RATE.

    ``states``: (t, finger positions, finger velocities) as the mock arm would publish them (the velocity of a
    moving finger its step over DT, exact zeros at rest).
    """

    def __init__(self, fingers: Any = OPEN) -> None:
        self.k, self.fingers = 0, np.asarray(fingers, dtype=np.float64)
        self.states: list[tuple[float, np.ndarray, np.ndarray]] = [(0.0, self.fingers, np.zeros(3))]

    @property
    def t(self) -> float:
        return self.k / RATE

    def rest(self, seconds: float) -> Fingers:
        for _ in range(round(seconds * RATE)):
            self.k += 1
            self.states.append((self.t, self.fingers, np.zeros(3)))
        return self

    def move(self, to: Any, speed: float = 1.0) -> Fingers:
        """To ``to`` at ``speed`` rad/s (the farthest finger's; the others in proportion), in whole steps."""
        start, to = self.fingers, np.asarray(to, dtype=np.float64)
        steps = math.ceil(round(float(np.max(np.abs(to - start))) / (speed * DT), 6))
        for i in range(1, steps + 1):
            self.k += 1
            previous, self.fingers = self.fingers, start + (to - start) * i / steps
            self.states.append((self.t, self.fingers, (self.fingers - previous) * RATE))
        return self

    def messages(self, driver: str = 'exact', seed: int = 0) -> list[tuple[str, float, Any]]:
        """The joint states as ``driver`` (one of DRIVERS) publishes them."""
        rng = np.random.default_rng(seed)
        messages = []
        for t, fingers, velocities in self.states:
            q, qd = np.array([*Q_GRASP, *fingers]), np.array([0.0] * 6 + list(velocities))
            if driver in ('noisy', 'partial'):
                q, qd = q + rng.normal(0.0, POSITION_NOISE, 9), qd + rng.normal(0.0, VELOCITY_NOISE, 9)
            if driver == 'split':  # the arm's first: each finger reading has the arm of its own time
                messages += [(JOINT_STATES, t, joint_state([0.5, *q[5::-1]], np.array([]),
                                                           [EXTRA_JOINT, *JOINT_NAMES[5::-1]])),
                             (JOINT_STATES, t, joint_state(q[:5:-1], np.array([]), JOINT_NAMES[:5:-1]))]
            elif driver == 'partial':
                halves = ([2, 0, 1], [3, 8, 4, 5, 7, 6])
                messages += [(JOINT_STATES, t, joint_state(q[half], np.array([]), [JOINT_NAMES[i] for i in half]))
                             for half in halves]
            else:
                messages.append((JOINT_STATES, t, joint_state(q, np.array([]) if driver == 'positions only' else qd)))
        return messages


def run(messages: list[tuple[str, float, Any]], *, tasks: int | None = USAGE, max_pose_age: float = math.inf,
        rule: CloseRule = CloseRule()) -> Any:
    return extract(sorted(messages, key=lambda m: m[1]), KIN, task_names=DEFAULT_TASKS, tasks=tasks,
                   max_pose_age=max_pose_age, rule=rule)


def features_at(messages: list[tuple[str, float, Any]], t: float) -> np.ndarray:
    """The features of the joint states received at ``t`` s: the hand's pose and its finger positions."""
    named = {name: float(p) for topic, t_msg, msg in messages if topic == JOINT_STATES and t_msg == t
             for name, p in zip(msg.name, msg.position)}
    q = np.array([named[name] for name in JOINT_NAMES])
    return obj_T_ee_to_features(np.linalg.inv(BASE_T_OBJ) @ KIN.fk(q[:6]), q[6:])


def closes(hand: Fingers) -> list[tuple[str, float, Any]]:
    """``hand`` at rest 1 s, closed to CLOSED, at rest 1 s (the first object pose 0.5 s in): one grasp."""
    return [(OBJECT_POSE, 0.505, pose()), *hand.rest(1.0).move(CLOSED).rest(1.0).messages()]


@pytest.mark.parametrize('driver', DRIVERS)
def test_a_close_is_found_on_the_positions_whatever_the_driver_publishes_as_velocities(driver: str) -> None:
    """One grasp at the first joint state with every finger still for SETTLE_WINDOW s, after 20 s at rest.

    The rest is long enough for the noise to matter (2000 joint states): it never makes a motion, and it does not
    keep the fingers from settling. Still means within SETTLE_TOLERANCE: the window's first joint state may be
    the close's last step or two (at 1 rad/s a finger moves 0.01 rad per joint state), so the grasp comes up to
    SETTLE_TOLERANCE / 1 rad/s before the fingers were SETTLE_WINDOW s at their closures, at a joint state after
    they reached them. Noisy, the features are those of the noisy joint state where the fingers settled.
    """
    hand = Fingers().rest(20.0).move(CLOSED)
    reached = hand.t
    messages = [(OBJECT_POSE, 21.005, pose()), *hand.rest(1.0).messages(driver)]
    found = run(messages, max_pose_age=1.0)
    assert len(found.grasps) == 1 and found.rejected == () and found.openings == 0
    grasp = found.grasps[0]
    assert reached + SETTLE_WINDOW - SETTLE_TOLERANCE - 1e-9 <= grasp.t <= reached + SETTLE_WINDOW  # 1e-9: rounding
    assert_allclose(grasp.x, features_at(messages, grasp.t), rtol=0.0, atol=1e-12)
    if driver not in ('noisy', 'partial'):
        assert_allclose(grasp.x[7:], CLOSED, rtol=0.0, atol=0.0)
        assert_allclose(grasp.x[:7], GRASP_X[:7], atol=2 * IK_ROT_TOL)
    assert (grasp.task_set, grasp.label) == (USAGE, '--tasks')


@pytest.mark.parametrize('driver', DRIVERS)
def test_a_slow_close_is_one_grasp_at_its_end(driver: str) -> None:
    """At 0.1 rad/s (10 s from open to CLOSED): the fingers move 0.05 rad per window, never still until the end."""
    hand = Fingers().rest(1.0).move(CLOSED, speed=0.1)
    reached = hand.t
    messages = [(OBJECT_POSE, 0.505, pose()), *hand.rest(1.0).messages(driver)]
    found = run(messages)
    assert len(found.grasps) == 1 and found.rejected == () and found.openings == 0
    assert reached <= found.grasps[0].t <= reached + SETTLE_WINDOW


def test_joint_states_held_up_and_written_in_a_burst_are_timed_by_their_stamps() -> None:
    """A recorder's backlog: what was published in [1.3, 1.9) s, mid-close, written just before 1.9 s, 1 us apart.

    By receive times (this test's constant stamps: no clock) the burst's first joint state has the one before the
    backlog within its window, 10 ms of motion: the fingers are called at rest mid-close, a grasp taken there, and
    the rest of the close is a second one. By the driver's stamps (the publication times) the close is one grasp,
    where the fingers stopped: the rule and its clock are the suite's (wire.joint_states).
    """
    def backlog(stamps: bool) -> list[tuple[str, float, Any]]:
        out, held = [], 0
        for topic, t, msg in closes(Fingers()):
            if topic == JOINT_STATES and stamps:
                stamp = T['builtin_interfaces/msg/Time'](sec=1_764_500_000 + math.floor(t), nanosec=round(t % 1 * 1e9))
                msg = T['sensor_msgs/msg/JointState'](header=T['std_msgs/msg/Header'](stamp=stamp, frame_id=''),
                                                      name=msg.name, position=msg.position, velocity=msg.velocity,
                                                      effort=msg.effort)
            if topic == JOINT_STATES and 1.3 <= t < 1.9:
                t, held = 1.8995 + held * 1e-6, held + 1
            out.append((topic, t, msg))
        return out

    by_receipts, by_stamps = run(backlog(stamps=False)), run(backlog(stamps=True))
    assert len(by_receipts.grasps) == 2 and np.all(by_receipts.grasps[0].x[7:] < 0.5 * CLOSED)
    assert len(by_stamps.grasps) == 1 and (by_stamps.rejected, by_stamps.openings) == ((), 0)
    assert_allclose(by_stamps.grasps[0].x[7:], CLOSED, rtol=0.0, atol=0.0)


def test_a_motion_slower_than_the_tolerance_over_the_window_is_a_rest() -> None:
    """The rule's stated limit: a finger slower than SETTLE_TOLERANCE / SETTLE_WINDOW is always at rest.

    At 0.03 rad/s the rest follows the fingers, and a rise of 0.6 rad is no close.
    """
    hand = Fingers().rest(1.0).move(CLOSED * 0.6, speed=0.03).rest(1.0)
    assert SETTLE_TOLERANCE / SETTLE_WINDOW > 0.03
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages()])
    assert (found.grasps, found.rejected, found.openings) == ((), (), 0)


def test_the_amounts_count_inclusively_and_times_compare_in_nanoseconds() -> None:
    """The bounds count: a rise of exactly ``rise``, a span of exactly ``tolerance``, a window of exactly ``window``.

    Dyadic amounts and closures, so every closure and span is exact; times k / RATE s, exact in nanoseconds.
    """
    rule = CloseRule(rise=0.25, tolerance=0.0625, window=0.5)
    hand = Fingers().rest(1.0)
    hand.fingers = np.full(3, 0.25)  # one step from the rest at 0: the mean closure rises by exactly 0.25
    for _ in range(100):  # then finger 1 wobbles by exactly 0.0625 below it
        hand.rest(1 / RATE).fingers = np.array([0.1875 if hand.k % 2 else 0.25, 0.25, 0.25])
    messages = [(OBJECT_POSE, 0.505, pose()), *hand.messages()]
    found = run(messages, rule=rule)
    assert [g.t for g in found.grasps] == [1.51]  # seen at 1.01, at rest once the joint state at 1.01 is 0.5 s old
    finer = run(messages, rule=dataclasses.replace(rule, tolerance=math.nextafter(0.0625, 0.0)))
    assert finer.grasps == () and finer.rejected[0].reasons[0].startswith('fingers never settled: the bag ends')
    higher = run(messages, rule=dataclasses.replace(rule, rise=math.nextafter(0.25, 1.0)))
    assert (higher.grasps, higher.rejected) == ((), ())


def test_a_twitch_below_the_close_rise_is_no_motion() -> None:
    hand = Fingers().rest(1.0).move(CLOSED * 0.15).move(OPEN).move(CLOSED * 0.15).rest(1.0)
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages('noisy')])
    assert (found.grasps, found.rejected, found.openings) == ((), (), 0)


def test_an_opening_is_no_grasp_and_no_rejection() -> None:
    hand = Fingers(CLOSED).rest(1.0).move(OPEN).rest(1.0)
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages()])
    assert (found.grasps, found.rejected, found.openings) == ((), (), 1)


def test_a_close_then_an_opening_is_a_grasp_then_an_opening() -> None:
    hand = Fingers().rest(1.0).move(CLOSED).rest(1.0).move(OPEN).rest(1.0)
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages('noisy')])
    assert (len(found.grasps), found.rejected, found.openings) == (1, (), 1)
    assert_allclose(found.grasps[0].x[7:], CLOSED, atol=5 * POSITION_NOISE)


def test_a_close_right_after_an_opening_is_found() -> None:
    hand = Fingers(CLOSED).rest(1.0).move(CLOSED * 0.5).move(CLOSED).rest(1.0)
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages()])
    assert (len(found.grasps), found.rejected, found.openings) == (1, (), 1)
    assert_allclose(found.grasps[0].x[7:], CLOSED)


@pytest.mark.parametrize('driver', DRIVERS)
def test_a_close_that_opens_before_settling_is_rejected(driver: str) -> None:
    """Closed to a mean closure of 0.5 rad, held 0.3 s (< SETTLE_WINDOW), opened: rejected, the opening counted.

    The fingers opened where the mean has fallen 0.2 rad from its highest: 0.22 s into the opening (the fastest
    finger, 1.1 times the mean, moves at 1 rad/s), within a step for the noise. The close is seen where the mean
    has risen 0.2 rad from the rest, which follows the fingers while they stay within SETTLE_TOLERANCE: 0.22 s into
    the close, up to SETTLE_TOLERANCE / 1 rad/s later.
    """
    hand = Fingers().rest(1.0).move(CLOSED * 0.5).rest(0.3)
    opened = hand.t
    found = run([(OBJECT_POSE, 0.505, pose()), *hand.move(OPEN).rest(1.0).messages(driver)])
    assert found.grasps == () and found.openings == 1 and len(found.rejected) == 1
    rejected = found.rejected[0]
    assert 1.22 - DT <= rejected.t <= 1.22 + SETTLE_TOLERANCE + DT
    t_opened = float(rejected.reasons[0].removeprefix('fingers never settled: they opened at ').removesuffix(' s'))
    assert t_opened == pytest.approx(opened + 0.22, abs=1.5 * DT)


@pytest.mark.parametrize('driver', DRIVERS)
def test_a_close_the_bag_ends_in_is_rejected(driver: str) -> None:
    """Cut while the fingers close, or at their closures but still for less than SETTLE_WINDOW."""
    for hand in (Fingers().rest(1.0).move(CLOSED * 0.5), Fingers().rest(1.0).move(CLOSED).rest(SETTLE_WINDOW - 0.1)):
        found = run([(OBJECT_POSE, 0.505, pose()), *hand.messages(driver)])
        assert found.grasps == () and len(found.rejected) == 1
        rejected = found.rejected[0]
        assert rejected.reasons == (f'fingers never settled: the bag ends {hand.t - rejected.t:.3f} s after the close '
                                    'began',)


@pytest.mark.parametrize(('pose_messages', 'reason'), [
    ([], 'no object pose'),
    ([(OBJECT_POSE, 0.505, pose())], 'stale object pose: the latest, at 0.505 s, is 2.'),
    ([(OBJECT_POSE, 1.505, pose()), (OBJECT_POSE, 1.605, pose(frame='world'))],
     "the latest object pose, at 1.605 s, is malformed: pose must be given in frame 'm1n6s300_link_base'"),
])
def test_a_close_without_a_usable_object_pose_is_rejected(pose_messages: list[Any], reason: str) -> None:
    hand = Fingers().rest(1.0).move(CLOSED).rest(1.0)
    found = run([*pose_messages, *hand.messages()], max_pose_age=1.0)
    assert found.grasps == () and len(found.rejected) == 1
    assert found.rejected[0].reasons[0].startswith(reason)
    assert len(run([*pose_messages, *hand.messages()]).grasps) == reason.startswith('stale')


@pytest.mark.parametrize('age', [0.3, 0.5, 0.7])
def test_a_pose_exactly_max_pose_age_old_is_used(age: float) -> None:
    """A pose received exactly ``max_pose_age`` s before the settled joint state is used (the next float down: not).

    Ages are compared in integer nanoseconds, so the rounding of the two times in s decides nothing.
    """
    hand = Fingers().rest(1.0).move(CLOSED).rest(1.0)
    k_grasp = round(run([(OBJECT_POSE, 0.505, pose()), *hand.messages()]).grasps[0].t * RATE)
    messages = [(OBJECT_POSE, (k_grasp - round(age * RATE)) / RATE, pose()), *hand.messages()]
    messages.sort(key=lambda m: (m[1], m[0] == JOINT_STATES))  # the pose first at its joint state's time
    for max_pose_age, found in ((age, 1), (math.nextafter(age, 0.0), 0)):
        assert len(extract(messages, KIN, task_names=DEFAULT_TASKS, tasks=USAGE, max_pose_age=max_pose_age).grasps) == (
            found)


def test_a_close_away_from_the_object_is_rejected() -> None:
    moved = BASE_T_OBJ.copy()
    moved[:3, 3] += [0.0, 0.0, 0.3]
    found = run([(OBJECT_POSE, 0.505, pose(moved)), *Fingers().rest(1.0).move(CLOSED).rest(1.0).messages()])
    assert found.grasps == ()
    assert found.rejected[0].reasons == ('the hand is not at the object: palm_z = -0.2300 outside the feature bounds',)


def session(*labels: tuple[float, str]) -> list[tuple[str, float, Any]]:
    """Three closes 4 s apart, each opened again; the object pose every second at k + 0.005 s; ``labels`` (t, text).

    Each close starts at 1.5, 5.5 and 9.5 s (seen about 0.22 s later), reaches CLOSED 1.1 s later and stays 0.8 s
    (settled after 0.5 s), then opens in 1.1 s and stays open 0.5 s.
    """
    hand = Fingers().rest(1.0)
    for _ in range(3):
        hand.rest(0.5).move(CLOSED).rest(0.8).move(OPEN).rest(0.5)
    return [*hand.messages(), *[(OBJECT_POSE, k + 0.005, pose()) for k in range(round(hand.t) + 1)],
            *[(OPERATOR_GRASP_TASKS, t, text(value)) for t, value in labels]]


def test_a_label_message_labels_the_next_close_only() -> None:
    messages = session((1.25, 'usage, transfer'), (5.25, 'handover'))
    found = run(messages, tasks=TRANSFER)
    assert [(g.task_set, g.label) for g in found.grasps] == [
        (USAGE | TRANSFER, 'label at 1.250 s'), (HANDOVER, 'label at 5.250 s'), (TRANSFER, '--tasks')]
    assert found.rejected == () and found.notes == () and found.openings == 3
    unlabelled = run(messages, tasks=None)
    assert [g.task_set for g in unlabelled.grasps] == [USAGE | TRANSFER, HANDOVER]
    assert [r.reasons for r in unlabelled.rejected] == [('unlabelled: no label before the close and no --tasks',)]


def test_a_label_received_during_a_close_labels_the_next_one() -> None:
    for t in (1.8, 4.0):  # after the first close was seen; during the first opening
        found = run(session((1.25, 'usage'), (t, 'handover')), tasks=None)
        assert [g.task_set for g in found.grasps] == [USAGE, HANDOVER] and found.notes == ()


def test_a_replaced_or_unknown_label_is_reported() -> None:
    replaced = run(session((0.25, 'usage'), (1.25, 'handover')), tasks=None)
    assert [g.task_set for g in replaced.grasps] == [HANDOVER]
    assert replaced.notes == ('the label at 0.250 s is replaced by the one at 1.250 s before any close',)
    unknown = run(session((1.25, 'usage,pour')), tasks=None)
    assert unknown.grasps == ()
    assert unknown.rejected[0].reasons == (
        'the label at 1.250 s: unknown task(s) pour in \'usage,pour\'; tasks: usage, transfer, handover',)


def test_a_malformed_joint_state_is_a_bad_session() -> None:
    bad = joint_state([*Q_GRASP, 0.0, 0.0, math.nan])
    with pytest.raises(DataError, match='malformed joint_states message at 0.305 s: .*finite'):
        run([*Fingers().rest(1.0).messages(), (JOINT_STATES, 0.305, bad)])


@pytest.mark.parametrize(('rise', 'tolerance', 'window'), [
    (0.2, 0.2, 0.5), (0.2, -0.01, 0.5), (0.2, 0.02, 0.0), (math.inf, 0.02, 0.5), (0.2, 0.02, math.nan)])
def test_a_close_rule_refuses_amounts_that_tell_nothing(rise: float, tolerance: float, window: float) -> None:
    with pytest.raises(DataError):
        CloseRule(rise, tolerance, window)
    assert CloseRule(0.2, 0.0, 0.01) == CloseRule(rise=0.2, tolerance=0.0, window=0.01)


@pytest.mark.parametrize('text_', ['', 'usage,,transfer', 'usage,usage', 'pour'])
def test_parse_tasks_refuses_what_is_no_task_set(text_: str) -> None:
    with pytest.raises(DataError):
        parse_tasks(text_, DEFAULT_TASKS)
    assert parse_tasks(' handover ,usage', DEFAULT_TASKS) == USAGE | HANDOVER


# ------------------------------------------------------------------ the mock arm, end to end
def demonstration_rows(count_per_set: int) -> list[tuple[np.ndarray, int]]:
    """The first ``count_per_set`` demonstrations of config/data/cup.csv of each single task set."""
    demos = load_csv(config_dir() / 'data' / 'cup.csv')
    rows = []
    for task_set in (USAGE, TRANSFER, USAGE | TRANSFER):
        rows += [(demos.x[i], task_set) for i in np.flatnonzero(demos.task_sets == task_set)[:count_per_set]]
    return rows


def record_session(path: Path, rows: list[tuple[np.ndarray, int]], closure_error: float,
                   rng: np.random.Generator) -> list[np.ndarray]:
    """Drive the mock arm to each demonstration, close, open: a session bag as the recorder writes one.

    Joint states every DT s, the object pose at 10 Hz, a label before each close but the first (its task set
    comes from --tasks). Returns the executed closures of each close (the plan's plus the closure error).
    """
    arm = MockArm(KIN, [*HOME_Q, 0.0, 0.0, 0.0])
    executed, t = [], 0.0
    with SessionWriter(path) as bag:
        for topic, msgtype in ((JOINT_STATES, 'sensor_msgs/msg/JointState'),
                               (OBJECT_POSE, 'geometry_msgs/msg/PoseStamped'),
                               (OPERATOR_GRASP_TASKS, 'std_msgs/msg/String')):
            bag.add_topic(f'/{topic}', msgtype, qos=QosSpec())

        def advance(until: Any) -> None:
            nonlocal t
            while not until():
                t += DT
                arm.step(t, DT)
                stamp = round(t * 1e9)
                bag.write_message('/joint_states', stamp, joint_state(arm.q, arm.qd))
                if round(t / DT) % 10 == 0:
                    bag.write_message('/object/pose', stamp, pose())

        for k, (x, task_set) in enumerate(rows):
            ik = KIN.ik(BASE_T_OBJ @ features_to_obj_T_ee(x), arm.q[:6])
            assert ik.success, ik.message
            arm.command_trajectory(TrajectoryCommand(JOINT_NAMES, [3.0], [[*ik.q, 0.0, 0.0, 0.0]], [[]], [[]]), t)
            advance(lambda: arm.mode == 'hold')
            if k > 0:
                label = ','.join(name for i, name in enumerate(DEFAULT_TASKS) if task_set >> i & 1)
                bag.write_message(f'/{OPERATOR_GRASP_TASKS}', round(t * 1e9) + 1, text(label))
            executed.append(arm.close_fingers(x[7:] + rng.normal(0.0, closure_error, 3)))
            advance(lambda: not np.any(arm.qd[6:]) and np.array_equal(arm.q[6:], executed[-1]))
            rest_until = t + 2 * SETTLE_WINDOW
            advance(lambda: t >= rest_until)
    return executed


def test_demonstrations_recorded_on_the_mock_arm_come_back_as_their_features(tmp_path: Path, capsys: Any) -> None:
    """Demonstrations driven on the mock arm, closed, recorded, extracted: the known features within tolerances.

    The tolerances: the mock arm's state is the commanded position (a trajectory ends exactly at its IK answer),
    so the hand's pose is the demonstration's within IK's tolerances (IK_POS_TOL m, IK_ROT_TOL rad: position
    and rotation angle), plus the CSV's 6 decimals; the fingers are the executed closures (the demonstration's
    plus the mock arm's closure error, drawn here as its node draws it) within the CSV's rounding, never the
    plan's.
    """
    rows = demonstration_rows(2)
    closure_error = next(spec.default for spec in MOCK_ARM if spec.name == 'closure_error')
    executed = record_session(tmp_path / 'session', rows, closure_error, np.random.default_rng(3))
    csv = tmp_path / 'demos.csv'
    assert main([str(tmp_path / 'session'), '--out', str(csv), '--tasks', 'usage', '--task-names',
                 'usage,transfer']) == 0
    printed = capsys.readouterr().out
    assert f'{len(rows)} grasp(s), 0 close(s) rejected, {len(rows) - 1} opening(s)' in printed
    demos = load_csv(csv)
    assert demos.task_names == ('usage', 'transfer')
    assert demos.task_sets.tolist() == [task_set for _, task_set in rows]
    rounding = 5e-7
    for x, (x_known, _), closures in zip(demos.x, rows, executed):
        obj_T_ee, obj_T_known = features_to_obj_T_ee(x), features_to_obj_T_ee(x_known)
        assert np.linalg.norm(obj_T_ee[:3, 3] - obj_T_known[:3, 3]) <= IK_POS_TOL + 2 * rounding
        assert rotation_angle(obj_T_known[:3, :3], obj_T_ee[:3, :3]) <= IK_ROT_TOL + 1e-5  # + rounding of x
        assert_allclose(x[7:], closures, atol=rounding)
        assert np.any(np.abs(x[7:] - x_known[7:]) > rounding)  # the executed closures, not the plan's
    model, _, _ = train(csv, 'U,T,UT', out=tmp_path / 'model.yaml')
    assert model.task_names == ('usage', 'transfer') and model.zones == (USAGE, TRANSFER, USAGE | TRANSFER)


def test_the_command_appends_refuses_and_exits_as_documented(tmp_path: Path, capsys: Any) -> None:
    rows = demonstration_rows(1)[:1]
    record_session(tmp_path / 'session', rows, 0.0, np.random.default_rng(0))
    csv = tmp_path / 'demos.csv'
    session = str(tmp_path / 'session')
    assert main([session, '--out', str(csv)]) == 1  # the one close is unlabelled: nothing written
    assert 'rejected: unlabelled' in capsys.readouterr().out and not csv.exists()
    assert main([session, '--out', str(csv), '--tasks', 'usage']) == 0
    assert main([session, '--out', str(csv), '--tasks', 'usage']) == 2  # exists
    assert 'exists: --append adds to it' in capsys.readouterr().err
    assert main([session, '--out', str(csv), '--tasks', 'usage', '--append']) == 0
    assert len(load_csv(csv)) == 2
    assert main([session, '--out', str(csv), '--append', '--task-names', 'a,b']) == 2
    assert main([str(tmp_path / 'no_bag'), '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage']) == 2
    assert 'cannot read bag' in capsys.readouterr().err
    assert main([session, '--out', str(tmp_path / 'x.csv'), '--tasks', 'pour']) == 2
    assert main([session, '--out', str(tmp_path / 'x.csv'), '--max-pose-age', '0']) == 2
    assert main([session, '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage', '--settle-tolerance', '0.2']) == 2
    assert 'the close rule needs 0 <= settle tolerance < close rise' in capsys.readouterr().err
    assert main([session, '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage', '--settle-window', '0']) == 2
    assert main([session, '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage', '--close-rise', '1.6']) == 1
    assert '0 grasp(s), 0 close(s) rejected, 0 opening(s)' in capsys.readouterr().out  # no mean closure rises 1.6
    with SessionWriter(tmp_path / 'poses_only') as bag:
        bag.add_topic('/object/pose', 'geometry_msgs/msg/PoseStamped', qos=QosSpec())
        bag.write_message('/object/pose', 1, pose())
    assert main([str(tmp_path / 'poses_only'), '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage']) == 2
    assert 'has no /joint_states' in capsys.readouterr().err and not (tmp_path / 'x.csv').exists()
