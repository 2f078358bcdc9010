"""The robot's twist toward the planned grasp, ROS-free: Cartesian or in joint space, and raised to the operator's pace.

Twists are 6-vectors (linear m/s, angular rad/s) of the end effector (EE) in the base frame; the linear part is the
velocity of the EE origin. :class:`~.assistance.Assistance` composes these with the arbitration (:mod:`.arbitration`)
into the command.

The robot's twist
-----------------
Toward the pre-grasp (the grasp pose moved back by ``standoff`` along its approach axis, the EE z axis)
until the hand is in the approach corridor, then toward the grasp (:func:`assistance_target`): the hand
is in the corridor when it is within ``corridor_radius`` of the grasp, or behind it (along the approach
axis) within ``corridor_radius`` of that axis and within ``corridor_angle`` of the grasp's orientation.
With the arm's kinematics (:class:`~.assistance.Assistance` given a
:class:`~grasp_intent_ros.mico.kinematics.MicoKinematics`), the twist is the end effector's motion while the joints
move straight toward the target's inverse kinematics q_t (solved from the current joints q without random restarts,
its wrist on the 2 pi branch that turns the hand the short way, :func:`~.joint_path.line_turns`, once per target and
planned grasp), ``J(q) k_q (q_t - q)`` (:func:`joint_space_twist`). When the target has no IK solution from q (the
descent from q stops at a joint limit or in the wrist's singularity), q_t is an IK solution from other seeds whose
straight joint line from q keeps the hand near the grasp and the wrist on its side, or, when no straight line does,
whose two lines through one via point do: the joints aim at the via point until within
:data:`~.joint_path.VIA_REACHED` of it, then at q_t (:func:`~.joint_path.joint_path`; "near": within the hand's
distance to the grasp when the first path to this proposal was sought, or its present distance if larger, plus
``corridor_radius``). A path whose open hand goes into the object as perceived
(:meth:`~.assistance.Assistance.set_object`) is replaced by a clear one (:func:`~.clearance.clear_path`). Without
the kinematics, or when there is no such path either, it is proportional to the pose error, ``(k_lin (p_t - p),
k_ang log3(R_t R^T))`` (the rotation vector in the base frame, :func:`robot_twist`). Either way each part is scaled
down to its speed limit; with ``keep_joint_line`` (off by default) the joint-space twist is scaled by one factor
instead, so that it stays the image of a motion along the straight joint line (:func:`joint_space_twist`'s
``whole``). Why joint space: the Cartesian twist turns the hand along the straight rotation to the
target, which for many of the MICO's grasps runs the wrist (joint 5) through 0 or pi, a singularity; there a servo's
damped least squares cannot make the motion asked for and the arm settles in the singular configuration, short of
the grasp. The joint-space twist lies in the range of J, so the servo can follow it, and following it the joints go
straight to q_t. Its price: the hand's path curves and the hand turns on the way (the image of a straight
joint-space line); near the target it agrees with the Cartesian error to first order.

**Keeping the operator's pace** (``keep_pace``, off by default; :func:`keep_pace`). The robot's twist follows a
straight line in joint space, so its linear part can point well away from the approach target's Cartesian error
(against which the agreement is measured) while the operator heads straight at it: a two-mode operator's
translation then meets a robot's twist that runs against it, and at alpha about 0.4 the two cancel
(docs/shared_control.md, "Keeping the operator's pace"). With ``keep_pace``, before blending, the robot's twist
is raised in each part the operator moves (faster than its deadband) to at least the operator's speed along
the operator's direction of that part: the blend then never slows the operator's own motion, and the robot adds
what lies across it (its turn of the hand, its correction sideways). The other remedy for the same cancellation
is :func:`~.arbitration.robot_agreement`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..mico.frames import pose_error, pre_grasp
from .approach import in_corridor
from .limits import clip_norm, norm

__all__ = ['assistance_target', 'robot_twist', 'joint_space_twist', 'keep_pace']


def assistance_target(base_T_ee: NDArray[np.float64], base_T_grasp: NDArray[np.float64], *, standoff: float,
                      corridor_radius: float, corridor_angle: float) -> tuple[NDArray[np.float64], str]:
    """The pose the robot's twist aims at, and its name: ``'grasp'`` in the approach corridor, else ``'pre-grasp'``.

    The corridor is :func:`~.approach.in_corridor`'s.
    """
    if in_corridor(base_T_ee, base_T_grasp[None, :3, 3], base_T_grasp[None, :3, :3], corridor_radius=corridor_radius,
                   corridor_angle=corridor_angle)[0]:
        return base_T_grasp, 'grasp'
    return pre_grasp(base_T_grasp, standoff), 'pre-grasp'


def robot_twist(base_T_ee: NDArray[np.float64], base_T_target: NDArray[np.float64], *, gain_linear: float,
                gain_angular: float, max_linear: float, max_angular: float) -> NDArray[np.float64]:
    """The proportional twist toward ``base_T_target``, each part within its speed limit; shape (6,)."""
    error = pose_error(base_T_ee, base_T_target)
    return np.concatenate([clip_norm(gain_linear * error[:3], max_linear),
                           clip_norm(gain_angular * error[3:], max_angular)])


def joint_space_twist(jacobian: NDArray[np.float64], q: NDArray[np.float64], q_target: NDArray[np.float64], *,
                      gain: float, max_linear: float, max_angular: float,
                      whole: bool = False) -> NDArray[np.float64]:
    """The EE twist ``J(q) gain (q_target - q)`` within the speed limits; shape (6,).

    Each part scaled down to its own limit (default), or, with ``whole``, the twist scaled by one factor, the largest
    in (0, 1] that brings both parts within their limits (``keep_joint_line``: its joint image then stays on the
    straight joint line to ``q_target``, which separate factors turn off it).

    Parameters
    ----------
    jacobian : ndarray, shape (6, 6)
        The geometric Jacobian at ``q`` (:meth:`~grasp_intent_ros.mico.kinematics.MicoKinematics.jacobian`:
        linear rows m/rad, angular rows rad/rad, base frame).
    q, q_target : ndarray, shape (6,)
        Joint angles now and at the target (rad), ``q_target`` on the 2 pi branch the joints are to turn to.
    gain : float
        1/s.
    max_linear, max_angular : float
        m/s, rad/s.
    """
    twist = jacobian @ (gain * (q_target - q))
    if whole:
        linear, angular = norm(twist[:3]), norm(twist[3:])
        scale = min(1.0, max_linear / linear if linear > max_linear else 1.0,
                    max_angular / angular if angular > max_angular else 1.0)
        return scale * twist
    return np.concatenate([clip_norm(twist[:3], max_linear), clip_norm(twist[3:], max_angular)])


def keep_pace(robot: NDArray[np.float64], operator: NDArray[np.float64], *, deadband_linear: float,
              deadband_angular: float) -> NDArray[np.float64]:
    """``robot`` (shape (6,)) at least as fast as ``operator`` along the operator's direction, per part.

    For each part (linear, angular) the operator moves faster than its deadband (m/s, rad/s), with e the unit
    vector of the operator's part h: the part of ``robot`` nearest it (Euclidean) whose component along e is at
    least |h|, i.e. ``r + max(0, |h| - r . e) e`` (the projection onto that half-space: unique); its part across
    e is kept. The other parts are ``robot``'s. So ``alpha r' + (1 - alpha) h`` has at least h's speed along h.
    Not clipped to the robot's speed limits (the output's limits follow the blend).
    """
    out = np.array(robot, dtype=np.float64)
    for part, deadband in ((slice(0, 3), deadband_linear), (slice(3, 6), deadband_angular)):
        speed = norm(operator[part])
        if speed <= deadband:
            continue
        unit = operator[part] / speed
        out[part] += max(0.0, speed - float(out[part] @ unit)) * unit
    return out
