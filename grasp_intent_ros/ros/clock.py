"""A node's clock read as the core takes time: float seconds.

The core (assistance, the intent estimator, the mock arm) takes times as float seconds; the nodes read them from
their own clock, ROS time: the system clock, or the ``/clock`` topic under the ``use_sim_time`` parameter.
Message stamps are read by :mod:`grasp_intent_ros.wire.robot_state` (ROS-free).
"""

from __future__ import annotations

from rclpy.node import Node

__all__ = ['now_seconds']


def now_seconds(node: Node) -> float:
    """``node``'s clock now (ROS time), in seconds: its integer nanoseconds times 1e-9."""
    return float(node.get_clock().now().nanoseconds * 1e-9)
