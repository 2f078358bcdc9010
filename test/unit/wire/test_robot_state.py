"""The hand read from a joint state (its pose and executed closures) and when a close has settled."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.mico.kinematics import ARM_JOINTS, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.wire.robot_state import Hand, fingers_settled, hand_state

FINGERS = np.array([0.8, 0.75, 0.9])


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def joint_state(names: list[str], positions: list[float], velocities: list[float]) -> SimpleNamespace:
    return SimpleNamespace(name=names, position=positions, velocity=velocities)


def test_hand_state_reads_the_pose_and_the_fingers_in_any_order(kin: MicoKinematics) -> None:
    names = list(FINGER_JOINTS) + list(ARM_JOINTS)  # fingers first: read by name
    msg = joint_state(names, FINGERS.tolist() + list(HOME_Q), [0.0] * 9)
    hand = hand_state(msg, kin, 12.5)
    assert hand is not None
    assert hand.received == 12.5 and hand.fingers_at_rest
    assert_allclose(hand.base_T_ee, kin.fk(HOME_Q), atol=0.0)
    assert_allclose(hand.fingers, FINGERS, atol=0.0)


def test_a_moving_finger_is_not_at_rest_and_a_missing_velocity_is(kin: MicoKinematics) -> None:
    names = list(ARM_JOINTS) + list(FINGER_JOINTS)
    moving = hand_state(joint_state(names, list(HOME_Q) + FINGERS.tolist(), [0.0] * 7 + [0.3, 0.0]), kin, 0.0)
    assert moving is not None and not moving.fingers_at_rest
    arm_moving = hand_state(joint_state(names, list(HOME_Q) + FINGERS.tolist(), [0.2] * 6 + [0.0] * 3), kin, 0.0)
    assert arm_moving is not None and arm_moving.fingers_at_rest  # the fingers' velocities only
    unreported = hand_state(joint_state(names, list(HOME_Q) + FINGERS.tolist(), []), kin, 0.0)
    assert unreported is not None and unreported.fingers_at_rest


def test_hand_state_is_none_without_the_fingers_or_the_arm(kin: MicoKinematics) -> None:
    assert hand_state(joint_state(list(ARM_JOINTS), list(HOME_Q), [0.0] * 6), kin, 0.0) is None
    assert hand_state(joint_state(list(FINGER_JOINTS), FINGERS.tolist(), [0.0] * 3), kin, 0.0) is None


def test_fingers_settled_needs_a_state_received_settle_seconds_after_the_close_and_at_rest() -> None:
    def hand(received: float, at_rest: bool) -> Hand:
        return Hand(received, np.eye(4), FINGERS, at_rest)

    assert not fingers_settled(None, 10.0, 0.3)
    assert not fingers_settled(hand(10.29, True), 10.0, 0.3)  # perhaps sent before the close was served
    assert not fingers_settled(hand(10.5, False), 10.0, 0.3)  # still closing
    assert fingers_settled(hand(10.4, True), 10.0, 0.3)
