"""The MICO's reach of a grasp from home: IK, the approach corridor, and a Cartesian servo that gets there.

:func:`servo_reaches` drives a :class:`~.mock_arm.MockArm` by a proportional Cartesian servo (the twist of a
person or an assistance heading straight for a pose) and says whether it brings the hand to its goals in time.
:class:`ArmReach` is what a grasp at an object's pose needs from the arm at home: IK converges (the planner's
reachability), the approach corridor is followed (:class:`~.grasp.ApproachReach`), and the servo from home
reaches the pre-grasp and then the grasp, and the grasp straight. The servo is the continuity criterion: IK
alone may answer on another branch of the arm (the wrist's q5 of the other sign, past the singularity q5 = 0)
that a servo from home would have to cross the singularity or a joint limit to reach, and stalls before.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..method.features import FINGERS, MICO_3F
from .frames import PRE_GRASP_STANDOFF, REACH_POS, REACH_ROT, pose_error, pre_grasp
from .grasp import ApproachReach
from .kinematics import BASE_FRAME, MicoKinematics
from .mock_arm import MockArm, TwistCommand
from .reachability import Reachability

__all__ = ['SERVO_GAIN', 'SERVO_MAX_LINEAR', 'SERVO_MAX_ANGULAR', 'SERVO_PERIOD', 'SERVO_TIMEOUT', 'servo_reaches',
           'ArmReach']


SERVO_GAIN = 1.5
"""Gain (1/s) of :func:`servo_reaches`: the twist is this times the pose error."""
SERVO_MAX_LINEAR = 0.12
"""Speed cap (m/s) of :func:`servo_reaches` (a scripted joystick operator's)."""
SERVO_MAX_ANGULAR = 0.6
"""Turn rate cap (rad/s) of :func:`servo_reaches`."""
SERVO_PERIOD = 0.05
"""Step (s) of :func:`servo_reaches`."""
SERVO_TIMEOUT = 25.0
"""Time (s) :func:`servo_reaches` allows for all its goals: a closed-loop benchmark episode's."""


def servo_reaches(kin: MicoKinematics, q0: ArrayLike, goals: Sequence[NDArray[np.float64]], *,
                  timeout: float = SERVO_TIMEOUT) -> bool:
    """Whether a proportional Cartesian servo of a :class:`~.mock_arm.MockArm` from ``q0`` reaches ``goals`` in time.

    Each step of :data:`SERVO_PERIOD` s commands the twist ``SERVO_GAIN * pose_error(hand, goal)`` (base frame,
    :func:`~.frames.pose_error`), scaled down as a whole so that its speed is at most :data:`SERVO_MAX_LINEAR` and
    its turn rate at most :data:`SERVO_MAX_ANGULAR`; a goal is reached within :data:`~.frames.REACH_POS` and
    :data:`~.frames.REACH_ROT` (:func:`~.frames.reached`), then the next one is aimed at. A joint stops at its
    limit while the others go on (the mock arm's default ``twist_joint_limit``, ``'clip'``) and the arm is damped at
    a singularity (:meth:`~.mock_arm.MockArm.step`), so a goal behind either is not reached.

    Parameters
    ----------
    kin : MicoKinematics
    q0 : array_like, shape (6,)
        The arm's start (rad), within the limits.
    goals : sequence of ndarray, shape (4, 4)
        End-effector poses in the base frame.
    timeout : float
        Time (s) for all goals.

    Returns
    -------
    bool
        True when the hand has reached the last goal within ``timeout`` s (True for no goals). Costs one forward
        kinematics and one Jacobian (SVD) per step: at most ``timeout / SERVO_PERIOD`` steps.
    """
    arm = MockArm(kin, np.concatenate([kin.check_q(q0, 'q0'), MICO_3F.lower[FINGERS]]))
    pending = list(goals)
    now = 0.0
    while pending:
        error = pose_error(kin.fk(arm.q[:6]), pending[0])
        distance, angle = float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))
        if distance <= REACH_POS and angle <= REACH_ROT:
            pending.pop(0)
            continue
        if now >= timeout:
            return False
        scale = SERVO_GAIN / max(1.0, SERVO_GAIN * distance / SERVO_MAX_LINEAR, SERVO_GAIN * angle / SERVO_MAX_ANGULAR)
        now += SERVO_PERIOD
        arm.command_twist(TwistCommand(scale * error[:3], scale * error[3:], BASE_FRAME), now)
        arm.step(now, SERVO_PERIOD)
    return True


class ArmReach:
    """Whether the MICO at ``q_home`` takes a grasp at an object's pose, and why not.

    A grasp x (MICO 3-finger features, object frame) is taken when (1) IK of its pose converges from ``q_home``
    with the planner's random restarts (:class:`~.reachability.Reachability`), (2) its approach corridor from the
    pre-grasp (:data:`~.frames.PRE_GRASP_STANDOFF` behind it) is followed within the joint limits
    (:class:`~.grasp.ApproachReach`), and (3) the servo from ``q_home`` reaches the pre-grasp and then the grasp (the
    assistance's way in), and, started again from ``q_home``, the grasp straight (a person heading for it), each
    within :data:`SERVO_TIMEOUT` (:func:`servo_reaches`): the paths from home neither cross the wrist singularity
    nor stop at a joint limit. Checked in that order, the cheapest first: (1) and (2) cost some milliseconds, (3)
    up to ``SERVO_TIMEOUT / SERVO_PERIOD`` steps each servo, one forward kinematics and one Jacobian (SVD) a step.

    Parameters
    ----------
    kin : MicoKinematics
    base_T_obj : array_like, shape (4, 4)
        The object's pose in the base frame (e.g. :func:`~.frames.default_base_T_obj`).
    q_home : array_like, shape (6,), optional
        Where the arm starts (rad); :data:`~.kinematics.HOME_Q` if None.
    """

    def __init__(self, kin: MicoKinematics, base_T_obj: ArrayLike, q_home: ArrayLike | None = None) -> None:
        self.reach = Reachability(kin, base_T_obj, q_home)
        self.approach = ApproachReach(self.reach)
        self._faults: dict[bytes, str | None] = {}

    def fault(self, x: NDArray[np.float64]) -> str | None:
        """Why the arm does not take grasp x (the first check that fails, in words); None when it does.

        Each grasp is checked once (cached by ``x.tobytes()``).
        """
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key not in self._faults:
            self._faults[key] = self._check(x)
        return self._faults[key]

    def _check(self, x: NDArray[np.float64]) -> str | None:
        if not self.reach(x):
            answer = self.reach.answer(x)
            return (f'IK does not converge: position error {1e3 * answer.pos_error_m:.3g} mm, rotation error '
                    f'{answer.rot_error_rad:.3g} rad')
        if not self.approach(x):
            return self.approach.faults[np.asarray(x, dtype=np.float64).tobytes()]
        grasp = self.reach.target(x)
        for goals, what in (((pre_grasp(grasp, PRE_GRASP_STANDOFF), grasp), 'the pre-grasp and then the grasp'),
                            ((grasp,), 'the grasp straight')):
            if not servo_reaches(self.reach.kin, self.reach.q_seed, goals):
                return (f'a Cartesian servo from home does not reach {what} within {SERVO_TIMEOUT:g} s (the wrist '
                        f'singularity or a joint limit lies between)')
        return None
