"""The joint path's target kept for a proposal: the IK seeded at the end of the path last taken (``seek_path``)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.mico.frames import pose_error
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance, AssistanceConfig, TwistLimiter
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


def _end(answer: PathAnswer) -> NDArray[np.float64]:
    assert answer.path is not None
    return answer.path[-1]


def test_the_target_stays_the_solution_the_proposals_path_went_to(kin: MicoKinematics) -> None:
    q, pre, grasp = _case(kin)
    assert_allclose(pose_error(kin.fk(OTHER_SIDE_Q), pre), np.zeros(6), atol=1e-3)  # the case: two solutions (6 digits)
    descended = _end(seek_path(kin, PathRequest((0, 0, 'pre-grasp'), q, pre, grasp, SLACK, 0.0, None)))
    assert np.sin(descended[4]) < 0.0  # without the former end, the descent from q takes the other side
    kept = _end(seek_path(kin, PathRequest((0, 0, 'pre-grasp'), q, pre, grasp, SLACK, 0.0, None,
                                           former=PRE_GRASP_Q)))
    assert_allclose(pose_error(kin.fk(kept), pre), np.zeros(6), atol=1e-6)
    # the former solution: joints 1-3 and 5 as it has them on the branch nearest q (line_turns may turn 4 and 6)
    assert_allclose(kept[[0, 1, 2, 4]], kin.nearest_branch(PRE_GRASP_Q, q)[[0, 1, 2, 4]], atol=1e-4)


def test_the_assistance_seeds_each_search_at_its_proposals_last_path_end(kin: MicoKinematics) -> None:
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

    def search(now: float) -> PathRequest:
        assistance.set_operator(np.zeros(6), now)
        assistance.command(now)
        return asked[-1]

    assistance.set_grasp(pre)
    first = search(0.0)
    assert first.former is None
    taken = _end(PathSearch(kin).seek(first))
    assistance.set_grasp(pre)  # the same plan again: sought again from the same joints, seeded at the last end
    assert_allclose(search(0.01).former, taken, rtol=0, atol=0)
    moved = pre.copy()
    moved[:3, 3] += 0.01  # within the corridor: the same proposal keeps its end
    assistance.set_grasp(moved)
    assert_allclose(search(0.02).former, taken, rtol=0, atol=0)
    other = moved.copy()
    other[:3, 3] += 0.05  # a new proposal: sought from q alone
    assistance.set_grasp(other)
    assert search(0.03).former is None


def test_a_clear_way_that_replaced_the_path_leaves_the_seed_at_the_own_paths_end(kin: MicoKinematics) -> None:
    q, pre, _ = _case(kin)
    own, way = kin.nearest_branch(PRE_GRASP_Q, q), np.array(OTHER_SIDE_Q)
    answers = [(own, False), (way, True), (own, False)]
    asked: list[PathRequest] = []

    class Scripted:
        """Answers each request with the next of ``answers``: (the path's end, whether it is a clear way)."""

        def seek(self, request: PathRequest) -> PathAnswer:
            asked.append(request)
            end, cleared = answers[len(asked) - 1]
            return PathAnswer(request.key, [end], cleared)

    assistance = Assistance(AssistanceConfig(assist_without_input=True, standoff=0.0),
                            TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.paths = Scripted()
    assistance.set_joints(q)
    assistance.set_v(np.eye(len(LABELS))[0], LABELS)
    assistance.set_posterior(np.eye(len(LABELS))[0], LABELS, TASKS)
    for tick in range(3):
        assistance.set_grasp(pre)
        assistance.set_operator(np.zeros(6), 0.01 * tick)
        assistance.command(0.01 * tick)
    assert asked[0].former is None
    assert_allclose(asked[1].former, own, rtol=0, atol=0)
    assert_allclose(asked[2].former, own, rtol=0, atol=0)  # the clear way's end (the other side) is not the seed
