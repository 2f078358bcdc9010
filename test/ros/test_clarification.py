"""grasp_intent_ros.ros.clarification: requests on intent/clarification, reported in the node's status."""

from __future__ import annotations

import rclpy
from std_msgs.msg import String

from grasp_intent_ros.ros.clarification import ClarificationRequests
from grasp_intent_ros.ros.diagnostics import NodeDiagnostics
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import WARN, level_value, status_values


def test_requests_are_published_counted_and_reported_once_per_key(ros) -> None:
    probe = ros.add(rclpy.create_node('clarify_probe', context=ros.context))
    received = ros.subscribe(String, topics.INTENT_CLARIFICATION)
    diag = NodeDiagnostics(probe, 'planning')
    requests = ClarificationRequests(probe, diag, count_key='clarifications requested',
                                     outcome_key='last plan status', level=WARN)
    assert status_values(diag.status())['clarifications requested'] == '0'
    assert ros.wait_for(lambda: probe.count_subscribers(topics.INTENT_CLARIFICATION) > 0)
    requests.request('no reachable grasp: far', once_for=(1, 'cup'))
    requests.request('no reachable grasp: still far', once_for=(1, 'cup'))  # same intent and model
    requests.request('v gives no probability', once_for=(2, 'cup'))
    assert ros.wait_for(lambda: len(received) == 2)
    assert [m.data for m in received] == ['no reachable grasp: far', 'v gives no probability']
    diag.processed(0.001)  # the note becomes the status once the input is processed
    status = diag.status()
    assert level_value(status.level) == WARN
    assert status.message == 'clarification requested: v gives no probability'
    values = status_values(status)
    assert values['clarifications requested'] == '2' and requests.count == 2
    assert values['last plan status'] == 'clarification requested: v gives no probability'
