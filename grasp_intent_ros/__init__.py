"""grasp_intent_ros: intent-uncertainty-aware shared-control tele-grasping for the Kinova MICO.

The method lives in :mod:`grasp_intent_ros.method` (no ROS), rosbag2 sessions in
:mod:`grasp_intent_ros.sessions.bag`, and the rclpy layer in :mod:`grasp_intent_ros.ros` and the node modules; the
browser viewer's scene in :mod:`grasp_intent_ros.scene`.
"""

__version__ = '0.1.0'
