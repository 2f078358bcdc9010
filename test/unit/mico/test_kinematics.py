"""grasp_intent_ros.mico.kinematics (no rclpy): the arm's model, its joint checks and 2 pi branches.

Forward kinematics against an independent DH table, the URDF's joints and limits, the checks of joint angles, the
nearest 2 pi branch and the IK's restart seeds.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.method.features import FINGER_CLOSED
from grasp_intent_ros.mico.kinematics import (
    ARM_JOINTS,
    EE_FRAME,
    FINGER_JOINTS,
    HOME_Q,
    MicoKinematics,
    default_urdf_path,
)

from .arm_joints import WIDE

# -- an independent implementation of Kinova's MICO DH table (standard DH, theta = s q + o) -------------
_K = math.sin(math.radians(30)) / math.sin(math.radians(60))
_D1, _D2, _D3, _D4, _D5, _D6, _E2 = 0.2755, 0.2900, 0.1233, 0.0741, 0.0741, 0.1600, 0.0070
_DH = (  # a, d, alpha, s, o
    (0.0, _D1, math.pi / 2, -1.0, 0.0),
    (_D2, 0.0, math.pi, 1.0, -math.pi / 2),
    (0.0, -_E2, math.pi / 2, 1.0, math.pi / 2),
    (0.0, -(_D3 + _K * _D4), math.radians(60), 1.0, 0.0),
    (0.0, -_K * (_D4 + _D5), math.radians(60), 1.0, -math.pi),
    (0.0, -(_K * _D5 + _D6), math.pi, 1.0, math.pi / 2),
)


def dh_fk(q: NDArray[np.float64]) -> NDArray[np.float64]:
    base_T_i = np.eye(4)
    for (a, d, alpha, s, o), q_i in zip(_DH, q):
        theta = s * q_i + o
        ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
        base_T_i = base_T_i @ np.array([[ct, -st * ca, st * sa, a * ct],
                                        [st, ct * ca, -ct * sa, a * st],
                                        [0.0, sa, ca, d],
                                        [0.0, 0.0, 0.0, 1.0]])
    return base_T_i


# -- URDF and model -------------------------------------------------------------------------------------

def test_model_joints_and_limits(kin: MicoKinematics) -> None:
    assert kin.joint_names == ARM_JOINTS
    assert kin.model.nq == 6
    assert_allclose(kin.lower[[1, 2]], np.radians([50.0, 35.0]))
    assert_allclose(kin.upper[[1, 2]], np.radians([310.0, 325.0]))
    assert np.all(kin.lower[list(WIDE)] <= HOME_Q[list(WIDE)] - 2 * math.pi)
    assert np.all(kin.upper[list(WIDE)] >= HOME_Q[list(WIDE)] + 2 * math.pi)
    assert np.all((kin.lower < HOME_Q) & (HOME_Q < kin.upper))
    assert_allclose(kin.velocity_limits, np.radians([36, 36, 36, 48, 48, 48]))
    with pytest.raises(ValueError):
        kin.lower[0] = 0.0


def test_urdf_fingers() -> None:
    full = pin.buildModelFromUrdf(str(default_urdf_path()))
    for name in FINGER_JOINTS:
        jid = full.getJointId(name)
        assert jid < full.njoints
        assert full.lowerPositionLimit[full.idx_qs[jid]] == 0.0
        assert full.upperPositionLimit[full.idx_qs[jid]] == pytest.approx(FINGER_CLOSED)
    for i in (1, 2, 3):
        assert full.existFrame(f'm1n6s300_link_finger_{i}')
        assert full.existFrame(f'm1n6s300_link_finger_tip_{i}')
    assert full.nq == 9  # fingertips are fixed


def test_fk_matches_dh_table(kin: MicoKinematics) -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = rng.uniform(-2 * math.pi, 2 * math.pi, 6)
        assert_allclose(kin.fk(q), dh_fk(q), rtol=0.0, atol=1e-9)


def test_home_fk(kin: MicoKinematics) -> None:
    base_T_ee = kin.fk(HOME_Q)
    assert_allclose(base_T_ee[:3, 3], (0.2149, -0.2036, 0.4187), atol=1e-3)


def test_check_q_gives_a_float_vector_and_names_what_is_wrong(kin: MicoKinematics) -> None:
    q = np.array(HOME_Q)
    assert kin.check_q(q) is q  # a float64 vector of shape (6,): as given
    assert_allclose(kin.check_q(HOME_Q.tolist()), HOME_Q, rtol=0, atol=0)
    for bad in (np.zeros(5), np.full(6, np.inf), 'abcdef'):
        with pytest.raises(KinematicsError, match='q_seed'):
            kin.check_q(bad, 'q_seed')


def test_into_limits_wraps_the_wide_joints_by_whole_turns_then_clips(kin: MicoKinematics) -> None:
    q = np.array(HOME_Q)
    q[0] = kin.upper[0] + 1.0  # a wide joint past its limit: wrapped by whole turns, the pose kept
    q[3] = kin.lower[3] - 7.0
    q[1] = kin.upper[1] + 0.3  # joint 2 (end stops, range < 2 pi): clipped
    before = q.copy()
    out = kin.into_limits(q)
    assert np.array_equal(q, before) and out is not q  # a new array
    assert np.all((kin.lower <= out) & (out <= kin.upper))
    turns = (out[[0, 3]] - q[[0, 3]]) / (2 * math.pi)
    assert_allclose(turns, np.round(turns), rtol=0, atol=1e-12) and np.all(np.round(turns) != 0)
    assert out[1] == kin.upper[1]
    assert_allclose(out[[2, 4, 5]], q[[2, 4, 5]], rtol=0, atol=0)  # within the limits: as given
    unclipped = out.copy()
    unclipped[1] = q[1]
    assert_allclose(kin.fk(unclipped), kin.fk(q), atol=1e-12)  # the wrap keeps the pose


def test_fk_rejects_bad_q(kin: MicoKinematics) -> None:
    for bad in (np.zeros(5), np.zeros((6, 1)), np.full(6, np.nan), 'abcdef'):
        with pytest.raises(KinematicsError):
            kin.fk(bad)


def test_missing_urdf_raises(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        MicoKinematics(tmp_path / 'nope.urdf')
    bad = tmp_path / 'two_link.urdf'
    bad.write_text('<robot name="r"><link name="a"/><link name="b"/>'
                   '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                   '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                   '</joint></robot>')
    with pytest.raises(KinematicsError):
        MicoKinematics(bad)


def test_core_kinematics_does_not_import_rclpy() -> None:
    code = ('import sys, grasp_intent_ros.mico.kinematics, grasp_intent_ros.resources; '
            'sys.exit("rclpy" in sys.modules)')
    assert subprocess.run([sys.executable, '-c', code], check=False, timeout=60).returncode == 0


def test_ee_frame_name(kin: MicoKinematics) -> None:
    assert kin.model.existFrame(EE_FRAME)


# -- 2 pi branches and restart seeds --------------------------------------------------------------------

def test_nearest_branch(kin: MicoKinematics) -> None:
    q = np.array([0.1, 2.0, 2.0, 0.2, 0.3, 0.4])
    ref = np.array([6.3, 5.0, 0.7, -6.0, -12.5, 30.0])
    out = kin.nearest_branch(q, ref)
    assert_allclose(out[[1, 2]], q[[1, 2]])
    assert_allclose(out[[0, 3]], q[[0, 3]] + np.array([2 * math.pi, -2 * math.pi]))
    assert kin.lower[4] <= out[4] and out[5] <= kin.upper[5]
    assert_allclose(kin.fk(out), kin.fk(q), atol=1e-12)


def test_nearest_branch_is_the_nearest_whole_turn_within_the_limits(kin: MicoKinematics) -> None:
    rng = np.random.default_rng(11)
    wide = [0, 3, 4, 5]
    for _ in range(300):
        q, ref = rng.uniform(-20.0, 20.0, 6), rng.uniform(-20.0, 20.0, 6)
        out = kin.nearest_branch(q, ref)
        assert_allclose(out[[1, 2]], q[[1, 2]], rtol=0, atol=0)  # joints with end stops: as given
        turns = (out[wide] - q[wide]) / (2 * math.pi)
        assert_allclose(turns, np.round(turns), rtol=0, atol=1e-9)  # the pose is kept
        nearest = q[wide] + 2 * math.pi * np.round((ref[wide] - q[wide]) / (2 * math.pi))
        inside = (kin.lower[wide] <= nearest) & (nearest <= kin.upper[wide])
        assert_allclose(out[wide][inside], nearest[inside], rtol=0, atol=1e-12)
        assert np.all((kin.lower[wide] <= out[wide]) & (out[wide] <= kin.upper[wide]))


def test_restart_seed_draws_joints_2_3_within_limits_and_the_others_within_pi_of_the_reference(
        kin: MicoKinematics) -> None:
    q_ref = np.array(HOME_Q)
    seeds = np.array([kin.restart_seed(q_ref, np.random.default_rng(k)) for k in range(200)])
    assert np.all(seeds >= kin.lower) and np.all(seeds <= kin.upper)
    wide = list(WIDE)
    assert np.all(np.abs(seeds[:, wide] - q_ref[wide]) <= math.pi)
    for j in (1, 2):  # spread over the limits, not near the reference
        assert seeds[:, j].min() < kin.lower[j] + 0.2 * (kin.upper[j] - kin.lower[j])
        assert seeds[:, j].max() > kin.upper[j] - 0.2 * (kin.upper[j] - kin.lower[j])
