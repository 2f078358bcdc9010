"""grasp_intent_ros.shared_control.operator_loop: a scripted operator on a wall clock (the node's core)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.mico.frames import PRE_GRASP_STANDOFF, pre_grasp
from grasp_intent_ros.shared_control.operator_loop import OperatorEpisodes, Perceived, operator_step, task_set_of
from grasp_intent_ros.shared_control.operators import OperatorConstants, ScriptedOperator

QUIET = OperatorConstants(noise_linear=0.0, noise_angular=0.0)
OWN = np.eye(4)
OWN[:3, :3] = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # approaching along +x of the base
OWN[:3, 3] = (0.3, -0.3, 0.1)


def moved(pose: np.ndarray, by: tuple[float, float, float], turn: float = 0.0) -> np.ndarray:
    out = pose.copy()
    out[:3, 3] += by
    out[:3, :3] = pin.exp3(np.array([0.0, 0.0, turn])) @ pose[:3, :3]
    return out


HOME = moved(OWN, (-0.2, 0.25, 0.2))
"""A hand far from the goal, out of its approach corridor."""


def operator(device: str = 'spacemouse') -> ScriptedOperator:
    return ScriptedOperator(device, QUIET, np.random.default_rng(0))  # type: ignore[arg-type]


def test_perceived_gives_the_newest_value_received_by_a_moment() -> None:
    seen: Perceived[str] = Perceived(keep=3)
    assert seen.at(10.0) is None
    for t, value in ((1.0, 'a'), (2.0, 'b'), (3.0, 'c')):
        seen.add(t, value)
    assert (seen.at(0.99), seen.at(1.0), seen.at(2.5), seen.at(99.0)) == (None, 'a', 'b', 'c')
    seen.add(4.0, 'd')  # 'a' is forgotten
    assert seen.at(1.5) is None and seen.at(2.0) == 'b'
    seen.clear()
    assert seen.at(99.0) is None


def test_task_names_become_a_set_over_the_models_tasks_and_an_unknown_one_is_named() -> None:
    tasks = ('usage', 'transfer', 'handover')
    assert task_set_of(['usage', 'transfer'], tasks) == 0b011
    assert task_set_of(['handover'], tasks) == 0b100
    with pytest.raises(GraspIntentError, match=r'no task pouring; its tasks are usage, transfer, handover'):
        task_set_of(['usage', 'pouring'], tasks)
    with pytest.raises(GraspIntentError, match='no task named'):
        task_set_of([], tasks)


def test_a_step_steers_to_the_pre_grasp_follows_a_near_shown_grasp_and_closes_at_the_goal() -> None:
    op = operator()
    step = operator_step(op, 0.0, HOME, None, OWN)
    assert (step.pursued, step.close) == ('own', False)
    toward = pre_grasp(OWN, PRE_GRASP_STANDOFF)[:3, 3] - HOME[:3, 3]
    assert_allclose(step.twist[:3], QUIET.max_linear * toward / np.linalg.norm(toward), atol=1e-12)
    near = moved(OWN, (0.0, 0.03, 0.0), 0.3)  # within 6 cm and 0.8 rad of its own: on its way
    far = moved(OWN, (0.0, 0.1, 0.0))
    assert operator_step(op, 0.01, HOME, near, OWN).pursued == 'shown'
    assert operator_step(op, 0.02, HOME, far, OWN).pursued == 'own'
    at_goal = operator_step(op, 0.03, moved(near, (0.005, 0.0, 0.0)), near, OWN)
    assert at_goal.close and at_goal.pursued == 'shown' and not at_goal.twist.any()
    assert_allclose(at_goal.goal, near)
    assert not operator_step(op, 0.04, None, near, OWN).twist.any()  # no hand seen yet: no input


def test_the_episodes_wait_start_reach_close_hold_reset_and_end() -> None:
    loop = OperatorEpisodes(operator(), start_delay=1.0, hold=0.5, episodes=2)
    assert loop.step(0.0) is None and loop.status(0.0) == 'waiting for its own grasp and the hand (joint_states)'
    loop.hand(0.0, HOME)
    loop.own = OWN
    assert loop.step(0.1) is None and loop.state == 'starting' and loop.status(0.6) == 'reaching in 0.5 s'
    assert loop.step(1.05) is None and loop.state == 'starting'
    step = loop.step(1.1)
    assert step is not None and not step.close and step.twist.any() and loop.state == 'reaching'
    # it sees the hand reaction (0.25 s) late: a hand at the goal received at 2.0 s closes at 2.25 s
    loop.hand(2.0, OWN)
    assert loop.step(2.2) is not None and loop.state == 'reaching'
    closing = loop.step(2.25)
    assert closing is not None and closing.close and loop.state == 'holding'
    assert len(loop.closed) == 1 and loop.closed[0].episode == 1 and loop.closed[0].pursued == 'own'
    assert loop.closed[0].time_to_grasp == pytest.approx(1.15)
    assert loop.step(2.7) is None and loop.state == 'holding'
    assert loop.step(2.75) is None and loop.state == 'resetting'
    loop.reset_done(True)  # the hand is seen again only from the reset on
    assert (loop.state, loop.episode, loop.hands.at(99.0)) == ('waiting', 2, None)
    loop.hand(3.0, HOME)
    loop.step(3.0)
    loop.step(4.0)
    loop.hand(4.5, OWN)
    closing = loop.step(4.75)
    assert closing is not None and closing.close and loop.closed[-1].episode == 2
    loop.step(5.25)
    assert loop.state == 'done' and loop.step(99.0) is None
    assert loop.status(99.0) == 'done: episode 2 reached the own grasp in 0.75 s'


def test_a_failed_reset_ends_and_episodes_zero_never_end() -> None:
    loop = OperatorEpisodes(operator(), start_delay=0.0, hold=0.0, episodes=0, own=OWN)
    for episode in range(1, 4):
        loop.hand(10.0 * episode, OWN)
        loop.step(10.0 * episode)
        step = loop.step(10.0 * episode + 0.3)
        assert step is not None and step.close
        loop.step(10.0 * episode + 0.3)
        assert loop.state == 'resetting'
        loop.reset_done(True)
    loop.hand(40.0, OWN)
    loop.step(40.0)
    loop.step(40.3)
    loop.step(40.3)
    loop.reset_done(False)
    assert loop.state == 'done' and [c.episode for c in loop.closed] == [1, 2, 3, 4]


def test_without_its_own_grasp_it_waits_and_a_lost_grasp_stops_the_reach() -> None:
    loop = OperatorEpisodes(operator('joystick'), start_delay=0.0, hold=0.0)
    loop.hand(0.0, HOME)
    assert loop.step(1.0) is None and loop.state == 'waiting' and loop.status(1.0) == 'waiting for its own grasp'
    loop.own = OWN
    assert loop.step(1.0) is not None and loop.state == 'reaching'
    loop.own = None  # re-planned (a new model or object pose): no input meanwhile
    assert loop.step(1.01) is None and loop.state == 'reaching'
