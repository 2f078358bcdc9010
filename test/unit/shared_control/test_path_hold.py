"""The IK solution a proposal's line goes to, held while its line stays clear and the joints near it.

:func:`ik_line`, ``seek_path``; let go when the joints stall short of it, :class:`LineHold`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.mico.frames import pose_error
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance, AssistanceConfig, TwistLimiter
from grasp_intent_ros.shared_control.joint_path import ik_line, line_turns
from grasp_intent_ros.shared_control.line_hold import STALL_PROGRESS, STALL_WINDOW, LineHold, stalled
from grasp_intent_ros.shared_control.path_search import PathAnswer, PathRequest, PathSearch, seek_path

from .robot_alone import LABELS, TASKS

# the flashlight's pre-grasp of test_line_turns (seed 1, episode 4 of the closed-loop benchmark's joystick) and two
# of its IK solutions, on the wrist's two sides: the IK from Home descends to the first; from joints a tenth of the
# way from Home toward the second, it descends to the second
PRE_GRASP_Q = np.array([3.736374, 3.99417, 1.877749, 6.050218, 1.17646, 4.361846])
OTHER_SIDE_Q = np.array([4.094865, 3.983954, 1.915617, 3.544768, -1.204767, 2.243004])
SLACK = AssistanceConfig().corridor_radius


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def _case(kin: MicoKinematics) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The joints moved off Home toward the other side's solution, the pre-grasp and its grasp (8 cm on)."""
    home = np.array(HOME_Q, dtype=np.float64)
    q = home + 0.1 * (OTHER_SIDE_Q - home)
    pre = kin.fk(PRE_GRASP_Q)
    grasp = pre.copy()
    grasp[:3, 3] += AssistanceConfig().standoff * pre[:3, 2]
    return q, pre, grasp


def _line(kin: MicoKinematics, q: NDArray[np.float64], pre: NDArray[np.float64], grasp: NDArray[np.float64],
          **kwargs: object) -> NDArray[np.float64]:
    end = ik_line(kin, q, pre, grasp, slack=SLACK, **kwargs)  # type: ignore[arg-type]
    assert end is not None
    assert_allclose(pose_error(kin.fk(end), pre), np.zeros(6), atol=1e-6)  # an IK solution of the target
    return end


def _wrist_side(end: NDArray[np.float64]) -> float:
    return float(np.sign(np.sin(end[4])))


def test_the_case_has_two_solutions_and_the_descent_takes_the_other_side(kin: MicoKinematics) -> None:
    q, pre, grasp = _case(kin)
    assert_allclose(pose_error(kin.fk(OTHER_SIDE_Q), pre), np.zeros(6), atol=1e-3)  # 6 digits
    descended = _line(kin, q, pre, grasp)
    assert _wrist_side(descended) < 0.0
    ik = kin.ik(pre, q, restarts=0)  # without a held solution: the descent's line, as line_turns ends it
    assert_allclose(descended, line_turns(kin, q, ik.q, pre, grasp, slack=SLACK), rtol=0, atol=0)
    answer = seek_path(kin, PathRequest((0, 0, 'pre-grasp'), q, pre, grasp, SLACK, 0.0, None))
    assert answer.path is not None and not answer.cleared
    assert_allclose(answer.path[-1], descended, rtol=0, atol=0)


def test_the_held_solution_is_kept_while_its_line_is_clear(kin: MicoKinematics) -> None:
    q, pre, grasp = _case(kin)
    for clear in (None, lambda path: True):
        kept = _line(kin, q, pre, grasp, held=PRE_GRASP_Q, clear=clear)
        assert _wrist_side(kept) > 0.0  # the held side, not the descent's
        # joints 1-3 and 5 as the held solution has them on the branch nearest q (line_turns may turn 4 and 6)
        assert_allclose(kept[[0, 1, 2, 4]], kin.nearest_branch(PRE_GRASP_Q, q)[[0, 1, 2, 4]], atol=1e-4)
    answer = seek_path(kin, PathRequest((0, 0, 'pre-grasp'), q, pre, grasp, SLACK, 0.0, None, held=PRE_GRASP_Q))
    assert answer.path is not None
    assert_allclose(answer.path[-1], kept, rtol=0, atol=0)


def test_a_held_line_that_sweeps_gives_way_to_a_clear_one(kin: MicoKinematics) -> None:
    # hand-built: the held side's line sweeps the object, the other side's is clear
    q, pre, grasp = _case(kin)
    swept: list[float] = []

    def clear(path: list[NDArray[np.float64]]) -> bool:
        swept.append(_wrist_side(path[-1]))
        return _wrist_side(path[-1]) < 0.0

    end = _line(kin, q, pre, grasp, held=PRE_GRASP_Q, clear=clear)
    assert _wrist_side(end) < 0.0
    assert swept == [1.0, -1.0]  # the held line checked first, then the descent's


def test_the_held_solution_is_kept_when_no_line_is_clear(kin: MicoKinematics) -> None:
    # the tie-break: no switch to a line that sweeps too (each switch reverses the robot's twist); the clearance
    # filter (clear_path) then seeks a clear way from the held line
    q, pre, grasp = _case(kin)
    end = _line(kin, q, pre, grasp, held=PRE_GRASP_Q, clear=lambda path: False)
    assert _wrist_side(end) > 0.0
    # and with no held solution, the descent's line whether it sweeps or not
    assert _wrist_side(_line(kin, q, pre, grasp, clear=lambda path: False)) < 0.0


def test_the_assistance_holds_its_proposals_last_own_solution(kin: MicoKinematics) -> None:
    q, pre, grasp = _case(kin)
    asked: list[PathRequest] = []
    ends: list[NDArray[np.float64]] = []
    cleared = False

    class Recording(PathSearch):
        def seek(self, request: PathRequest) -> PathAnswer:
            asked.append(request)
            answer = super().seek(request)
            assert answer.path is not None
            ends.append(answer.path[-1])
            return PathAnswer(answer.key, answer.path, cleared)

    assistance = Assistance(AssistanceConfig(assist_without_input=True, standoff=0.0),
                            TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.paths = Recording(kin)
    assistance.set_joints(q)
    assistance.set_v(np.eye(len(LABELS))[0], LABELS)
    assistance.set_posterior(np.eye(len(LABELS))[0], LABELS, TASKS)

    def search(now: float) -> PathRequest:
        assistance.set_operator(np.zeros(6), now)
        assistance.command(now)
        return asked[-1]

    assistance.set_grasp(pre)
    assert search(0.0).held is None
    assistance.set_grasp(pre)  # the same plan again: sought again, the last answer's end held
    assert_allclose(search(0.01).held, ends[0], rtol=0, atol=0)
    moved = pre.copy()
    moved[:3, 3] += 0.01  # within the corridor: the same proposal keeps it
    assistance.set_grasp(moved)
    assert_allclose(search(0.02).held, ends[1], rtol=0, atol=0)
    cleared = True  # a clear way's answer is not held
    assistance.set_grasp(moved.copy())
    assert_allclose(search(0.03).held, ends[2], rtol=0, atol=0)
    assistance.set_grasp(moved.copy())
    assert_allclose(search(0.04).held, ends[2], rtol=0, atol=0)
    other = moved.copy()
    other[:3, 3] += 0.05  # a new proposal: nothing held
    assistance.set_grasp(other)
    assert search(0.05).held is None


# the hold let go when the joints stall short of the held solution (line_hold)

HELD = np.array([0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
AWAY = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # a unit direction in joint space


def _requests(hold: LineHold, joints: Callable[[float], NDArray[np.float64]],
              until: float) -> list[tuple[float, NDArray[np.float64] | None]]:
    """The hold's answers to requests every 0.1 s from 0 to ``until`` (s), the joints ``joints(t)``."""
    times = np.round(np.arange(0.0, until + 1e-9, 0.1), 9)
    return [(float(t), hold.request('pre-grasp', joints(float(t)), float(t))) for t in times]


def test_stalled_is_the_distances_decrease_below_the_threshold() -> None:
    for start, now, expected in ((0.5, 0.5, True), (0.5, 0.6, True), (0.5, 0.45, False),
                                 (0.5, 0.5 - STALL_PROGRESS / 2, True), (0.5, 0.5 - 2 * STALL_PROGRESS, False)):
        assert stalled(HELD + start * AWAY, HELD + now * AWAY, HELD) is expected


def test_a_held_solution_is_let_go_after_a_window_without_progress() -> None:
    hold = LineHold()
    assert hold.request('pre-grasp', HELD + AWAY, 0.0) is None  # nothing held yet: nothing recorded either
    hold.answered('pre-grasp', [HELD], False)
    answers = _requests(hold, lambda t: HELD + AWAY, 2.0)  # the joints stay where they are
    held_until = [t for t, held in answers if held is not None]
    assert held_until == pytest.approx(np.arange(0.0, STALL_WINDOW - 0.05, 0.1))  # let go at the window's end
    assert all(held is None for t, held in answers if t >= STALL_WINDOW)
    assert hold.let_go('pre-grasp') and not hold.let_go('grasp')
    hold.answered('pre-grasp', [HELD + AWAY], False)  # let go: the phase's answers are no longer held
    assert hold.request('pre-grasp', HELD + AWAY, 2.1) is None
    hold.reset()  # a new proposal
    hold.answered('pre-grasp', [HELD], False)
    assert_allclose(hold.request('pre-grasp', HELD + AWAY, 2.2), HELD, rtol=0, atol=0)


def test_a_held_solution_is_kept_while_the_joints_near_it() -> None:
    hold = LineHold()
    hold.answered('pre-grasp', [HELD], False)
    speed = 2.0 * STALL_PROGRESS / STALL_WINDOW  # rad/s, toward the held solution
    answers = _requests(hold, lambda t: HELD + (1.0 - speed * t) * AWAY, 5.0)
    assert all(held is not None for _, held in answers)
    assert_allclose(answers[-1][1], HELD, rtol=0, atol=0)
    assert not hold.let_go('pre-grasp')


def test_a_held_solution_is_let_go_when_the_joints_near_it_too_slowly_or_move_away() -> None:
    for speed in (0.5 * STALL_PROGRESS / STALL_WINDOW, -0.1):  # rad/s toward it: too slow, then away from it
        hold = LineHold()
        hold.answered('pre-grasp', [HELD], False)
        answers = _requests(hold, lambda t, speed=speed: HELD + (1.0 - speed * t) * AWAY, 3.0)
        assert [t for t, held in answers if held is None][0] == pytest.approx(STALL_WINDOW)


def test_a_clear_ways_answer_is_not_held() -> None:
    hold = LineHold()
    hold.answered('pre-grasp', [HELD], True)
    hold.answered('grasp', None, False)
    assert hold.request('pre-grasp', HELD, 0.0) is None and hold.request('grasp', HELD, 0.0) is None


def test_the_assistance_lets_go_of_a_held_solution_the_joints_stall_short_of(kin: MicoKinematics) -> None:
    # the joints stay where they are (no set_joints): the search's request carries the held solution for a
    # window, then none, and the answer is the descent's from q (the answer without a held solution)
    q, pre, grasp = _case(kin)
    asked: list[PathRequest] = []

    class Recording(PathSearch):
        def seek(self, request: PathRequest) -> PathAnswer:
            asked.append(request)
            return super().seek(request)

    assistance = Assistance(AssistanceConfig(assist_without_input=True, standoff=0.0),
                            TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.paths = Recording(kin)
    assistance.set_joints(q)
    assistance.set_v(np.eye(len(LABELS))[0], LABELS)
    assistance.set_posterior(np.eye(len(LABELS))[0], LABELS, TASKS)
    for now in np.round(np.arange(0.0, 1.5, 0.1), 9):
        assistance.set_grasp(pre)
        assistance.set_operator(np.zeros(6), float(now))
        assistance.command(float(now))
    held = [request.held is not None for request in asked]
    assert held == [False] + [True] * 10 + [False] * 4  # held from the first answer, let go a window later
    alone = seek_path(kin, PathRequest((0, 0, 'pre-grasp'), q, pre, grasp, SLACK, 0.0, None))
    assert alone.path is not None
    answer = seek_path(kin, asked[-1])
    assert answer.path is not None
    assert_allclose(answer.path[-1], alone.path[-1], rtol=0, atol=0)
