"""grasp_intent_ros.shared_control.loop_steps: the steps both simulated loops take (here, the grasp command's rule).

The plan fed, the grasp command and the sweep's figures are exercised through the loops (test_simulator.py,
test_scene_simulator.py).
"""

from __future__ import annotations

from grasp_intent_ros.shared_control.loop_steps import executes_shown


def test_only_the_shown_grasp_is_executed_and_only_under_the_suites_assistance() -> None:
    assert executes_shown('shown', True)
    assert not executes_shown('own', True)  # the operator's own grasp: the fingers close where the hand is
    assert not executes_shown('shown', False)  # direct, ADA, or the grasp command's execute off
