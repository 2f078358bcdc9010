"""The robot path's clearance from the perceived object: hand-built scenes around straight joint lines."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.method.body import Box, Cylinder, ObjectBody
from grasp_intent_ros.mico.frames import pose_error
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.clearance import JOINT_REACH, PathClearance, clear_path, default_hand
from grasp_intent_ros.shared_control.joint_path import near_grasp
from grasp_intent_ros.shared_control.limits import TwistLimiter

CUP = ObjectBody((Cylinder(np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]), 0.04, 0.1),))
"""A cup-sized cylinder standing on the object frame's z = 0."""
STEP = np.array([-0.034, -0.544, 0.375, -0.618, -0.174, 0.027])
"""From Home, a joint line whose hand passes 5 cm deep through CUP centred at the line's middle hand pose."""


def _on_the_way(kin: MicoKinematics, q0: NDArray[np.float64], q1: NDArray[np.float64]) -> NDArray[np.float64]:
    """The object pose that puts CUP's centre at the hand of the line's midpoint (upright, base-aligned)."""
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = kin.fk(q0 + 0.5 * (q1 - q0))[:3, 3] - (0.0, 0.0, 0.05)
    return base_T_obj


def _deepest(clearance: PathClearance, q: NDArray[np.float64], path: list[NDArray[np.float64]]) -> float:
    """The largest intrusion at 401 evenly spaced points of each of the path's lines (finer than the check)."""
    points = [q, *path]
    return max(clearance.intrusion(a + s * (b - a)) for a, b in zip(points[:-1], points[1:])
               for s in np.linspace(0.0, 1.0, 401))


def test_a_line_through_the_body_is_replaced_by_a_clear_one(kin: MicoKinematics) -> None:
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    clearance = PathClearance(kin, default_hand(), CUP, _on_the_way(kin, q0, q1))
    assert clearance.intrusion(q0) < 0.0 and clearance.intrusion(q1) < 0.0  # both ends clear
    assert _deepest(clearance, q0, [q1]) > 0.04 and clearance.goes_in(q0, [q1])
    target = kin.fk(q1)
    path = clear_path(clearance, q0, [q1], target)
    assert not np.array_equal(path[-1], q1) or len(path) == 2
    error = pose_error(kin.fk(path[-1]), target)
    assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6
    assert _deepest(clearance, q0, path) <= 0.0
    for point in path:  # the wrist stays on its side of 0 and pi
        assert np.sin(point[4]) * np.sin(q0[4]) > 0.0


def test_a_clear_line_is_kept_unchanged(kin: MicoKinematics) -> None:
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    base_T_obj = _on_the_way(kin, q0, q1)
    base_T_obj[:3, 3] += (0.0, 0.0, -0.4)  # the cup 40 cm below the hand's way
    clearance = PathClearance(kin, default_hand(), CUP, base_T_obj)
    path = [q1]
    assert not clearance.goes_in(q0, path)
    assert clear_path(clearance, q0, path, kin.fk(q1)) is path


def test_without_a_clear_candidate_the_path_is_kept(kin: MicoKinematics) -> None:
    # a wall 4 m wide between the line's ends, across the hand's way: every path from one side to the other
    # goes through it, so the assistance's own path stays
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    start, end = kin.fk(q0)[:3, 3], kin.fk(q1)[:3, 3]
    across = (end - start) / np.linalg.norm(end - start)
    base_T_obj = np.eye(4)
    base_T_obj[:3, 0] = across
    base_T_obj[:3, 1] = np.cross((0.0, 0.0, 1.0), across) / np.linalg.norm(np.cross((0.0, 0.0, 1.0), across))
    base_T_obj[:3, 2] = np.cross(base_T_obj[:3, 0], base_T_obj[:3, 1])
    base_T_obj[:3, 3] = 0.5 * (start + end)
    wall = ObjectBody((Box(np.zeros(3), np.array([0.005, 2.0, 2.0])),))
    clearance = PathClearance(kin, default_hand(), wall, base_T_obj)
    assert clearance.intrusion(q0) < 0.0 and clearance.intrusion(q1) < 0.0
    path = [q1]
    assert clearance.goes_in(q0, path)
    assert clear_path(clearance, q0, path, kin.fk(q1)) is path


def test_a_depth_the_path_starts_with_is_allowed_not_a_deeper_one(kin: MicoKinematics) -> None:
    # the hand starts 2 cm inside the cup and leaves it: the path does not go in; back in deeper, it does
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = kin.fk(q0 + 0.45 * (q1 - q0))[:3, 3] - (0.0, 0.0, 0.05)
    clearance = PathClearance(kin, default_hand(), CUP, base_T_obj)
    middle = q0 + 0.45 * (q1 - q0)
    assert clearance.intrusion(middle) > 0.02 and clearance.intrusion(q1) < 0.0
    assert not clearance.goes_in(middle, [q1])
    assert clearance.goes_in(q0, [q1])


def test_the_joint_reach_bounds_the_hand_s_motion(kin: MicoKinematics) -> None:
    # every hand point within the hand's reach of the end effector moves at most sum_j JOINT_REACH_j |dq_j|:
    # checked for the end effector and the reach's bound on small random steps
    rng = np.random.default_rng(5)
    for _ in range(200):
        q = kin.restart_seed(np.asarray(HOME_Q, dtype=np.float64), rng)
        dq = rng.normal(0.0, 1e-3, 6)
        a, b = kin.fk(q), kin.fk(q + dq)
        moved = np.linalg.norm(b[:3, 3] - a[:3, 3]) + 0.17 * np.linalg.norm(pose_error(a, b)[3:])
        assert moved <= float(JOINT_REACH @ np.abs(dq)) * (1.0 + 1e-3)


def test_the_assistance_takes_the_perceived_object_and_refuses_a_bad_pose(kin: MicoKinematics) -> None:
    assistance = Assistance(AssistanceConfig(), TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assert assistance.clearance is None
    assistance.set_object(np.eye(4), CUP)
    clearance = assistance.clearance
    assert clearance is not None
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(KinematicsError):
        assistance.set_object(bad, CUP)
    assert assistance.clearance is clearance  # nothing changed
    assistance.set_object(np.eye(4), None)  # a model without a body: no check
    assert assistance.clearance is None
    assert Assistance(AssistanceConfig(), TwistLimiter(0.2, 1.0, 1.0, 5.0)).clearance is None


def test_a_previous_clear_way_is_kept_for_a_target_moved_by_millimetres(kin: MicoKinematics,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    # the search's answer for the target, then the target moved by 2 mm: the same way, re-targeted, not a new search
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    clearance = PathClearance(kin, default_hand(), CUP, _on_the_way(kin, q0, q1))
    first = clear_path(clearance, q0, [q1], kin.fk(q1))
    assert clearance.goes_in(q0, [q1]) and not clearance.goes_in(q0, first)
    moved = kin.fk(q1)
    moved[:3, 3] += (0.002, 0.0, 0.0)
    own = kin.ik(moved, q1, restarts=0)
    assert own.success and clearance.goes_in(q0, [own.q])  # the assistance's own line still goes in
    def no_search(*args: object) -> None:
        raise AssertionError('searched again')
    monkeypatch.setattr('grasp_intent_ros.shared_control.clearance.ik_candidates', no_search)
    kept = clear_path(clearance, q0, [own.q], moved, previous=first)
    assert len(kept) == len(first)
    for a, b in zip(kept[:-1], first[:-1]):  # the way's via point, if any, unchanged
        assert np.array_equal(a, b)
    assert np.linalg.norm(kept[-1] - first[-1]) < 0.05  # the end re-targeted next to the former end
    error = pose_error(kin.fk(kept[-1]), moved)
    assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6
    assert not clearance.goes_in(q0, kept)


def test_a_previous_way_that_now_goes_in_is_searched_again(kin: MicoKinematics) -> None:
    # a "previous" way that is the line through the body itself: checked, refused, and the search answers
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    clearance = PathClearance(kin, default_hand(), CUP, _on_the_way(kin, q0, q1))
    searched = clear_path(clearance, q0, [q1], kin.fk(q1))
    again = clear_path(clearance, q0, [q1], kin.fk(q1), previous=[q1])
    assert len(again) == len(searched) and all(np.array_equal(a, b) for a, b in zip(again, searched))


def test_only_admissible_ways_are_taken(kin: MicoKinematics) -> None:
    # the search's answer refused by the predicate: another answer, itself admissible; nothing admissible: the path
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    clearance = PathClearance(kin, default_hand(), CUP, _on_the_way(kin, q0, q1))
    free = clear_path(clearance, q0, [q1], kin.fk(q1))
    assert clearance.goes_in(q0, [q1]) and not clearance.goes_in(q0, free)

    def not_free(path: list[NDArray[np.float64]]) -> bool:
        return not (len(path) == len(free) and all(np.array_equal(a, b) for a, b in zip(path, free)))

    other = clear_path(clearance, q0, [q1], kin.fk(q1), admissible=not_free)
    assert not_free(other)
    path = [q1]
    assert clear_path(clearance, q0, path, kin.fk(q1), admissible=lambda p: False) is path


def test_near_grasp_bounds_the_hand_s_distance_on_the_way(kin: MicoKinematics) -> None:
    # a short step toward the grasp stays near it; the line through the cup's scene, 5 cm deep, ends 0.2 m off
    q0 = np.asarray(HOME_Q, dtype=np.float64)
    q1 = q0 + STEP
    base_T_grasp = kin.fk(q0)
    assert near_grasp(kin, q0, [q0 + 0.01 * STEP], base_T_grasp, slack=0.02)
    far = float(np.linalg.norm(kin.fk(q1)[:3, 3] - base_T_grasp[:3, 3]))
    assert far > 0.1 and not near_grasp(kin, q0, [q1], base_T_grasp, slack=0.02)
    assert near_grasp(kin, q0, [q1], base_T_grasp, slack=0.02, reference=far + 0.2)
