"""The demo's check that its domain is free: which nodes count as another chain on it."""

from __future__ import annotations

from grasp_intent_ros.launch.demo import other_nodes


def test_a_domain_with_another_chain_is_in_use() -> None:
    seen = [('model_server', '/'), ('grasp_planner', '/robot1'), ('grasp_intent_demo_sender', '/')]
    assert other_nodes(seen, {'grasp_intent_demo_sender'}) == ['/model_server', '/robot1/grasp_planner']


def test_the_ros2_clis_daemon_and_other_hidden_nodes_leave_the_domain_free() -> None:
    # the daemon a `ros2 topic echo` started stays up after it: a second demo run on that domain must still start
    seen = [('_ros2cli_daemon_95_0a1b2c3d4e5f', '/'), ('_ros2cli_12345', '/'), ('grasp_intent_demo_observer', '/')]
    assert other_nodes(seen, {'grasp_intent_demo_observer'}) == []
