"""grasp_intent_ros.sessions.outputs: messages read into comparable values; rejections from diagnostics."""

from __future__ import annotations

import numpy as np

from grasp_intent_ros.sessions.outputs import (
    Joints,
    Pose,
    Rejection,
    RejectionTracker,
    Text,
    Trajectory,
    Undecodable,
    Vector,
)
from grasp_intent_ros.wire.model_document import ModelHeader

from ..session_bags import (
    SHA_A,
    T,
    diagnostics,
    header,
)


# ---------------------------------------------------------------- rejections
def test_rejection_tracker_reports_each_rejection_once() -> None:
    tracker = RejectionTracker()
    name = '/grasp_planner: inputs'
    assert tracker.update(diagnostics(name, received=3, rejected=0, level=0)) == []
    assert tracker.update(diagnostics(name, received=4, rejected=1, reason='v is empty')) == [
        Rejection(name, 1, 'v is empty')]
    assert tracker.update(diagnostics(name, received=4, rejected=1, reason='v is empty')) == []  # periodic repeat
    assert tracker.update(diagnostics(name, received=5, rejected=2, reason='internal', level=2)) == [
        Rejection(name, 2, 'internal')]
    foreign = T['diagnostic_msgs/msg/DiagnosticArray'](header=header(''), status=[
        T['diagnostic_msgs/msg/DiagnosticStatus'](level=1, name='other', message='x', hardware_id='', values=[])])
    assert tracker.update(foreign) == []
    assert tracker.update_cdr(b'\x00\x01\x00\x00garbage') == []




def test_reduced_values_of_every_kind_render_on_one_line() -> None:
    from grasp_intent_ros.sessions.compare import summarize

    values = [Vector(('a',), np.arange(12.0)), Text('x'), Pose('f', np.zeros(3), np.array([0, 0, 0, 1.0])),
              Joints(('j',), np.zeros(1)), Trajectory(('j',), np.zeros((1, 1)), np.zeros(1)),
              ModelHeader('m', 1, SHA_A), Rejection('n', 1, 'r'), Undecodable('bad')]
    assert all('\n' not in summarize(v) and summarize(v) for v in values)
