"""The robot twist's joint path for a target without an IK from the joints: the line IK and its via point."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.mico.frames import pose_error, pre_grasp
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.joint_path import LINE_IK_SEEDS, joint_path
from grasp_intent_ros.shared_control.limits import TwistLimiter

from .robot_alone import assistance_joint_path, robot_alone

# the arm 28 cm from a cup grasp after the operator's goal changed (the closed-loop benchmark's goal-changing
# operator, seed 0, episode 37): the pre-grasp has no IK from these joints, and the straight joint line to each
# of its IK solutions on the wrist's side swings the hand beyond its present distance to the grasp plus 2 cm
FAR_Q = np.array([3.83514, 4.223431, 0.721664, 5.037367, 0.245971, 3.483116])
FAR_PRE_GRASP_Q = np.array([2.699395, 4.583705, 0.777801, 7.244014, 1.419568, 2.38279])


def _hand_distances(kin: MicoKinematics, start: NDArray[np.float64], end: NDArray[np.float64],
                    grasp: NDArray[np.float64]) -> NDArray[np.float64]:
    """The hand's distance to the grasp at 101 points of the joint line (finer than the rule's 20)."""
    return np.array([np.linalg.norm(kin.fk(start + s * (end - start))[:3, 3] - grasp[:3, 3])
                     for s in np.linspace(0.0, 1.0, 101)])


def test_a_pre_grasp_without_a_straight_admissible_line_is_reached_through_one_via_point() -> None:
    kin = MicoKinematics()
    config = AssistanceConfig(assist_without_input=True)
    pre = kin.fk(FAR_PRE_GRASP_Q)
    grasp = pre.copy()
    grasp[:3, 3] += config.standoff * pre[:3, 2]
    assert_allclose(pre_grasp(grasp, config.standoff), pre, atol=1e-12)
    assert not kin.ik(pre, FAR_Q, restarts=0).success
    bound = float(np.linalg.norm(kin.fk(FAR_Q)[:3, 3] - grasp[:3, 3])) + config.corridor_radius
    # the case, searched wider than the rule does: no IK solution from 200 restart seeds has an admissible line
    rng = np.random.default_rng(11)
    solutions = 0
    for _ in range(200):
        ik = kin.ik(pre, kin.restart_seed(FAR_Q, rng), restarts=0)
        if ik.success:
            solutions += 1
            q_t = kin.nearest_branch(ik.q, FAR_Q)
            assert np.sin(q_t[4]) * np.sin(FAR_Q[4]) <= 0.0 or _hand_distances(kin, FAR_Q, q_t, grasp).max() > bound
    assert solutions > 0
    assistance = Assistance(config, TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.set_joints(FAR_Q)
    assistance.set_grasp(grasp)
    path = assistance_joint_path(assistance, pre)
    assert path is not None and len(path) == 2
    via, q_t = path
    error = pose_error(kin.fk(q_t), pre)
    assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6
    for point in path:  # the wrist stays on its side
        assert np.sin(point[4]) * np.sin(FAR_Q[4]) > 0.0
    for start, end in ((FAR_Q, via), (via, q_t)):  # 1 mm of slack between the rule's 20 points
        assert _hand_distances(kin, start, end, grasp).max() <= bound + 1e-3
    # the robot alone (the operator still, assistance without input) brings the hand to the grasp
    error = pose_error(kin.fk(robot_alone(kin, assistance, FAR_Q, 4, 1500)), grasp)
    assert np.linalg.norm(error[:3]) <= 1e-3 and np.linalg.norm(error[3:]) <= 1e-2


@dataclass
class _Result:
    q: NDArray[np.float64]
    success: bool


class _ToyArm:
    """A toy arm: the hand at 0.1 q[:3] m, its IK answer chosen by the seed (``answers[k]`` for the k-th seed)."""

    lower, upper, velocity_limits = np.full(6, -20.0), np.full(6, 20.0), np.ones(6)

    def __init__(self, answers: dict[int, NDArray[np.float64]]) -> None:
        self.answers = answers
        self._drawn = 0

    def fk(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        pose = np.eye(4)
        pose[:3, 3] = 0.1 * q[:3]
        return pose

    def restart_seed(self, q_ref: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        self._drawn += 1
        return np.full(6, float(self._drawn))  # seed k (Home is seed 0)

    def ik(self, base_T_target: NDArray[np.float64], seed: NDArray[np.float64], *, restarts: int) -> _Result:
        k = int(seed[0]) if seed[0] == round(seed[0]) and seed[0] >= 1 else 0
        answer = self.answers.get(k)
        return _Result(np.zeros(6) if answer is None else answer, answer is not None)

    def nearest_branch(self, q: NDArray[np.float64], q_ref: NDArray[np.float64]) -> NDArray[np.float64]:
        return q


def test_equally_long_lines_go_to_the_earlier_seed() -> None:
    # two solutions mirrored about q (exactly equal lengths), both admissible: the earlier seed's wins
    q = np.array([0.0, 0.0, 0.0, 0.0, 1.0, 0.0])
    plus, minus = q + [0.2, 0, 0, 0, 0, 0], q - [0.2, 0, 0, 0, 0, 0]
    grasp = np.eye(4)
    target = np.eye(4)
    for first, second in ((plus, minus), (minus, plus)):
        arm = _ToyArm({3: first, 5: second, 7: first + [0, 0.3, 0, 0, 0, 0]})
        path = joint_path(cast(MicoKinematics, arm), q, target, grasp, slack=0.05)
        assert path is not None and len(path) == 1
        assert_allclose(path[0], first, rtol=0, atol=0)
    assert LINE_IK_SEEDS > 7  # the seeds the toy answers are tried


def test_the_bound_never_falls_below_the_reference_distance() -> None:
    # FAR_Q's straight lines to the pre-grasp swing the hand beyond its present distance plus the slack: with a
    # reference distance 5 cm larger a straight line qualifies, and stays within that bound
    kin = MicoKinematics()
    slack = AssistanceConfig().corridor_radius
    pre = kin.fk(FAR_PRE_GRASP_Q)
    grasp = pre.copy()
    grasp[:3, 3] += AssistanceConfig().standoff * pre[:3, 2]
    present = float(np.linalg.norm(kin.fk(FAR_Q)[:3, 3] - grasp[:3, 3]))
    path = joint_path(kin, FAR_Q, pre, grasp, slack=slack)
    assert path is not None and len(path) == 2
    wide = joint_path(kin, FAR_Q, pre, grasp, slack=slack, reference=present + 0.05)
    assert wide is not None and len(wide) == 1
    assert _hand_distances(kin, FAR_Q, wide[0], grasp).max() <= present + 0.05 + slack + 1e-3
    # the assistance's reference: the hand's distance at its first path to this proposal, kept while the grasp
    # stays within the corridor (the hand since 12 cm from the grasp), the present distance for a new proposal
    assistance = Assistance(AssistanceConfig(), TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.set_joints(FAR_Q)
    assistance.set_grasp(grasp)
    assert assistance_joint_path(assistance, pre) is not None
    via, q_t = path
    nearer = via + 0.75 * (q_t - via)
    near = float(np.linalg.norm(kin.fk(nearer)[:3, 3] - grasp[:3, 3]))
    assert near < present - 0.1
    assistance.set_joints(nearer)
    assistance.set_grasp(grasp.copy())
    assistance_joint_path(assistance, pre)
    assert assistance._path_reference == present
    moved = grasp.copy()
    moved[:3, 3] += [0.0, 0.0, 0.05]  # beyond the corridor: a new proposal
    assistance.set_grasp(moved)
    assistance_joint_path(assistance, pre)
    assert assistance._path_reference == float(np.linalg.norm(kin.fk(nearer)[:3, 3] - moved[:3, 3]))
