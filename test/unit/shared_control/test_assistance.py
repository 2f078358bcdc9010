"""shared_control.assistance: the blend of the operator's and the robot's twists, alpha in it, the safety rules."""

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
    serving_probability,
)
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.limits import TwistLimiter
from grasp_intent_ros.shared_control.robot_twist import assistance_target

from .assistance_case import ARGS, GRASP, H, T, U
from .robot_alone import LABELS, TASKS, assistance_joint_path, robot_alone


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


@pytest.mark.parametrize('pace', [False, True])
def test_keep_pace_lets_the_blend_never_slow_the_operator(pace: bool) -> None:
    assistance = make_assistance(keep_pace=pace)
    fast = np.r_[0.0, 0.0, -0.3, 0.0, 0.0, 0.0]  # straight at the grasp, faster than the robot's 0.15 limit
    assistance.set_operator(fast, now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == pytest.approx(0.9)  # the arbitration is unchanged
    assert command.twist[2] == pytest.approx(-0.3 if pace else -(0.9 * 0.15 + 0.1 * 0.3), abs=1e-12)
    assert AssistanceConfig().keep_pace is False  # off by default: the blend as published


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


@pytest.mark.parametrize('idle', [False, True])
def test_the_robot_turns_the_hand_at_its_full_share_while_a_two_mode_operator_translates(
        idle: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    robot = np.r_[0.0, 0.0, -0.15, 0.0, 0.0, 0.3]  # down at the grasp, turning
    oblique = np.r_[0.05, 0.0, -0.05, 0.0, 0.0, 0.0]  # 45 degrees off the grasp, not turning: alpha 0.9 cos 45
    alpha = 0.9 * 0.5**0.5
    assistance = make_assistance(assist_idle_part=idle)
    monkeypatch.setattr(assistance, '_robot_twist', lambda target, phase: robot.copy())
    assistance.set_operator(oblique, now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == pytest.approx(alpha)  # the published alpha: the blended part's
    shares = np.r_[np.full(3, alpha), np.full(3, 0.9 if idle else alpha)]
    assert_allclose(command.twist, shares * robot + (1.0 - shares) * oblique, atol=1e-15)
    assistance.set_operator(np.r_[0.005, 0.0, 0.0, 0.0, 0.02, 0.0], now=0.02)  # no input at all: no motion
    assert assistance.command(0.02).alpha == 0.0
    assert AssistanceConfig().assist_idle_part is True  # on by default


@pytest.mark.parametrize('missing, phase', [('base_T_grasp', 'no grasp'), ('base_T_ee', 'no joint state')])
def test_no_assistance_without_a_grasp_or_a_hand(missing: str, phase: str) -> None:
    assistance = make_assistance()
    setattr(assistance, missing, None)
    assistance.set_operator(np.zeros(6), now=0.0)
    command = assistance.command(0.01)
    assert command.alpha == 0.0 and command.phase == phase and not np.any(command.twist)
    assert make_assistance(arbitration='none').alpha() == (0.0, 'direct teleoperation')


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
    assert all(a == pytest.approx(0.9, abs=1e-12) for _, a in alphas)
    assert assistance.agreement[0] == pytest.approx(1.0, abs=1e-12)  # a cosine of parallel vectors: 1 to rounding
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


@pytest.mark.parametrize('whole', [False, True])
def test_keep_joint_line_moves_the_joints_straight_to_the_targets_ik(whole: bool) -> None:
    # the robot alone (the operator still) toward a pre-grasp whose IK from the joints is 0.6 rad away: the
    # joint-space twist's linear and angular parts are over their limits by other factors; scaled as a whole the
    # arm's joints stay on the straight line to the IK, each part to its own limit they leave it
    kin = MicoKinematics()
    q0 = np.radians([244.0, 233.0, 62.0, 192.0, 50.0, 125.0])
    q_t = q0 + np.radians([10.0, -20.0, 5.0, 30.0, -10.0, 20.0])
    assistance = Assistance(AssistanceConfig(assist_without_input=True, keep_joint_line=whole),
                            TwistLimiter(10.0, 10.0, 1e6, 1e6), kin)
    assistance.set_grasp(_grasp_ahead_of(kin.fk(q_t), 0.08))  # its pre-grasp is the hand's pose at q_t
    arm = MockArm(kin, np.r_[q0, 0.0, 0.0, 0.0])
    assistance.set_v(np.eye(7)[1], LABELS)
    assistance.set_posterior(np.eye(7)[1], LABELS, TASKS)
    off_line = 0.0
    for tick in range(40):
        now = 0.01 * tick
        assistance.set_joints(arm.q[:6].copy())
        assistance.set_operator(np.zeros(6), now)
        command = assistance.command(now)
        assert command.phase == 'pre-grasp' and command.alpha == pytest.approx(0.9, abs=1e-12)
        arm.command_twist(TwistCommand(command.twist[:3], command.twist[3:], BASE_FRAME), now)
        arm.step(now + 0.01, 0.01)
        moved, line = arm.q[:6] - q0, (q_t - q0) / np.linalg.norm(q_t - q0)
        off_line = max(off_line, float(np.linalg.norm(moved - (moved @ line) * line)))
    assert (off_line < 1e-6) if whole else (off_line > 0.01)
    assert AssistanceConfig().keep_joint_line is False  # off by default
