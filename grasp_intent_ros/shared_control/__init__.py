"""Shared control: the operator's twist blended with assistance toward the planned grasp.

ROS-free. Modules
-----------------
assistance
    Arbitration (how much to help), the robot's twist toward the grasp, blending and limits.
estimator
    The intent estimator: the operator's twist -> a posterior over the model's demonstrated grasps -> w.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method`,
:mod:`~grasp_intent_ros.planning` and :mod:`~grasp_intent_ros.mico`.
"""
