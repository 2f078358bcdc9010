"""The Kinova MICO (3 fingers): its hand's frames, its kinematics, a grasp it can reach, a mock arm's dynamics.

ROS-free. Modules
-----------------
frames
    Grasp features <-> the end-effector pose in the object frame; poses as 4x4 transforms.
kinematics
    Forward and inverse kinematics (pinocchio, the URDF in config/), reachability.
grasp
    The planner node's policy: plan, then a grasp the arm reaches (joint targets, move time).
mock_arm
    A simulated arm for the closed loop without hardware: trajectories, twists, differential IK.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.resources`,
:mod:`~grasp_intent_ros.method`, :mod:`~grasp_intent_ros.planning` and :mod:`~grasp_intent_ros.kernels`.
"""
