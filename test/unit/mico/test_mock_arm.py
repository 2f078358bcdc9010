"""grasp_intent_ros.mico.mock_arm: trajectories by the joint_trajectory_controller's rules, twists by DLS IK."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import CommandError, KinematicsError
from grasp_intent_ros.mico.grasp import JOINT_NAMES
from grasp_intent_ros.mico.kinematics import EE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import (
    MockArm,
    TrajectoryCommand,
    TrajectoryExecution,
    check_trajectory,
    check_twist,
    dls_joint_velocities,
)

Q0 = np.concatenate([HOME_Q, np.zeros(3)])


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def command(times, positions, velocities=None, accelerations=None, names=JOINT_NAMES, start=None):
    n = len(times)
    return TrajectoryCommand(tuple(names), np.asarray(times, dtype=float), [list(p) for p in positions],
                             [list(v) for v in (velocities or [[]] * n)],
                             [list(a) for a in (accelerations or [[]] * n)], start=start)


def run(arm: MockArm, until: float, dt: float = 0.01, start: float = 0.0) -> float:
    t = start
    while t < until - 1e-12:
        t += dt
        arm.step(t, dt)
    return t


@pytest.mark.parametrize('fields', ['positions', 'velocities', 'accelerations'])
def test_the_arm_follows_a_trajectory_to_its_end_state(kin: MicoKinematics, fields: str) -> None:
    arm = MockArm(kin, Q0)
    mid, end = Q0 + 0.1, Q0 + np.r_[0.3, -0.2, 0.25, 0.4, -0.3, 0.2, 0.8, 0.8, 0.6]
    zero = np.zeros(9)
    vel = [list(0.5 * (end - Q0) / 2.0), list(zero)] if fields != 'positions' else None
    acc = [list(zero), list(zero)] if fields == 'accelerations' else None
    arm.command_trajectory(command([1.0, 2.0], [mid, end], vel, acc), now=0.0)
    assert arm.mode == 'trajectory'
    run(arm, 3.0)
    assert_allclose(arm.q, end, atol=1e-3)  # the tolerance; exact in fact after the hold
    assert arm.mode == 'hold' and not np.any(arm.qd)


def test_the_interpolation_meets_every_point_with_its_velocity(kin: MicoKinematics) -> None:
    arm = MockArm(kin, Q0)
    points = [Q0 + 0.05, Q0 + 0.1, Q0 + 0.12]
    velocities = [np.full(9, 0.04), np.full(9, 0.02), np.zeros(9)]
    checked = check_trajectory(command([1.0, 2.0, 3.0], points, velocities), JOINT_NAMES, arm.lower, arm.upper,
                               now=10.0)
    execution = TrajectoryExecution(checked, arm.q, arm.qd)
    for t, p, v in zip((11.0, 12.0, 13.0), points, velocities):
        q, qd = execution.sample(t)
        assert_allclose(q, p, atol=1e-12)
        assert_allclose(qd, v, atol=1e-12)
    q, qd = execution.sample(10.0)  # the start: the state it arrived in
    assert_allclose(q, Q0, atol=0) and assert_allclose(qd, 0.0, atol=0)
    assert_allclose(execution.sample(99.0)[0], points[-1], atol=0)  # held after the end


def test_velocity_limits_hold_while_a_fast_trajectory_is_followed(kin: MicoKinematics) -> None:
    arm = MockArm(kin, Q0)
    end = Q0.copy()
    end[0] += 1.0  # 1 rad in 0.1 s: ten times joint 1's limit
    arm.command_trajectory(command([0.1], [end]), now=0.0)
    t, dt = 0.0, 0.01
    while arm.mode == 'trajectory' and t < 5.0:
        t += dt
        arm.step(t, dt)
        assert np.all(np.abs(arm.qd) <= arm.velocity_limits + 1e-9)
    assert_allclose(arm.q, end, atol=1e-12)
    assert t == pytest.approx(1.0 / kin.velocity_limits[0], abs=0.02)


@pytest.mark.parametrize('bad, reason', [
    (dict(names=(*JOINT_NAMES[:8], 'elbow')), 'does not have'),
    (dict(names=(*JOINT_NAMES[:8], JOINT_NAMES[0])), 'twice'),
    (dict(names=JOINT_NAMES[:6]), 'lacks the controller joints'),
    (dict(times=[1.0, 1.0]), 'strictly increasing'),
    (dict(times=[2.0, 1.0]), 'strictly increasing'),
    (dict(times=[0.0, 1.0]), 'after time 0'),
    (dict(times=[1.0, float('nan')]), 'NaN'),
    (dict(positions=[Q0, Q0[:8]]), 'point 1 has 8 positions'),
    (dict(positions=[Q0, np.r_[Q0[:8], np.nan]]), 'NaN'),
    (dict(positions=[Q0, np.r_[Q0[:8], 3.0]]), 'outside its limits'),
    (dict(velocities=[np.zeros(9), []]), 'in every point or in none'),
    (dict(velocities=[np.zeros(9), np.ones(9)]), 'zero velocities'),
    (dict(accelerations=[np.zeros(9), np.zeros(9)]), 'without velocities'),
    (dict(start=1.0), 'in the past'),
])
def test_bad_trajectories_are_rejected_with_the_reason(kin: MicoKinematics, bad: dict, reason: str) -> None:
    arm = MockArm(kin, Q0)
    fields = dict(times=[1.0, 2.0], positions=[Q0, Q0], names=JOINT_NAMES) | bad
    names = fields['names']
    k = len(names)
    positions = [np.resize(p, k) if len(p) == 9 and k != 9 else p for p in fields['positions']]
    with pytest.raises(CommandError, match=reason):
        arm.command_trajectory(command(fields['times'], positions, bad.get('velocities'), bad.get('accelerations'),
                                       names=names, start=fields.get('start')), now=100.0)
    assert arm.mode == 'hold'


def test_partial_and_empty_trajectories(kin: MicoKinematics) -> None:
    arm = MockArm(kin, Q0)
    fingers = [0.5, 0.6, 0.7]
    arm.command_trajectory(command([0.5], [fingers], names=JOINT_NAMES[6:]), now=0.0, allow_partial=True)
    run(arm, 2.0)
    assert_allclose(arm.q, np.r_[HOME_Q, fingers], atol=1e-12)
    arm.command_trajectory(command([5.0], [Q0]), now=2.0)
    run(arm, 2.5, start=2.0)
    arm.command_trajectory(command([], []), now=2.5)  # an empty trajectory stops the arm where it is
    held = arm.q.copy()
    run(arm, 3.0, start=2.5)
    assert_allclose(arm.q, held, atol=0)


def test_dls_is_the_damped_least_squares_minimiser_within_the_limits(kin: MicoKinematics) -> None:
    J = kin.jacobian(HOME_Q)
    xi = np.array([0.05, -0.02, 0.03, 0.1, 0.0, -0.1])
    sigma_min = np.linalg.svd(J)[1][-1]  # 0.064 at Home
    no_limits = np.full(6, 100.0)
    assert_allclose(J @ dls_joint_velocities(J, xi, 0.05, no_limits, threshold=0.05), xi, atol=1e-12)  # undamped
    qd = dls_joint_velocities(J, xi, 0.05, no_limits, threshold=0.1)
    lam2 = 0.05**2 * (1.0 - (sigma_min / 0.1) ** 2)
    # the normal equations of min |J qd - xi|^2 + lam^2 |qd|^2
    assert_allclose((J.T @ J + lam2 * np.eye(6)) @ qd, J.T @ xi, atol=1e-12)
    limits = np.full(6, 0.01)
    scaled = dls_joint_velocities(J, xi, 0.05, limits, threshold=0.1)
    assert np.max(np.abs(scaled) / limits) == pytest.approx(1.0, abs=1e-12)
    assert_allclose(scaled / np.linalg.norm(scaled), qd / np.linalg.norm(qd), atol=1e-12)
    singular = HOME_Q.copy()
    singular[4] = 0.0  # the wrist stretched out
    J = kin.jacobian(singular)
    assert np.all(np.isfinite(dls_joint_velocities(J, xi, 0.05, kin.velocity_limits)))


def test_twists_move_the_hand_and_stop_after_the_timeout(kin: MicoKinematics) -> None:
    arm = MockArm(kin, Q0, command_timeout=0.1)
    start = kin.fk(arm.q[:6])
    arm.command_twist(check_twist([0.0, 0.0, 0.05], [0.0, 0.0, 0.0], ''), now=0.0)
    run(arm, 0.1)
    moved = kin.fk(arm.q[:6])
    assert_allclose(moved[:3, 3] - start[:3, 3], [0.0, 0.0, 0.005], atol=3e-5)  # 10 Euler steps of 0.5 mm
    run(arm, 0.5, start=0.1)  # no new twist: stopped once the last is 0.1 s old
    assert arm.mode == 'hold' and not np.any(arm.qd)
    assert_allclose(kin.fk(arm.q[:6]), moved, atol=1e-4)
    # a twist in the EE frame: along the hand axis
    arm.command_twist(check_twist([0.0, 0.0, 0.05], [0.0, 0.0, 0.0], EE_FRAME), now=1.0)
    before = kin.fk(arm.q[:6])
    arm.step(1.01, 0.01)
    after = kin.fk(arm.q[:6])
    assert_allclose(after[:3, 3] - before[:3, 3], 0.0005 * before[:3, 2], atol=2e-5)


def test_a_twist_ends_a_trajectory_and_bad_twists_are_rejected(kin: MicoKinematics) -> None:
    arm = MockArm(kin, Q0)
    arm.command_trajectory(command([1.0], [Q0 + 0.1]), now=0.0)
    arm.command_twist(check_twist([0.0] * 3, [0.0] * 3, ''), now=0.1)
    assert arm.mode == 'twist'
    with pytest.raises(CommandError, match='no TF'):
        check_twist([0.0] * 3, [0.0] * 3, 'map')
    with pytest.raises(CommandError, match='finite'):
        check_twist([np.nan, 0.0, 0.0], [0.0] * 3, '')
    with pytest.raises(KinematicsError, match='outside the joint limits'):
        arm.reset(np.r_[HOME_Q, 0.0, 0.0, 2.0])
