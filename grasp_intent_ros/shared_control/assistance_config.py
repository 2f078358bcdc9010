"""The assistance's settings, ROS-free: one frozen record the assistance node's parameters fill (:mod:`.parameters`)."""

from __future__ import annotations

from dataclasses import dataclass

from ..mico.frames import PRE_GRASP_STANDOFF
from .arbitration import Arbitration

__all__ = ['AssistanceConfig']


@dataclass(frozen=True)
class AssistanceConfig:
    """The assistance's settings (the node's parameters of the same names; units m, rad, s).

    Attributes
    ----------
    arbitration : 'confidence', 'blend' or 'none'
        The rule (:mod:`.arbitration`).
    alpha_max, margin
        Of :func:`~.arbitration.arbitration`.
    standoff, corridor_radius, corridor_angle
        Of :func:`~.robot_twist.assistance_target`.
    gain_linear, gain_angular, robot_max_linear, robot_max_angular, gain_joint
        Of :func:`~.robot_twist.robot_twist` (1/s, 1/s, m/s, rad/s; the limits bound
        :func:`~.robot_twist.joint_space_twist` too), its gain (1/s).
    deadband_linear, deadband_angular : float
        Operator speeds (m/s, rad/s) up to which a part is no input: no evidence for
        :func:`~.arbitration.operator_agreement`, and no input at all when both parts are within them.
    yield_time : float
        Seconds of sustained opposition after which the robot yields, and of heading toward the grasp
        after which it assists again ('confidence'; :mod:`.assistance`, "The operator wins").
    assist_without_input : bool
        Whether the robot's twist moves the hand while the operator gives no input (default False).
    keep_pace : bool
        Whether the robot's twist is raised to the operator's speed along the operator's direction in each part
        the operator moves, before blending (:func:`~.robot_twist.keep_pace`; :mod:`.robot_twist`). Default False:
        the blend as is.
    robot_agreement : bool
        Whether alpha is also multiplied by the operator's agreement with the robot's own twist (the one blended,
        after ``keep_pace``) (:func:`~.arbitration.robot_agreement`; :mod:`.arbitration`). Default False: alpha
        as is.
    assist_idle_part : bool
        Whether the robot's share in a part (linear, angular) the operator leaves within its deadband while moving
        the other is ``alpha_max`` rather than alpha, when alpha > 0 (:func:`~.arbitration.part_shares`;
        :mod:`.arbitration`). Default True (``False``: alpha in both parts).
    keep_joint_line : bool
        Whether the joint-space robot twist is scaled into ``robot_max_linear`` and ``robot_max_angular`` by one
        factor, so that its joint image stays on the straight joint line to the path's point
        (:func:`~.robot_twist.joint_space_twist`'s ``whole``; :mod:`.robot_twist`). Default False: each part
        scaled to its own limit.
    operator_timeout : float
        An operator twist older than this gives the zero twist.
    clearance_margin : float
        m: :class:`~.clearance.PathClearance`'s ``margin`` (beyond the planner's limits).
    """

    arbitration: Arbitration = 'confidence'
    alpha_max: float = 0.9
    margin: float = 0.2
    standoff: float = PRE_GRASP_STANDOFF
    corridor_radius: float = 0.02
    corridor_angle: float = 0.2
    gain_linear: float = 2.0
    gain_angular: float = 2.0
    robot_max_linear: float = 0.15
    robot_max_angular: float = 0.8
    gain_joint: float = 2.0
    deadband_linear: float = 0.01
    deadband_angular: float = 0.05
    yield_time: float = 0.15
    assist_without_input: bool = False
    keep_pace: bool = False
    robot_agreement: bool = False
    assist_idle_part: bool = True
    keep_joint_line: bool = False
    operator_timeout: float = 0.1
    clearance_margin: float = 0.0
