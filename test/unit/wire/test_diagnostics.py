"""grasp_intent_ros.wire.diagnostics: levels as rclpy and rosbags give them, status names and values."""

from __future__ import annotations

from types import SimpleNamespace

from grasp_intent_ros.wire import diagnostics


def test_diagnostics_levels_and_values() -> None:
    assert [diagnostics.level_value(b) for b in (b'\x00', b'\x01', b'\x02', 3)] == [0, 1, 2, 3]
    assert diagnostics.LEVEL_NAMES[diagnostics.WARN] == 'WARN'
    status = SimpleNamespace(values=[SimpleNamespace(key=diagnostics.KEY_REJECTED, value='2')])
    assert diagnostics.status_values(status) == {'messages rejected': '2'}
    assert diagnostics.status_name('/robot1/grasp_planner', 'planning') == '/robot1/grasp_planner: planning'
