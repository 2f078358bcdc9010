"""grasp_intent_ros.shared_control.scene_simulator: the simulated loop over several objects, its intent and judge."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_error, pose_to_matrix
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.objects.judge import judge, judge_scene
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.ada import AdaAssistance
from grasp_intent_ros.shared_control.estimator import IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at, reachable_goals
from grasp_intent_ros.shared_control.limits import TwistLimiter
from grasp_intent_ros.shared_control.operators import OperatorConstants, PersistentIntent, ScriptedOperator
from grasp_intent_ros.shared_control.scene_estimator import SceneEstimator
from grasp_intent_ros.shared_control.scene_simulator import SceneIntent, SceneObject, simulate_scene
from grasp_intent_ros.shared_control.simulator import Scene, certain_grasps, simulate

CUP_AT = pose_to_matrix((0.3, -0.33, 0.0), (0.0, 0.0, 1.0, 0.0))
FLASHLIGHT_AT = pose_to_matrix((0.3, -0.06, 0.0), (0.0, 0.0, 1.0, 0.0))
H = 4


@pytest.fixture(scope='module')
def scene() -> list[SceneObject]:
    """The cup and the flashlight 0.27 m apart, each seen exactly (tracker and operator)."""
    kin = MicoKinematics()
    models = ModelFiles(config_dir() / 'models')
    objects = []
    for name, model_name, at in (('cup', 'cup_7zone', CUP_AT), ('flashlight', 'flashlight_7zone', FLASHLIGHT_AT)):
        model = models.load(model_name)
        grasps = certain_grasps(model, at, kin)
        objects.append(SceneObject(name, Scene(model, at, at, kin), {s: (g.base_T_ee, g.positions[6:])
                                                                     for s, g in grasps.items()},
                                   [g.base_T_ee for g in grasps.values()]))
    return objects


@pytest.fixture(scope='module')
def scene_estimator(scene) -> SceneEstimator:
    """The intent estimator over the scene's objects, each object's goals its reachable demonstrations there."""
    estimator = SceneEstimator()
    for obj in scene:
        model, at = obj.scene.model, obj.scene.base_T_obj
        estimator.set_object(obj.name, IntentEstimator(goals_at(model, at, reachable_goals(model, at, obj.scene.kin))))
    return estimator


def test_the_true_object_is_drawn_from_the_held_p_o_and_its_intent_gives_the_true_set() -> None:
    for favoured in (0.6, 0.9):
        draws = [SceneIntent.draw(i, 2, np.random.default_rng(i), favoured) for i in range(2000)]
        top = [int(np.argmax(d.probabilities)) for d in draws]
        assert np.mean(top) == pytest.approx(0.5, abs=0.04)  # the favoured object uniform of the two
        assert all(sorted(d.probabilities) == pytest.approx([1.0 - favoured, favoured]) for d in draws)
        on_top = np.mean([d.true_object == t for d, t in zip(draws, top)])
        assert on_top == pytest.approx(favoured, abs=0.03)  # the true object drawn from P(o)
        assert all(d.task_set(0.0) == d.intents[d.true_object].true_set for d in draws)
        assert all(d.intents[0].case == d.intents[1].case for d in draws)  # the paper's case i mod 5, each object
    rng = np.random.default_rng(3)
    reports = np.array([draws[0].object_probabilities(rng) for _ in range(500)])
    assert np.allclose(reports.sum(axis=1), 1.0)
    assert reports.mean(axis=0) == pytest.approx(draws[0].probabilities, abs=0.01)  # centred on the held P(o)
    assert 0.01 < reports.std(axis=0)[0] < 0.1


def test_one_object_draws_the_one_object_intent_and_reports_p_o_one_drawing_nothing() -> None:
    one, rng = SceneIntent.draw(7, 1, np.random.default_rng(5)), np.random.default_rng(5)
    assert one.intents == (PersistentIntent.draw(7, rng),) and one.probabilities == (1.0,) and one.true_object == 0
    report_rng, untouched = np.random.default_rng(9), np.random.default_rng(9)
    assert one.object_probabilities(report_rng).tolist() == [1.0]
    assert report_rng.uniform() == untouched.uniform()


def test_the_judge_fails_a_close_on_the_wrong_object_even_when_it_serves_the_task_there(scene) -> None:
    cup, flashlight = scene
    placed = [(o.scene.model, o.scene.base_T_obj_true) for o in scene]
    hand, closures = cup.own_goals[H]  # the cup's handover grasp: the flashlight's rules give it handover too
    assert judge(flashlight.scene.model, FLASHLIGHT_AT, hand, closures).serves(H)
    wrong = judge_scene(placed, 1, H, hand, closures)  # the operator wanted the flashlight
    assert wrong.at == 0 and wrong.wrong_object and not wrong.serves
    right = judge_scene(placed, 0, H, hand, closures)  # the same grasp, the cup wanted
    assert right.serves and not right.wrong_object
    hand, closures = flashlight.own_goals[H]
    assert judge_scene(placed, 1, H, hand, closures).serves and judge_scene(placed, 0, H, hand, closures).wrong_object


@pytest.mark.parametrize(('condition', 'device'), [('suite', 'spacemouse'), ('suite', 'joystick'),
                                                   ('direct', 'joystick')])
def test_one_object_with_p_o_one_is_the_one_object_episode_bit_for_bit(scene, condition, device) -> None:
    cup = scene[0]
    one = SceneIntent.draw(0, 1, np.random.default_rng(11))
    intent = one.intents[0]
    episodes = []
    for run in ('scene', 'one'):
        operator = ScriptedOperator(device, OperatorConstants(), np.random.default_rng(3))
        intent_rng, closure_rng = np.random.default_rng(4), np.random.default_rng(5)
        if run == 'scene':
            episodes.append(simulate_scene([cup], condition, one, operator, intent_rng, closure_rng,
                                           plan_caches=[{}], timeout=15.0))
        else:
            cache: dict[bytes, Grasp | None] = {}
            episodes.append(simulate(cup.scene, condition, intent, operator, cup.own_goals, intent_rng, closure_rng,
                                     ada_goals=[], plan_cache=cache, timeout=15.0))
    scene_ep, one_ep = episodes
    assert one_ep.closed_at is not None and scene_ep.closed_at == one_ep.closed_at
    assert one_ep.hand is not None and scene_ep.hand is not None and np.array_equal(scene_ep.hand, one_ep.hand)
    assert one_ep.closures is not None and scene_ep.closures is not None
    assert np.array_equal(scene_ep.closures, one_ep.closures)
    for name in ('alpha_mean', 'effort_linear', 'effort_angular', 'executed', 'pursued', 'task_set', 'swept',
                 'swept_palm', 'swept_finger', 'closing_palm', 'closing_finger', 'in_at_closing'):
        assert getattr(scene_ep, name) == getattr(one_ep, name), name
    assert scene_ep.wrong_object_alpha == 0.0 and scene_ep.switches == 0
    assert scene_ep.followed == ('cup' if condition == 'suite' else None)


def test_the_suite_follows_the_less_likely_object_the_operator_reaches_and_top_object_never_switches(scene) -> None:
    intent = SceneIntent((0.6, 0.4), (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.9, 0.1), 3)),
                         true_object=1)  # the flashlight wanted, the cup more likely
    runs = {}
    for condition in ('suite', 'top_object'):
        operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
        runs[condition] = simulate_scene(scene, condition, intent, operator, np.random.default_rng(4),
                                         np.random.default_rng(5), plan_caches=[{}, {}], timeout=20.0)
    suite, top = runs['suite'], runs['top_object']
    assert suite.followed == 'flashlight' and suite.executed_object == 'flashlight'
    assert suite.wrong_object_alpha < top.wrong_object_alpha
    assert top.followed == 'cup' and top.switches == 0  # the bet on the first report's top object, held
    placed = [(o.scene.model, o.scene.base_T_obj_true) for o in scene]
    assert suite.hand is not None and suite.closures is not None
    assert judge_scene(placed, 1, 3, suite.hand, suite.closures).serves


def test_ada_over_objects_takes_each_goals_target_of_least_value(scene) -> None:
    cup, flashlight = scene
    hand = cup.scene.kin.fk(HOME_Q)
    near = min(cup.ada_targets, key=lambda t: float(np.linalg.norm(t[:3, 3] - hand[:3, 3])))
    far = max(cup.ada_targets, key=lambda t: float(np.linalg.norm(t[:3, 3] - hand[:3, 3])))
    u = np.r_[0.05, 0.0, 0.0, 0.0, 0.0, 0.0]
    both = AdaAssistance([[far, near]], TwistLimiter(0.2, 1.0, 1.0, 5.0)).command(hand, u, 0.01)
    alone = AdaAssistance([[near]], TwistLimiter(0.2, 1.0, 1.0, 5.0)).command(hand, u, 0.01)
    assert np.array_equal(both, alone) and not np.array_equal(both, AdaAssistance(
        [[far]], TwistLimiter(0.2, 1.0, 1.0, 5.0)).command(hand, u, 0.01))
    # the distribution over objects moves to the object the operator heads for
    ada = AdaAssistance([cup.ada_targets, flashlight.ada_targets], TwistLimiter(0.2, 1.0, 1.0, 5.0))
    toward = pose_error(hand, flashlight.ada_targets[0])[:3]
    for _ in range(100):
        ada.command(hand, np.r_[0.1 * toward / np.linalg.norm(toward), 0.0, 0.0, 0.0], 0.01)
    p = ada.distribution()
    assert p.sum() == pytest.approx(1.0) and p[1] > 0.6  # from 0.5, the hand held still
    with pytest.raises(ValueError):
        AdaAssistance([[near], []], TwistLimiter(0.2, 1.0, 1.0, 5.0))


@pytest.mark.parametrize('true_object', [0, 1])
def test_estimated_p_o_rises_for_the_object_the_operator_reaches_whatever_the_script_says(
        scene, scene_estimator, true_object) -> None:
    script_for_the_other = (0.98, 0.02) if true_object == 1 else (0.02, 0.98)  # the script bets on the other one
    cases = (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.9, 0.1), 3))
    intent = SceneIntent(script_for_the_other, cases, true_object=true_object)
    operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
    ep = simulate_scene(scene, 'estimated', intent, operator, np.random.default_rng(4), np.random.default_rng(5),
                        plan_caches=[{}, {}], timeout=20.0, estimator=scene_estimator)
    name = scene[true_object].name
    assert ep.estimated_p_true is not None and ep.estimated_p_true > 0.9  # from 0.5 at the start (reset)
    assert scene_estimator.object_probabilities[true_object] == ep.estimated_p_true
    assert scene_estimator.updates > 100  # fed every period the operator moved
    assert ep.followed == name and ep.executed_object == name
    assert ep.wrong_object_alpha < 0.5
    placed = [(o.scene.model, o.scene.base_T_obj_true) for o in scene]
    assert ep.hand is not None and ep.closures is not None
    assert judge_scene(placed, true_object, 3, ep.hand, ep.closures).serves
    # the script's P(o) and w^o never reach the loop: another script with the same true object and set, the same run
    other = SceneIntent((0.5, 0.5), (PersistentIntent((0.1, 0.1, 0.9), 3), PersistentIntent((0.1, 0.2, 0.3), 3)),
                        true_object=true_object)
    again = simulate_scene(scene, 'estimated', other, ScriptedOperator('spacemouse', OperatorConstants(),
                                                                        np.random.default_rng(3)),
                           np.random.default_rng(6), np.random.default_rng(5), plan_caches=[{}, {}], timeout=20.0,
                           estimator=scene_estimator)
    assert again.closed_at == ep.closed_at and again.estimated_p_true == ep.estimated_p_true
    assert again.hand is not None and np.array_equal(again.hand, ep.hand)


def test_the_estimator_is_the_source_under_estimated_alone_and_over_the_scenes_objects(scene, scene_estimator) -> None:
    intent = SceneIntent((0.5, 0.5), (PersistentIntent((0.9, 0.9, 0.1), 3),) * 2, true_object=0)
    operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
    rngs = (np.random.default_rng(4), np.random.default_rng(5))
    with pytest.raises(ValueError, match='estimated'):
        simulate_scene(scene, 'estimated', intent, operator, *rngs, plan_caches=[{}, {}])
    with pytest.raises(ValueError, match='estimated'):
        simulate_scene(scene, 'suite', intent, operator, *rngs, plan_caches=[{}, {}], estimator=scene_estimator)
    with pytest.raises(ValueError, match='objects'):
        simulate_scene(scene[::-1], 'estimated', intent, operator, *rngs, plan_caches=[{}, {}],
                       estimator=scene_estimator)


def test_the_operator_heading_for_the_other_object_first_switches_at_a_time_drawn_from_the_seed() -> None:
    base = SceneIntent((0.6, 0.4), (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.1, 0.9), 5)),
                       true_object=0)
    changed = base.first_move_other(np.random.default_rng(8))
    again = base.first_move_other(np.random.default_rng(8))
    assert changed == again  # the switch's time drawn from the generator alone
    assert len({base.first_move_other(np.random.default_rng(seed)).t_switch for seed in range(50)}) == 50
    draws = np.random.default_rng(0)
    times = [base.first_move_other(draws).t_switch for _ in range(2000)]
    assert 1.5 <= min(times) and max(times) <= 3.0
    assert np.mean(times) == pytest.approx(2.25, abs=0.04) and np.std(times) == pytest.approx(0.433, abs=0.03)
    assert changed.first_object == 0 and changed.true_object == 1  # the drawn object first, then the other for good
    t = changed.t_switch
    assert changed.pursued_object(0.0) == changed.pursued_object(t - 1e-9) == 0
    assert changed.pursued_object(t) == changed.pursued_object(t + 30.0) == 1
    assert changed.pursued_task_set(t - 1e-9) == 3 and changed.pursued_task_set(t) == 5 == changed.task_set(0.0)
    assert base.pursued_object(0.0) == 0 and base.pursued_task_set(0.0) == 3  # a straight operator: the true object
    # the script's P(o) follows the change `delay` s late: the held P(o) until then, certain of the true object after
    rng = np.random.default_rng(1)
    before = np.mean([changed.object_probabilities(rng, t + changed.delay - 0.01) for _ in range(400)], axis=0)
    after = np.mean([changed.object_probabilities(rng, t + changed.delay) for _ in range(400)], axis=0)
    assert before == pytest.approx([0.6, 0.4], abs=0.01) and after == pytest.approx([0.05, 0.95], abs=0.01)
    with pytest.raises(ValueError):
        changed.first_move_other(np.random.default_rng(8))  # it changes already
    with pytest.raises(ValueError):
        SceneIntent.draw(0, 1, np.random.default_rng(0)).first_move_other(np.random.default_rng(8))


def test_the_operator_heads_for_the_other_object_until_the_switch_then_the_estimator_follows_it(
        scene, scene_estimator) -> None:
    cases = (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.9, 0.1), 3))
    intent = replace(SceneIntent((0.5, 0.5), cases, true_object=1, first_object=0), t_switch=2.0)

    def run(timeout: float):
        operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
        return simulate_scene(scene, 'estimated', intent, operator, np.random.default_rng(4),
                              np.random.default_rng(5), plan_caches=[{}, {}], timeout=timeout,
                              estimator=scene_estimator)

    cut = run(1.9)  # before the switch: the estimator is sure of the object the operator heads for first
    assert cut.closed_at is None and cut.estimated_p_true is not None and cut.estimated_p_true < 0.1
    assert cut.follow_delay is None and cut.estimate_delay is None and cut.wrong_object_alpha > 0.0
    assert cut.wrong_object_alpha_after == 0.0
    ep = run(20.0)  # then the flashlight for good
    assert ep.estimated_p_true is not None and ep.estimated_p_true > 0.9
    assert ep.followed == 'flashlight' and ep.executed_object == 'flashlight'
    assert ep.estimate_delay is not None and ep.follow_delay is not None and 0.0 < ep.estimate_delay < ep.follow_delay
    assert ep.wrong_object_alpha_after is not None and ep.wrong_object_alpha_after < ep.wrong_object_alpha
    placed = [(o.scene.model, o.scene.base_T_obj_true) for o in scene]
    assert ep.hand is not None and ep.closures is not None
    assert judge_scene(placed, 1, 3, ep.hand, ep.closures).serves


@pytest.mark.parametrize(('condition', 'estimated', 'scripted'), [('estimated_objects', 'p', 'w'),
                                                                   ('estimated_tasks', 'w', 'p')])
def test_the_split_conditions_take_one_source_from_the_estimator_and_the_other_from_the_script(
        scene, scene_estimator, condition, estimated, scripted) -> None:
    cases = (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.9, 0.1), 3))
    scripts = {'base': SceneIntent((0.3, 0.7), cases, true_object=0),
               'p': SceneIntent((0.9, 0.1), cases, true_object=0),  # another script's P(o) only
               'w': SceneIntent((0.3, 0.7), (PersistentIntent((0.1, 0.1, 0.9), 3),) * 2, true_object=0)}  # its w^o
    runs = {}
    for name, intent in scripts.items():
        operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
        runs[name] = simulate_scene(scene, condition, intent, operator, np.random.default_rng(4),
                                    np.random.default_rng(5), plan_caches=[{}, {}], timeout=20.0,
                                    estimator=scene_estimator)
    same, other = runs[estimated], runs[scripted]
    base = runs['base']
    assert base.hand is not None and same.hand is not None and other.hand is not None
    assert np.array_equal(same.hand, base.hand) and same.alpha_mean == base.alpha_mean  # the script's part unread
    assert other.alpha_mean != base.alpha_mean  # the script's other part drives the run
    assert base.estimated_p_true is not None and base.estimated_p_true > 0.9


def test_alpha_mean_is_the_mean_over_the_commands_sent_also_at_the_timeout(scene) -> None:
    # ADA's help is added in full: alpha 1 in every command, so its mean is 1 exactly, whether or not the episode
    # timed out (a timeout sends one command per tick, none after the last)
    intent = SceneIntent((0.6, 0.4), (PersistentIntent((0.9, 0.9, 0.1), 3), PersistentIntent((0.9, 0.9, 0.1), 3)),
                         true_object=1)
    operator = ScriptedOperator('spacemouse', OperatorConstants(), np.random.default_rng(3))
    ep = simulate_scene(scene, 'ada', intent, operator, np.random.default_rng(4), np.random.default_rng(5),
                        plan_caches=[{}, {}], timeout=0.5)
    assert ep.closed_at is None and ep.alpha_mean == 1.0
    cup = scene[0]
    own = cup.own_goals
    one = simulate(cup.scene, 'ada', PersistentIntent((0.9, 0.9, 0.1), 3), ScriptedOperator(
        'spacemouse', OperatorConstants(), np.random.default_rng(3)), own, np.random.default_rng(4),
        np.random.default_rng(5), ada_goals=[(g[0], np.zeros(1)) for g in own.values()], plan_cache={}, timeout=0.5)
    assert one.closed_at is None and one.alpha_mean == 1.0
