"""grasp_intent_ros.shared_control.operator_loop: a scripted operator on a wall clock (the node's core)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.mico.frames import PRE_GRASP_STANDOFF, pre_grasp
from grasp_intent_ros.shared_control.operator_loop import (
    REST_ANGLE,
    REST_DISTANCE,
    SETTLE,
    STOP_WAIT,
    GraspCommand,
    OperatorEpisodes,
    Perceived,
    Step,
    executes,
    hand_at_rest,
    operator_step,
    task_set_of,
)
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
    loop.episodes = 3  # raised after the last episode (a parameter change): one more, without a restart
    assert loop.step(100.0) is None and loop.state == 'resetting'
    loop.reset_done(True)
    assert (loop.state, loop.episode) == ('waiting', 3)


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
    loop.episodes = 10  # a failed reset ends for good, whatever the episodes
    assert loop.step(50.0) is None and loop.state == 'done'


def test_without_its_own_grasp_it_waits_and_a_lost_grasp_stops_the_reach() -> None:
    loop = OperatorEpisodes(operator('joystick'), start_delay=0.0, hold=0.0)
    loop.hand(0.0, HOME)
    assert loop.step(1.0) is None and loop.state == 'waiting' and loop.status(1.0) == 'waiting for its own grasp'
    loop.own = OWN
    assert loop.step(1.0) is not None and loop.state == 'reaching'
    loop.own = None  # re-planned (a new model or object pose): no input meanwhile
    assert loop.step(1.01) is None and loop.state == 'reaching'


def closing_loop(**kwargs: object) -> OperatorEpisodes:
    """A loop reaching from 0 s that sees, from 1 s on (closing at 1.25 s), the hand at a shown grasp near its own."""
    loop = OperatorEpisodes(operator(), start_delay=0.0, hold=0.5, own=OWN, execute_shown=True,
                            execute_timeout=4.0, **kwargs)  # type: ignore[arg-type]
    loop.hand(0.0, HOME)
    loop.shown(0.0, NEAR)
    assert loop.step(0.0) is not None and loop.state == 'reaching'
    loop.hand(1.0, NEAR)
    return loop


def stopped(loop: OperatorEpisodes) -> Step:
    """The loop of :func:`closing_loop` closed at 1.25 s, its hand seen at rest from 1.27 s: the execute step."""
    step = loop.step(1.25)
    assert step is not None and not step.execute and not step.close and not step.twist.any()
    assert loop.state == 'closing' and loop.status(1.25) == 'stopping to execute the shown grasp'
    assert loop.step(1.26) is None  # the two newest hands differ: not at rest yet
    loop.hand(1.27, NEAR)
    step = loop.step(1.27)
    assert step is not None and step.execute and not step.close and not step.twist.any()
    assert loop.status(1.27) == 'executing the shown grasp' and not loop.closed
    return step


NEAR = moved(OWN, (0.0, 0.02, 0.0))
"""A shown grasp within the operator's reach of its own: it follows it."""


def test_a_close_on_the_shown_grasp_stops_executes_it_and_closes_once_its_trajectory_has_had_its_time() -> None:
    loop = closing_loop()
    step = stopped(loop)
    assert_allclose(step.goal, NEAR)
    loop.reset_done(True)  # a reset answer meanwhile is not the loop's: the execution goes on
    assert loop.state == 'closing'
    loop.executed(1.3, True, 'following the latest trajectory from now', 0.8)  # due at 1.3 + 0.8 + SETTLE
    assert loop.command is not None and loop.command.close_at == pytest.approx(1.3 + 0.8 + SETTLE)
    for now in (1.31, 2.0, 2.19):
        assert loop.step(now) is None and loop.state == 'closing'  # zero twists while the arm executes
    step = loop.step(2.21)
    assert step is not None and step.close and not step.execute and not step.twist.any()
    assert_allclose(step.goal, NEAR)
    assert loop.state == 'holding' and len(loop.closed) == 1
    closed = loop.closed[0]
    assert (closed.pursued, closed.executed, closed.refused) == ('shown', True, '')
    assert closed.time_to_grasp == pytest.approx(2.21)  # to the fingers' close, the execution included
    assert loop.step(2.7) is None and loop.state == 'holding'  # hold counts from the fingers' close
    assert loop.step(2.72) is None and loop.state == 'done'
    assert loop.status(3.0) == 'done: episode 1 reached the shown grasp in 2.21 s (executed)'


def test_a_hand_never_seen_at_rest_is_executed_stop_wait_after_the_close() -> None:
    loop = closing_loop()
    assert loop.step(1.25) is not None and loop.state == 'closing'
    for now in np.arange(1.26, 1.25 + STOP_WAIT - 0.005, 0.01):
        loop.hand(now, moved(NEAR, (0.01 * now, 0.0, 0.0)))  # creeping at 0.1 mm a tick
        assert loop.step(now) is None
    step = loop.step(1.25 + STOP_WAIT)
    assert step is not None and step.execute


def test_a_refused_or_unanswered_execute_closes_where_the_hand_is() -> None:
    loop = closing_loop()
    stopped(loop)
    loop.executed(1.3, False, 'no trajectory received: nothing to execute', None)
    step = loop.step(1.31)
    assert step is not None and step.close and loop.state == 'holding'
    assert (loop.closed[0].executed, loop.closed[0].refused) == (False, 'no trajectory received: nothing to execute')
    assert 'execute refused: no trajectory received' in loop.status(1.4)
    loop.executed(1.4, True, 'late', 0.1)  # outside closing: ignored
    assert loop.state == 'holding'

    silent = closing_loop()
    stopped(silent)
    assert silent.step(5.26) is None and silent.state == 'closing'
    step = silent.step(5.28)  # execute_timeout (4 s) after the request at 1.27 s
    assert step is not None and step.close
    assert (silent.closed[0].executed, silent.closed[0].refused) == (False, 'no answer within 4 s')


def test_a_close_on_its_own_grasp_or_without_execute_shown_closes_at_once() -> None:
    own = closing_loop()
    own.shown(0.5, moved(OWN, (0.0, 0.2, 0.0)))  # far from its own: it pursues its own
    own.hand(1.0, OWN)
    step = own.step(1.25)
    assert step is not None and step.close and not step.execute and step.pursued == 'own'
    assert own.state == 'holding' and own.command is None and not own.closed[0].executed
    off = closing_loop()
    off.execute_shown = False
    step = off.step(1.25)
    assert step is not None and step.close and not step.execute and step.pursued == 'shown'
    assert off.state == 'holding'


def test_the_hand_is_at_rest_when_its_two_newest_poses_agree() -> None:
    hands: Perceived[np.ndarray] = Perceived(keep=10)
    hands.add(0.0, NEAR)
    assert not hand_at_rest(hands, 1.0)  # one pose says nothing
    hands.add(0.01, NEAR)
    assert hand_at_rest(hands, 1.0)
    hands.add(0.02, moved(NEAR, (2 * REST_DISTANCE, 0.0, 0.0)))
    assert not hand_at_rest(hands, 1.0) and hand_at_rest(hands, 0.015)  # as received by then
    hands.add(0.03, moved(NEAR, (2 * REST_DISTANCE, 0.0, 0.0), 2 * REST_ANGLE))
    assert not hand_at_rest(hands, 1.0)


def test_the_grasp_command_is_due_after_the_trajectory_at_once_when_refused_and_at_the_latest_on_the_timeout() -> None:
    command = GraspCommand(10.0, 3.0)
    assert not command.ready(10.5, False) and command.ready(10.5, True) and command.ready(10.0 + STOP_WAIT, False)
    command.answered(10.1, True, 'before the request', 0.1)  # not asked yet: ignored
    assert command.answered_at is None and not command.due(99.0)  # never due before the request
    command.request(10.0)
    assert not command.ready(99.0, True)  # asked once
    assert not command.due(12.99) and command.due(13.0)  # no answer: the timeout
    command.answered(10.1, True, 'ok', 1.0)
    command.answered(10.2, False, 'a second answer', None)  # only the first counts
    assert command.close_at == pytest.approx(11.1 + SETTLE) and command.refused == ''
    for duration, close_at in ((9.0, 13.0), (None, 13.0)):  # longer than the timeout, or unknown: the timeout
        other = GraspCommand(10.0, 3.0)
        other.request(10.0)
        other.answered(10.1, True, 'ok', duration)
        assert other.close_at == close_at
    refused = GraspCommand(10.0, 3.0)
    refused.request(10.0)
    refused.answered(10.1, False, '', None)
    assert refused.due(10.1) and refused.refused == 'refused'
    assert executes(operator_step(operator(), 0.0, NEAR, NEAR, OWN), True)
    assert not executes(operator_step(operator(), 0.0, NEAR, NEAR, OWN), False)
    assert not executes(operator_step(operator(), 0.0, HOME, NEAR, OWN), True)  # not at the goal: no close
