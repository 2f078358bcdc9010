"""The Kinova MICO (3 fingers): frames, kinematics, the hand's collisions, a grasp it takes, a mock arm.

ROS-free. Modules
-----------------
frames
    Grasp features <-> the end-effector pose in the object frame; poses as 4x4 transforms.
kinematics
    The arm's model (pinocchio, the URDF in config/): forward kinematics, the Jacobian, joint limits and branches.
ik
    Inverse kinematics: joint angles that put the hand at a pose (seeded, random restarts).
reachability
    The planner's robot constraint: a grasp is reachable when IK of its pose converges; the answers kept.
parameters (ROS-free tables)
    The grasp planner node's and the mock arm node's parameter tables; the object pose and the URDF they share.
collision
    The hand (the URDF's collision primitives, coal) against the table and the object: on the approach with the
    fingers open, and closing until contact.
grasp_clearance
    What that check reports for one grasp (the table, the depths, where the fingers stop) and its verdict.
limits
    How deep the hand may go in before a grasp counts as in collision (the collision check's thresholds), and a
    margin for the error of the object's pose.
grasp
    The planner node's policy: plan, then a grasp the arm reaches (joint targets, move time).
trajectory
    A joint trajectory by the joint_trajectory_controller's rules: checked, then sampled as its splines.
mock_arm
    A simulated arm for the closed loop without hardware: trajectories, twists, differential IK, joint limits.
reach
    A grasp the arm reaches from home: IK, the approach corridor, a Cartesian servo of the mock arm.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.resources`,
:mod:`~grasp_intent_ros.method`, :mod:`~grasp_intent_ros.planning` and :mod:`~grasp_intent_ros.kernels`.
"""
