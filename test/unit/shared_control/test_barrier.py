"""The command's clearance filter: a hand driven at a cylinder as perceived, toward it, along it and away."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from grasp_intent_ros.method.body import Cylinder, ObjectBody
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.barrier import RATE, WEIGHTS, clearance_filter, intrusion_gradient
from grasp_intent_ros.shared_control.clearance import PathClearance, default_hand
from grasp_intent_ros.shared_control.limits import TwistLimiter

CUP = ObjectBody((Cylinder(np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]), 0.04, 0.1),))
"""A cup-sized cylinder standing on the object frame's z = 0."""
PERIOD = 0.01
"""s: the output's period (100 Hz)."""


def _ahead(kin: MicoKinematics, distance: float = 0.15) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                                 PathClearance]:
    """The hand at Home, its approach axis (EE z, base frame) and CUP ``distance`` m ahead of it along that axis."""
    base_T_ee = kin.fk(np.asarray(HOME_Q, dtype=np.float64))
    axis = base_T_ee[:3, 2].copy()
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = base_T_ee[:3, 3] + distance * axis - (0.0, 0.0, 0.05)
    return base_T_ee, axis, PathClearance(kin, default_hand(), CUP, base_T_obj)


def _moved(base_T_ee: NDArray[np.float64], twist: NDArray[np.float64]) -> NDArray[np.float64]:
    """The end effector after one period under ``twist`` (EE origin's velocity, angular velocity; base frame)."""
    out = base_T_ee.copy()
    out[:3, 3] += twist[:3] * PERIOD
    out[:3, :3] = Rotation.from_rotvec(twist[3:] * PERIOD).as_matrix() @ base_T_ee[:3, :3]
    return out


def _drive(clearance: PathClearance, base_T_ee: NDArray[np.float64], twist: NDArray[np.float64], *,
           filtered: bool, seconds: float = 3.0) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Hold ``twist`` for ``seconds`` (filtered or not): the deepest intrusion, the last output and the last pose."""
    deepest, out = clearance.intrusion_at(base_T_ee), twist
    for _ in range(int(round(seconds / PERIOD))):
        out = clearance_filter(clearance, base_T_ee, twist) if filtered else twist
        base_T_ee = _moved(base_T_ee, out)
        deepest = max(deepest, clearance.intrusion_at(base_T_ee))
    return deepest, out, base_T_ee


@pytest.mark.parametrize('turn', [0.0, 0.5])
def test_a_hand_heading_into_a_cylinder_stops_at_the_limits(kin: MicoKinematics, turn: float) -> None:
    base_T_ee, axis, clearance = _ahead(kin)
    into = np.r_[0.1 * axis, 0.0, 0.0, turn]  # 10 cm/s at the cup, 30 cm away in 3 s; turning about z or not
    assert _drive(clearance, base_T_ee, into, filtered=False)[0] > 0.03  # unfiltered, the hand goes deep in
    deepest, _, end = _drive(clearance, base_T_ee, into, filtered=True)
    # the barrier's rate keeps it out to first order; what one step's linearisation misses, below 1 mm
    assert deepest <= 1e-3
    depth, out = clearance.intrusion_at(end), clearance_filter(clearance, end, into)
    rate = float(intrusion_gradient(clearance, end, depth) @ out)
    assert rate <= RATE * max(-depth, 0.0) + 1e-12  # the output closes in no faster than the barrier allows
    if turn == 0.0:  # (turning, the hand slides past the cup after a while)
        assert float(out[:3] @ axis) < 0.01  # slowed from 0.1 m/s to (nearly) a stop along the approach


def test_motion_away_or_far_from_the_object_is_unchanged(kin: MicoKinematics) -> None:
    base_T_ee, axis, clearance = _ahead(kin)
    away = np.r_[-0.1 * axis, 0.2, -0.1, 0.3]
    out = clearance_filter(clearance, base_T_ee, away)
    assert np.array_equal(out, away) and out is not away
    near = _drive(clearance, base_T_ee, np.r_[0.1 * axis, 0.0, 0.0, 0.0], filtered=True)[2]  # at the limits
    assert clearance.intrusion_at(near) > -2e-3
    assert np.array_equal(clearance_filter(clearance, near, away), away)


def test_the_command_is_the_nearest_twist_that_meets_the_barrier(kin: MicoKinematics) -> None:
    base_T_ee, axis, clearance = _ahead(kin)
    near = _drive(clearance, base_T_ee, np.r_[0.1 * axis, 0.0, 0.0, 0.0], filtered=True, seconds=1.0)[2]
    blended = np.r_[0.15 * axis, 0.1, 0.0, -0.2]
    out = clearance_filter(clearance, near, blended)
    depth = clearance.intrusion_at(near)
    c = intrusion_gradient(clearance, near, depth)
    bound = RATE * max(-depth, 0.0)
    assert float(c @ blended) > bound  # the blend would close in too fast
    # KKT of min |W (u - u_b)|^2 s.t. c.u <= bound: active constraint, u_b - u = lambda W^-2 c with lambda > 0
    assert float(c @ out) == pytest.approx(bound, abs=1e-12)
    step = (blended - out) * WEIGHTS**2
    lam = float(step @ c) / float(c @ c)
    assert lam > 0.0
    np.testing.assert_allclose(step, lam * c, atol=1e-12)


def test_a_hand_past_the_limits_is_neither_pushed_out_nor_let_deeper(kin: MicoKinematics) -> None:
    base_T_ee, axis, clearance = _ahead(kin)
    inside = base_T_ee.copy()
    inside[:3, 3] += 0.12 * axis  # the fingers in the cup
    depth = clearance.intrusion_at(inside)
    assert depth > 0.0
    assert np.array_equal(clearance_filter(clearance, inside, np.zeros(6)), np.zeros(6))
    out = clearance_filter(clearance, inside, np.r_[0.1 * axis, 0.0, 0.0, 0.0])
    assert float(intrusion_gradient(clearance, inside, depth) @ out) <= 1e-12


def _assistance(kin: MicoKinematics, arbitration: str) -> tuple[Assistance, NDArray[np.float64]]:
    """An assistance at Home, CUP ahead (perceived), the hand at most 1 mm short of the limits; a twist into CUP.

    No grasp: alpha is 0.
    """
    near, far = 0.0, 0.15  # CUP's distance: the hand in at ``near``, more than 0.5 mm clear at ``far``
    while far - near > 1e-4:  # bisection to 0.1 mm
        middle = 0.5 * (near + far)
        base_T_ee, _, clearance = _ahead(kin, middle)
        near, far = (near, middle) if clearance.intrusion_at(base_T_ee) < -5e-4 else (middle, far)
    _, axis, clearance = _ahead(kin, far)
    limiter = TwistLimiter(1.0, 2.0, 1e6, 1e6)  # no acceleration limit in the way
    assistance = Assistance(AssistanceConfig(arbitration=arbitration), limiter, kin)  # type: ignore[arg-type]
    assistance.set_joints(np.asarray(HOME_Q, dtype=np.float64))
    assistance.set_object(np.linalg.inv(clearance.obj_T_base), CUP)
    return assistance, np.r_[0.1 * axis, 0.0, 0.0, 0.0]


def test_the_assistance_filters_its_output_but_not_when_off_or_direct(kin: MicoKinematics) -> None:
    assistance, into = _assistance(kin, 'confidence')
    assert assistance.clearance is not None and assistance.base_T_ee is not None
    assert -1e-3 < assistance.clearance.intrusion_at(assistance.base_T_ee) < 0.0  # just short of the limits
    assistance.set_operator(into, 0.0)
    command = assistance.command(0.0)
    assert command.alpha == 0.0 and command.phase == 'no grasp'
    depth = assistance.clearance.intrusion_at(assistance.base_T_ee)  # filtered though not assisting
    c = intrusion_gradient(assistance.clearance, assistance.base_T_ee, depth)
    assert float(c @ into) > RATE * -depth and float(c @ command.twist) <= RATE * -depth + 1e-12
    assert np.array_equal(assistance.limiter.last, command.twist)  # the limiter goes on from what was sent
    assistance.enabled = False
    assistance.set_operator(into, 0.01)
    assert np.array_equal(assistance.command(0.01).twist, into)  # off: the operator's twist exactly
    direct, into = _assistance(kin, 'none')
    direct.set_operator(into, 0.0)
    assert np.array_equal(direct.command(0.0).twist, into)  # direct teleoperation: unfiltered


def test_the_paths_margin_is_left_out_so_the_hand_still_reaches_the_limits(kin: MicoKinematics) -> None:
    base_T_ee, axis, clearance = _ahead(kin)
    into = np.r_[0.1 * axis, 0.0, 0.0, 0.0]
    near = _drive(clearance, base_T_ee, into, filtered=True, seconds=1.0)[2]
    assert -0.02 < clearance.intrusion_at(near) < 0.0  # within 2 cm of the limits: within the margin below
    wide = PathClearance(kin, default_hand(), CUP, np.linalg.inv(clearance.obj_T_base), margin=0.02)
    np.testing.assert_allclose(clearance_filter(wide, near, into), clearance_filter(clearance, near, into),
                               atol=1e-9)
