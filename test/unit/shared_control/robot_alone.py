"""The robot alone under the assistance: a mock MICO driven by the assistance's twist with the operator still."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from grasp_intent_ros.mico.kinematics import BASE_FRAME, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm, TwistCommand
from grasp_intent_ros.shared_control.assistance import Assistance
from grasp_intent_ros.shared_control.joint_path import joint_path

LABELS = ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
TASKS = ('usage', 'transfer', 'handover')


def robot_alone(kin: MicoKinematics, assistance: Assistance, q0: NDArray[np.float64], zone: int,
                ticks: int) -> NDArray[np.float64]:
    """The arm's joints after ``ticks`` steps of 0.01 s from ``q0``, the operator's twist zero throughout.

    v and P are set certain of zone ``zone`` (an index of :data:`LABELS`); the assistance's grasp must be set.
    """
    arm = MockArm(kin, np.r_[q0, 0.0, 0.0, 0.0])
    certain = np.eye(len(LABELS))[zone]
    assistance.set_v(certain, LABELS)
    assistance.set_posterior(certain, LABELS, TASKS)
    for tick in range(ticks):
        now = 0.01 * tick
        assistance.set_joints(arm.q[:6].copy())
        assistance.set_operator(np.zeros(6), now)
        command = assistance.command(now)
        arm.command_twist(TwistCommand(command.twist[:3], command.twist[3:], BASE_FRAME), now)
        arm.step(now + 0.01, 0.01)
    return np.asarray(arm.q[:6], dtype=np.float64)


def assistance_joint_path(assistance: Assistance,
                          base_T_target: NDArray[np.float64]) -> list[NDArray[np.float64]] | None:
    """:func:`~grasp_intent_ros.shared_control.joint_path.joint_path` as the assistance's search asks for it now.

    With :meth:`~grasp_intent_ros.shared_control.assistance.Assistance.path_request`'s joints, target, grasp,
    slack and reference (the phase does not enter the line IK); the assistance needs its kinematics.
    """
    assert assistance.kin is not None
    r = assistance.path_request('pre-grasp', base_T_target)
    return joint_path(assistance.kin, r.q, r.base_T_target, r.base_T_grasp, slack=r.slack, reference=r.reference)
