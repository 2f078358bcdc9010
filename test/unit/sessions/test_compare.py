"""grasp_intent_ros.sessions.compare: recorded vs live answers at the replay tolerances."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from grasp_intent_ros.sessions.compare import Difference, Tolerances, answered, compare_step, diverged
from grasp_intent_ros.sessions.outputs import Output, Rejection, Undecodable, output_of
from grasp_intent_ros.sessions.pairing import Step, load_paired_session
from grasp_intent_ros.wire.topics import DIAGNOSTICS, PLAN_TOPICS

from ..session_bags import (
    ARM,
    SHA_A,
    SHA_B,
    W_OUT,
    P,
    Q,
    X,
    f64,
    features_msg,
    joint_msg,
    live_plan,
    model_doc,
    outputs,
    pose_msg,
    posterior_msg,
    rotation_z,
    text,
    trajectory_msg,
    v_msg,
)


def test_identical_answers_match(plan_step: Step) -> None:
    assert compare_step(plan_step, live_plan()) == []
    assert compare_step(plan_step, list(reversed(live_plan()))) == []  # order across topics does not matter


def test_stamps_are_not_compared(plan_step: Step) -> None:
    later = posterior_msg(P, W_OUT, stamp='stamp=99.000000001')
    assert compare_step(plan_step, live_plan(**{'grasp/posterior': later})) == []


CASES: list[tuple[str, Callable[[float], dict[str, Any]], float, str]] = [
    # (what, live message built from a perturbation, tolerance, field named in the difference)
    ('v', lambda d: {'intent/v': v_msg([P[0] + d, *P[1:]])}, 1e-9, 'v[U]'),
    ('P', lambda d: {'grasp/posterior': posterior_msg([*P[:3], P[3] + d, *P[4:]], W_OUT)}, 1e-4, 'P[UT]'),
    ('w', lambda d: {'grasp/posterior': posterior_msg(P, [W_OUT[0] + d, *W_OUT[1:]])}, 1e-4, 'w[usage]'),
    ('position', lambda d: {'grasp/pose': pose_msg((0.3, -0.25 + d, 0.1))}, 1e-3, 'position'),
    ('orientation', lambda d: {'grasp/pose': pose_msg((0.3, -0.25, 0.1), rotation_z(d))}, 0.01, 'orientation'),
    ('joints', lambda d: {'grasp/joint_targets': joint_msg([*Q[:2], Q[2] + d, *Q[3:]])}, 1e-3,
     'position[m1n6s300_joint_3]'),
    ('trajectory', lambda d: {'grasp/trajectory': trajectory_msg([*Q[:8], Q[8] + d])}, 1e-3,
     'points[0].positions[m1n6s300_joint_finger_3]'),
    ('palm feature', lambda d: {'grasp/features': features_msg([X[0] + d, *X[1:]])}, 1e-3, '[palm_x]'),
]


@pytest.mark.parametrize(('what', 'perturbed', 'tol', 'field'), CASES, ids=[c[0] for c in CASES])
def test_each_quantity_is_compared_at_its_tolerance(plan_step: Step, what: str,
                                                    perturbed: Callable[[float], dict[str, Any]],
                                                    tol: float, field: str) -> None:
    assert compare_step(plan_step, live_plan(**perturbed(0.8 * tol))) == []
    diffs = compare_step(plan_step, live_plan(**perturbed(1.5 * tol)))
    assert len(diffs) == 1 and diffs[0].field == field and diffs[0].fatal, diffs
    assert diffs[0].step == 2 and diffs[0].input == 'intent/w [0.9, 0.9, 0.1]'


def test_a_nan_never_matches(plan_step: Step) -> None:
    diffs = compare_step(plan_step, live_plan(**{'intent/v': v_msg([math.nan, *P[1:]])}))
    assert [d.field for d in diffs] == ['v[U]']


def test_names_and_frames_must_be_identical(plan_step: Step) -> None:
    other_frame = pose_msg((0.3, -0.25, 0.1), frame='world')
    assert [d.field for d in compare_step(plan_step, live_plan(**{'grasp/pose': other_frame}))] == ['frame_id']
    renamed = joint_msg(Q, names=(*ARM[:8], 'other'))
    assert [d.field for d in compare_step(plan_step, live_plan(**{'grasp/joint_targets': renamed}))] == ['name']
    relabelled = f64(P, ('U,T,H,UT,UH,TH,X', 7))
    assert [d.field for d in compare_step(plan_step, live_plan(**{'intent/v': relabelled}))] == ['layout']


def test_missing_and_extra_messages_are_differences(plan_step: Step) -> None:
    live = [o for o in live_plan() if o.topic != 'grasp/pose']
    diffs = compare_step(plan_step, live)
    assert [(d.topic, d.field, d.live) for d in diffs] == [('grasp/pose', 'message', 'nothing')]
    extra = live_plan() + outputs([('intent/clarification', text('why'))])
    diffs = compare_step(plan_step, extra)
    assert [(d.topic, d.recorded, d.live) for d in diffs] == [('intent/clarification', 'nothing', "'why'")]


def test_differences_list_the_cause_first_and_read_well(plan_step: Step) -> None:
    live = live_plan(**{'intent/v': v_msg([P[0] + 1e-3, *P[1:]]),
                        'grasp/features': features_msg([X[0] + 1.0, *X[1:]]),
                        'grasp/posterior': posterior_msg([*P[:3], P[3] + 0.1, *P[4:]], W_OUT)})
    diffs = compare_step(plan_step, live)
    assert [d.topic for d in diffs] == ['intent/v', 'grasp/posterior', 'grasp/features']
    line = str(diffs[1])
    assert line.startswith('input #2 (intent/w [0.9, 0.9, 0.1]): grasp/posterior P[UT]: recorded 0.6, live 0.7')
    assert '> 0.0001' in line


def test_clarifications_and_rejections_must_be_identical(session_bag: Path) -> None:
    steps = load_paired_session(session_bag).steps
    assert compare_step(steps[3], outputs([('intent/clarification', text('P(no task) = 0.729 >= 0.5'))])) == []
    diffs = compare_step(steps[3], outputs([('intent/clarification', text('P(no task) = 0.73 >= 0.5'))]))
    assert [d.field for d in diffs] == ['text']
    same = Output(DIAGNOSTICS, 0, Rejection('/intent_interpreter: intent', 1, 'w contains NaN'))
    assert compare_step(steps[2], [same]) == []
    other = Output(DIAGNOSTICS, 0, Rejection('/intent_interpreter: intent', 1, 'w is empty'))
    diffs = compare_step(steps[2], [other])
    assert [d.field for d in diffs] == ['rejection'] and "'w is empty'" in diffs[0].live
    # a rejection instead of a plan
    diffs = compare_step(steps[5], [other])
    assert {d.topic for d in diffs} == {*PLAN_TOPICS, DIAGNOSTICS}


def test_model_name_must_match_and_other_content_is_a_note(session_bag: Path) -> None:
    step = load_paired_session(session_bag).steps[4]
    answer = [o for o in step.expected if o.topic != 'model/active']
    assert compare_step(step, outputs([('model/active', model_doc('cup_5zone', SHA_B, 7))]) + answer) == []
    notes = compare_step(step, outputs([('model/active', model_doc('cup_5zone', SHA_A))]) + answer)
    assert [(d.field, d.fatal) for d in notes] == [('model content', False)]
    assert str(notes[0]).startswith('note: input #5 (model switch to cup_5zone): model/active model content')
    wrong = compare_step(step, outputs([('model/active', model_doc('cup_4zone', SHA_B))]) + answer)
    assert [(d.field, d.fatal) for d in wrong] == [('model name', True)]


def test_an_undecodable_live_message_is_a_difference(plan_step: Step) -> None:
    broken = output_of('grasp/pose', 0, b'\x00\x01\x00\x00\x01')
    assert isinstance(broken.value, Undecodable)
    live = [o for o in live_plan() if o.topic != 'grasp/pose'] + [broken]
    diffs = compare_step(plan_step, live)
    assert [(d.topic, d.field) for d in diffs] == [('grasp/pose', 'message')] and 'undecodable' in diffs[0].live


def test_answered_and_diverged_count_messages_per_topic(plan_step: Step) -> None:
    live = live_plan()
    assert not answered(plan_step, live[:-1]) and answered(plan_step, live)
    assert not diverged(plan_step, live)
    assert diverged(plan_step, live + outputs([('intent/v', v_msg(P))]))
    silent = Step(1, 'joint_states', 0, '', b'', (), 'joint_states')
    assert answered(silent, []) and not diverged(silent, []) and diverged(silent, live[:1])


def test_difference_text_names_input_topic_field_and_values() -> None:
    d = Difference(3, 'intent/w [0.9, 0.1, 0.9]', 'grasp/pose', 'position', '(0, 0, 0) m', '(1, 0, 0) m')
    assert str(d) == 'input #3 (intent/w [0.9, 0.1, 0.9]): grasp/pose position: recorded (0, 0, 0) m, live (1, 0, 0) m'
    assert Tolerances().v == 1e-9 and Tolerances().posterior == 1e-4
