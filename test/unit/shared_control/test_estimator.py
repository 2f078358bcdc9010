"""shared_control.estimator: goal inference from the operator's twist, on hand-built scenes and the cup."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import InvalidIntentError, KinematicsError
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.approach import approach_positions
from grasp_intent_ros.shared_control.estimator import EstimatorConfig, IntentEstimator, progress_rates
from grasp_intent_ros.shared_control.goals import goals_at, goals_from_poses
from grasp_intent_ros.shared_control.operators import OperatorConstants, ScriptedOperator

from .hand_built import DT, SPEED, STRAIGHT, pose

U, T, H = 1, 2, 4
CONFIG = EstimatorConfig()


def scene() -> IntentEstimator:
    """Three goals 0.3 m from the origin: usage on +x, transfer on +y, handover on -x."""
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.0, 0.3, 0.0)), pose((-0.3, 0.0, 0.0))], [U, T, H], 3)
    return IntentEstimator(goals, CONFIG)


def reach(est: IntentEstimator, hand: np.ndarray, velocity: np.ndarray, seconds: float) -> np.ndarray:
    """Move the hand at constant ``velocity`` (m/s) for ``seconds``, feeding the estimator; returns the hand."""
    hand = hand.copy()
    for _ in range(round(seconds / DT)):
        est.update(hand, np.r_[velocity, 0.0, 0.0, 0.0], DT)
        hand[:3, 3] += velocity * DT
    return hand


def test_the_prior_w_is_each_tasks_share_of_the_goals_prior() -> None:
    goals = goals_from_poses([pose((0.1 * k, 0.0, 0.0)) for k in range(4)], [U, U, U, T | H], 3)
    assert_allclose(IntentEstimator(goals).w, [0.5, 0.5, 0.5], rtol=1e-12)  # goals' prior 1/6, 1/6, 1/6, 1/2


def test_motion_straight_at_the_usage_goal_raises_w_usage_and_away_lowers_it() -> None:
    prior = scene().w
    toward = scene()
    reach(toward, np.eye(4), np.array([SPEED, 0.0, 0.0]), 1.0)
    assert toward.w[0] > prior[0] + 0.3 and toward.w[2] < prior[2] - 0.2
    away = scene()
    reach(away, np.eye(4), np.array([-SPEED, 0.0, 0.0]), 1.0)
    assert away.w[0] < prior[0] - 0.2 and away.w[2] > prior[2] + 0.3


def test_holding_still_keeps_the_estimate_and_reset_returns_to_the_prior() -> None:
    est = scene()
    prior = est.w
    hand = reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 0.5)
    before = est.w
    for _ in range(200):
        est.update(hand, np.zeros(6), DT)
    assert_allclose(est.w, before, rtol=0, atol=0)
    est.reset()
    assert_allclose(est.w, prior, rtol=0, atol=0)


def test_a_goal_change_is_followed_within_memory_ln2_of_motion() -> None:
    """After 2 s toward usage, the operator heads for transfer: w_transfer leads within L ln 2 of motion."""
    est = scene()
    hand = reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 2.0)
    assert est.w[0] > est.w[1]
    bound = CONFIG.memory * math.log(2.0) / SPEED  # s
    elapsed = 0.0
    while est.w[1] <= est.w[0]:
        direction = np.array([0.0, 0.3, 0.0]) - hand[:3, 3]
        hand = reach(est, hand, SPEED * direction / np.linalg.norm(direction), DT)
        elapsed += DT
        assert elapsed <= bound + DT, f'not followed within {bound:.2f} s'


def test_goals_at_the_same_pose_keep_their_prior_ratio() -> None:
    """What the motion cannot tell apart (two task sets at one pose, differing only in the fingers)."""
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.3, 0.0, 0.0)), pose((-0.3, 0.0, 0.0))], [H, U | H, T], 3)
    est = IntentEstimator(goals)
    reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 2.0)
    p = est.posterior
    assert p[0] == pytest.approx(p[1], rel=1e-12) and p[2] < 0.05
    assert est.w[2] > 0.95 and est.w[0] == pytest.approx(0.5, abs=0.03)


def test_a_classifiers_w_is_the_independent_task_prior_over_the_served_sets() -> None:
    """pi(S) proportional to prod w_i^s_i (1 - w_i)^(1 - s_i) over the served sets, then uniform over a set's goals."""
    goals = goals_from_poses([pose((0.1 * k, 0.0, 0.0)) for k in range(4)], [U, U, U | T, H], 3)
    est = IntentEstimator(goals)
    w = np.array([0.9, 0.6, 0.2])
    est.set_task_prior(w)
    joint = {U: 0.9 * 0.4 * 0.8, U | T: 0.9 * 0.6 * 0.8, H: 0.1 * 0.4 * 0.2}
    total = sum(joint.values())
    assert_allclose(est.posterior, [joint[U] / total / 2, joint[U] / total / 2, joint[U | T] / total,
                                    joint[H] / total], rtol=1e-12)
    assert_allclose(est.task_prior, w, rtol=0, atol=0)
    est.set_task_prior([0.5, 0.5, 0.5])  # the uniform prior, up to rounding
    assert_allclose(est.log_prior, goals.log_prior, rtol=0, atol=1e-12)
    est.set_task_prior(None)
    assert est.log_prior is goals.log_prior and est.task_prior is None


def test_the_prior_decides_what_the_motion_cannot_tell_apart_and_the_motion_the_rest() -> None:
    """Two sets at one pose keep the classifier's ratio; motion at a goal the classifier doubts still wins."""
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.3, 0.0, 0.0)), pose((-0.3, 0.0, 0.0))], [H, U | H, T], 3)
    est = IntentEstimator(goals)
    est.set_task_prior([0.9, 0.1, 0.9])  # usage + handover likely, transfer not
    reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 2.0)
    p = est.posterior
    assert p[1] / p[0] == pytest.approx(0.9 / 0.1, rel=1e-9), 'the classifier tells U+H from H where motion cannot'
    assert est.w[0] > 0.85
    doubted = IntentEstimator(goals)
    doubted.set_task_prior([0.9, 0.1, 0.9])
    reach(doubted, np.eye(4), np.array([-SPEED, 0.0, 0.0]), 1.0)  # straight at the transfer goal
    assert doubted.w[1] > 0.95, 'motion overrides a classifier that doubts the goal it heads for'


def test_a_new_classifier_w_reweights_the_motion_seen_so_far_and_reset_keeps_it() -> None:
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.3, 0.0, 0.0)), pose((-0.3, 0.0, 0.0))], [H, U | H, T], 3)
    est = IntentEstimator(goals)
    reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 1.0)
    evidence = est.evidence.copy()
    est.set_task_prior([0.1, 0.1, 0.9])
    assert_allclose(est.evidence, evidence, rtol=0, atol=0)
    p = est.posterior
    assert p[0] / p[1] == pytest.approx(0.9 / 0.1, rel=1e-9), 'H over U+H at once, on the motion already seen'
    est.reset()
    assert_allclose(est.task_prior, [0.1, 0.1, 0.9], rtol=0, atol=0)
    assert est.posterior[0] > est.posterior[1]


def test_a_classifier_w_of_0_or_1_rules_no_set_out_and_bad_ones_are_refused() -> None:
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((-0.3, 0.0, 0.0))], [U, T], 2)
    est = IntentEstimator(goals)
    est.set_task_prior([1.0, 0.0])
    assert_allclose(est.task_prior, [0.99, 0.01], rtol=0, atol=0)
    assert est.posterior[1] > 0.0
    reach(est, np.eye(4), np.array([-SPEED, 0.0, 0.0]), 1.0)
    assert est.w[1] > 0.9, 'the motion recovers a task the classifier put at 0'
    before = est.log_prior
    for bad in ([0.5], [0.5, 0.5, 0.5], [0.5, math.nan], [1.5, 0.5], [-0.1, 0.5], [[0.5, 0.5]]):
        with pytest.raises(InvalidIntentError):
            est.set_task_prior(bad)
        assert est.log_prior is before


def near_scene(config: EstimatorConfig = STRAIGHT) -> IntentEstimator:
    """Usage and handover goals 1 cm apart at 0.3 m on +x, transfer 0.3 m away on +y."""
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.3, 0.01, 0.0)), pose((0.0, 0.3, 0.0))], [U, H, T], 3)
    return IntentEstimator(goals, config)


def test_goals_near_the_shown_grasp_gain_the_progress_toward_it() -> None:
    """An operator heading for the shown grasp says only that its own goal lies near it, not which one."""
    toward_h = np.array([0.3, 0.01, 0.0]) / np.linalg.norm([0.3, 0.01, 0.0]) * SPEED
    unshown = near_scene()
    end = reach(unshown, np.eye(4), toward_h, 2.45)  # to within 1 cm of the handover goal (0.294 m of 0.300)
    assert unshown.w[2] > unshown.w[0] + 0.2, 'without a proposal the motion separates goals 1 cm apart'
    shown = near_scene()
    shown.set_proposal(pose((0.3, 0.0, 0.0)))  # the usage goal is shown; handover lies 1 cm from it
    reach(shown, np.eye(4), toward_h, 2.45)
    p = shown.posterior
    assert p[0] == pytest.approx(p[1], rel=1e-9), 'both near goals gain the same evidence: their prior ratio stays'
    assert shown.w[1] < 0.05, 'the far transfer goal still loses'
    ignored = near_scene(EstimatorConfig(standoff=0.0, proposal_radius=0.0))
    ignored.set_proposal(pose((0.3, 0.0, 0.0)))
    reach(ignored, np.eye(4), toward_h, 2.45)
    assert_allclose(ignored.evidence, unshown.evidence, rtol=0, atol=0)
    assert np.linalg.norm(end[:3, 3] - [0.3, 0.01, 0.0]) < 0.01


def test_a_goal_outside_the_proposal_keeps_its_own_progress() -> None:
    est = near_scene()
    est.set_proposal(pose((0.3, 0.0, 0.0)))
    reach(est, np.eye(4), np.array([0.0, SPEED, 0.0]), 2.0)  # straight at transfer, away from the proposal
    assert est.w[1] > 0.95 and est.w[0] < 0.05 and est.w[2] < 0.05


def beyond_scene(config: EstimatorConfig = STRAIGHT) -> IntentEstimator:
    """Usage and handover 1 cm apart at 0.3 m on +x; transfer 3 cm beyond usage on the same line, turned 1 rad."""
    goals = goals_from_poses([pose((0.3, 0.0, 0.0)), pose((0.3, 0.01, 0.0)), pose((0.33, 0.0, 0.0), (1.0, 0.0, 0.0))],
                             [U, H, T], 3)
    return IntentEstimator(goals, config)


def test_fine_motion_at_the_shown_grasp_is_no_evidence() -> None:
    """Within position_scale and angle_scale of the shown grasp the hand is being placed on it.

    The last corrections, which point on past it at a goal outside its neighbourhood, change no evidence.
    """
    fine = np.array([0.03, 0.0, 0.0])  # the final approach: slow, on toward the shown grasp and transfer beyond it
    runs = {}
    for name, config in (('shown', STRAIGHT), ('ignored', EstimatorConfig(standoff=0.0, proposal_radius=0.0))):
        est = beyond_scene(config)
        est.set_proposal(pose((0.3, 0.0, 0.0)))
        hand = reach(est, np.eye(4), np.array([SPEED, 0.0, 0.0]), 2.35)  # 0.282 m: 1.8 cm short, in the core
        assert est.at_proposal(hand) == (name == 'shown')
        arrived = est.evidence.copy()
        reach(est, hand, fine, 0.5)  # to 0.297 m
        runs[name] = (arrived, est)
    arrived, shown = runs['shown']
    assert_allclose(shown.evidence, arrived, rtol=0, atol=0)
    assert shown.w[1] < 0.5, 'transfer keeps what the approach gave it (the three lie on one line: a third)'
    arrived, ignored = runs['ignored']
    assert ignored.evidence[2] - ignored.evidence[0] > arrived[2] - arrived[0] + 3.0, \
        'without the shown grasp the same corrections are read as progress toward transfer'
    assert ignored.w[1] > 0.9


def test_motion_outside_the_shown_grasps_core_or_away_from_it_is_evidence() -> None:
    """Motion outside the shown grasp's core, or in it away from the grasp, is evidence.

    2.5 cm short of the shown grasp, or at its position turned 0.1 rad past angle_scale, motion toward it counts;
    in the core, motion that moves the hand away from it (turning off it toward a goal elsewhere while something
    else holds the hand there, or backing off) counts too.
    """
    for hand, twist in ((pose((0.275, 0.0, 0.0)), np.array([0.03, 0.0, 0.0, 0.0, 0.0, 0.0])),
                        (pose((0.3, 0.0, 0.0), (0.0, 0.0, CONFIG.angle_scale + 0.1)),
                         np.array([0.0, 0.0, 0.0, 0.0, 0.0, -0.3]))):
        est = beyond_scene()
        est.set_proposal(pose((0.3, 0.0, 0.0)))
        assert not est.at_proposal(hand)
        est.update(hand, twist, DT)
        assert est.evidence[0] > 0.0 and est.evidence[0] == est.evidence[1], 'toward the shown grasp: its neighbours'
    est = beyond_scene()
    est.set_proposal(pose((0.3, 0.0, 0.0)))
    hand = pose((0.295, 0.0, 0.0), (0.05, 0.0, 0.0))
    assert est.at_proposal(hand)
    for _ in range(50):  # 0.5 s turning at 0.6 rad/s toward transfer's roll, the hand held in place
        est.update(hand, np.array([0.0, 0.0, 0.0, 0.6, 0.0, 0.0]), DT)
    assert est.evidence[0] < 0.0 < est.evidence[2] and est.w[1] > 0.9, 'turning off the shown grasp says transfer'


def test_proposal_turned_away_is_outside_and_none_or_reset_forget_it() -> None:
    turned = near_scene()
    turned.set_proposal(pose((0.3, 0.0, 0.0), (CONFIG.proposal_angle + 0.1, 0.0, 0.0)))  # beyond the angle
    reach(turned, np.eye(4), np.array([0.3, 0.01, 0.0]) / np.linalg.norm([0.3, 0.01, 0.0]) * SPEED, 2.4)
    plain = near_scene()
    reach(plain, np.eye(4), np.array([0.3, 0.01, 0.0]) / np.linalg.norm([0.3, 0.01, 0.0]) * SPEED, 2.4)
    assert_allclose(turned.evidence, plain.evidence, rtol=0, atol=0)
    for forget in ('none', 'reset'):
        est = near_scene()
        est.set_proposal(pose((0.3, 0.0, 0.0)))
        if forget == 'none':
            est.set_proposal(None)
        else:
            est.reset()
        reach(est, np.eye(4), np.array([0.0, SPEED, 0.0]), 0.5)
        fresh = near_scene()
        reach(fresh, np.eye(4), np.array([0.0, SPEED, 0.0]), 0.5)
        assert_allclose(est.evidence, fresh.evidence, rtol=0, atol=0)
    est = near_scene()
    with pytest.raises(KinematicsError):
        est.set_proposal(2.0 * np.eye(4))


def test_likely_sets_lists_the_likeliest_first_and_ties_by_bitmask() -> None:
    names = ('usage', 'transfer', 'handover')
    est = scene()
    assert est.likely_sets(names) == 'U: 0.33, T: 0.33, H: 0.33'
    reach(est, np.eye(4), np.array([0.0, SPEED, 0.0]), 1.0)
    assert est.likely_sets(names, count=1).startswith('T: ')


def test_a_proposal_given_at_construction_is_set() -> None:
    shown = near_scene()
    shown.set_proposal(pose((0.3, 0.0, 0.0)))
    built = IntentEstimator(shown.goals, STRAIGHT, proposal=pose((0.3, 0.0, 0.0)))
    toward = np.array([0.3, 0.01, 0.0]) / np.linalg.norm([0.3, 0.01, 0.0]) * SPEED
    reach(shown, np.eye(4), toward, 1.0)
    reach(built, np.eye(4), toward, 1.0)
    assert_allclose(built.evidence, shown.evidence, rtol=0, atol=0)


def test_progress_rates_are_the_decrease_of_the_huber_pose_distance() -> None:
    """Against finite differences of D_g, written out here independently, at poses far from and near the goals.

    D_g is measured to g's approach target, which is piecewise constant in the hand's pose (the pre-grasp outside
    g's corridor, g inside): D_g is smooth, and s_g its rate of decrease, wherever the step stays on one side of
    every corridor's boundary (checked here); on a boundary D_g jumps.
    """
    rng = np.random.default_rng(1)
    cfg = CONFIG

    def target(goal: np.ndarray, hand: np.ndarray) -> np.ndarray:
        d = hand[:3, 3] - goal[:3, 3]
        z = goal[:3, 2]
        theta = float(np.linalg.norm(pin.log3(goal[:3, :3] @ hand[:3, :3].T)))
        inside = (np.linalg.norm(d) <= cfg.corridor_radius
                  or (d @ z <= 0.0 and np.linalg.norm(d - (d @ z) * z) <= cfg.corridor_radius
                      and theta <= cfg.corridor_angle))
        return goal[:3, 3] if inside else goal[:3, 3] - cfg.standoff * z

    def distance(goal: np.ndarray, hand: np.ndarray, position: np.ndarray) -> float:
        e = float(np.linalg.norm(position - hand[:3, 3]))
        h = e * e / (2 * cfg.position_scale) if e <= cfg.position_scale else e - cfg.position_scale / 2
        theta = float(np.linalg.norm(pin.log3(goal[:3, :3] @ hand[:3, :3].T)))
        s = math.sin(cfg.angle_scale / 2)
        c = (1 - math.cos(theta)) / (2 * s) if theta <= cfg.angle_scale else 2 * math.sin(theta / 2) - s
        return h + cfg.rotation_length * c

    goal_poses = [pose(tuple(rng.uniform(-0.3, 0.3, 3)), tuple(rng.normal(0.0, 1.0, 3))) for _ in range(6)]
    goals = goals_from_poses(goal_poses, [U, T, H, U | T, U | H, T | H], 3)
    hands = [pose(tuple(rng.uniform(-0.3, 0.3, 3)), tuple(rng.normal(0.0, 1.0, 3))) for _ in range(5)]
    hands.append(goal_poses[0] @ pose((0.005, 0.0, 0.0), (0.0, 0.05, 0.0)))  # inside both quadratic cores
    hands.append(goal_poses[1] @ pose((0.01, 0.0, -0.05), (0.0, 0.1, 0.0)))  # in the corridor, 5 cm behind the goal
    hands.append(goal_poses[2] @ pose((0.0, 0.0, -0.09), (0.0, 0.0, 0.02)))  # 1 cm behind the pre-grasp, in its core
    step = 1e-6
    inside = 0
    for hand in hands:
        twist = rng.normal(0.0, 0.1, 6)
        moved = hand.copy()
        moved[:3, 3] += twist[:3] * step
        moved[:3, :3] = pin.exp3(twist[3:] * step) @ hand[:3, :3]
        targets = [target(g, hand) for g in goal_poses]
        assert all(np.array_equal(t, target(g, moved)) for t, g in zip(targets, goal_poses)), 'a step across a boundary'
        inside += sum(np.array_equal(t, g[:3, 3]) for t, g in zip(targets, goal_poses))
        numeric = [-(distance(g, moved, t) - distance(g, hand, t)) / step for g, t in zip(goal_poses, targets)]
        assert_allclose(progress_rates(goals, hand, twist, cfg), numeric, rtol=0, atol=1e-6)
    assert inside >= 3, 'some hands lie in a corridor (the target is the goal itself)'


def test_heading_for_a_goals_pre_grasp_is_evidence_for_it_over_a_goal_on_the_way() -> None:
    """Goal A (usage) approached from below; B (transfer) lies on the line to A's pre-grasp, approached along +y.

    The operator heads for A's pre-grasp: the approach model credits A with the full progress and B with less
    (B's own pre-grasp lies 8 cm off the line); an operator model heading straight at each goal prefers B, which
    lies on the line, to A, which lies 8 cm above its end.
    """
    goal_a = pose((0.3, 0.0, 0.0))  # approach axis +z: pre-grasp at (0.3, 0, -0.08)
    goal_b = pose((0.15, 0.0, -0.04), (-math.pi / 2, 0.0, 0.0))  # halfway to A's pre-grasp, approach axis +y
    assert_allclose(goal_b[:3, 2], [0.0, 1.0, 0.0], atol=1e-12)
    pre_a = goal_a[:3, 3] - CONFIG.standoff * goal_a[:3, 2]
    velocity = SPEED * pre_a / np.linalg.norm(pre_a)
    w = {}
    for name, config in (('approach', CONFIG), ('straight', STRAIGHT)):
        est = IntentEstimator(goals_from_poses([goal_a, goal_b], [U, T], 2), config)
        hand = reach(est, np.eye(4), velocity, 0.1 / SPEED)  # 10 cm of the 15.5 cm to B
        assert np.linalg.norm(hand[:3, 3] - goal_b[:3, 3]) > 0.05
        w[name] = est.posterior
    assert w['approach'][0] > 0.9, 'heading for A\'s pre-grasp says A'
    assert w['straight'][1] > w['straight'][0], 'without the approach, B on the way wins'


def test_the_target_switches_to_the_goal_in_its_approach_corridor() -> None:
    """The pose steered to: the pre-grasp outside the corridor, the goal inside (the operators' own rule)."""
    goals = goals_from_poses([pose((0.0, 0.0, 0.0))], [U], 1)  # approach axis +z, pre-grasp at z = -0.08
    up, sideways = np.r_[0.0, 0.0, SPEED, 0.0, 0.0, 0.0], np.r_[-SPEED, 0.0, 0.0, 0.0, 0.0, 0.0]
    beside_pre = pose((0.05, 0.0, -0.08))  # 5 cm beside the pre-grasp: outside the corridor
    assert progress_rates(goals, beside_pre, up, CONFIG)[0] == pytest.approx(0.0, abs=1e-15)  # across its line
    assert progress_rates(goals, beside_pre, sideways, CONFIG)[0] == pytest.approx(SPEED, rel=1e-12)
    on_axis = pose((0.0, 0.01, -0.05), (0.0, 0.1, 0.0))  # behind the goal, 1 cm off its axis, turned 0.1 rad
    assert progress_rates(goals, on_axis, up, CONFIG)[0] == pytest.approx(SPEED * 0.05 / math.hypot(0.01, 0.05))
    turned = pose((0.0, 0.01, -0.05), (0.0, CONFIG.corridor_angle + 0.05, 0.0))  # the same, turned past the corridor
    assert progress_rates(goals, turned, up, CONFIG)[0] == pytest.approx(-SPEED * 0.03 / math.hypot(0.01, 0.03))
    in_front = pose((0.0, 0.015, 0.01), (1.0, 0.0, 0.0))  # within corridor_radius of the goal, in front, turned 1 rad
    toward = np.r_[0.0, -SPEED, 0.0, 0.0, 0.0, 0.0]
    in_core = SPEED * 0.015 / CONFIG.position_scale  # 1.8 cm from the goal: the Huber core's rate
    assert progress_rates(goals, in_front, toward, CONFIG)[0] == pytest.approx(in_core)
    # one definition: the operators' approach target, for hands around goals of any orientation
    rng = np.random.default_rng(3)
    operator = ScriptedOperator('spacemouse', OperatorConstants(), rng)
    switched = 0
    for _ in range(200):
        goal = pose(tuple(rng.uniform(-0.1, 0.1, 3)), tuple(rng.normal(0.0, 1.0, 3)))
        hand = goal @ pose(tuple(rng.normal(0.0, 0.02, 3) - [0.0, 0.0, 0.03]), tuple(rng.normal(0.0, 0.15, 3)))
        ours = approach_positions(hand, goal[None, :3, 3], goal[None, :3, :3], standoff=CONFIG.standoff,
                                  corridor_radius=CONFIG.corridor_radius, corridor_angle=CONFIG.corridor_angle)
        assert_allclose(ours[0], operator.approach_target(hand, goal)[:3, 3], rtol=0, atol=0)
        switched += bool(np.array_equal(ours[0], goal[:3, 3]))
    assert 20 <= switched <= 180, 'both sides of the corridor are drawn'


def test_rates_are_bounded_by_the_pose_speed_and_defined_at_the_goal_and_opposite_it() -> None:
    goals = goals_from_poses([pose((0.0, 0.0, 0.0)), pose((0.0, 0.0, 0.0), (math.pi, 0.0, 0.0))], [U, T], 2)
    twist = np.array([0.1, -0.2, 0.05, 0.3, -0.4, 0.9])
    rates = progress_rates(goals, np.eye(4), twist, CONFIG)
    assert np.all(np.isfinite(rates))
    assert np.all(np.abs(rates) <= np.linalg.norm(twist[:3]) + CONFIG.rotation_length * np.linalg.norm(twist[3:]))


def test_w_stays_finite_and_in_range_under_extreme_input() -> None:
    est = scene()
    floor = CONFIG.w_floor
    for twist, dt in ((np.full(6, 1e300), 0.01), (np.full(6, -1.7e308), 1e9), (np.full(6, 1e-300), 0.01),
                      (np.ones(6), 0.0), (np.ones(6), -5.0)):
        w = est.update(np.eye(4), twist, dt)
        assert np.all(np.isfinite(w)) and np.all(w >= floor) and np.all(w <= 1 - floor)
        assert np.all(np.abs(est.evidence) <= CONFIG.rationality * CONFIG.memory * (1 + 1e-12))
    before = est.evidence.copy()
    for bad in ((np.eye(4), np.full(6, np.nan), 0.01), (np.eye(4), np.full(6, np.inf), 0.01),
                (np.eye(4), np.ones(6), math.nan), (np.full((4, 4), np.nan), np.ones(6), 0.01),
                (np.eye(4), np.ones(5), 0.01)):
        with pytest.raises(KinematicsError):
            est.update(*bad)
    assert_allclose(est.evidence, before, rtol=0, atol=0)


def test_bad_settings_are_refused() -> None:
    for bad in (dict(rationality=0.0), dict(memory=-1.0), dict(w_floor=0.5), dict(angle_scale=4.0),
                dict(max_dt=math.inf), dict(proposal_radius=-0.1), dict(proposal_angle=math.nan), dict(standoff=-0.01),
                dict(corridor_radius=math.inf), dict(corridor_angle=-0.1)):
        with pytest.raises(InvalidIntentError):
            EstimatorConfig(**bad)  # type: ignore[arg-type]


def test_cup_reach_from_home_toward_a_usage_demonstration_raises_w_usage() -> None:
    """The shipped cup model at the planner's default object pose: a straight reach for a usage-only grasp."""
    model = ModelFiles(config_dir() / 'models').load('cup_7zone')
    base_T_obj = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
    goals = goals_at(model, base_T_obj)
    est = IntentEstimator(goals)
    prior = est.w
    target = int(np.flatnonzero(goals.task_sets == U)[0])
    hand = MicoKinematics().fk(HOME_Q)
    direction = goals.positions[target] - hand[:3, 3]
    distance = float(np.linalg.norm(direction))
    reach(est, hand, SPEED * direction / distance, 0.9 * distance / SPEED)
    assert est.w[0] > prior[0]
    sets = est.set_posterior()
    assert sum(sets.values()) == pytest.approx(1.0, abs=1e-12) and set(sets) == set(range(1, 8))
