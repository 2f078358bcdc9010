"""grasp_intent_ros.ros.diagnostics: one component's status on /diagnostics, and callbacks that never raise."""

from __future__ import annotations

import time
from types import SimpleNamespace

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus

from grasp_intent_ros.errors import InvalidIntentError
from grasp_intent_ros.ros import diagnostics
from grasp_intent_ros.ros.diagnostics import MAX_TEXT, NodeDiagnostics, cap_text
from grasp_intent_ros.wire.diagnostics import (
    ERROR,
    KEY_DROPPED,
    KEY_LAST_ERROR,
    KEY_MODEL,
    KEY_RECEIVED,
    KEY_REJECTED,
    OK,
    WARN,
    level_value,
    status_name,
    status_values,
)


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
    assert status.name == status_name('/diag_probe', 'intent')
    assert level_value(status.level) == WARN
    assert status.message == 'rejected input: w must be >= 0, got -1'
    values = status_values(status)
    assert (values[KEY_RECEIVED], values[KEY_REJECTED]) == ('2', '1')
    assert values[KEY_LAST_ERROR] == 'w must be >= 0, got -1'
    guarded(0)  # does not raise
    assert level_value(diag.status().level) == ERROR
    assert 'ZeroDivisionError: a bug' in diag.status().message
    guarded(2)
    assert (level_value(diag.status().level), diag.status().message) == (OK, 'ok')
    assert seen == [1, 2]
    assert ros.wait_for(lambda: any(s.level == DiagnosticStatus.ERROR and s.name.endswith(': intent')
                                    for s in statuses)), 'a rejection is published at once'


def test_state_and_values_join_the_status(ros) -> None:
    probe = ros.add(rclpy.create_node('diag_probe', context=ros.context))
    diag = NodeDiagnostics(probe, 'planning')
    diag.set_state(OK, 'waiting for model/active')
    diag.set_values({'plans': 2, KEY_MODEL: 'cup_7zone'})
    status = diag.status()
    assert status.message == 'waiting for input; waiting for model/active'
    assert status_values(status)['plans'] == '2'
    diag.set_state(ERROR, 'no model')
    assert (level_value(diag.status().level), diag.status().message) == (ERROR, 'no model')


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
    values = status_values(status)
    assert len(status.message) <= MAX_TEXT + len('rejected input: ')
    assert len(values[KEY_LAST_ERROR]) <= MAX_TEXT and len(values['model']) <= MAX_TEXT
    assert values[KEY_REJECTED] == '1'
def test_count_dropped_from_sequence_gaps(ros) -> None:
    probe = ros.add(rclpy.create_node('diag_probe', context=ros.context))
    diag = NodeDiagnostics(probe, 'intent')
    assert KEY_DROPPED not in status_values(diag.status()), 'no input tracked yet'
    seen: list[int] = []
    counted = diag.count_dropped(diag.guard(seen.append))
    for seq in (1, 2, 5, 6, 10):  # 3, 4 and 7..9 never taken
        counted(seq, {'publication_sequence_number': seq})
    assert seen == [1, 2, 5, 6, 10]
    assert status_values(diag.status())[KEY_DROPPED] == '5'
    counted(1, {'publication_sequence_number': 1})  # a restarted publisher starts afresh
    counted(3, {'publication_sequence_number': 3})
    counted(4, {'publication_sequence_number': None})  # a middleware without sequence numbers
    assert status_values(diag.status())[KEY_DROPPED] == '6'
    assert status_values(diag.status())[KEY_RECEIVED] == '8'


def test_dropped_messages_of_a_full_queue_are_counted(ros) -> None:
    """A subscription with keep-last 1 that is not spun while 20 messages arrive takes only the last."""
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import input_qos, output_qos
    sink = ros.add(rclpy.create_node('diag_sink', context=ros.context))
    diag = NodeDiagnostics(sink, 'intent')
    taken: list[float] = []
    sink.create_subscription(Float64MultiArray, 'drops', diag.count_dropped(diag.guard(
        lambda m: taken.append(m.data[0]))), input_qos(depth=1))
    pub = ros.publisher(Float64MultiArray, 'drops', output_qos())
    assert ros.wait_for(lambda: pub.get_subscription_count() > 0)
    pub.publish(Float64MultiArray(data=[0.0]))
    assert ros.wait_for(lambda: taken == [0.0])
    ros.executor.remove_node(sink)  # not spun: the queue keeps the newest message only
    for i in range(1, 21):
        pub.publish(Float64MultiArray(data=[float(i)]))
    ros.executor.add_node(sink)
    assert ros.wait_for(lambda: taken[-1] == 20.0)
    values = status_values(diag.status())
    assert values[KEY_DROPPED] == str(20 - (len(taken) - 1)), (taken, values)
    assert int(values[KEY_DROPPED]) >= 1


def test_rejection_log_lines_are_throttled_but_every_rejection_counts(ros, capfd, monkeypatch) -> None:
    probe = ros.add(rclpy.create_node('diag_flood', context=ros.context))
    diag = NodeDiagnostics(probe, 'intent', period=10.0)
    now = [100.0]
    monkeypatch.setattr(diagnostics, 'time', SimpleNamespace(monotonic=lambda: now[0], perf_counter=time.perf_counter))
    for i in range(5):
        diag.rejected(f'bad w {i}')
    diag.rejected('a bug', level=ERROR, detail='Traceback: here')
    now[0] += diagnostics.LOG_PERIOD
    diag.rejected('bad w 5')
    assert status_values(diag.status())[KEY_REJECTED] == '7'
    err = capfd.readouterr().err
    assert 'bad w 0' in err and 'a bug' in err and 'Traceback: here' in err
    assert not any(f'bad w {i}' in err for i in range(1, 5))
    assert 'bad w 5 (4 more since the last such line, not logged)' in err


def test_a_rejection_is_published_as_it_was_when_another_thread_processes_an_input_meanwhile(ros) -> None:
    """The status a rejection publishes at once is that rejection's, not what another thread set since.

    E.g. a model follower's thread rejects a document while the executor thread's guard finishes the
    message that handed it over (one NodeDiagnostics for both): its WARN must still go out.
    """
    probe = ros.add(rclpy.create_node('diag_probe', context=ros.context))
    statuses = ros.diagnostics()
    diag = NodeDiagnostics(probe, 'model', period=100.0)
    log_line = diag._log_line

    def processed_meanwhile(error: bool, text: str) -> str | None:  # between the rejection and its publication
        diag.processed(0.001)
        return log_line(error, text)
    diag._log_line = processed_meanwhile  # type: ignore[method-assign]
    diag.rejected('model document is oversized')
    assert level_value(diag.status().level) == OK  # the input processed since
    assert ros.wait_for(lambda: [s for s in statuses if s.level == DiagnosticStatus.WARN
                                 and s.message == 'rejected input: model document is oversized'])
