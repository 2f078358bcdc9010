"""shared_control.scene_estimator: P(o) and each object's w from one posterior over several objects' goals."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from grasp_intent_ros.errors import InvalidIntentError, KinematicsError
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.estimator import EstimatorConfig, IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at, goals_from_poses
from grasp_intent_ros.shared_control.operators import OperatorConstants, ScriptedOperator
from grasp_intent_ros.shared_control.scene_estimator import SceneEstimator

from .hand_built import DT, SPEED, STRAIGHT, pose

U, T, H = 1, 2, 4


def two_objects(config: EstimatorConfig = STRAIGHT, b_near: tuple[float, float, float] = (0.3, -0.25, 0.0)
                ) -> SceneEstimator:
    """Object 'a' at +y (usage at (0.3, 0.2), handover 5 cm on), object 'b' at -y (usage, transfer at ``b_near``)."""
    scene = SceneEstimator()
    scene.set_object('a', IntentEstimator(goals_from_poses([pose((0.3, 0.2, 0.0)), pose((0.3, 0.25, 0.0))], [U, H], 3),
                                          config))
    scene.set_object('b', IntentEstimator(goals_from_poses([pose((0.3, -0.2, 0.0)), pose(b_near)], [U, T], 3), config))
    return scene


def reach(scene: SceneEstimator, hand: np.ndarray, target: tuple[float, float, float], seconds: float) -> np.ndarray:
    """Move the hand straight at ``target`` at SPEED for ``seconds``, feeding the scene; returns the hand."""
    hand = hand.copy()
    for _ in range(round(seconds / DT)):
        direction = np.asarray(target) - hand[:3, 3]
        velocity = SPEED * direction / np.linalg.norm(direction)
        scene.update(hand, np.r_[velocity, 0.0, 0.0, 0.0], DT)
        hand[:3, 3] += velocity * DT
    return hand


def in_range(scene: SceneEstimator) -> None:
    p = scene.object_probabilities
    assert np.all(np.isfinite(p)) and np.all(p > 0.0) and np.all(p <= 1.0) and p.sum() == pytest.approx(1.0, abs=1e-12)
    for name in scene:
        w = scene.w(name)
        floor = scene[name].config.w_floor
        assert np.all(np.isfinite(w)) and np.all(w >= floor) and np.all(w <= 1.0 - floor)


def test_the_prior_is_uniform_over_objects_then_task_sets_then_goals() -> None:
    """pi_g = 1 / (n_objects n_sets(o) n_S(o)); P(o) sums o's goals, w^o is o's goals' marginals renormalised."""
    scene = SceneEstimator()
    scene.set_object('a', IntentEstimator(goals_from_poses([pose((0.1 * k, 0.3, 0.0)) for k in range(3)],
                                                           [U, U, T], 3)))
    scene.set_object('b', IntentEstimator(goals_from_poses([pose((0.3, -0.3, 0.0))], [H], 3)))
    joint = scene.goal_posterior()
    assert_allclose(joint['a'], [1 / 8, 1 / 8, 1 / 4], rtol=1e-12)
    assert_allclose(joint['b'], [1 / 2], rtol=1e-12)
    assert_allclose(scene.object_probabilities, [0.5, 0.5], rtol=1e-12)
    reach(scene, np.eye(4), (0.1, 0.3, 0.0), 1.0)
    joint, p = scene.goal_posterior(), scene.object_probabilities
    assert_allclose(p, [joint['a'].sum(), joint['b'].sum()], rtol=1e-12)
    a = scene['a']
    assert_allclose(scene.w('a'), np.clip(joint['a'] @ a.goals.membership / p[0], 0.01, 0.99), rtol=1e-12)


def test_a_reach_at_as_usage_grasp_raises_p_a_and_w_a_usage() -> None:
    scene = two_objects()
    assert_allclose(scene.object_probabilities, [0.5, 0.5], rtol=1e-12)
    reach(scene, np.eye(4), (0.3, 0.2, 0.0), 2.0)
    p = scene.object_probabilities
    assert p[0] > 0.99, f'P(a) {p[0]:.3f}'
    assert scene.w('a')[0] > 0.8 and scene.w('a')[2] < 0.2, 'within a: usage, not the handover 5 cm on'
    in_range(scene)


def test_a_reach_that_turns_to_b_is_followed_within_memory_ln3_of_motion() -> None:
    """After 2 s at a's usage grasp the operator heads for b's: P(b) leads within L ln 3 of motion (0.92 s).

    The bound: the new heading makes more than a right angle with a's goals (their progress rate r <= 0), and b's
    usage goal gains at the full rate from its evidence E >= -beta L; with x = exp(-l / L) over the path l since the
    turn, E_a <= beta L x and E_b >= beta L (1 - 2x): b leads by x = 1/3 (the objects' two-goal priors shift it by
    log 2 nats of beta L = 100, 1 %).
    """
    scene = two_objects()
    hand = reach(scene, np.eye(4), (0.3, 0.2, 0.0), 2.0)
    assert scene.object_probabilities[0] > 0.99
    bound = STRAIGHT.memory * math.log(3.0) * 1.01 / SPEED  # s
    elapsed = 0.0
    while scene.object_probabilities[1] <= 0.5:
        hand = reach(scene, hand, (0.3, -0.2, 0.0), DT)
        elapsed += DT
        assert elapsed <= bound + DT, f'not followed within {bound:.2f} s'
    hand = reach(scene, hand, (0.3, -0.2, 0.0), 1.0)
    assert scene.object_probabilities[1] > 0.99 and scene.w('b')[0] > 0.7 > 0.3 > scene.w('b')[1]
    in_range(scene)


def test_no_objects_probability_reaches_0_and_w_stays_in_range_under_extreme_input() -> None:
    """The forgetting bounds the odds of two objects by exp(2 beta L): P(o) >= 1 / (1 + exp(2 beta L)) > 0."""
    scene = SceneEstimator()
    for name, x in (('a', 1.0), ('b', -1.0)):
        scene.set_object(name, IntentEstimator(goals_from_poses([pose((x, 0.0, 0.0))], [U], 3), STRAIGHT))
    reach(scene, np.eye(4), (1.0, 0.0, 0.0), 5.0)  # 0.6 m, six memories: E_a near beta L, E_b near -beta L
    bound = 1.0 / (1.0 + math.exp(2.0 * STRAIGHT.rationality * STRAIGHT.memory))
    assert bound <= scene.object_probabilities[1] < 1e-80
    in_range(scene)
    for twist, dt in ((np.full(6, 1e300), 0.01), (np.full(6, -1.7e308), 1e9), (np.full(6, 1e-300), 0.01),
                      (np.ones(6), 0.0), (np.ones(6), -5.0)):
        scene.update(np.eye(4), twist, dt)
        in_range(scene)
    before = {name: scene[name].evidence.copy() for name in scene}
    for bad in ((np.eye(4), np.full(6, np.nan), 0.01), (np.eye(4), np.ones(6), math.inf),
                (np.full((4, 4), np.nan), np.ones(6), 0.01), (np.eye(4), np.ones(5), 0.01)):
        with pytest.raises(KinematicsError):
            scene.update(*bad)
    for name in scene:
        assert_array_equal(scene[name].evidence, before[name])


def test_a_task_prior_on_one_object_moves_its_w_not_p_o_nor_the_other_w() -> None:
    """intent/prior per object: pi_{g|o} from its w, still summing to 1 within o."""
    plain, primed = two_objects(), two_objects()
    primed['a'].set_task_prior([0.9, 0.5, 0.1])
    assert_allclose(primed.object_probabilities, [0.5, 0.5], rtol=1e-12)
    assert primed.w('a')[0] > plain.w('a')[0] + 0.3 and primed.w('a')[2] < plain.w('a')[2] - 0.3
    assert_array_equal(primed.w('b'), plain.w('b'))
    for scene in (plain, primed):
        reach(scene, np.eye(4), (0.3, -0.2, 0.0), 2.0)  # at b's usage grasp: the motion decides P(o)
        assert scene.object_probabilities[1] > 0.99


def test_each_objects_shown_grasp_credits_only_that_objects_goals() -> None:
    """The grasp shown for a at a's usage goal, b's transfer goal 3 cm from it: b's goal keeps its own progress."""
    near = (0.3, 0.17, 0.0)
    plain, shown = two_objects(b_near=near), two_objects(b_near=near)
    shown['a'].set_proposal(pose((0.3, 0.2, 0.0)))
    for scene in (plain, shown):
        reach(scene, np.eye(4), (0.3, 0.25, 0.0), 2.0)  # straight at a's handover, 5 cm from the shown usage grasp
    assert_array_equal(shown['b'].evidence, plain['b'].evidence)
    a = shown['a'].evidence
    assert a[0] == a[1] and not np.array_equal(a, plain['a'].evidence), "a's goals near it: the shown grasp's progress"


def test_placing_the_hand_on_any_objects_shown_grasp_holds_every_object() -> None:
    """In the core of a's shown grasp, fine motion toward it changes no evidence of a or of b (P(o) held)."""
    runs = {}
    for name, placing in (('shown', STRAIGHT), ('ignored', EstimatorConfig(standoff=0.0, proposal_radius=0.0))):
        scene = two_objects(placing)
        scene['a'].set_proposal(pose((0.3, 0.2, 0.0)))
        hand = reach(scene, np.eye(4), (0.3, 0.2, 0.0), 2.9)  # 1.2 cm short of it, in the core
        assert scene['a'].at_proposal(hand) == (name == 'shown')
        arrived = {o: scene[o].evidence.copy() for o in scene}
        p = scene.object_probabilities
        reach(scene, hand, (0.3, 0.2, 0.0), 0.05)
        runs[name] = (arrived, p, scene)
    arrived, p, scene = runs['shown']
    for o in scene:
        assert_array_equal(scene[o].evidence, arrived[o])
    assert_array_equal(scene.object_probabilities, p)
    arrived, _, scene = runs['ignored']
    assert not np.array_equal(scene['b'].evidence, arrived['b']), 'without the rule the same motion is evidence'


def test_set_object_replaces_one_object_and_keeps_the_others() -> None:
    scene = two_objects()
    reach(scene, np.eye(4), (0.3, 0.2, 0.0), 1.0)
    a = scene['a'].evidence.copy()
    fresh = IntentEstimator(scene['b'].goals, STRAIGHT)
    scene.set_object('b', fresh)
    assert list(scene) == ['a', 'b'] and scene['b'] is fresh
    assert_array_equal(scene['a'].evidence, a)
    assert_allclose(scene.log_masses()[1], 0.0, atol=1e-12)
    calibrated = IntentEstimator(fresh.goals, EstimatorConfig(standoff=0.0, calibration_slope=1.4,
                                                              calibration_offset=-0.2))
    scene.set_object('c', calibrated)  # a model's own calibration map: accepted
    with pytest.raises(InvalidIntentError):
        scene.set_object('d', IntentEstimator(fresh.goals, EstimatorConfig(standoff=0.0, memory=0.2)))
    with pytest.raises(InvalidIntentError):
        scene.set_object('', IntentEstimator(fresh.goals, STRAIGHT))
    assert list(scene) == ['a', 'b', 'c']
    scene['c'].config = EstimatorConfig(memory=0.2)
    with pytest.raises(InvalidIntentError):
        scene.update(np.eye(4), np.ones(6), DT)
    scene.remove('c')
    scene.remove('b')
    assert_array_equal(scene.object_probabilities, [1.0])
    scene.remove('a')
    assert scene.object_probabilities.size == 0
    with pytest.raises(InvalidIntentError):
        scene.update(np.eye(4), np.ones(6), DT)
    with pytest.raises(KeyError):
        scene.w('a')


def cup_estimator() -> IntentEstimator:
    model = ModelFiles(config_dir() / 'models').load('cup_7zone')
    return IntentEstimator(goals_at(model, pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))))


def test_one_object_gives_the_one_object_estimators_w_to_the_last_bit() -> None:
    """A scene of one object is the one-object estimator: every w, the evidence, and P(o) = 1, bit for bit.

    The cup at the planner's default pose; a scripted spacemouse operator (noisy twists) reaches from Home for a
    usage grasp, shown from tick 300 on, into its core (the placing rule).
    """
    alone, inside = cup_estimator(), cup_estimator()
    scene = SceneEstimator()
    scene.set_object('cup', inside)
    goals = alone.goals
    goal_index = int(np.flatnonzero(goals.task_sets == U)[0])
    goal = np.eye(4)
    goal[:3, :3], goal[:3, 3] = goals.rotations[goal_index], goals.positions[goal_index]
    operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(7))
    hand = MicoKinematics().fk(HOME_Q)
    placed = 0
    for tick in range(800):
        if tick == 300:
            alone.set_proposal(goal)
            inside.set_proposal(goal)
        twist = operator.twist(tick * DT, hand, goal)
        placed += alone.at_proposal(hand)
        alone.update(hand, twist, DT)
        scene.update(hand, twist, DT)
        assert_array_equal(scene.w('cup'), alone.w)
        assert_array_equal(scene.object_probabilities, [1.0])
        hand = hand.copy()
        hand[:3, 3] += twist[:3] * DT
        hand[:3, :3] = pin.exp3(twist[3:] * DT) @ hand[:3, :3]
    assert_array_equal(inside.evidence, alone.evidence)
    assert alone.w[0] > 0.9 and placed > 0, "the reach arrived, into the shown grasp's core"


def test_the_cup_and_the_flashlight_a_reach_for_the_flashlight_finds_it() -> None:
    """The shipped models at two poses 0.43 m apart: a reach for a flashlight usage grasp finds the flashlight.

    A scripted joystick operator from Home: P(flashlight) and its w_usage end near 1, every step in range.
    """
    files = ModelFiles(config_dir() / 'models')
    scene = SceneEstimator()
    scene.set_object('cup', IntentEstimator(goals_at(files.load('cup_7zone'),
                                                     pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0)))))
    scene.set_object('flashlight', IntentEstimator(goals_at(files.load('flashlight_7zone'),
                                                            pose_to_matrix((0.45, 0.1, 0.0), (0.0, 0.0, 1.0, 0.0)))))
    goals = scene['flashlight'].goals
    index = int(np.flatnonzero(goals.task_sets == U)[0])
    goal = np.eye(4)
    goal[:3, :3], goal[:3, 3] = goals.rotations[index], goals.positions[index]
    operator = ScriptedOperator('joystick', OperatorConstants(), np.random.default_rng(1))
    hand = MicoKinematics().fk(HOME_Q)
    for tick in range(1500):
        twist = operator.twist(tick * DT, hand, goal)
        scene.update(hand, twist, DT)
        in_range(scene)
        hand = hand.copy()
        hand[:3, 3] += twist[:3] * DT
        hand[:3, :3] = pin.exp3(twist[3:] * DT) @ hand[:3, :3]
        if operator.at_goal(hand, goal):
            break
    assert operator.at_goal(hand, goal)
    assert scene.object_probabilities[1] > 0.99 and scene.w('flashlight')[0] > 0.9
