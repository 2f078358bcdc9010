"""grasp_intent_ros.ros.qos: the three profiles."""

from __future__ import annotations

from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

from grasp_intent_ros.ros.qos import DEFAULT_DEPTH, input_qos, latched_qos, output_qos


def test_input_accepts_ros2_topic_pub_and_output_offers_the_same() -> None:
    for profile in (input_qos(), output_qos()):
        assert (profile.history, profile.depth) == (HistoryPolicy.KEEP_LAST, DEFAULT_DEPTH)
        assert (profile.reliability, profile.durability) == (ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE)
        assert profile.deadline == Duration() and profile.liveliness_lease_duration == Duration()  # none
    assert input_qos(1).depth == 1 and output_qos(3).depth == 3
    assert input_qos() is not input_qos(), 'a new profile each call (profiles are mutable)'


def test_latched_is_transient_local_keep_last_one() -> None:
    profile = latched_qos()
    assert (profile.durability, profile.reliability) == (DurabilityPolicy.TRANSIENT_LOCAL, ReliabilityPolicy.RELIABLE)
    assert (profile.history, profile.depth) == (HistoryPolicy.KEEP_LAST, 1)
