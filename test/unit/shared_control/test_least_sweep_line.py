"""The target's IK solution whose line sweeps the perceived object least, then turns least."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.method.body import Cylinder, ObjectBody
from grasp_intent_ros.mico.collision import SWEEP_STEP
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control import joint_path
from grasp_intent_ros.shared_control.assistance import AssistanceConfig
from grasp_intent_ros.shared_control.clearance import PathClearance, default_hand
from grasp_intent_ros.shared_control.joint_path import (
    ik_candidates,
    least_sweep_line,
    line_cost,
    line_turns,
    wrist_flip,
)
from grasp_intent_ros.shared_control.path_search import PathRequest, seek_path

# the flashlight's pre-grasp of test_line_turns (seed 1, episode 4, the joystick), from Home: the descent from
# Home finds the solution with joint 5 on Home's side (joint 6 turning 3.2 rad), the descent from Home's wrist
# flip the one with joint 5 through 0, whose line swings the hand out 0.2 m but is quicker (joint 4 turning less)
PRE_Q = np.array([3.736374, 3.99417, 1.877749, 6.050218, 1.17646, 4.361846])
SLACK = AssistanceConfig().corridor_radius


def _case() -> tuple[MicoKinematics, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                     NDArray[np.float64], NDArray[np.float64]]:
    """``kin, q, pre, grasp``, and the two candidates' line ends: the descent's and the wrist flip's."""
    kin = MicoKinematics()
    home = np.array(HOME_Q, dtype=np.float64)
    pre = kin.fk(PRE_Q)
    grasp = pre.copy()
    grasp[:3, 3] += AssistanceConfig().standoff * pre[:3, 2]
    descent = line_turns(kin, home, kin.ik(pre, home, restarts=0).q, pre, grasp, slack=SLACK)
    flip = kin.ik(pre, wrist_flip(home), restarts=0)
    assert flip.success
    flipped = line_turns(kin, home, kin.nearest_branch(flip.q, home), pre, grasp, slack=SLACK)
    assert np.sin(descent[4]) * np.sin(home[4]) > 0.0 > np.sin(flipped[4]) * np.sin(home[4])  # the two sides
    return kin, home, pre, grasp, descent, flipped


def _clearance(kin: MicoKinematics, at: NDArray[np.float64]) -> PathClearance:
    """A cylinder 3 cm in radius, 8 cm long, upright, centred where the end effector is at joints ``at``."""
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = kin.fk(at)[:3, 3]
    body = ObjectBody((Cylinder(np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.03, 0.08),))
    return PathClearance(kin, default_hand(), body, base_T_obj)


def test_with_equal_sweeps_the_line_that_turns_less_is_chosen() -> None:
    kin, home, pre, grasp, descent, flipped = _case()
    assert line_cost(kin, home, flipped, pre[:3, :3]) < line_cost(kin, home, descent, pre[:3, :3])
    for sweep in (None, lambda end: 0, lambda end: 3):
        assert_allclose(least_sweep_line(kin, home, pre, grasp, slack=SLACK, sweep=sweep), flipped, rtol=0, atol=0)


def test_a_line_that_sweeps_the_body_loses_to_one_that_does_not() -> None:
    kin, home, pre, grasp, descent, flipped = _case()
    clearance = _clearance(kin, home + 0.6 * (flipped - home))  # on the quicker line's way, 0.2 m off the other's
    assert clearance.sweep(home, [flipped]) > 0 and clearance.goes_in(home, [flipped])
    assert clearance.sweep(home, [descent]) == 0 and not clearance.goes_in(home, [descent])
    chosen = least_sweep_line(kin, home, pre, grasp, slack=SLACK, sweep=lambda end: clearance.sweep(home, [end]))
    assert_allclose(chosen, descent, rtol=0, atol=0)
    # the search answers with it (its own line, clear: no clear way replaces it)
    answer = seek_path(kin, PathRequest((0, 0, 'pre-grasp'), home, pre, grasp, SLACK, 0.0, clearance))
    assert answer.path is not None and not answer.cleared
    assert_allclose(answer.path[0], descent, rtol=0, atol=0)


def test_the_deeper_sweep_loses_whatever_the_turns() -> None:
    kin, home, pre, grasp, descent, flipped = _case()
    deeper = {True: 2, False: 1}  # the quicker line one quantum deeper
    chosen = least_sweep_line(kin, home, pre, grasp, slack=SLACK,
                              sweep=lambda end: deeper[bool(np.allclose(end, flipped, rtol=0, atol=0))])
    assert_allclose(chosen, descent, rtol=0, atol=0)


def test_equal_sweeps_and_turns_go_to_the_first_in_seed_order(monkeypatch: pytest.MonkeyPatch) -> None:
    kin, home, pre, grasp, _, _ = _case()
    monkeypatch.setattr(joint_path, 'line_cost', lambda *args: (0, 0))  # every line turns alike
    descent = line_turns(kin, home, kin.ik(pre, home, restarts=0).q, pre, grasp, slack=SLACK)  # under the patch
    for depth in (0, 1):  # every line clear (the first one asked ends the search), or every one as deep
        asked: list[NDArray[np.float64]] = []
        chosen = least_sweep_line(kin, home, pre, grasp, slack=SLACK,
                                  sweep=lambda end, depth=depth: asked.append(end) or depth)
        assert_allclose(chosen, descent, rtol=0, atol=0)  # the descent's, the first candidate
        assert_allclose(asked[0], descent, rtol=0, atol=0)
        assert len(asked) == 1 if depth == 0 else len(asked) >= 2


def test_the_choice_is_the_same_for_the_same_inputs() -> None:
    kin, home, pre, grasp, _, _ = _case()
    clearance = _clearance(kin, home)
    answers = [least_sweep_line(MicoKinematics(), home.copy(), pre.copy(), grasp.copy(), slack=SLACK,
                                sweep=lambda end: clearance.sweep(home, [end])) for _ in range(2)]
    assert answers[0] is not None and answers[1] is not None
    assert np.array_equal(answers[0], answers[1])


def test_a_target_without_an_ik_has_no_line() -> None:
    kin, home, _, grasp, _, _ = _case()
    far = np.eye(4)
    far[:3, 3] = (2.0, 0.0, 0.0)  # beyond the arm's reach
    assert least_sweep_line(kin, home, far, grasp, slack=SLACK) is None


def test_the_sweep_counts_the_depth_beyond_the_allowance_in_whole_steps() -> None:
    kin, home, _, _, _, flipped = _case()
    middle = home + 0.6 * (flipped - home)
    clearance = _clearance(kin, middle)
    deepest = max(clearance.intrusion(home + s * (flipped - home)) for s in np.linspace(0.05, 1.0, 20))
    assert deepest > SWEEP_STEP  # the case: the line's hand goes through the body
    assert clearance.sweep(home, [flipped]) == int(np.ceil(deepest / SWEEP_STEP))
    # from inside the body, only what goes deeper than the start counts
    start = clearance.intrusion(middle)
    assert start > 0.0
    later = max(clearance.intrusion(middle + s * (flipped - middle)) for s in np.linspace(0.05, 1.0, 20))
    assert clearance.sweep(middle, [flipped]) == max(0, int(np.ceil((later - start) / SWEEP_STEP)))
    assert clearance.sweep(middle, [flipped]) < clearance.sweep(home, [flipped])
    # a path through a via point: its lines' deepest point
    assert clearance.sweep(home, [middle, flipped]) >= 1


def test_the_candidates_on_either_side_of_the_wrist_include_those_on_qs_side() -> None:
    kin, home, pre, _, _, _ = _case()
    either = ik_candidates(kin, home, pre, wrist_side=False)
    own = ik_candidates(kin, home, pre)
    assert {bool(np.sin(q_t[4]) > 0.0) for q_t in either} == {True, False}
    assert all(np.sin(q_t[4]) * np.sin(home[4]) > 0.0 for q_t in own)
    assert all(any(np.array_equal(q_t, other) for other in either) for q_t in own)
