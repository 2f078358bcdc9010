"""shared_control.assistance, .arbitration, .robot_twist: arbitration, the robot's twist, blending, limits, safety."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.method.intent import all_zones, interpret, zone_labels
from grasp_intent_ros.mico.frames import pose_error, pose_to_matrix, pre_grasp
from grasp_intent_ros.mico.kinematics import BASE_FRAME, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm, TwistCommand
from grasp_intent_ros.shared_control.arbitration import (
    arbitration,
    grasp_task_set,
    operator_agreement,
    robot_agreement,
    serving_probability,
)
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.limits import TwistLimiter
from grasp_intent_ros.shared_control.robot_twist import assistance_target, joint_space_twist, keep_pace, robot_twist

from .robot_alone import LABELS, TASKS, assistance_joint_path, robot_alone

GRASP = pose_to_matrix((0.3, -0.3, 0.05), (1.0, 0.0, 0.0, 0.0))  # approach (EE z) straight down
ARGS = dict(alpha_max=0.9, margin=0.2)
U, T, H = 1, 2, 4


@pytest.mark.parametrize('w, task_set, serving', [
    # the ambiguous cases: the planned grasp's task set by the rules, and P(it serves T | w)
    ((0.7, 0.7, 0.7), U | T | H, 1.0),
    ((0.9, 0.5, 0.5), U | T | H, 1.0),
    ((0.6, 0.6, 0.1), U | T, (0.9 - 0.4 * 0.4 * 0.9) / (1 - 0.4 * 0.4 * 0.9)),
    ((0.9, 0.9, 0.1), U | T, (0.9 - 0.1 * 0.1 * 0.9) / (1 - 0.1 * 0.1 * 0.9)),
    ((0.9, 0.1, 0.1), U, (0.9 * 0.9 - 0.1 * 0.9 * 0.9) / (1 - 0.1 * 0.9 * 0.9)),
    ((0.9, 0.9, 0.1), U, (0.9 * 0.1 * 0.9) / (1 - 0.1 * 0.1 * 0.9)),  # a grasp for usage only: 9 %
])
def test_alpha_is_high_where_the_grasp_serves_every_likely_task(w: tuple[float, ...], task_set: int,
                                                               serving: float) -> None:
    # under the independent-task model P(T within S | T not empty) = (prod_{i not in S} (1 - w_i) - prod_i (1 - w_i))
    # / (1 - prod_i (1 - w_i)): the closed forms above
    v = interpret(w).v
    labels = zone_labels(all_zones(3), TASKS)
    s = serving_probability(v, labels, TASKS, task_set=task_set)
    assert s == pytest.approx(serving, abs=1e-12)
    assert arbitration('confidence', v, s, **ARGS) == pytest.approx(0.9 * serving, abs=1e-12)
    assistance = make_assistance()
    assistance.set_v(v, labels)
    assistance.set_task_set(task_set)
    straight = np.array([0.0, 0.0, -0.05, 0.0, 0.0, 0.0])  # the grasp is straight below the hand: o = 1
    assistance.set_operator(straight, now=0.0)
    assert assistance.command(0.01).alpha == pytest.approx(0.9 * serving, abs=1e-12)


def test_serving_probability_of_a_grasp_that_is_no_demonstration_is_the_models_expectation() -> None:
    v = np.array([0.5, 0.1, 0.1, 0.1, 0.1, 0.05, 0.05])  # over LABELS: U, T, H, UT, UH, TH, UTH
    model = ('U', 'T', 'UT', 'UTH')  # a 4-zone model: its posterior names only these
    e = {'U': 0.5, 'T': 0.1, 'UT': 0.7, 'UTH': 1.0}
    p = np.array([0.1, 0.2, 0.3, 0.4])
    expected = sum(pk * e[k] for pk, k in zip(p, model))
    assert serving_probability(v, LABELS, TASKS, posterior=p, zone_labels=model) == pytest.approx(expected, abs=1e-15)
    assert serving_probability(v, LABELS, TASKS, task_set=U | T) == pytest.approx(0.7, abs=1e-15)
    assert serving_probability(v, LABELS, TASKS, posterior=[1.0, 0.0], zone_labels=('U', 'X')) == 0.0
    assert serving_probability(np.zeros(7), LABELS, TASKS, task_set=U) == 0.0
    assert serving_probability(v, LABELS, TASKS) == 0.0  # neither a task set nor a posterior


def test_the_grasp_task_set_is_the_demonstrations_label() -> None:
    demo_x = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 1.0]])
    sets = np.array([U, T | H, U], dtype=np.int64)
    scale = np.array([0.5, 2.0])
    assert grasp_task_set(np.array([1.0, 1.0 + 1e-7]), demo_x, sets, scale) == T | H  # the first of equal ones
    assert grasp_task_set(np.array([0.5, 1.0]), demo_x, sets, scale) is None  # moved: no label


def test_arbitration_rules() -> None:
    certain, uniform = np.eye(7)[0], np.full(7, 1 / 7)
    assert arbitration('confidence', certain, 1.0, **ARGS) == pytest.approx(0.9)
    assert arbitration('confidence', uniform, 1.0, **ARGS) == pytest.approx(0.9)  # v's spread vetoes nothing
    assert arbitration('confidence', certain, 0.5, **ARGS) == pytest.approx(0.45)
    assert arbitration('none', certain, 1.0, **ARGS) == 0.0
    assert arbitration('blend', [0.5, 0.35, 0.15], 0.0, **ARGS) == 0.0  # leads by 0.15 < 0.2
    assert arbitration('blend', [0.5, 0.25, 0.25], 0.0, **ARGS) == 0.9


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


def test_limits_bound_speed_and_acceleration_and_never_pass_a_nan() -> None:
    limiter = TwistLimiter(0.2, 1.0, 1.0, 5.0)
    out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 0.01)
    assert_allclose(out, [0.01, 0, 0, 0, 0, 0.05], atol=1e-15)  # acceleration-limited from rest
    for _ in range(100):
        out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 0.01)
    assert_allclose(out, [0.2, 0, 0, 0, 0, 1.0], atol=1e-15)  # speed-limited
    out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 5.0)  # a gap grants max_dt only
    assert np.all(np.isfinite(limiter.limit(np.full(6, np.nan), 0.01)))
    assert_allclose(limiter.stop(), 0.0, atol=0)


def make_assistance(**config: object) -> Assistance:
    assistance = Assistance(AssistanceConfig(**config), TwistLimiter(10.0, 10.0, 1e6, 1e6))  # type: ignore[arg-type]
    assistance.base_T_ee = pose_to_matrix((0.3, -0.3, 0.25), (1.0, 0.0, 0.0, 0.0))
    assistance.set_grasp(GRASP)
    assistance.set_v(np.eye(7)[0], LABELS)
    assistance.set_posterior(np.eye(7)[0], LABELS, TASKS)
    return assistance


def test_the_blend_and_the_safety_rules() -> None:
    assistance = make_assistance()
    human = np.array([0.05, 0.0, -0.05, 0.0, 0.0, 0.0])
    assistance.set_operator(human, now=0.0)
    command = assistance.command(0.01)
    alpha = 0.9 * 0.5**0.5  # 45 degrees off the grasp: o = cos 45 deg
    assert command.alpha == pytest.approx(alpha) and command.phase == 'grasp'
    robot = np.array([0.0, 0.0, -0.15, 0.0, 0.0, 0.0])  # 0.2 m above the grasp: gain 2, limited to 0.15
    assert_allclose(command.twist, alpha * robot + (1.0 - alpha) * human, atol=1e-12)
    # a stale operator input: the zero twist as soon as it is older than the timeout
    assert np.any(assistance.command(0.1).twist)
    stale = assistance.command(0.1 + 1e-6)
    assert not np.any(stale.twist) and stale.phase == 'operator input stale' and stale.alpha == 0.0
    # a clarification pending: alpha 0 (the operator alone) until the next grasp
    assistance.set_operator(human, now=1.0)
    assistance.clarification()
    command = assistance.command(1.01)
    assert command.alpha == 0.0 and command.phase == 'clarification pending'
    assert_allclose(command.twist, human, atol=0)
    assistance.set_grasp(GRASP)  # the same grasp: the operator's oblique motion (o = cos 45 deg) is remembered
    assistance.set_operator(np.array([0.0, 0.0, 0.0, 0.0, 0.06, 0.0]), now=1.02)  # turning only: no evidence
    assert assistance.command(1.02).alpha == pytest.approx(alpha)


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


@pytest.mark.parametrize('pace', [False, True])
def test_keep_pace_lets_the_blend_never_slow_the_operator(pace: bool) -> None:
    assistance = make_assistance(keep_pace=pace)
    fast = np.r_[0.0, 0.0, -0.3, 0.0, 0.0, 0.0]  # straight at the grasp, faster than the robot's 0.15 limit
    assistance.set_operator(fast, now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == pytest.approx(0.9)  # the arbitration is unchanged
    assert command.twist[2] == pytest.approx(-0.3 if pace else -(0.9 * 0.15 + 0.1 * 0.3), abs=1e-12)
    assert AssistanceConfig().keep_pace is False  # off by default: the blend as published


def test_the_agreement_with_the_robots_twist_is_the_cosine_faded_out_below_the_deadbands() -> None:
    kw = dict(deadband_linear=0.01, deadband_angular=0.05)
    operator = np.r_[0.0, 0.12, 0.0, 0.0, 0.0, 0.0]  # a joystick translating: no rotation
    assert robot_agreement(operator, np.r_[0.0, -0.15, 0.0, 0.0, 0.0, 0.8], **kw) == 0.0  # against: the operator alone
    assert robot_agreement(operator, np.r_[0.15, 0.0, 0.0, 0.4, 0.0, 0.8], **kw) == 0.0  # at right angles: alone too
    assert robot_agreement(operator, np.r_[0.0, 0.15, 0.0, 0.4, 0.0, 0.8], **kw) == 1.0  # its way: alpha unchanged
    oblique = np.r_[0.1, 0.1, 0.0, 0.0, 0.0, 0.0]
    assert robot_agreement(operator, oblique, **kw) == pytest.approx(0.5**0.5, abs=1e-15)  # cos 45 deg
    turning = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.3]  # a turn against the robot's, no translation: the angular part's
    assert robot_agreement(turning, np.r_[0.0, -0.15, 0.0, 0.0, 0.0, -0.8], **kw) == 0.0
    assert robot_agreement(np.zeros(6), np.r_[0.0, -0.15, 0.0, 0.0, 0.0, -0.8], **kw) == 1.0  # zero h: unchanged
    assert robot_agreement(operator, np.zeros(6), **kw) == 1.0  # zero r: unchanged
    # below a deadband the disagreement fades out linearly: continuous, no threshold for a last bit to cross
    assert robot_agreement(operator, np.r_[0.0, -0.005, 0.0, 0.0, 0.0, 0.0], **kw) == pytest.approx(0.5, abs=1e-15)
    assert robot_agreement(np.r_[0.0, 0.0025, 0.0, 0.0, 0.0, 0.0], np.r_[0.0, -0.15, 0.0, 0.0, 0.0, 0.0],
                           **kw) == pytest.approx(0.75, abs=1e-15)
    edge = np.r_[0.0, -0.01, 0.0, 0.0, 0.0, 0.0]
    for bit in (-1.0, 1.0):
        near = robot_agreement(operator, np.nextafter(edge, bit), **kw)
        assert near == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize('agree', [False, True])
def test_robot_agreement_lets_the_operator_move_alone_where_the_robots_twist_runs_against_it(
        agree: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    straight = np.r_[0.0, 0.0, -0.05, 0.0, 0.0, 0.0]  # straight at the grasp below: o = 1
    for robot, alpha in ((np.r_[0.0, 0.0, 0.15, 0.0, 0.0, 0.0], 0.0 if agree else 0.9),  # the joint line, against
                         (np.r_[0.0, 0.0, -0.15, 0.0, 0.0, 0.3], 0.9)):  # the operator's way (and a turn): unchanged
        assistance, today = make_assistance(robot_agreement=agree), make_assistance()
        for a in (assistance, today):
            monkeypatch.setattr(a, '_robot_twist', lambda target, phase, robot=robot: robot.copy())
            a.set_operator(straight, now=0.0)
        command, reference = assistance.command(0.01), today.command(0.01)
        assert command.alpha == alpha
        assert_allclose(command.twist, alpha * robot + (1.0 - alpha) * straight, atol=1e-15)
        if not agree:  # off: today's command to the bit
            assert command.alpha == reference.alpha and command.phase == reference.phase
            assert np.array_equal(command.twist, reference.twist)
    assert AssistanceConfig().robot_agreement is False  # off by default


@pytest.mark.parametrize('missing, phase', [('base_T_grasp', 'no grasp'), ('base_T_ee', 'no joint state')])
def test_no_assistance_without_a_grasp_or_a_hand(missing: str, phase: str) -> None:
    assistance = make_assistance()
    setattr(assistance, missing, None)
    assistance.set_operator(np.zeros(6), now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == 0.0 and command.phase == phase and not np.any(command.twist)
    assert make_assistance(arbitration='none').alpha() == (0.0, 'direct teleoperation')


def test_operator_agreement_lets_the_operator_take_the_control_back() -> None:
    kw = dict(deadband_linear=0.01, deadband_angular=0.05)
    robot = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.5])
    assert operator_agreement(np.zeros(6), robot, **kw) == (None, None)  # holding still: no evidence
    assert operator_agreement(np.r_[0.005, 0, 0, 0, 0, 0], -robot, **kw) == (None, None)  # within the deadband
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, 0], robot, **kw) == (pytest.approx(1.0), None)
    assert operator_agreement(np.r_[0, 0.05, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.0)  # at right angles
    assert operator_agreement(np.r_[-0.05, 0, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.0)  # against it
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, -0.2], robot, **kw) == (pytest.approx(1.0), pytest.approx(0.0))
    assert operator_agreement(np.r_[0.05, 0, 0, 0, 0, 0], np.zeros(6), **kw) == (None, None)  # the robot holds
    assert operator_agreement(np.r_[1e308, -1e308, 0, 0, 0, 0], robot, **kw)[0] == pytest.approx(0.5**0.5)


@pytest.mark.parametrize('degrees', [0.0, 30.0, 60.0, 80.0, 90.0, 135.0])
def test_alpha_falls_with_the_share_of_the_operators_motion_toward_the_grasp(degrees) -> None:
    # an operator turning toward another goal (a goal change) moves at an angle to the grasp: alpha follows the
    # share of its motion that goes toward the grasp, cos theta, at once (0 from right angles on), where
    # (1 + cos theta) / 2 kept 0.59 of alpha_max at 80 degrees and 0.5 at right angles
    assistance = make_assistance()
    assert assistance.base_T_ee is not None
    toward = pose_error(assistance.base_T_ee, GRASP)[:3]
    toward /= np.linalg.norm(toward)
    side = np.cross(toward, [0.0, 1.0, 0.0] if abs(toward[1]) < 0.9 else [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    theta = np.radians(degrees)
    assistance.set_operator(np.r_[0.1 * (np.cos(theta) * toward + np.sin(theta) * side), 0.0, 0.0, 0.0], now=0.0)
    alpha = assistance.command(0.01).alpha
    assert alpha == pytest.approx(0.9 * max(np.cos(theta), 0.0), abs=1e-9)
    if degrees >= 80.0:
        assert alpha <= 0.16


def test_the_agreement_is_measured_against_the_grasps_approach_target() -> None:
    # a two-mode operator lines the hand up beside the pre-grasp (8 cm above the grasp, out of the corridor), then
    # turns it: its way in goes to the pre-grasp, 80 degrees off the direction to the grasp itself, and the robot
    # helps with both the translation and the turn (measured against the grasp, o was 0.17 and the robot yielded)
    assistance = make_assistance()
    hand = np.eye(4)
    c, s = math.cos(0.5), math.sin(0.5)
    hand[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ GRASP[:3, :3]  # 0.5 rad off
    hand[:3, 3] = (0.34, -0.3, 0.11)
    assistance.base_T_ee = hand
    cfg = assistance.config
    target, phase = assistance_target(hand, GRASP, standoff=cfg.standoff, corridor_radius=cfg.corridor_radius,
                                      corridor_angle=cfg.corridor_angle)
    assert phase == 'pre-grasp'
    assert_allclose(target, pre_grasp(GRASP, cfg.standoff), atol=1e-15)
    toward, grasp = pose_error(hand, target), pose_error(hand, GRASP)
    assert_allclose(toward[3:], grasp[3:], atol=1e-15)  # the pre-grasp keeps the grasp's orientation
    cos = float(toward[:3] @ grasp[:3]) / float(np.linalg.norm(toward[:3]) * np.linalg.norm(grasp[:3]))
    assert 0.1 < cos < 0.2
    translate = np.r_[0.05 * toward[:3] / np.linalg.norm(toward[:3]), 0.0, 0.0, 0.0]
    alphas = run_operator(assistance, translate, 0.0, 0.3)
    assert all(a == pytest.approx(0.9, abs=1e-12) for _, a in alphas) and not assistance.yielded
    rotate = np.r_[0.0, 0.0, 0.0, 0.3 * toward[3:] / np.linalg.norm(toward[3:])]  # the linear agreement held: 1
    alphas = run_operator(assistance, rotate, 0.5, 0.3)
    assert all(a == pytest.approx(0.9, abs=1e-12) for _, a in alphas) and assistance.agreement[0] == 1.0
    # heading at the grasp itself from out of the corridor (through the object's side) is off the approach by 80
    # degrees, and away from the pre-grasp is against it
    alphas = run_operator(assistance, np.r_[0.05 * grasp[:3] / np.linalg.norm(grasp[:3]), 0.0, 0.0, 0.0], 1.0, 0.01)
    assert alphas[0][1] == pytest.approx(0.9 * cos, abs=1e-12)
    assert run_operator(assistance, -translate, 1.1, 0.01)[0][1] == pytest.approx(0.0, abs=1e-12)


def test_the_operator_who_steered_against_the_robot_keeps_the_control() -> None:
    assistance = make_assistance()
    away = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])  # the grasp is below the hand: the robot goes down
    assistance.set_operator(away, now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == pytest.approx(0.0) and command.twist[2] > 0.0
    # then rotating only (a joystick's other mode), or letting go: the linear disagreement is held
    assistance.set_operator(np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.2]), now=0.02)
    assert assistance.command(0.03).alpha == pytest.approx(0.0)
    assistance.set_operator(np.zeros(6), now=0.04)
    assert assistance.command(0.05).alpha == pytest.approx(0.0)
    # moving along with the robot again gives it back
    assistance.set_operator(np.array([0.0, 0.0, -0.05, 0.0, 0.0, 0.0]), now=0.06)
    assert assistance.command(0.07).alpha == pytest.approx(0.9)
    # a grasp that moves by more than the corridor is a new proposal: the agreement starts afresh
    assistance.set_operator(away, now=0.08)
    assistance.command(0.09)
    assert assistance.agreement[0] == pytest.approx(0.0)
    jitter = GRASP.copy()
    jitter[0, 3] += 0.005
    assistance.set_grasp(jitter)
    assert assistance.agreement[0] == pytest.approx(0.0)  # the same grasp, replanned
    moved = GRASP.copy()
    moved[0, 3] += 0.05
    assistance.set_grasp(moved)
    assert assistance.agreement == (1.0, 1.0)
    blend = make_assistance(arbitration='blend')  # ADA's baseline does not listen
    blend.set_operator(away, now=0.0)
    assert blend.command(0.01).alpha == pytest.approx(0.9)


def run_operator(assistance: Assistance, twist: NDArray[np.float64], start: float, seconds: float,
                 period: float = 0.01) -> list[tuple[float, float]]:
    """(time, alpha) of each output while the operator sends ``twist`` every ``period`` for ``seconds``."""
    out = []
    for i in range(round(seconds / period)):
        now = start + i * period
        assistance.set_operator(twist, now)
        out.append((now, assistance.command(now).alpha))
    return out


def test_sustained_opposition_makes_the_robot_yield_until_the_operator_heads_back() -> None:
    assistance = make_assistance()  # the grasp 0.2 m straight below the hand
    oblique = np.array([0.0, 0.05, 0.05, 0.0, 0.0, 0.0])  # 135 degrees off the grasp: o = 0 at once
    alphas = run_operator(assistance, oblique, 0.0, 0.01)
    assert alphas[0][1] == 0.0 and not assistance.yielded
    steps = np.arange(1, 40) * 0.01
    yielded = next(t for t in steps if run_operator(assistance, oblique, t, 0.01) and assistance.yielded)
    assert yielded <= 0.15 + 0.01  # yield_time (0.15 s) after the opposition began, within one output
    # letting go, or turning only, keeps the control with the operator
    run_operator(assistance, np.zeros(6), 0.4, 0.5)
    assert assistance.yielded
    # heading toward the grasp again: the robot assists once that lasted yield_time
    toward = np.array([0.0, 0.0, -0.05, 0.0, 0.0, 0.0])
    alphas = run_operator(assistance, toward, 1.0, 0.3)
    back = next(t for t, a in alphas if a > 0.0)
    assert 1.0 + 0.15 - 1e-9 <= back <= 1.0 + 0.15 + 0.01 and alphas[-1][1] == pytest.approx(0.9, abs=1e-12)
    # a short opposition (below yield_time) only lowers alpha by the agreement
    alphas = run_operator(assistance, -toward, 2.0, 0.1)
    assert not assistance.yielded and all(a == pytest.approx(0.0, abs=1e-12) for _, a in alphas)
    alphas = run_operator(assistance, toward, 2.1, 0.05)
    assert alphas[-1][1] == pytest.approx(0.9, abs=1e-12)
    # a new grasp (moved by more than the corridor) is a new proposal: no longer yielded
    run_operator(assistance, -toward, 3.0, 0.3)
    assert assistance.yielded
    moved = GRASP.copy()
    moved[1, 3] += 0.05
    assistance.set_grasp(moved)
    assert not assistance.yielded


def test_the_switch_gives_the_operators_twist_exactly() -> None:
    assistance = make_assistance()
    fast = np.array([0.5, -0.3, 0.1, 2.0, 0.0, -1.5])  # beyond every speed and acceleration limit
    assistance.enabled = False
    assistance.set_operator(fast, now=0.0)
    command = assistance.command(0.01)
    assert_allclose(command.twist, fast, atol=0, rtol=0)
    assert command.alpha == 0.0 and command.phase == 'assistance off'
    assert not np.any(assistance.command(0.2).twist)  # stale: still the stop
    assistance.enabled = True  # on again: blended and limited, from the last output on
    fast = np.array([0.1, -0.1, -0.5, 2.0, 0.0, -1.5])  # mostly toward the grasp below
    assistance.set_operator(fast, now=0.3)
    command = assistance.command(0.31)
    assert command.alpha > 0.0 and not np.allclose(command.twist, fast)


@pytest.mark.parametrize('assist_without_input', [False, True])
def test_no_robot_motion_without_operator_input(assist_without_input: bool) -> None:
    assistance = make_assistance(assist_without_input=assist_without_input)
    within = np.array([0.005, 0.0, 0.0, 0.0, 0.02, 0.0])  # inside both deadbands
    outputs = [None] * 50
    for i in range(50):
        assistance.set_operator(within, now=0.01 * i)
        outputs[i] = assistance.command(0.01 * i)
    if assist_without_input:
        assert outputs[-1].alpha == pytest.approx(0.9) and outputs[-1].twist[2] < -0.1  # the robot drives down
    else:
        assert all(c.alpha == 0.0 and c.phase == 'no operator input' for c in outputs)
        assert_allclose(outputs[-1].twist, within, atol=1e-15)  # the operator's own (tiny) twist, nothing more


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


def _unit(q: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(np.asarray(q) / np.linalg.norm(q))


TRANSFER_GRASP = pose_to_matrix((0.3002, -0.2918, 0.1061), _unit((0.9772, -0.1969, 0.0776, -0.0196)))
"""A cup grasp for transfer (the benchmark's, rounded): the Cartesian twist to it turns the MICO's wrist into a
singularity (joint 5 near 0) from the configuration below."""


@pytest.mark.parametrize('with_kinematics, reaches', [(True, True), (False, False)])
def test_the_robot_twist_in_joint_space_keeps_the_arm_out_of_the_wrist_singularity(with_kinematics: bool,
                                                                                    reaches: bool) -> None:
    # the hand 1 cm from the grasp, 0.5 rad misoriented, the arm well conditioned (sigma_min 0.076): turning the
    # hand by a Cartesian twist leads the damped servo into the wrist singularity, where it settles 22 cm away;
    # the joint-space twist turns the joints straight to the grasp's IK
    kin = MicoKinematics()
    arm = MockArm(kin, np.r_[np.radians([244.0, 233.0, 62.0, 192.0, 50.0, 125.0]), 0.0, 0.0, 0.0])
    assistance = Assistance(AssistanceConfig(assist_without_input=True), TwistLimiter(0.2, 1.0, 1.0, 5.0),
                            kin if with_kinematics else None)
    assistance.set_grasp(TRANSFER_GRASP)
    assistance.set_v(np.eye(7)[1], LABELS)
    assistance.set_posterior(np.eye(7)[1], LABELS, TASKS)
    for tick in range(1000):  # 10 s of 100 Hz outputs; the operator holds still, the robot moves (alpha 0.9)
        now = 0.01 * tick
        if with_kinematics:
            assistance.set_joints(arm.q[:6].copy())
        else:
            assistance.base_T_ee = kin.fk(arm.q[:6])
        assistance.set_operator(np.zeros(6), now)
        command = assistance.command(now)
        assert command.alpha == pytest.approx(0.9, abs=1e-12)
        arm.command_twist(TwistCommand(command.twist[:3], command.twist[3:], BASE_FRAME), now)
        arm.step(now + 0.01, 0.01)
    error = pose_error(kin.fk(arm.q[:6]), TRANSFER_GRASP)
    assert (np.linalg.norm(error[:3]) <= 1e-3 and np.linalg.norm(error[3:]) <= 1e-2) == reaches
    if not reaches:
        assert np.linalg.norm(error[:3]) > 0.1  # the documented trap: held in the singularity, far from the grasp


# the arm 7 cm from a cup grasp after the operator's goal changed (the closed-loop benchmark's goal-changing
# operator, seed 0, episode 0): the pre-grasp has no IK from these joints (the descent stops with the elbow at
# its limit) and lies on another branch, reached by a straight joint line that keeps the hand near the grasp
GOAL_CHANGED_Q = np.array([4.847526, 4.233469, 0.686679, 3.743465, 1.448577, 3.146208])
PRE_GRASP_Q = np.array([2.692064, 4.45801, 0.612733, 1.108852, 1.271732, 2.066687])


def _grasp_ahead_of(base_T_pre: NDArray[np.float64], standoff: float) -> NDArray[np.float64]:
    grasp = base_T_pre.copy()
    grasp[:3, 3] += standoff * base_T_pre[:3, 2]
    return grasp


def test_a_pre_grasp_without_ik_from_the_joints_is_reached_by_a_joint_line_near_the_grasp() -> None:
    kin = MicoKinematics()
    config = AssistanceConfig(assist_without_input=True)
    grasp = _grasp_ahead_of(kin.fk(PRE_GRASP_Q), config.standoff)
    pre = pre_grasp(grasp, config.standoff)
    assert not kin.ik(pre, GOAL_CHANGED_Q, restarts=0).success  # the case: no IK from the joints
    assistance = Assistance(config, TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.set_joints(GOAL_CHANGED_Q)
    assistance.set_grasp(grasp)
    path = assistance_joint_path(assistance, pre)
    assert path is not None and len(path) == 1  # a straight line
    q_t = path[0]
    error = pose_error(kin.fk(q_t), pre)
    assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6
    assert np.sin(q_t[4]) * np.sin(GOAL_CHANGED_Q[4]) > 0.0  # the wrist stays on its side
    start = float(np.linalg.norm(kin.fk(GOAL_CHANGED_Q)[:3, 3] - grasp[:3, 3]))
    for s in np.linspace(0.0, 1.0, 101):  # finer than the check's 20 points: 1 mm of slack between them
        hand = kin.fk(GOAL_CHANGED_Q + s * (q_t - GOAL_CHANGED_Q))
        assert np.linalg.norm(hand[:3, 3] - grasp[:3, 3]) <= start + config.corridor_radius + 1e-3
    # the robot alone (the operator still, assistance without input) brings the hand to the grasp; the
    # Cartesian twist toward the pre-grasp held the elbow at its limit, 9 cm away, to the end
    error = pose_error(kin.fk(robot_alone(kin, assistance, GOAL_CHANGED_Q, 4, 1000)), grasp)
    assert np.linalg.norm(error[:3]) <= 1e-3 and np.linalg.norm(error[3:]) <= 1e-2


def test_no_joint_line_through_the_wrist_singularity() -> None:
    # the target's only IK near the hand has joint 5 on the other side of 0: its straight line keeps the hand near
    # the grasp, but crosses the singularity the servo cannot follow, so the line IK gives none
    kin = MicoKinematics()
    config = AssistanceConfig()
    q = np.radians([240.0, 231.0, 66.0, 172.0, 31.0, 133.0])
    across = np.radians([237.0, 228.0, 106.0, 198.0, -64.0, 127.0])
    target = kin.fk(across)
    grasp = _grasp_ahead_of(target, config.standoff)
    assert not kin.ik(target, q, restarts=0).success
    assistance = Assistance(config, TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.set_joints(q)
    assistance.set_grasp(grasp)
    start = float(np.linalg.norm(kin.fk(q)[:3, 3] - grasp[:3, 3]))
    line = [kin.fk(q + s * (across - q))[:3, 3] for s in np.linspace(0.0, 1.0, 21)]
    assert max(float(np.linalg.norm(p - grasp[:3, 3])) for p in line) <= start + config.corridor_radius
    assert np.sin(across[4]) * np.sin(q[4]) < 0.0
    assert assistance_joint_path(assistance, target) is None
