"""grasp_intent_ros.ros.compat: the rclpy its workarounds were checked against."""

from __future__ import annotations

from grasp_intent_ros.ros.compat import CHECKED_RCLPY, rclpy_version


def test_rclpy_is_the_one_the_workarounds_were_checked_against() -> None:
    """Another rclpy may fix what a workaround works around, or break it: each must be checked again."""
    installed = rclpy_version()
    assert installed == CHECKED_RCLPY, (
        f'rclpy {installed} is installed, but ros/compat.py was checked against rclpy {CHECKED_RCLPY}: re-check '
        'each workaround listed in its docstring against this rclpy, then set CHECKED_RCLPY')
