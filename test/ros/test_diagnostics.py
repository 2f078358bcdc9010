"""grasp_intent_ros.ros.diagnostics: one component's status on /diagnostics, and callbacks that never raise."""

from __future__ import annotations

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus

from grasp_intent_ros import protocol
from grasp_intent_ros.core.errors import InvalidIntentError
from grasp_intent_ros.ros.diagnostics import MAX_TEXT, NodeDiagnostics, cap_text


def test_guard_turns_exceptions_into_rejections_and_counts(ros) -> None:
    probe = ros.add(rclpy.create_node('diag_probe', context=ros.context))
    statuses = ros.diagnostics()
    diag = NodeDiagnostics(probe, 'intent', period=0.2)
    seen: list[int] = []

    def callback(value: int) -> None:
        if value < 0:
            raise InvalidIntentError(f'w must be >= 0, got {value}')
        if value == 0:
            raise ZeroDivisionError('a bug')
        seen.append(value)

    guarded = diag.guard(callback)
    guarded(1)
    guarded(-1)
    status = diag.status()
    assert status.name == protocol.status_name('/diag_probe', 'intent')
    assert protocol.level_value(status.level) == protocol.WARN
    assert status.message == 'rejected input: w must be >= 0, got -1'
    values = protocol.status_values(status)
    assert (values[protocol.KEY_RECEIVED], values[protocol.KEY_REJECTED]) == ('2', '1')
    assert values[protocol.KEY_LAST_ERROR] == 'w must be >= 0, got -1'
    guarded(0)  # does not raise
    assert protocol.level_value(diag.status().level) == protocol.ERROR
    assert 'ZeroDivisionError: a bug' in diag.status().message
    guarded(2)
    assert (protocol.level_value(diag.status().level), diag.status().message) == (protocol.OK, 'ok')
    assert seen == [1, 2]
    assert ros.wait_for(lambda: any(s.level == DiagnosticStatus.ERROR and s.name.endswith(': intent')
                                    for s in statuses)), 'a rejection is published at once'


def test_state_and_values_join_the_status(ros) -> None:
    probe = ros.add(rclpy.create_node('diag_probe', context=ros.context))
    diag = NodeDiagnostics(probe, 'planning')
    diag.set_state(protocol.OK, 'waiting for model/active')
    diag.set_values({'plans': 2, protocol.KEY_MODEL: 'cup_7zone'})
    status = diag.status()
    assert status.message == 'waiting for input; waiting for model/active'
    assert protocol.status_values(status)['plans'] == '2'
    diag.set_state(protocol.ERROR, 'no model')
    assert (protocol.level_value(diag.status().level), diag.status().message) == (protocol.ERROR, 'no model')


def test_texts_are_capped(ros) -> None:
    assert cap_text('short') == 'short'
    long = 'a' * 400_000 + 'END'
    capped = cap_text(long)
    assert len(capped) <= MAX_TEXT and capped.startswith('aaa') and capped.endswith('END')
    assert '400003 characters in all' in capped
    probe = ros.add(rclpy.create_node('diag_cap_probe', context=ros.context))
    diag = NodeDiagnostics(probe, 'inputs')

    def echo(names: list[str]) -> None:  # a reason that quotes a 500 kB input
        raise InvalidIntentError(f'bad names: {names}')

    diag.guard(echo)(['x' * 5000] * 100)
    diag.set_value('model', long)
    status = diag.status()
    values = protocol.status_values(status)
    assert len(status.message) <= MAX_TEXT + len('rejected input: ')
    assert len(values[protocol.KEY_LAST_ERROR]) <= MAX_TEXT and len(values['model']) <= MAX_TEXT
    assert values[protocol.KEY_REJECTED] == '1'
