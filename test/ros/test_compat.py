"""The rclpy workarounds (grasp_intent_ros.ros.compat) are re-checked whenever rclpy changes."""

from __future__ import annotations

from grasp_intent_ros.ros.compat import CHECKED_RCLPY, rclpy_version


def test_rclpy_is_the_release_the_workarounds_were_checked_against() -> None:
    assert rclpy_version() == CHECKED_RCLPY, (
        f'rclpy {rclpy_version()} is installed; ros/compat.py was checked against {CHECKED_RCLPY}: re-check each '
        'of its items against the new release, drop what it fixed, then update CHECKED_RCLPY')
