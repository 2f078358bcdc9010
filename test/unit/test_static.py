"""Static checks of the ROS-free layers: mypy --strict on core/ and bag/ (house style), and the core's
import boundary (it never imports rclpy)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_mypy_strict_on_core_and_bag() -> None:
    result = subprocess.run(
        [sys.executable, '-m', 'mypy', '--strict', '--follow-imports=silent',
         'grasp_intent_ros/core', 'grasp_intent_ros/bag'],
        cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_core_and_bag_do_not_import_rclpy() -> None:
    code = ('import sys, grasp_intent_ros.core as c, grasp_intent_ros.bag\n'
            'from grasp_intent_ros.core import ambiguity, data, intent, kinematics, model, planner\n'
            'assert "rclpy" not in sys.modules, "rclpy imported"\n')
    subprocess.run([sys.executable, '-c', code], cwd=REPO, check=True, timeout=120)
