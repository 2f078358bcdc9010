"""shared_control.robot_twist: the robot's twist toward the grasp (its target, Cartesian and joint-space, pace)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.mico.frames import pose_error, pose_to_matrix, pre_grasp
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.shared_control.robot_twist import assistance_target, joint_space_twist, keep_pace, robot_twist

from .assistance_case import GRASP


def test_the_robot_aims_at_the_pre_grasp_then_the_grasp() -> None:
    pre = pre_grasp(GRASP, 0.08)
    assert_allclose(pre[:3, 3], [0.3, -0.3, 0.13], atol=1e-15)  # 8 cm back up the approach axis
    kw = dict(standoff=0.08, corridor_radius=0.02, corridor_angle=0.2)
    side = pose_to_matrix((0.4, -0.3, 0.05), (1.0, 0.0, 0.0, 0.0))
    assert assistance_target(side, GRASP, **kw)[1] == 'pre-grasp'  # beside the object
    above = pose_to_matrix((0.305, -0.3, 0.12), (1.0, 0.0, 0.0, 0.0))
    assert assistance_target(above, GRASP, **kw)[1] == 'grasp'  # in the corridor
    tilted = pose_to_matrix((0.305, -0.3, 0.12), (math.sin(0.2), 0.0, 0.0, math.cos(0.2)))  # 0.4 rad off
    assert assistance_target(tilted, GRASP, **kw)[1] == 'pre-grasp'
    below = pose_to_matrix((0.3, -0.3, 0.035), (1.0, 0.0, 0.0, 0.0))  # past the grasp
    assert assistance_target(below, GRASP, **kw)[1] == 'grasp'  # within the radius of the grasp


def test_the_robot_twist_is_proportional_and_bounded() -> None:
    hand = pose_to_matrix((0.3, -0.3, 0.10), (1.0, 0.0, 0.0, 0.0))
    twist = robot_twist(hand, GRASP, gain_linear=2.0, gain_angular=2.0, max_linear=0.15, max_angular=0.8)
    assert_allclose(twist, [0.0, 0.0, -0.10, 0.0, 0.0, 0.0], atol=1e-15)
    far = pose_to_matrix((0.0, 0.0, 0.5), (0.0, 0.0, 0.0, 1.0))
    twist = robot_twist(far, GRASP, gain_linear=2.0, gain_angular=2.0, max_linear=0.15, max_angular=0.8)
    assert np.linalg.norm(twist[:3]) == pytest.approx(0.15) and np.linalg.norm(twist[3:]) == pytest.approx(0.8)
    error = pose_error(far, GRASP)  # the twist points along the error
    assert_allclose(twist[:3] / 0.15, error[:3] / np.linalg.norm(error[:3]), atol=1e-12)
    # integrating the rotation part takes the hand's orientation to the grasp's
    import pinocchio as pin
    R = far[:3, :3]
    for _ in range(2000):
        w = robot_twist(np.r_[np.c_[R, far[:3, 3]], [[0, 0, 0, 1]]], GRASP, gain_linear=2.0, gain_angular=2.0,
                        max_linear=0.15, max_angular=0.8)[3:]
        R = pin.exp3(w * 0.01) @ R
    assert_allclose(R, GRASP[:3, :3], atol=1e-9)


def test_keeping_pace_raises_the_robots_twist_to_the_operators_speed_along_its_direction() -> None:
    kw = dict(deadband_linear=0.01, deadband_angular=0.05)
    operator = np.r_[0.0, 0.12, 0.0, 0.0, 0.0, 0.0]  # a joystick translating: no rotation
    against = np.r_[0.03, -0.15, 0.0, 0.4, 0.0, 0.8]  # the joint path's image, against the operator's translation
    paced = keep_pace(against, operator, **kw)
    assert_allclose(paced, [0.03, 0.12, 0.0, 0.4, 0.0, 0.8], atol=1e-15)  # across kept; the turn kept (no input)
    for alpha in (0.0, 0.4, 0.9):  # the blend keeps the operator's speed along its direction, whatever alpha
        assert (alpha * paced + (1.0 - alpha) * operator)[1] == pytest.approx(0.12, abs=1e-15)
    faster = np.r_[0.0, 0.15, 0.02, 0.0, 0.0, 0.0]
    assert_allclose(keep_pace(faster, operator, **kw), faster, atol=0)  # already ahead: unchanged
    turning = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, -0.5]  # a turn against the robot's: the angular part alone raised
    assert_allclose(keep_pace(against, turning, **kw), [0.03, -0.15, 0.0, 0.4, 0.0, -0.5], atol=1e-15)
    assert_allclose(keep_pace(against, np.r_[0.0, 0.005, 0.0, 0.0, 0.0, 0.04], **kw), against, atol=0)  # deadbands


def test_the_joint_space_twist_is_the_hands_motion_under_the_joint_motion() -> None:
    kin = MicoKinematics()
    q = np.radians([244.0, 233.0, 62.0, 192.0, 50.0, 125.0])
    step = np.radians([1.0, -2.0, 0.5, 3.0, -1.0, 2.0]) * 1e-2
    jacobian = kin.jacobian(q)
    assert_allclose(joint_space_twist(jacobian, q, q + step, gain=2.0, max_linear=0.15, max_angular=0.8),
                    jacobian @ (2.0 * step), atol=1e-15)
    far = joint_space_twist(jacobian, q, q + 100 * step, gain=2.0, max_linear=0.01, max_angular=0.02)
    assert np.linalg.norm(far[:3]) == pytest.approx(0.01, abs=1e-15)
    assert np.linalg.norm(far[3:]) == pytest.approx(0.02, abs=1e-15)
    assert_allclose(far[:3] / 0.01, (jacobian @ step)[:3] / np.linalg.norm((jacobian @ step)[:3]), atol=1e-12)


def test_the_joint_space_twist_scaled_as_a_whole_keeps_the_joint_line() -> None:
    kin = MicoKinematics()
    q = np.radians([244.0, 233.0, 62.0, 192.0, 50.0, 125.0])
    step = np.radians([1.0, -2.0, 0.5, 3.0, -1.0, 2.0])
    jacobian = kin.jacobian(q)
    full = jacobian @ (2.0 * step)
    kw = dict(gain=2.0, max_linear=0.02, max_angular=0.05)
    linear, angular = 0.02 / np.linalg.norm(full[:3]), 0.05 / np.linalg.norm(full[3:])
    assert linear < 1.0 and angular < 1.0 and abs(linear - angular) > 0.05  # both parts over, by other factors
    whole = joint_space_twist(jacobian, q, q + step, whole=True, **kw)
    assert_allclose(whole, min(linear, angular) * full, atol=1e-15)  # one factor: the binding part at its limit
    assert max(np.linalg.norm(whole[:3]) / 0.02, np.linalg.norm(whole[3:]) / 0.05) == pytest.approx(1.0, abs=1e-12)
    # its joint image is on the line to the target; each part to its own limit leaves it
    assert_allclose(np.linalg.solve(jacobian, whole), min(linear, angular) * 2.0 * step, atol=1e-12)
    per_part = np.linalg.solve(jacobian, joint_space_twist(jacobian, q, q + step, **kw))
    cos = float(per_part @ step) / (np.linalg.norm(per_part) * np.linalg.norm(step))
    assert cos < 0.9  # here 33 degrees off the line
    near = joint_space_twist(jacobian, q, q + 1e-3 * step, whole=True, **kw)  # within both limits: unscaled
    assert_allclose(near, jacobian @ (2e-3 * step), atol=1e-15)
