"""The joint line's end on the wrist's 2 pi branch that turns the hand the short way (:func:`line_turns`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.mico.frames import pose_error, rotation_angle
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.joint_path import TURN_SLACK, WRIST_TURNS, joint_path, line_turns
from grasp_intent_ros.shared_control.path_search import PathRequest, seek_path

# the flashlight's pre-grasp of the closed-loop benchmark's joystick operator (seed 1, episode 4) and its IK (no
# restarts) from Home: joint 6 turns by 3.04 rad, and on that branch the hand's orientation error to the
# pre-grasp rises from 1.98 rad up through pi before it falls
LONG_WAY_Q_T = np.array([3.736374, 3.99417, 1.877749, 6.050218, 1.17646, 4.361846])


def _turn_away(kin: MicoKinematics, q: NDArray[np.float64], q_t: NDArray[np.float64],
               target: NDArray[np.float64]) -> float:
    """rad: the rise of the hand's orientation error over its start on 101 points of the line (finer than 20)."""
    errors = [float(np.linalg.norm(pose_error(kin.fk(q + s * (q_t - q)), target)[3:]))
              for s in np.linspace(0.0, 1.0, 101)]
    return max(errors) - errors[0]


def _case() -> tuple[MicoKinematics, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    kin = MicoKinematics()
    home = np.array(HOME_Q, dtype=np.float64)
    pre = kin.fk(LONG_WAY_Q_T)
    grasp = pre.copy()
    grasp[:3, 3] += AssistanceConfig().standoff * pre[:3, 2]
    return kin, home, pre, grasp


def test_a_line_that_turns_the_hand_through_pi_ends_on_the_branch_that_turns_it_the_short_way() -> None:
    kin, home, pre, grasp = _case()
    slack = AssistanceConfig().corridor_radius
    ik = kin.ik(pre, home, restarts=0)
    assert ik.success
    assert_allclose(ik.q, LONG_WAY_Q_T, atol=1e-5)
    assert _turn_away(kin, home, ik.q, pre) > 0.9  # the case: the IK's own branch turns the long way
    q_t = line_turns(kin, home, ik.q, pre, grasp, slack=slack)
    turns = (q_t - ik.q) / (2.0 * math.pi)
    assert_allclose(turns, np.round(turns), atol=1e-12)  # only 2 pi branches
    assert np.all(turns[[j for j in range(6) if j not in WRIST_TURNS]] == 0.0)
    assert np.any(turns != 0.0)
    error = pose_error(kin.fk(q_t), pre)
    assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6
    assert _turn_away(kin, home, q_t, pre) <= TURN_SLACK
    # the line still keeps the hand near the grasp (joint_path's bound), and the search answers with it
    bound = float(np.linalg.norm(kin.fk(home)[:3, 3] - grasp[:3, 3])) + slack
    assert max(np.linalg.norm(kin.fk(home + s * (q_t - home))[:3, 3] - grasp[:3, 3])
               for s in np.linspace(0.0, 1.0, 101)) <= bound + 1e-3
    answer = seek_path(kin, PathRequest((0, 0, 'pre-grasp'), home, pre, grasp, slack, 0.0, None))
    assert answer.path is not None and len(answer.path) == 1
    assert_allclose(answer.path[0], q_t, rtol=0, atol=0)


def test_the_line_ik_of_a_target_without_an_ik_from_the_joints_takes_the_short_way_too() -> None:
    # joint_path's straight line (step 1) ends on line_turns's branch: the same rule, one definition
    kin, home, pre, grasp = _case()
    slack = AssistanceConfig().corridor_radius
    path = joint_path(kin, home, pre, grasp, slack=slack)
    assert path is not None and len(path) == 1
    assert _turn_away(kin, home, path[0], pre) <= TURN_SLACK


def test_a_line_that_turns_the_hand_the_short_way_keeps_the_iks_own_answer() -> None:
    kin, home, pre, grasp = _case()
    short = line_turns(kin, home, LONG_WAY_Q_T, pre, grasp, slack=0.02)
    assert _turn_away(kin, home, short, pre) <= TURN_SLACK
    assert_allclose(line_turns(kin, home, short, pre, grasp, slack=0.02), short, rtol=0, atol=0)


def test_a_tie_goes_to_the_iks_own_answer_whatever_the_last_bits() -> None:
    # the hand rolled by pi about its own axis (joint 6 alone): either way round the error falls straight from
    # pi to 0 and the line takes the same time, so the costs tie; the IK's own answer wins, and a change in
    # the last bits of q_t (either sign) does not move the choice to the other branch
    kin = MicoKinematics()
    q = np.array(HOME_Q, dtype=np.float64)
    for nudge in (0.0, 1e-9, -1e-9):
        q_t = q + np.array([0.0, 0.0, 0.0, 0.0, 0.0, math.pi + nudge])
        target = kin.fk(q_t)
        assert_allclose(line_turns(kin, q, q_t, target, target, slack=0.02), q_t, rtol=0, atol=0)
        other = q_t - np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2.0 * math.pi])
        assert abs(_turn_away(kin, q, other, target) - _turn_away(kin, q, q_t, target)) <= 1e-6


def _exhaustive(kin: MicoKinematics, q: NDArray[np.float64], q_t: NDArray[np.float64], target: NDArray[np.float64],
                grasp: NDArray[np.float64], slack: float) -> NDArray[np.float64]:
    """line_turns's rule as its docstring states it, every candidate costed (no shortcut)."""
    from itertools import product

    from grasp_intent_ros.shared_control.joint_path import TIME_STEP, TURN_STEP, near_grasp

    def error(q_s: NDArray[np.float64]) -> float:
        return rotation_angle(target[:3, :3], kin.fk(q_s)[:3, :3])

    best, best_cost = q_t, None
    for turns in product((0, -1, 1), repeat=len(WRIST_TURNS)):
        candidate = q_t.copy()
        candidate[list(WRIST_TURNS)] += 2.0 * math.pi * np.array(turns, dtype=np.float64)
        if np.any(candidate < kin.lower) or np.any(candidate > kin.upper):
            continue
        rise = max(error(q + s * (candidate - q)) for s in np.linspace(0.0, 1.0, 21)[1:]) - error(q)
        away = max(0.0, rise - TURN_SLACK)
        time = float(np.max(np.abs(candidate - q) / kin.velocity_limits))
        cost = (math.floor(away / TURN_STEP), math.floor(time / TIME_STEP))
        if best_cost is None:
            best, best_cost = candidate, cost
        elif cost < best_cost and near_grasp(kin, q, [candidate], grasp, slack=slack):
            best, best_cost = candidate, cost
    return best


def test_the_answer_is_the_rules_minimum_over_every_candidate_on_random_reaches() -> None:
    # the shortcut (the IK's own answer returned when it turns the hand the short way) never changes the answer
    kin = MicoKinematics()
    rng = np.random.default_rng(7)
    slack, checked, moved = AssistanceConfig().corridor_radius, 0, 0
    while checked < 40:
        q = np.array(HOME_Q, dtype=np.float64) + rng.uniform(-1.0, 1.0, 6) * np.array([1.5, 0.4, 0.4, 3.0, 1.0, 3.0])
        q = np.clip(q, kin.lower, kin.upper)
        target = kin.fk(np.clip(q + rng.uniform(-1.0, 1.0, 6) * np.array([0.8, 0.3, 0.3, 3.0, 0.8, 3.0]),
                                kin.lower, kin.upper))
        ik = kin.ik(target, q, restarts=0)
        if not ik.success:
            continue
        grasp = target.copy()
        grasp[:3, 3] += AssistanceConfig().standoff * target[:3, 2]
        expected = _exhaustive(kin, q, ik.q, target, grasp, slack)
        assert_allclose(line_turns(kin, q, ik.q, target, grasp, slack=slack), expected, rtol=0, atol=0)
        checked += 1
        moved += not np.array_equal(expected, ik.q)
    assert moved >= 1  # the reaches include some the rule moves to another branch
