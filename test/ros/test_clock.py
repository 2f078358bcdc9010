"""grasp_intent_ros.ros.clock: a node's clock in float seconds."""

from __future__ import annotations

import rclpy
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from grasp_intent_ros.ros.clock import now_seconds
from grasp_intent_ros.ros.qos import output_qos


def test_now_seconds_reads_the_nodes_own_clock_under_sim_time(ros) -> None:  # type: ignore[no-untyped-def]
    node = ros.add(rclpy.create_node('clock_reader', context=ros.context,
                                     parameter_overrides=[Parameter('use_sim_time', value=True)]))
    clock = ros.publisher(Clock, '/clock', output_qos())
    msg = Clock()
    msg.clock.sec, msg.clock.nanosec = 1_764_500_000, 250_000_000
    assert ros.publish_until(clock, msg, lambda: now_seconds(node) != 0.0), 'the simulated clock never arrived'
    assert now_seconds(node) == 1_764_500_000_250_000_000 * 1e-9
