"""The assistance over several objects: one object is today's to the last bit; P(o) scales alpha; the switch."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.mico.frames import pose_to_matrix, pre_grasp
from grasp_intent_ros.mico.kinematics import BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm, TwistCommand
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.limits import TwistLimiter
from grasp_intent_ros.shared_control.path_search import warm_up_scene
from grasp_intent_ros.shared_control.scene_assistance import SceneAssistance
from grasp_intent_ros.shared_control.scene_target import FollowRule

from .robot_alone import LABELS, TASKS

DOWN = (1.0, 0.0, 0.0, 0.0)  # the approach (EE z) straight down
CUP = pose_to_matrix((0.45, -0.3, 0.05), DOWN)
FLASHLIGHT = pose_to_matrix((0.15, -0.3, 0.05), DOWN)
HAND = pose_to_matrix((0.3, -0.3, 0.25), DOWN)
V = np.array([0.3, 0.1, 0.05, 0.3, 0.1, 0.05, 0.1])  # over LABELS: U, T, H, UT, UH, TH, UTH
POSTERIOR = np.array([0.1, 0.1, 0.1, 0.4, 0.1, 0.1, 0.1])


def _toward(target: np.ndarray, speed: float = 0.05) -> np.ndarray:
    """The operator's twist: straight at ``target``'s pre-grasp from the hand, no rotation."""
    step = pre_grasp(target, AssistanceConfig().standoff)[:3, 3] - HAND[:3, 3]
    return np.r_[speed * step / np.linalg.norm(step), 0.0, 0.0, 0.0]


def _scene(**rule: float) -> SceneAssistance:
    """Two objects, both planned (v, posterior, grasp), the hand above between them; no kinematics."""
    assistance = Assistance(AssistanceConfig(), TwistLimiter(10.0, 10.0, 1e6, 1e6))
    assistance.base_T_ee = HAND
    scene = SceneAssistance(assistance, ['flashlight', 'cup'], FollowRule(**rule))
    for name, grasp in (('cup', CUP), ('flashlight', FLASHLIGHT)):
        channel = scene.channel(name)
        channel.set_v(V, LABELS)
        channel.set_posterior(POSTERIOR, LABELS, TASKS)
        channel.set_task_set(3)  # usage and transfer
        channel.set_grasp(grasp)
    return scene


def test_one_object_gives_todays_alpha_and_twist_to_the_last_bit() -> None:
    kin = MicoKinematics()
    grasp, base_T_obj, body = warm_up_scene(kin)
    config = AssistanceConfig()
    plain = Assistance(config, TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    scene = SceneAssistance(Assistance(config, TwistLimiter(0.2, 1.0, 1.0, 5.0), kin), ['cup'])
    cup = scene.channel('cup')
    for target in (plain, cup):
        target.set_object(base_T_obj, body)
        target.set_v(V, LABELS)
        target.set_posterior(POSTERIOR, LABELS, TASKS)
        target.set_task_set(3)
        target.set_grasp(grasp)
    arm = MockArm(kin, np.r_[HOME_Q, 0.0, 0.0, 0.0])
    rng = np.random.default_rng(3)
    phases = set()
    for tick in range(150):
        now = 0.01 * tick
        if tick == 60:  # the planner's grasp moves by 3 cm (a new proposal), then a clarification, then the grasp
            moved = grasp.copy()
            moved[:3, 3] += (0.0, 0.03, 0.0)
            for target in (plain, cup):
                target.set_grasp(moved)
                target.clarification()
        if tick == 70:
            for target in (plain, cup):
                target.set_grasp(moved)
        q = arm.q[:6].copy()
        plain.set_joints(q)
        scene.assistance.set_joints(q)
        aim = plain.target()[0][:3, 3] - kin.fk(q)[:3, 3]
        operator = np.r_[0.05 * aim / np.linalg.norm(aim) + rng.normal(0.0, 0.01, 3), rng.normal(0.0, 0.05, 3)]
        plain.set_operator(operator, now)
        scene.set_operator(operator, now)
        expected, got = plain.command(now), scene.command(now)
        assert np.array_equal(got.twist, expected.twist) and got.alpha == expected.alpha, tick
        assert got.phase == expected.phase
        phases.add(expected.phase)
        arm.command_twist(TwistCommand(expected.twist[:3], expected.twist[3:], BASE_FRAME), now)
        arm.step(now + 0.01, 0.01)
    assert {'pre-grasp', 'clarification pending'} <= phases and scene.followed == 'cup'
    assert scene.probabilities == {'cup': 1.0}


def test_a_spread_p_o_keeps_alpha_low() -> None:
    scene = _scene()
    scene.set_operator(_toward(CUP), 0.0)
    unknown = scene.command(0.0)  # no intent/objects yet: P(o) uniform over the two objects
    assert scene.followed == 'cup' and scene.probabilities == {'cup': 0.5, 'flashlight': 0.5}
    serving = scene.objects['cup'].serving()
    assert 0.0 < serving < 1.0
    assert unknown.alpha == pytest.approx(0.9 * 0.5 * serving)  # agreement 1: straight at the cup's approach
    scene.set_probabilities({'cup': 0.98, 'flashlight': 0.02})
    assert scene.command(0.01).alpha == pytest.approx(0.9 * 0.98 * serving)
    scene.set_probabilities({'cup': 0.02, 'flashlight': 0.98})
    assert scene.command(0.02).alpha == pytest.approx(0.9 * 0.02 * serving)  # not switched yet: the hold time
    with pytest.raises(GraspIntentError):
        scene.set_probabilities({'mug': 1.0})


def test_the_assistance_switches_when_the_operator_heads_for_the_other_object() -> None:
    scene = _scene(margin=0.1, hold_time=0.25)
    scene.set_probabilities({'cup': 0.9, 'flashlight': 0.1})
    for tick in range(10):  # toward the cup, which the intent says
        scene.set_operator(_toward(CUP), 0.01 * tick)
        command = scene.command(0.01 * tick)
    assert scene.followed == 'cup' and command.alpha > 0.5 and scene.scores['flashlight'] == 0.0
    assert np.array_equal(scene.assistance.base_T_grasp, CUP)
    # the operator turns to the flashlight, and the intent follows: the switch after the hold time
    followed = {}
    for tick in range(10, 60):
        now = 0.01 * tick
        scene.set_probabilities({'cup': 0.2, 'flashlight': 0.8})
        scene.set_operator(_toward(FLASHLIGHT), now)
        command = scene.command(now)
        followed[tick] = (scene.followed, command.alpha)
    assert scene.scores['cup'] == 0.0  # the operator heads away from the cup's approach
    switched = min(tick for tick, (name, _) in followed.items() if name == 'flashlight')
    assert switched == 35  # led from the first period (tick 10) for 0.25 s
    assert all(alpha == 0.0 for name, alpha in followed.values() if name == 'cup')  # the operator away: alpha 0
    assert np.array_equal(scene.assistance.base_T_grasp, FLASHLIGHT) and followed[59][1] > 0.5


def test_a_followed_objects_clarification_and_an_unfollowed_ones_inputs() -> None:
    scene = _scene()
    scene.set_probabilities({'cup': 0.9, 'flashlight': 0.1})
    scene.set_operator(_toward(CUP), 0.0)
    assert scene.command(0.0).alpha > 0.0 and scene.followed == 'cup'
    scene.channel('flashlight').clarification()  # not followed: kept, the cup's assistance unchanged
    assert scene.command(0.01).alpha > 0.0 and scene.objects['flashlight'].clarification_pending
    scene.channel('cup').clarification()
    assert scene.command(0.02).phase == 'clarification pending'
    with pytest.raises(KeyError):
        scene.channel('mug')
