"""grasp_intent_ros.ros.robot: poses, joint states and trajectories."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from numpy.testing import assert_allclose
from sensor_msgs.msg import JointState

from grasp_intent_ros.errors import GraspIntentError, KinematicsError
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.ros.robot import joint_state_msg, joint_trajectory_msg, matrix_to_pose_msg
from grasp_intent_ros.wire.robot_state import (
    check_unit_quaternion,
    joint_positions,
    pose_msg_to_matrix,
    trajectory_time,
)

STAMP = Time(sec=3, nanosec=4)


def test_pose_round_trip_in_the_named_frame_only() -> None:
    half = 0.3
    base_T_obj = pose_to_matrix((0.3, -0.2, 0.1), (0.0, 0.0, math.sin(half), math.cos(half)))
    msg = matrix_to_pose_msg(base_T_obj, frame_id='base', stamp=STAMP)
    assert msg.header.frame_id == 'base' and msg.header.stamp == STAMP
    assert_allclose(pose_msg_to_matrix(msg, frame_id='base'), base_T_obj, atol=1e-12)
    with pytest.raises(KinematicsError, match="frame 'other'"):
        pose_msg_to_matrix(msg, frame_id='other')
    msg.pose.orientation.w *= 2.0
    with pytest.raises(KinematicsError, match='unit norm'):
        pose_msg_to_matrix(msg, frame_id='base')


def test_unit_quaternion_check() -> None:
    assert_allclose(check_unit_quaternion([0.0, 0.0, 0.0, 1.0005]), [0.0, 0.0, 0.0, 1.0005])
    for bad, reason in (([0.0, 0.0, 1.0], '4 entries'), ([0.0, 0.0, math.nan, 1.0], 'finite'),
                        ([0.0, 0.0, 0.0, 1.01], 'unit norm')):
        with pytest.raises(KinematicsError, match=reason):
            check_unit_quaternion(bad)


def test_joint_states_in_any_order() -> None:
    assert joint_positions(JointState(name=['a', 'b'], position=[1.0, 2.0]), ['b']) == pytest.approx([2.0])
    assert joint_positions(JointState(name=['a'], position=[1.0]), ['a', 'b']) is None
    with pytest.raises(KinematicsError, match=r"duplicate names: \['a'\]$"):
        joint_positions(JointState(name=['a', 'a', 'b'], position=[1.0, 2.0, 3.0]), ['a'])
    with pytest.raises(GraspIntentError, match='65 names, the limit is 64'):
        joint_positions(JointState(name=[f'j{i}' for i in range(65)], position=[0.0] * 65), ['j0'])
    with pytest.raises(GraspIntentError, match='name 0 has 300 characters'):
        joint_positions(JointState(name=['a' * 300], position=[0.0]), ['a'])
    with pytest.raises(KinematicsError, match='2 names but 1 positions'):
        joint_positions(JointState(name=['a', 'b'], position=[1.0]), ['a'])
    with pytest.raises(KinematicsError, match='finite'):
        joint_positions(JointState(name=['a'], position=[math.inf]), ['a'])
    msg = joint_state_msg(['a', 'b'], np.array([1.0, 2.0]), stamp=STAMP)
    assert (list(msg.name), list(msg.position), msg.header.stamp) == (['a', 'b'], [1.0, 2.0], STAMP)


def test_one_point_trajectory() -> None:
    msg = joint_trajectory_msg(['a', 'b'], [0.5, -0.5], 1.25, stamp=STAMP)
    (point,) = msg.points
    assert list(msg.joint_names) == ['a', 'b'] and list(point.positions) == [0.5, -0.5]
    assert list(point.velocities) == [0.0, 0.0]
    assert (point.time_from_start.sec, point.time_from_start.nanosec) == (1, 250_000_000)
    assert trajectory_time(msg) == 1.25  # read back: how long it runs
    msg.points = []
    assert trajectory_time(msg) is None
    with pytest.raises(ValueError, match='2 names'):
        joint_trajectory_msg(['a', 'b'], [0.5], 1.0, stamp=STAMP)
