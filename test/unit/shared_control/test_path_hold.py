"""The IK solution a proposal's line goes to, held while its line stays clear (:func:`ik_line`, ``seek_path``)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.mico.frames import pose_error
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance, AssistanceConfig, TwistLimiter
from grasp_intent_ros.shared_control.joint_path import ik_line, line_turns
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
