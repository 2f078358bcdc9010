"""Unit tests of grasp_intent_ros.mico.frames: grasp features <-> end-effector pose, poses, the drawn fingers."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from native_memory import growth_over, malloc_in_use
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import InvalidFeaturesError, KinematicsError
from grasp_intent_ros.method.features import APPROACH, FINGER_CLOSED, FINGERS, PALM, ROLL
from grasp_intent_ros.mico.frames import (
    FINGER_LENGTH,
    ORTHONORMAL_TOL,
    check_transform,
    features_to_obj_T_ee,
    finger_segments,
    matrix_to_pose,
    obj_T_ee_to_features,
    pose_to_matrix,
    rotation_angle,
    rotation_angles,
)

_unit_approach = st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)).filter(
    lambda v: 0.1 < math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    and v[2] / math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2) < 0.999)


@settings(max_examples=200, deadline=None)
@given(palm=st.tuples(*[st.floats(-0.3, 0.3)] * 3), approach=_unit_approach,
       roll=st.floats(-math.pi / 2, 3 * math.pi / 2, exclude_max=True),
       fingers=st.tuples(*[st.floats(0.0, FINGER_CLOSED)] * 3))
def test_features_round_trip(palm: tuple[float, ...], approach: tuple[float, ...], roll: float,
                             fingers: tuple[float, ...]) -> None:
    x = np.array([*palm, *approach, roll, *fingers])
    obj_T_ee = features_to_obj_T_ee(x)
    a_hat = x[APPROACH] / np.linalg.norm(x[APPROACH])
    assert_allclose(obj_T_ee[:3, 2], a_hat, atol=1e-12)  # EE z axis = approach
    assert_allclose(obj_T_ee[:3, 3], x[PALM])  # EE origin = palm centre
    assert_allclose(obj_T_ee[:3, :3].T @ obj_T_ee[:3, :3], np.eye(3), atol=1e-12)
    assert np.linalg.det(obj_T_ee[:3, :3]) == pytest.approx(1.0)
    back = obj_T_ee_to_features(obj_T_ee, x[FINGERS])
    expected = x.copy()
    expected[APPROACH] = a_hat
    # roll is periodic: compare on the circle, then exactly away from the wrap point
    assert abs(math.remainder(back[ROLL] - roll, 2 * math.pi)) < 1e-9
    assert -math.pi / 2 <= back[ROLL] < 3 * math.pi / 2
    back[ROLL] = expected[ROLL] = 0.0
    assert_allclose(back, expected, atol=1e-9)


def test_feature_convention_examples() -> None:
    top = np.zeros(10)
    top[APPROACH] = (0.0, 0.0, -1.0)
    assert_allclose(features_to_obj_T_ee(top)[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-15)
    # roll r turns the EE by -r about its own z axis (= +r about the object's z axis for a top grasp)
    top[ROLL] = math.pi / 2
    assert_allclose(features_to_obj_T_ee(top)[:3, 0], (0.0, 1.0, 0.0), atol=1e-15)
    side = np.zeros(10)
    side[APPROACH] = (2.0, 0.0, 0.0)  # not normalised on purpose
    R = features_to_obj_T_ee(side)[:3, :3]
    assert_allclose(R[:, 2], (1.0, 0.0, 0.0), atol=1e-15)
    assert_allclose(R[:, 0], (0.0, 0.0, 1.0), atol=1e-15)  # thumb up
    below = np.zeros(10)
    below[APPROACH] = (0.0, 0.0, 1.0)  # singular for R_min: deterministic R_x(pi)
    assert_allclose(features_to_obj_T_ee(below)[:3, :3], np.eye(3), atol=1e-15)
    nearly = below.copy()
    nearly[APPROACH] = (1e-9, 0.0, 1.0)
    R = features_to_obj_T_ee(nearly)[:3, :3]
    assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert_allclose(R[:, 2], (1e-9, 0.0, 1.0), atol=1e-12)


def test_features_reject_bad_input() -> None:
    for bad in (np.zeros(9), np.full(10, np.nan), np.zeros(10)):  # the last has a zero approach
        with pytest.raises(InvalidFeaturesError):
            features_to_obj_T_ee(bad)
    with pytest.raises(InvalidFeaturesError):
        obj_T_ee_to_features(np.eye(4), np.zeros(2))
    with pytest.raises(KinematicsError):
        obj_T_ee_to_features(np.eye(3), np.zeros(3))


def test_pose_matrix_round_trip() -> None:
    half = math.radians(45)
    T = pose_to_matrix((1.0, 2.0, 3.0), (0.0, 0.0, math.sin(half), math.cos(half)))  # 90 deg about z
    assert_allclose(T[:3, :3], [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-15)
    rng = np.random.default_rng(4)
    for _ in range(50):
        quat = rng.normal(size=4)
        quat /= np.linalg.norm(quat)
        position, back = matrix_to_pose(pose_to_matrix(rng.normal(size=3), 3.0 * quat))
        assert back[3] >= 0.0
        assert_allclose(back, quat * np.sign(quat[3]), atol=1e-12)
    with pytest.raises(KinematicsError):
        pose_to_matrix((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))
    with pytest.raises(KinematicsError):
        pose_to_matrix((0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


@pytest.mark.skipif(malloc_in_use() is None, reason='needs glibc mallinfo2')
def test_pose_from_matrix_holds_no_native_memory() -> None:
    # the planner converts a pose per plan: pin.Quaternion(R) leaked 80 bytes of malloc per call (400 kB here)
    T = pose_to_matrix((0.3, -0.3, 0.1), (0.0, 0.0, 1.0, 0.0))
    growth = growth_over(lambda _: matrix_to_pose(T), 5_000, warm_up=500)
    assert growth is not None and growth < 100_000


def test_check_transform_projects_a_rotation_unless_it_is_orthonormal_already() -> None:
    T = pose_to_matrix((0.1, -0.2, 0.3), (0.1, 0.7, -0.2, 0.6))  # orthonormal up to rounding
    assert np.abs(T[:3, :3].T @ T[:3, :3] - np.eye(3)).max() <= ORTHONORMAL_TOL
    assert np.array_equal(check_transform(T, 'T'), T), 'kept as it is: nothing to project'
    rng = np.random.default_rng(1)
    for deviation in (1e-10, 1e-8, 5e-7):  # within check_transform's tolerance of 1e-6
        skewed = T.copy()
        skewed[:3, :3] += deviation * rng.uniform(-1.0, 1.0, (3, 3))
        R = check_transform(skewed, 'skewed')[:3, :3]
        assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-14)  # onto SO(3) ...
        u, _, vt = np.linalg.svd(skewed[:3, :3])
        assert_allclose(R, u @ vt, rtol=0, atol=1e-15)  # ... the nearest rotation
    assert_allclose(check_transform(T + 1e-9 * np.eye(4)[3], 'T')[3], [0.0, 0.0, 0.0, 1.0], rtol=0, atol=0)
    bad = (('shape', np.eye(3)), ('finite', np.full((4, 4), np.nan)), ('last row', T + 0.1 * np.eye(4)[[3, 3, 3, 3]]),
           ('not a rotation matrix', T @ np.diag([1.0, 1.0, 1.0 + 1e-5, 1.0])),  # stretched beyond 1e-6
           ('not a rotation matrix', T @ np.diag([1.0, 1.0, -1.0, 1.0])))  # a reflection
    for reason, value in bad:
        with pytest.raises(KinematicsError, match=reason):
            check_transform(value, 'T')


def test_roll_at_the_lower_bound_stays_in_range() -> None:
    # found by hypothesis: a roll of exactly -pi/2 came back as 3 pi/2 (floating-point wrap)
    x = np.array([0.0, 0.0, 0.0, 0.0, 0.4970674496590066, 0.11519049771686585, -math.pi / 2, 0.0, 0.0, 0.0])
    back = obj_T_ee_to_features(features_to_obj_T_ee(x), x[FINGERS])
    assert -math.pi / 2 <= back[ROLL] < 3 * math.pi / 2
    assert abs(math.remainder(back[ROLL] + math.pi / 2, 2 * math.pi)) < 1e-9


def test_drawn_fingers_bend_inwards_by_their_closure() -> None:
    open_, closed = finger_segments([0.0, 0.0, 0.0]), finger_segments([FINGER_CLOSED] * 3)
    assert_allclose(np.linalg.norm(open_[:, 1] - open_[:, 0], axis=1), FINGER_LENGTH)
    assert_allclose(open_[:, 0], closed[:, 0])  # same bases
    assert_allclose(open_[0, 0], [0.03, 0.0, 0.0], atol=1e-15)  # finger 1 (thumb) at +x of the EE frame
    radial = np.linalg.norm(closed[:, 1, :2], axis=1) < np.linalg.norm(open_[:, 1, :2], axis=1)
    assert radial.all(), 'closed fingertips are nearer the approach axis'


def test_rotation_angles_are_each_rotations_angle_from_the_reference() -> None:
    rotation = pin.exp3(np.array([0.3, -0.2, 0.5]))
    turns = [np.zeros(3), np.array([0.0, 0.0, 0.4]), np.array([1.0, 2.0, -2.0]) / 3.0 * 2.5,
             np.array([0.0, math.pi, 0.0])]
    rotations = np.stack([pin.exp3(t) @ rotation for t in turns])  # turned by |t| from rotation
    # arccos near cosines of +-1 (0 and pi) is good to sqrt(2 eps) ~ 2e-8 rad; elsewhere to a few eps
    assert_allclose(rotation_angles(rotations, rotation), [0.0, 0.4, 2.5, math.pi], rtol=0.0, atol=3e-8)


def test_rotation_angle_is_the_turn_from_a_to_b_in_either_order() -> None:
    base_R_a = pin.exp3(np.array([0.3, -0.2, 0.5]))
    turns = [np.zeros(3), np.array([0.0, 0.0, 0.4]), np.array([1.0, 2.0, -2.0]) / 3.0 * 2.5,
             np.array([0.0, math.pi, 0.0])]
    for turn, angle in zip(turns, [0.0, 0.4, 2.5, math.pi]):
        base_R_b = base_R_a @ pin.exp3(turn)  # R_a^T R_b = exp3(turn), turned about an axis of a's own frame
        # arccos near cosines of +-1 (0 and pi) is good to sqrt(2 eps) ~ 2e-8 rad; elsewhere to a few eps
        assert rotation_angle(base_R_a, base_R_b) == pytest.approx(angle, rel=0.0, abs=3e-8)
        assert rotation_angle(base_R_b, base_R_a) == rotation_angle(base_R_a, base_R_b)  # the same nine products
        assert rotation_angles(base_R_b[None], base_R_a)[0] == pytest.approx(angle, rel=0.0, abs=3e-8)
