"""The demonstrations command: closes found in joint states, labels, rejections, and a mock-arm session end to end.

The rules (grasp_intent_ros.sessions.demonstrations' docstring) on hand-built message sequences, then the proof:
the mock arm's dynamics driven to demonstrations of config/data/cup.csv at the default object pose, closed,
recorded with the session bag writer, read back by the command, and trained on.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import DataError
from grasp_intent_ros.method.data import load_csv
from grasp_intent_ros.method.intent import DEFAULT_TASKS
from grasp_intent_ros.mico.frames import default_base_T_obj, features_to_obj_T_ee, matrix_to_pose, obj_T_ee_to_features
from grasp_intent_ros.mico.grasp import JOINT_NAMES
from grasp_intent_ros.mico.kinematics import HOME_Q, IK_POS_TOL, IK_ROT_TOL, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm, TrajectoryCommand
from grasp_intent_ros.mico.parameters import MOCK_ARM
from grasp_intent_ros.objects.train import train
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter
from grasp_intent_ros.sessions.demonstrations import extract, main, parse_tasks
from grasp_intent_ros.wire.robot_state import CLOSE_SETTLE
from grasp_intent_ros.wire.topics import JOINT_STATES, OBJECT_POSE, OPERATOR_GRASP_TASKS

from ..session_bags import T, header, text

KIN = MicoKinematics()
BASE_T_OBJ = default_base_T_obj()
USAGE, TRANSFER, HANDOVER = 1, 2, 4
DT = 0.01
"""The mock arm's joint_states period (s), its node's default."""


def joint_state(q: Any, qd: Any = None) -> Any:
    """A rosbags JointState of the 6 arm joints and 3 fingers (positions, velocities: zero by default)."""
    q = np.asarray(q, dtype=np.float64)
    qd = np.zeros(9) if qd is None else np.asarray(qd, dtype=np.float64)
    return T['sensor_msgs/msg/JointState'](header=header(), name=list(JOINT_NAMES), position=q, velocity=qd,
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
CLOSED = np.array([1.0, 1.1, 0.9])


def finger_motion(t0: float, start: Any, end: Any, *, q_arm: Any = Q_GRASP, speed: float = 1.0,
                  rest: float = 0.5) -> list[tuple[str, float, Any]]:
    """Joint states every DT s from ``t0``: fingers from ``start`` to ``end`` at ``speed`` rad/s, then at rest."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    steps = math.ceil(float(np.max(np.abs(end - start))) / (speed * DT))
    messages, fingers = [], start.copy()
    for k in range(1, steps + 1):
        previous, fingers = fingers, start + (end - start) * k / steps
        messages.append((JOINT_STATES, t0 + k * DT, joint_state([*q_arm, *fingers], [0.0] * 6 + list(
            (fingers - previous) / DT))))
    t_end = t0 + steps * DT
    messages += [(JOINT_STATES, t_end + k * DT, joint_state([*q_arm, *end])) for k in range(1, round(rest / DT) + 1)]
    return messages


def at_rest(t0: float, fingers: Any = (0.0, 0.0, 0.0), seconds: float = 0.2) -> list[tuple[str, float, Any]]:
    return [(JOINT_STATES, t0 + k * DT, joint_state([*Q_GRASP, *fingers])) for k in range(round(seconds / DT))]


def close_at(t0: float) -> list[tuple[str, float, Any]]:
    """Open fingers at rest, then closed to CLOSED: the close starts at ``t0 + DT``."""
    return [*finger_motion(t0, (0.0, 0.0, 0.0), CLOSED)]


def run(messages: list[tuple[str, float, Any]], *, tasks: int | None = USAGE, max_pose_age: float = 1.0) -> Any:
    return extract(sorted(messages, key=lambda m: m[1]), KIN, task_names=DEFAULT_TASKS, tasks=tasks,
                   max_pose_age=max_pose_age)


def test_a_close_that_settles_is_a_grasp_at_its_first_settled_joint_state() -> None:
    messages = [*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), *close_at(1.0)]
    found = run(messages)
    assert len(found.grasps) == 1 and found.rejected == () and found.openings == 0
    grasp = found.grasps[0]
    # the fingers reach CLOSED after 1.1 s (> CLOSE_SETTLE): the first joint state at rest after that
    assert grasp.t == pytest.approx(1.0 + 1.1 + DT)
    expected = obj_T_ee_to_features(np.linalg.inv(BASE_T_OBJ) @ KIN.fk(Q_GRASP), CLOSED)
    assert_allclose(grasp.x, expected, atol=1e-12)
    assert_allclose(grasp.x[:7], GRASP_X[:7], atol=2 * IK_ROT_TOL)
    assert (grasp.task_set, grasp.label) == (USAGE, '--tasks')


def test_rest_within_the_settle_time_does_not_end_a_close() -> None:
    small = CLOSED * 0.1  # at rest 0.11 s after the close began: settled only CLOSE_SETTLE s after it
    motion = finger_motion(1.0, (0.0, 0.0, 0.0), small)
    found = run([*at_rest(0.0), (OBJECT_POSE, 0.9, pose()), *motion])
    start = motion[0][1]
    assert [g.t for g in found.grasps] == [next(t for _, t, _ in motion if t >= start + CLOSE_SETTLE)]
    assert found.grasps[0].t == pytest.approx(start + CLOSE_SETTLE, abs=DT)
    assert_allclose(found.grasps[0].x[7:], small)


def test_an_opening_is_no_grasp_and_no_rejection() -> None:
    found = run([*at_rest(0.0, CLOSED), (OBJECT_POSE, 1.5, pose()), *finger_motion(1.0, CLOSED, (0.0, 0.0, 0.0))])
    assert (found.grasps, found.rejected, found.openings) == ((), (), 1)


def test_a_close_right_after_an_opening_is_found() -> None:
    opening = finger_motion(1.0, CLOSED, CLOSED * 0.5, rest=0.0)
    found = run([*at_rest(0.0, CLOSED), (OBJECT_POSE, 1.5, pose()), *opening,
                 *finger_motion(opening[-1][1], CLOSED * 0.5, CLOSED)])
    assert (len(found.grasps), found.rejected, found.openings) == (1, (), 1)
    assert_allclose(found.grasps[0].x[7:], CLOSED)


def test_a_close_that_opens_or_ends_the_bag_before_settling_is_rejected() -> None:
    opened = run([*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), *finger_motion(1.0, (0.0, 0.0, 0.0), CLOSED * 0.1,
                                                                            rest=0.1),
                  *finger_motion(1.21, CLOSED * 0.1, (0.0, 0.0, 0.0))])
    assert opened.grasps == () and opened.openings == 1
    assert [(r.t, r.reasons) for r in opened.rejected] == [
        (pytest.approx(1.0 + DT), ('fingers never settled: they opened at 1.220 s',))]
    cut = run([*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), *close_at(1.0)[:50]])
    assert cut.grasps == () and len(cut.rejected) == 1
    assert cut.rejected[0].reasons[0].startswith('fingers never settled: the bag ends 0.490 s after the close')


@pytest.mark.parametrize(('pose_messages', 'reason'), [
    ([], 'no object pose'),
    ([(OBJECT_POSE, 0.5, pose())], 'stale object pose: the latest, at 0.500 s, is 1.610 s old (at most 1 s)'),
    ([(OBJECT_POSE, 1.5, pose()), (OBJECT_POSE, 1.6, pose(frame='world'))],
     "the latest object pose, at 1.600 s, is malformed: pose must be given in frame 'm1n6s300_link_base'"),
])
def test_a_close_without_a_usable_object_pose_is_rejected(pose_messages: list[Any], reason: str) -> None:
    found = run([*at_rest(0.0), *pose_messages, *close_at(1.0)])
    assert found.grasps == () and len(found.rejected) == 1
    assert found.rejected[0].reasons[0].startswith(reason)
    assert len(run([*at_rest(0.0), *pose_messages, *close_at(1.0)], max_pose_age=math.inf).grasps) == (
        reason.startswith('stale'))


def test_a_pose_exactly_max_pose_age_old_is_used() -> None:
    grasp_t = 1.0 + 1.1 + DT
    assert len(run([*at_rest(0.0), (OBJECT_POSE, grasp_t - 0.5, pose()), *close_at(1.0)], max_pose_age=0.5).grasps)


def test_a_close_away_from_the_object_is_rejected() -> None:
    moved = BASE_T_OBJ.copy()
    moved[:3, 3] += [0.0, 0.0, 0.3]
    found = run([*at_rest(0.0), (OBJECT_POSE, 1.5, pose(moved)), *close_at(1.0)])
    assert found.grasps == ()
    assert found.rejected[0].reasons == ('the hand is not at the object: palm_z = -0.2300 outside the feature bounds',)


def test_a_label_message_labels_the_next_close_only() -> None:
    label = (OPERATOR_GRASP_TASKS, 0.8, text('usage, transfer'))
    messages = [*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), label, *close_at(1.0),
                *finger_motion(2.7, CLOSED, (0.0, 0.0, 0.0)),  # an opening does not take a label
                (OPERATOR_GRASP_TASKS, 4.0, text('handover')), *close_at(4.5), (OBJECT_POSE, 5.0, pose()),
                *finger_motion(6.2, CLOSED, (0.0, 0.0, 0.0)), *close_at(7.5), (OBJECT_POSE, 8.0, pose())]
    found = run(messages, tasks=TRANSFER)
    assert [(g.task_set, g.label) for g in found.grasps] == [
        (USAGE | TRANSFER, 'label at 0.800 s'), (HANDOVER, 'label at 4.000 s'), (TRANSFER, '--tasks')]
    assert found.rejected == () and found.notes == ()
    unlabelled = run(messages, tasks=None)
    assert [g.task_set for g in unlabelled.grasps] == [USAGE | TRANSFER, HANDOVER]
    assert [r.reasons for r in unlabelled.rejected] == [('unlabelled: no label before the close and no --tasks',)]


def test_a_label_received_during_a_close_labels_the_next_one() -> None:
    messages = [*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), (OPERATOR_GRASP_TASKS, 0.8, text('usage')),
                *close_at(1.0), (OPERATOR_GRASP_TASKS, 1.5, text('handover')),
                *finger_motion(2.7, CLOSED, (0.0, 0.0, 0.0)), *close_at(4.5), (OBJECT_POSE, 5.0, pose())]
    found = run(messages, tasks=None)
    assert [g.task_set for g in found.grasps] == [USAGE, HANDOVER] and found.notes == ()


def test_a_replaced_or_unknown_label_is_reported() -> None:
    replaced = run([*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), (OPERATOR_GRASP_TASKS, 0.6, text('usage')),
                    (OPERATOR_GRASP_TASKS, 0.7, text('handover')), *close_at(1.0)])
    assert [g.task_set for g in replaced.grasps] == [HANDOVER]
    assert replaced.notes == ('the label at 0.600 s is replaced by the one at 0.700 s before any close',)
    unknown = run([*at_rest(0.0), (OBJECT_POSE, 1.5, pose()), (OPERATOR_GRASP_TASKS, 0.6, text('usage,pour')),
                   *close_at(1.0)])
    assert unknown.grasps == ()
    assert unknown.rejected[0].reasons == (
        'the label at 0.600 s: unknown task(s) pour in \'usage,pour\'; tasks: usage, transfer, handover',)


def test_a_malformed_joint_state_is_a_bad_session() -> None:
    bad = joint_state([*Q_GRASP, 0.0, 0.0, math.nan])
    with pytest.raises(DataError, match='malformed joint_states message at 0.300 s: .*finite'):
        run([*at_rest(0.0), (JOINT_STATES, 0.3, bad)])


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
            rest_until = t + 2 * CLOSE_SETTLE
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
        cos_angle = (np.trace(obj_T_known[:3, :3].T @ obj_T_ee[:3, :3]) - 1.0) / 2.0
        assert math.acos(min(cos_angle, 1.0)) <= IK_ROT_TOL + 1e-5  # + the rounding of approach and roll
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
    with SessionWriter(tmp_path / 'poses_only') as bag:
        bag.add_topic('/object/pose', 'geometry_msgs/msg/PoseStamped', qos=QosSpec())
        bag.write_message('/object/pose', 1, pose())
    assert main([str(tmp_path / 'poses_only'), '--out', str(tmp_path / 'x.csv'), '--tasks', 'usage']) == 2
    assert 'has no /joint_states' in capsys.readouterr().err and not (tmp_path / 'x.csv').exists()
