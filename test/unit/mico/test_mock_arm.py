"""mico.mock_arm and mico.trajectory: trajectories by the controller's rules, twists by DLS IK, joint limits."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import CommandError, KinematicsError
from grasp_intent_ros.mico.grasp import JOINT_NAMES
from grasp_intent_ros.mico.kinematics import EE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import (
    JOINT_LIMIT_TOLERANCE,
    MockArm,
    check_twist,
    dls_joint_velocities,
    joint_limit_scale,
)
from grasp_intent_ros.mico.trajectory import TrajectoryCommand, TrajectoryExecution, check_trajectory

Q0 = np.concatenate([HOME_Q, np.zeros(3)])


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
    assert_allclose(arm.q, end, atol=1e-3)  # within 1 mrad; exact in fact after the hold
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


def test_joint_limit_scale_stops_at_the_first_limit_reached_with_its_tolerance() -> None:
    lower, upper = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    q = np.array([0.8, -0.5, 0.0])
    assert joint_limit_scale(q, np.array([0.4, -0.1, 0.3]), lower, upper) == pytest.approx(0.5, abs=1e-15)
    assert joint_limit_scale(q, np.array([0.4, -1.0, 0.3]), lower, upper) == pytest.approx(0.5, abs=1e-15)  # tie
    assert joint_limit_scale(q, np.array([0.1, -2.0, 0.3]), lower, upper) == pytest.approx(0.25, abs=1e-15)
    assert joint_limit_scale(q, np.array([-1.8, 0.5, 1.0]), lower, upper) == 1.0  # within, or onto a limit
    at = np.array([1.0, -1.0, 0.0])  # two joints exactly at a limit
    assert joint_limit_scale(at, np.array([-0.1, 0.1, 0.3]), lower, upper) == 1.0  # both inward: free
    assert joint_limit_scale(at, np.array([0.0, 0.0, 0.3]), lower, upper) == 1.0  # not moving: free
    assert joint_limit_scale(at, np.array([1e-3, 0.1, 0.3]), lower, upper) == 0.0  # one outward: halted
    assert joint_limit_scale(at, np.array([-0.1, -1e-3, 0.3]), lower, upper) == 0.0
    # no decision by a last bit: an outward step within the tolerance does not halt; beyond it, it does
    assert joint_limit_scale(at, np.array([0.5 * JOINT_LIMIT_TOLERANCE, 0.1, 0.3]), lower, upper) == 1.0
    assert joint_limit_scale(at, np.array([2.0 * JOINT_LIMIT_TOLERANCE, 0.1, 0.3]), lower, upper) == 0.0
    assert joint_limit_scale(np.nextafter(at, 0.0), np.array([1e-17, -1e-17, 0.3]), lower, upper) == 1.0


def hand_steps(kin: MicoKinematics, arm: MockArm, linear: list[float], seconds: float) -> list[np.ndarray]:
    """The hand's displacement (m, base frame) in each 0.01 s step of ``seconds`` under a live base-frame twist."""
    steps, t = [], 0.0
    while t < seconds - 1e-12:
        before = kin.fk(arm.q[:6])[:3, 3]
        t += 0.01
        arm.command_twist(check_twist(linear, [0.0] * 3, ''), now=t)
        arm.step(t, 0.01)
        steps.append(kin.fk(arm.q[:6])[:3, 3] - before)
    return steps


def test_at_a_joint_limit_the_stopping_arm_never_drifts_against_the_command(kin: MicoKinematics) -> None:
    """Down from Home with the elbow 0.01 rad above its limit: the elbow reaches it in four steps, then the arm stops.

    Clipping each joint instead lets the others carry the hand sideways and at times against the command.
    """
    q0 = Q0.copy()
    q0[2] = kin.lower[2] + 0.01
    down = np.array([0.0, 0.0, -0.05])
    stopping = MockArm(kin, q0, twist_joint_limit='stop')
    steps = hand_steps(kin, stopping, list(down), 1.0)
    moved = [d for d in steps if np.linalg.norm(d) > 0.0]
    assert 3 <= len(moved) <= 4  # 0.01 rad at the DLS answer's 0.28 rad/s of the elbow
    assert all(d @ down / (np.linalg.norm(d) * np.linalg.norm(down)) > 0.99 for d in moved)
    assert stopping.q[2] == pytest.approx(kin.lower[2], abs=1e-12)  # stopped at the limit, not short of it
    assert np.linalg.norm(sum(steps[len(moved):])) < 1e-12 and stopping.mode == 'twist' and not np.any(stopping.qd)
    clipping = MockArm(kin, q0)
    drift = hand_steps(kin, clipping, list(down), 1.0)
    assert min(float(d @ down) for d in drift) < 0.0  # today's rule: some steps go up while the command is down
    assert np.linalg.norm(sum(drift)[:2]) > 0.03  # and the hand drifts sideways by centimetres


def test_a_joint_at_its_limit_moving_inward_moves_the_stopping_arm(kin: MicoKinematics) -> None:
    q0 = Q0.copy()
    q0[2] = kin.lower[2]  # exactly at the limit
    arm = MockArm(kin, q0, twist_joint_limit='stop')
    assert np.linalg.norm(sum(hand_steps(kin, arm, [0.0, 0.0, -0.05], 0.2))) == 0.0  # outward: halted
    assert_allclose(arm.q, q0, atol=0)
    up = np.array([0.0, 0.0, 0.05])
    steps = hand_steps(kin, arm, list(up), 0.5)  # the elbow opens: the hand goes up
    assert arm.q[2] > kin.lower[2] + 0.1
    assert all(d @ up / (np.linalg.norm(d) * np.linalg.norm(up)) > 0.98 for d in steps)
    assert sum(steps) @ up / np.linalg.norm(up) > 0.02  # of 0.025 commanded: damped, the Jacobian near singular


def clip_reference(kin: MicoKinematics, q: np.ndarray, linear: list[float], dt: float) -> np.ndarray:
    """One twist step as MockArm took it before the option: each joint clipped to its limits on its own."""
    step = np.zeros(9)
    step[:6] = dls_joint_velocities(kin.jacobian(q[:6]), np.r_[linear, 0.0, 0.0, 0.0], 0.05, kin.velocity_limits,
                                    threshold=0.05) * dt
    return np.clip(q + step, np.r_[kin.lower, 0.0, 0.0, 0.0], np.r_[kin.upper, 1.51, 1.51, 1.51])


def test_the_default_clips_each_joint_bit_for_bit_and_trajectories_and_fingers_ignore_the_rule(
        kin: MicoKinematics) -> None:
    q0 = Q0.copy()
    q0[2] = kin.lower[2] + 0.01
    default, stopping = MockArm(kin, q0), MockArm(kin, q0, twist_joint_limit='stop')
    expected = q0.copy()
    for i in range(1, 101):  # into the elbow's limit and along it
        for arm in (default, stopping):
            arm.command_twist(check_twist([0.0, 0.0, -0.05], [0.0] * 3, ''), now=0.01 * i)
            arm.step(0.01 * i, 0.01)
        expected = clip_reference(kin, expected, [0.0, 0.0, -0.05], 0.01)
        assert np.array_equal(default.q, expected), f'step {i}'
    assert not np.array_equal(stopping.q, default.q)
    # a trajectory within the limits (onto the elbow's) and the fingers' close: the same under either rule
    end = q0 + np.r_[0.2, -0.1, 0.0, 0.3, -0.2, 0.1, 0.0, 0.0, 0.0]
    end[2] = kin.lower[2]
    for arm in (default, stopping):
        arm.reset(q0)
        arm.command_trajectory(command([0.5, 1.0], [(q0 + end) / 2, end], [list(0.8 * (end - q0)), [0.0] * 9]),
                               now=0.0)
        arm.close_fingers([1.0, 1.2, 0.4])
    for i in range(1, 151):
        for arm in (default, stopping):
            arm.step(0.01 * i, 0.01)
        assert np.array_equal(default.q, stopping.q), f'step {i}'
    assert_allclose(default.q, np.r_[end[:6], 1.0, 1.2, 0.4], atol=1e-12)
    with pytest.raises(ValueError, match='twist_joint_limit'):
        MockArm(kin, Q0, twist_joint_limit='halt')
