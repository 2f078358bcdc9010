"""Closed-loop sessions read for replay, and their outcome compared (sessions.closed_loop; no rclpy)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.sessions.closed_loop import (
    AHEAD_NS,
    AHEAD_TOPICS,
    REACH_POS,
    W_TOLERANCE,
    compare_outcomes,
    is_closed_loop,
    load_closed_loop,
    outcome,
)
from grasp_intent_ros.sessions.outputs import SessionError
from grasp_intent_ros.sessions.pairing import compact_session

from ..session_bags import (
    ARM,
    MS,
    SHA_B,
    T,
    diagnostics,
    f64,
    header,
    joint_msg,
    model_doc,
    session_messages,
    twist_msg,
    write_bag,
)

Q_END = np.array([4.6, 3.1, 1.2, 4.0, 1.6, 1.1])
"""Where the recorded arm ends; the recorded grasp is its hand pose."""
STEPS = 20


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def grasp_msg(base_T: np.ndarray) -> Any:
    x, y, z, w = pin.Quaternion(base_T[:3, :3]).coeffs()
    point = T['geometry_msgs/msg/Point'](x=base_T[0, 3], y=base_T[1, 3], z=base_T[2, 3])
    pose = T['geometry_msgs/msg/Pose'](position=point, orientation=T['geometry_msgs/msg/Quaternion'](x=x, y=y, z=z,
                                                                                                     w=w))
    return T['geometry_msgs/msg/PoseStamped'](header=header(), pose=pose)


def arm(q: np.ndarray) -> Any:
    return joint_msg([*q, 0.0, 0.0, 0.0])


def loop_messages(kin: MicoKinematics, *, end: np.ndarray = Q_END) -> list[tuple[str, Any]]:
    """A recorded closed loop: the arm walks from Home to ``end`` in STEPS operator twists.

    Model, a joint state at Home, w and its grasp, then per operator twist the blended twist, alpha and the
    arm moved 1/STEPS of the way; a model switch half way.
    """
    messages: list[tuple[str, Any]] = [('model/active', model_doc('cup_7zone')), ('joint_states', arm(HOME_Q)),
                                       ('intent/w', f64([0.9, 0.1, 0.1])), ('grasp/pose', grasp_msg(kin.fk(Q_END)))]
    for k in range(1, STEPS + 1):
        messages += [('operator/twist', twist_msg(0.01 * k)), ('assistance/twist', twist_msg(0.02 * k)),
                     ('assistance/alpha', T['std_msgs/msg/Float64'](data=0.5)),
                     ('joint_states', arm(HOME_Q + (end - HOME_Q) * k / STEPS))]
        if k == STEPS // 2:
            messages.append(('model/active', model_doc('cup_5zone', SHA_B, 2)))
    return messages


def test_a_session_with_operator_twists_is_closed_loop(tmp_path: Path, kin: MicoKinematics) -> None:
    assert is_closed_loop(write_bag(tmp_path / 'loop', loop_messages(kin)))
    plain = write_bag(tmp_path / 'plain', session_messages())
    assert not is_closed_loop(plain)
    with pytest.raises(SessionError):
        load_closed_loop(plain)


def test_the_replay_sends_the_operator_and_intent_inputs_in_order_and_never_the_arms_joint_states(
        tmp_path: Path, kin: MicoKinematics) -> None:
    session = load_closed_loop(write_bag(tmp_path / 'loop', loop_messages(kin)))
    assert session.initial_model is not None and session.initial_model.name == 'cup_7zone'
    topics = [send.topic for send in session.sends]
    half = STEPS // 2
    assert topics == ['intent/w', *['operator/twist'] * half, 'model/active', *['operator/twist'] * (STEPS - half)]
    assert [send.model for send in session.sends if send.model is not None] == ['cup_5zone']
    assert all(a.t_ns < b.t_ns for a, b in zip(session.sends, session.sends[1:]))
    assert len(session.trace.joints) == STEPS + 1 and len(session.trace.operator) == STEPS


def test_the_outcome_says_when_the_hand_reached_the_last_grasp(tmp_path: Path, kin: MicoKinematics) -> None:
    messages = loop_messages(kin)
    result = outcome(load_closed_loop(write_bag(tmp_path / 'loop', messages)).trace, kin)
    assert result.ends_at_grasp
    np.testing.assert_allclose(result.start_q, HOME_Q, atol=1e-12)
    grasp = kin.fk(Q_END)

    def at_grasp(q: np.ndarray) -> bool:
        hand = kin.fk(q)
        return (np.linalg.norm(hand[:3, 3] - grasp[:3, 3]) <= 0.01
                and np.linalg.norm(pin.log3(grasp[:3, :3] @ hand[:3, :3].T)) <= 0.1)

    first_twist = next(k for k, (topic, _) in enumerate(messages) if topic == 'operator/twist')
    first_there = next(k for k, (topic, msg) in enumerate(messages)
                       if topic == 'joint_states' and k > first_twist and at_grasp(np.asarray(msg.position[:6])))
    assert first_there > first_twist + 4  # not at the first step: a path was walked
    assert result.reached_s == pytest.approx((first_there - first_twist) * MS * 1e-9)  # write_bag: 1 ms apart
    assert result.alpha_mean == 0.5 and result.blended == STEPS - 1  # the last blended twist follows the last twist
    assert compare_outcomes(result, result) == []


def test_a_live_loop_that_ends_elsewhere_or_plans_another_grasp_fails_the_comparison(
        tmp_path: Path, kin: MicoKinematics) -> None:
    recorded = outcome(load_closed_loop(write_bag(tmp_path / 'rec', loop_messages(kin))).trace, kin)
    far = Q_END + np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    away = outcome(load_closed_loop(write_bag(tmp_path / 'far', loop_messages(kin, end=far))).trace, kin)
    assert not away.ends_at_grasp
    assert np.linalg.norm(away.final_hand[:3, 3] - recorded.final_grasp[:3, 3]) > REACH_POS
    (problem,) = compare_outcomes(recorded, away)
    assert problem.startswith('the recorded hand ended at the grasp; the live one did not')
    moved = recorded.final_grasp.copy()
    moved[0, 3] += 2e-3
    other_grasp = outcome(load_closed_loop(write_bag(tmp_path / 'other', [
        *loop_messages(kin), ('grasp/pose', grasp_msg(moved))])).trace, kin)
    assert any(p.startswith('last grasp: live 2.00 mm') for p in compare_outcomes(recorded, other_grasp))
    late_start = [(t, m) if t != 'joint_states' or k != 1 else (t, arm(HOME_Q + 0.01))
                  for k, (t, m) in enumerate(loop_messages(kin))]
    moved_start = outcome(load_closed_loop(write_bag(tmp_path / 'start', late_start)).trace, kin)
    assert any('from the recorded start' in p for p in compare_outcomes(recorded, moved_start))



def split_arm(messages: list[tuple[str, Any]]) -> list[tuple[str, Any]]:
    """``messages`` with each joint state split as two publishers may send it.

    Joints 1-3 with the fingers, then 4-6 (in reversed order, with a joint the suite does not know).
    """
    out = []
    for topic, msg in messages:
        if topic != 'joint_states':
            out.append((topic, msg))
            continue
        q = list(msg.position)
        out += [(topic, joint_msg([*q[:3], *q[6:]], (*ARM[:3], *ARM[6:]))),
                (topic, joint_msg([*q[5:2:-1], 9.0], (*ARM[5:2:-1], 'm1n6s300_joint_extra')))]
    return out


def test_the_arm_of_split_joint_states_is_traced_as_the_nodes_read_it(tmp_path: Path, kin: MicoKinematics) -> None:
    """Each arm joint's latest position, from whichever message named it last, as the nodes read the arm.

    A reading at each message that names an arm joint once all are known (the first half of a step's with the last
    step's other half, then the whole). The outcome is the one-message session's; the fingers' message alone, or a
    malformed one, adds nothing. (The tracer before read only messages with every arm joint: none here.)
    """
    one = load_closed_loop(write_bag(tmp_path / 'one', loop_messages(kin))).trace
    messages = split_arm(loop_messages(kin))
    fingers_only = joint_msg([0.1, 0.1, 0.1], ARM[6:])
    bad = joint_msg([0.0] * 2, ARM[:3])  # 3 names, 2 positions
    split = load_closed_loop(write_bag(tmp_path / 'split', [*messages, ('joint_states', fingers_only),
                                                            ('joint_states', bad)])).trace
    assert len(split.joints) == 2 * len(one.joints) - 1  # the first message alone: joints 4-6 unknown yet
    for (_, q_one), (_, q_split) in zip(one.joints, split.joints[::2]):
        np.testing.assert_array_equal(q_split, q_one)
    np.testing.assert_array_equal(split.joints[1][1], [*one.joints[1][1][:3], *one.joints[0][1][3:]])
    recorded, live = outcome(one, kin), outcome(split, kin)
    np.testing.assert_array_equal(live.start_q, recorded.start_q)
    np.testing.assert_array_equal(live.final_hand, recorded.final_hand)
    assert live.ends_at_grasp and compare_outcomes(recorded, live) == []


def estimated_messages(kin: MicoKinematics, w_end: list[float]) -> list[tuple[str, Any]]:
    """:func:`loop_messages` with the intent estimator's status first and its w after every operator twist."""
    out: list[tuple[str, Any]] = [('/diagnostics', diagnostics('/intent_estimator: intent estimator', received=0,
                                                              rejected=0))]
    for topic, msg in loop_messages(kin):
        out.append((topic, msg))
        if topic == 'operator/twist':
            out.append(('intent/w', f64([0.5, 0.5, 0.5])))
    return [*out, ('intent/w', f64(w_end))]


def test_a_session_recorded_with_the_estimator_replays_the_hand_and_compares_the_last_w(
        tmp_path: Path, kin: MicoKinematics) -> None:
    other = diagnostics('/assistance: assistance', received=0, rejected=0)
    raw = write_bag(tmp_path / 'raw', [*estimated_messages(kin, [0.9, 0.1, 0.2]), ('/diagnostics', other)])
    compact_session(raw, tmp_path / 'est', keep_components=['intent estimator'])
    session = load_closed_loop(tmp_path / 'est')  # the estimator's first status survived the compaction
    assert session.estimated and not load_closed_loop(write_bag(tmp_path / 'plain', loop_messages(kin))).estimated
    compact_session(raw, tmp_path / 'dropped')  # without keep_components the periodic statuses go
    assert not load_closed_loop(tmp_path / 'dropped').estimated
    topics = [send.topic for send in session.sends]
    assert 'intent/w' not in topics  # the estimator's output: compared, never sent
    assert topics.count('operator/twist') == STEPS and topics.count('joint_states') == STEPS + 1  # the hand too
    # the joint states (and grasps) go AHEAD_NS early, at their recorded times: the estimator pairs by stamps
    assert AHEAD_TOPICS == ('joint_states', 'grasp/pose')
    assert all(send.lead_ns == (AHEAD_NS if send.topic in AHEAD_TOPICS else 0) for send in session.sends)
    due = [send.t_ns - send.lead_ns for send in session.sends]
    assert due == sorted(due) and topics.index('joint_states') < topics.index('operator/twist')
    recorded = outcome(session.trace, kin)
    np.testing.assert_array_equal(recorded.final_w, [0.9, 0.1, 0.2])
    near = outcome(load_closed_loop(write_bag(tmp_path / 'near', estimated_messages(
        kin, [0.9, 0.1 + 0.9 * W_TOLERANCE, 0.2]))).trace, kin)
    far = outcome(load_closed_loop(write_bag(tmp_path / 'far', estimated_messages(
        kin, [0.9, 0.1 + 1.1 * W_TOLERANCE, 0.2]))).trace, kin)
    assert compare_outcomes(recorded, near, grasp=False) == []
    (problem,) = compare_outcomes(recorded, far, grasp=False)
    assert problem.startswith(f'last w: live [0.9, {0.1 + 1.1 * W_TOLERANCE:.3g}, 0.2], recorded [0.9, 0.1, 0.2]')


def test_a_classifiers_w_on_intent_prior_is_sent_again_to_the_estimator(tmp_path: Path, kin: MicoKinematics) -> None:
    messages = estimated_messages(kin, [0.9, 0.1, 0.2])
    messages.insert(3, ('intent/prior', f64([0.9, 0.9, 0.1])))
    session = load_closed_loop(write_bag(tmp_path / 'prior', messages))
    (prior,) = [send for send in session.sends if send.topic == 'intent/prior']
    assert prior.lead_ns == 0  # at its recorded time: the estimator keeps the newest, whenever it comes
    plain = loop_messages(kin)
    plain.insert(2, ('intent/prior', f64([0.9, 0.9, 0.1])))
    assert 'intent/prior' not in [send.topic for send in load_closed_loop(write_bag(tmp_path / 'plain', plain)).sends]
