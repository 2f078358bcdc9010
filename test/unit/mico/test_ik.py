"""grasp_intent_ros.mico.ik (no rclpy): the inverse kinematics, through MicoKinematics.ik, and its compiled kernel.

The kernel (kernels.ik) on the arm's chain: the chain's FK and log3 against Pinocchio, the residual's Jacobian
against central differences, warmed up with the types the IK uses.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
import pytest
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.kernels import warm_up
from grasp_intent_ros.kernels.ik import _chain_fk, _ik_descent, _ik_jacobian, _ik_residual, _log3
from grasp_intent_ros.method.features import APPROACH
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pose_to_matrix, rotation_angle
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.mico.reachability import Reachability

from .arm_joints import WIDE


def random_q(kin: MicoKinematics, rng: np.random.Generator) -> NDArray[np.float64]:
    """Joint angles within the limits, wide joints within pi of home."""
    return kin.restart_seed(np.array(HOME_Q), rng)


def pose_errors(base_T_a: NDArray[np.float64], base_T_b: NDArray[np.float64]) -> tuple[float, float]:
    pos = float(np.linalg.norm(base_T_a[:3, 3] - base_T_b[:3, 3]))
    return pos, rotation_angle(base_T_a[:3, :3], base_T_b[:3, :3])


# -- the compiled kernel --------------------------------------------------------------------------------

def test_compiled_chain_fk_matches_pinocchio(kin: MicoKinematics) -> None:
    """The compiled IK's chain (read from the Pinocchio model) gives Pinocchio's FK: the IK works on the URDF."""
    rng = np.random.default_rng(7)
    origins, zs = np.empty((6, 3)), np.empty((6, 3))
    for _ in range(50):
        q = random_q(kin, rng)
        R, p = _chain_fk(q, *kin.ik_chain, origins, zs)
        assert_allclose(kin.world_T_base[:3, :3] @ kin.fk(q)[:3, :3], R, atol=1e-12)
        assert_allclose(kin.world_T_base[:3, :3] @ kin.fk(q)[:3, 3] + kin.world_T_base[:3, 3], p, atol=1e-12)


def test_ik_kernel_warmed_up_with_the_types_ik_uses(kin: MicoKinematics) -> None:
    """After warm_up, IK compiles nothing more: a node that loaded its kernels at start never compiles in a plan."""
    warm_up()
    before = len(_ik_descent.signatures)
    kin.ik(kin.fk(HOME_Q + 0.2), HOME_Q)
    x = np.array([0.0, 0.0, 0.1, 0.0, 0.0, -1.0, 0.0, 0.5, 0.5, 0.5])  # palm 10 cm above, approach down
    Reachability(kin, pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 0.0, 1.0)))(x)
    assert len(_ik_descent.signatures) == before


@pytest.mark.parametrize('angle', [0.0, 1e-9, 1e-5, 0.3, 2.0, math.pi - 2e-3, math.pi - 1e-6, math.pi])
def test_log3_matches_pinocchio(angle: float) -> None:
    """The rotation vector, also within 1e-3 of pi where the kernel takes the axis from the symmetric part."""
    rng = np.random.default_rng(int(angle * 1e6))
    for _ in range(5):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        R = pin.exp3(angle * axis)
        phi = _log3(np.ascontiguousarray(R))
        assert_allclose(pin.exp3(phi), R, atol=1e-12)
        assert float(np.linalg.norm(phi)) == pytest.approx(angle, abs=1e-9)
        if angle < math.pi - 1e-6:  # at pi, phi and -phi are the same rotation
            assert_allclose(phi, np.asarray(pin.log3(R)), atol=1e-9)


def test_ik_jacobian_matches_central_differences(kin: MicoKinematics) -> None:
    """de/dq of the compiled IK against central differences (1e-6 relative), rotation errors up to 3 rad."""
    rng = np.random.default_rng(8)
    origins, zs = np.empty((6, 3)), np.empty((6, 3))
    for _ in range(20):
        q_target, q = random_q(kin, rng), random_q(kin, rng)
        W = kin.world_T_base @ kin.fk(q_target)
        R_t, p_t = np.ascontiguousarray(W[:3, :3]), np.ascontiguousarray(W[:3, 3])
        e, R, p = _ik_residual(q, *kin.ik_chain, R_t, p_t, origins, zs)
        if np.linalg.norm(e[3:]) > 3.0:  # log3 is not differentiable at pi
            continue
        J = _ik_jacobian(e, R, p, origins, zs)
        h = 1e-6
        numeric = np.empty((6, 6))
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            plus = _ik_residual(q + dq, *kin.ik_chain, R_t, p_t, origins.copy(), zs.copy())[0]
            minus = _ik_residual(q - dq, *kin.ik_chain, R_t, p_t, origins.copy(), zs.copy())[0]
            numeric[:, i] = (plus - minus) / (2 * h)
        assert_allclose(J, numeric, rtol=1e-6, atol=1e-7)


# -- inverse kinematics ---------------------------------------------------------------------------------

def test_ik_round_trip_from_home(kin: MicoKinematics) -> None:
    rng = np.random.default_rng(1)
    n, successes = 100, 0
    for _ in range(n):
        base_T_target = kin.fk(random_q(kin, rng))
        res = kin.ik(base_T_target, HOME_Q, restarts=8, rng=rng)
        assert np.all((kin.lower <= res.q) & (res.q <= kin.upper))
        assert np.all(np.abs(res.q[list(WIDE)] - HOME_Q[list(WIDE)]) <= math.pi + 1e-9)
        if res.success:
            successes += 1
            pos, rot = pose_errors(kin.fk(res.q), base_T_target)
            assert pos <= 1e-4 and rot <= 1e-3, res.message
            assert res.pos_error_m == pytest.approx(pos, abs=1e-9)
    assert successes / n >= 0.95


def test_ik_runs_to_the_solution_so_last_bits_do_not_move_it(kin: MicoKinematics) -> None:
    """Not the first point within tolerance: the seed moved by 1e-12 gives the same joints within 1e-8 rad."""
    rng = np.random.default_rng(3)
    for _ in range(40):
        base_T_target = kin.fk(random_q(kin, rng))
        res = kin.ik(base_T_target, HOME_Q)
        if not res.success:
            continue
        nudged = kin.ik(base_T_target, HOME_Q * (1.0 + 1e-12 * rng.standard_normal(6)))
        assert nudged.success
        assert res.pos_error_m <= 1e-10 and res.rot_error_rad <= 1e-10, res.message
        assert_allclose(nudged.q, res.q, atol=1e-8)


def test_ik_near_seed_is_fast_and_exact(kin: MicoKinematics) -> None:
    rng = np.random.default_rng(2)
    for _ in range(30):
        q_true = random_q(kin, rng)
        q_seed = np.clip(q_true + rng.normal(0.0, 0.05, 6), kin.lower, kin.upper)
        base_T_target = kin.fk(q_true)
        res = kin.ik(base_T_target, q_seed, restarts=0)
        assert res.success, res.message
        assert res.attempts == 1 and res.iterations <= 20
        pos, rot = pose_errors(kin.fk(res.q), base_T_target)
        assert pos <= 1e-4 and rot <= 1e-3
        # the same solution (joint errors of a few mrad are allowed near the wrist singularity q5 = 0)
        assert_allclose(res.q, q_true, atol=0.05)


def test_ik_answer_on_branch_nearest_seed(kin: MicoKinematics) -> None:
    q_true = np.array([1.0, 2.5, 1.5, -0.5, 2.0, 0.3])
    q_seed = q_true + np.array([2 * math.pi, 0.0, 0.0, -2 * math.pi, 4 * math.pi, 2 * math.pi]) + 0.02
    res = kin.ik(kin.fk(q_true), q_seed)
    assert res.success, res.message
    # joint 5's nearest branch (q + 4 pi = 14.6) lies beyond the 4 pi limit: the nearest one inside is taken
    expected = q_true + np.array([2 * math.pi, 0.0, 0.0, -2 * math.pi, 2 * math.pi, 2 * math.pi])
    assert_allclose(res.q, expected, atol=0.02)


def test_ik_reproducible(kin: MicoKinematics) -> None:
    q_true = random_q(kin, np.random.default_rng(3))
    target = kin.fk(q_true)
    first = kin.ik(target, rng=7)
    second = kin.ik(target, rng=7)
    assert_allclose(first.q, second.q)
    assert first.iterations == second.iterations


def test_ik_unreachable_reports_failure(kin: MicoKinematics) -> None:
    base_T_target = np.eye(4)
    base_T_target[:3, 3] = (2.0, 0.0, 0.3)
    res = kin.ik(base_T_target, restarts=2)
    assert not res.success
    assert res.pos_error_m > 1.0
    assert res.attempts == 0 and res.iterations == 0  # beyond MAX_REACH: answered without iterating
    assert np.all(np.isfinite(res.q)) and np.all((kin.lower <= res.q) & (res.q <= kin.upper))
    assert 'reach' in res.message


def test_ik_that_does_not_converge_reports_failure(kin: MicoKinematics) -> None:
    q_far = np.array(HOME_Q) + np.array([1.0, -0.6, 0.8, 1.0, 1.0, 1.0])
    res = kin.ik(kin.fk(q_far), restarts=2, max_iter=1)  # one iteration per attempt cannot get there
    assert not res.success
    assert res.attempts == 3
    assert np.all(np.isfinite(res.q)) and np.all((kin.lower <= res.q) & (res.q <= kin.upper))
    assert 'did not converge' in res.message


def test_ik_rejects_bad_input(kin: MicoKinematics) -> None:
    good = kin.fk(HOME_Q)
    skewed = good.copy()
    skewed[:3, :3] *= 1.1
    bottom = good.copy()
    bottom[3, 0] = 1.0
    for target in (np.eye(3), np.full((4, 4), np.nan), skewed, bottom):
        with pytest.raises(KinematicsError):
            kin.ik(target)
    with pytest.raises(KinematicsError):
        kin.ik(good, np.zeros(5))
    with pytest.raises(KinematicsError):
        kin.ik(good, restarts=-1)
    with pytest.raises(KinematicsError):
        kin.ik(good, pos_tol=0.0)


def test_features_to_base_pose_and_ik(kin: MicoKinematics) -> None:
    """The planner's path: features in the object frame -> base_T_ee -> joint angles."""
    base_T_obj = pose_to_matrix((0.35, -0.25, 0.0), (0.0, 0.0, math.sin(0.3), math.cos(0.3)))
    x = np.array([0.0, 0.0, 0.12, 0.0, 0.0, -1.0, 0.2, 0.5, 0.5, 0.5])
    base_T_ee = base_T_obj @ features_to_obj_T_ee(x)
    res = kin.ik(base_T_ee)
    assert res.success, res.message
    assert_allclose(kin.fk(res.q)[:3, 2], base_T_obj[:3, :3] @ x[APPROACH], atol=1e-3)


def test_ik_restarts_from_restart_seed(kin: MicoKinematics) -> None:
    # a target the seed's own descent misses and the restart seed's finds: the first restart is that descent
    rng = np.random.default_rng(4)
    for _ in range(200):
        target, q_seed = kin.fk(random_q(kin, rng)), random_q(kin, rng)
        by_hand = kin.ik(target, kin.restart_seed(q_seed, np.random.default_rng(9)), restarts=0)
        if not kin.ik(target, q_seed, restarts=0).success and by_hand.success:
            break
    else:
        pytest.fail('no target that the seed misses and the restart seed finds')
    restarted = kin.ik(target, q_seed, restarts=1, rng=np.random.default_rng(9))
    assert restarted.success and restarted.attempts == 2
    assert_allclose(restarted.q, kin.nearest_branch(by_hand.q, q_seed), rtol=0, atol=1e-12)
