"""In-process tests of the intent interpreter node (private Context per test, see test/conftest.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from numpy.testing import assert_allclose
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from grasp_intent_ros.method.intent import interpret
from grasp_intent_ros.nodes.intent_interpreter import IntentInterpreter
from grasp_intent_ros.ros.conversions import array_to_msg
from grasp_intent_ros.ros.params import ParameterError
from grasp_intent_ros.wire.arrays import msg_labels, msg_to_array
from grasp_intent_ros.wire.diagnostics import KEY_CLARIFICATIONS

REPO = Path(__file__).resolve().parents[2]
LABELS_7 = 'U,T,H,UT,UH,TH,UTH'


def w_msg(values: list[float]) -> Float64MultiArray:
    """What ``ros2 topic pub intent/w ... "{data: [...]}"`` sends: data only, no layout."""
    return Float64MultiArray(data=[float(v) for v in values])


@pytest.fixture
def interpreter(ros):
    node = ros.add(IntentInterpreter(context=ros.context))
    v_msgs = ros.subscribe(Float64MultiArray, 'intent/v')
    clarifications = ros.subscribe(String, 'intent/clarification')
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')
    return node, w_pub, v_msgs, clarifications


@pytest.mark.parametrize('w', [[0.9, 0.9, 0.1], [1.0, 0.0, 0.0], [0.5, 0.5, 0.5], [0.2, 0.7, 0.95]])
def test_v_equals_core_and_is_labelled(ros, interpreter, w):
    _, w_pub, v_msgs, clarifications = interpreter
    assert ros.publish_until(w_pub, w_msg(w), lambda: v_msgs), 'no intent/v received'
    expected = interpret(w)
    for msg in v_msgs:
        assert msg_labels(msg) == (tuple(LABELS_7.split(',')),)
        assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [(LABELS_7, 7, 7)]
        assert_allclose(msg_to_array(msg), expected.v, rtol=0, atol=1e-12)
    assert clarifications == []


def test_w_with_a_layout_is_read_as_a_message(ros, interpreter):
    """A w that is not a flat vector (dimensions, a data offset) is decoded as a message and answered alike."""
    _, w_pub, v_msgs, _ = interpreter
    w = [0.2, 0.7, 0.95]
    offset = w_msg([0.0, *w])
    offset.layout.data_offset = 1
    for msg in (array_to_msg(w, ['usage,transfer,handover']), offset):
        v_msgs.clear()
        assert ros.publish_until(w_pub, msg, lambda: v_msgs), 'no intent/v received'
        assert_allclose(msg_to_array(v_msgs[-1]), interpret(w).v, rtol=0, atol=1e-12)


def test_clarification_instead_of_v(ros, interpreter):
    node, w_pub, v_msgs, clarifications = interpreter
    w = [0.1, 0.1, 0.1]  # P(no task) = 0.729
    assert ros.publish_until(w_pub, w_msg(w), lambda: clarifications)
    assert 'P(no task) = 0.7290' in clarifications[0].data
    assert v_msgs == []
    # with the threshold above P(no task), the same w gives a v
    assert node.set_parameters([Parameter('clarification_threshold', value=0.8)])[0].successful
    assert ros.publish_until(w_pub, w_msg(w), lambda: v_msgs)
    assert_allclose(msg_to_array(v_msgs[-1]), interpret(w, clarification_threshold=0.8).v, atol=1e-12)


def _layout_mismatch() -> Float64MultiArray:
    msg = w_msg([0.5, 0.5, 0.5])
    msg.layout.dim = [MultiArrayDimension(label='U,T,H', size=4, stride=4)]
    return msg


BAD_W = {
    'wrong length': (w_msg([0.5, 0.5]), 'must have 3 entries'),
    'NaN': (w_msg([0.5, math.nan, 0.5]), 'NaN or infinity'),
    'Inf': (w_msg([0.5, 0.5, math.inf]), 'NaN or infinity'),
    'above 1': (w_msg([0.5, 1.5, 0.5]), 'in [0, 1]'),
    'negative': (w_msg([-0.1, 0.5, 0.5]), 'in [0, 1]'),
    'empty': (w_msg([]), 'w is empty'),
    'oversized': (w_msg([0.5] * 1000), 'oversized'),
    'bad layout': (_layout_mismatch(), 'malformed layout'),
    '2-D': (array_to_msg(np.full((3, 1), 0.5), ['U,T,H', 'x']), 'must have 1 dimension'),
}


@pytest.mark.parametrize('kind', list(BAD_W))
def test_bad_w_is_rejected_with_warn_and_node_keeps_serving(ros, interpreter, kind):
    node, w_pub, v_msgs, clarifications = interpreter
    statuses = ros.diagnostics()
    bad, reason = BAD_W[kind]
    warn = lambda: [s for s in statuses  # noqa: E731
                    if s.level == DiagnosticStatus.WARN and reason in s.message]
    assert ros.publish_until(w_pub, bad, warn), f'no WARN diagnostic naming {reason!r}'
    status = warn()[-1]
    assert status.name == '/intent_interpreter: intent'
    values = {kv.key: kv.value for kv in status.values}
    assert int(values['messages rejected']) >= 1 and reason in values['last error']
    assert v_msgs == [] and clarifications == []
    good = [0.9, 0.9, 0.1]
    assert ros.publish_until(w_pub, w_msg(good), lambda: v_msgs), 'node stopped serving'
    assert_allclose(msg_to_array(v_msgs[-1]), interpret(good).v, atol=1e-12)


def test_diagnostics_report_counts_and_recover_to_ok(ros, interpreter):
    _, w_pub, v_msgs, _ = interpreter
    statuses = ros.diagnostics()
    assert ros.publish_until(w_pub, w_msg([0.5, 2.0, 0.5]),
                             lambda: any(s.level == DiagnosticStatus.WARN for s in statuses))
    assert ros.publish_until(w_pub, w_msg([0.9, 0.9, 0.1]), lambda: v_msgs)
    periodic_ok = lambda: [s for s in statuses  # noqa: E731
                           if s.level == DiagnosticStatus.OK and s.message == 'ok']
    assert ros.wait_for(periodic_ok, timeout=3.0), 'no periodic OK status after a valid input'
    values = {kv.key: kv.value for kv in periodic_ok()[-1].values}
    assert int(values['messages received']) >= 2 and int(values['messages rejected']) >= 1
    assert 'in [0, 1]' in values['last error']
    assert float(values['last processing time [ms]']) > 0.0
    assert values['tasks'] == 'usage,transfer,handover'


def test_parameter_changes_are_validated_together(ros, interpreter):
    node, w_pub, v_msgs, _ = interpreter
    for bad in (0.0, -0.1, 1.5):
        result = node.set_parameters([Parameter('clarification_threshold', value=bad)])[0]
        assert not result.successful and result.reason
    result = node.set_parameters([Parameter('clarification_threshold', value='high')])[0]
    assert not result.successful and 'type' in result.reason
    for names, reason in ((['usage', 'usage'], 'unique'), ([f't{i}' for i in range(11)], '1..10'),
                          ([], '1..10'), (['a,b', 'c'], 'commas')):
        result = node.set_parameters([Parameter('task_names', Parameter.Type.STRING_ARRAY, names)])[0]
        assert not result.successful and reason in result.reason, result.reason
    # atomic: one bad value rejects the whole request; nothing is half-applied
    result = node.set_parameters_atomically([Parameter('clarification_threshold', value=0.3),
                                             Parameter('task_names', value=['a', 'a'])])
    assert not result.successful and 'unique' in result.reason
    assert node.get_parameter('clarification_threshold').value == 0.5
    # a new task list changes the expected length of w and the zone labels
    assert node.set_parameters([Parameter('task_names', value=['usage', 'transfer'])])[0].successful
    statuses = ros.diagnostics()
    assert ros.publish_until(w_pub, w_msg([0.5, 0.5, 0.5]),
                             lambda: any('must have 2 entries' in s.message for s in statuses))
    assert ros.publish_until(w_pub, w_msg([0.9, 0.2]), lambda: v_msgs)
    assert v_msgs[-1].layout.dim[0].label == 'U,T,UT'
    assert_allclose(msg_to_array(v_msgs[-1]), interpret([0.9, 0.2]).v, atol=1e-12)


def test_params_file_and_namespace(ros, tmp_path):
    text = (REPO / 'config' / 'intent_interpreter.yaml').read_text()
    assert 'clarification_threshold: 0.5' in text
    params_file = tmp_path / 'intent_interpreter.yaml'
    params_file.write_text(text.replace('clarification_threshold: 0.5', 'clarification_threshold: 0.8'))
    node = ros.add(IntentInterpreter(context=ros.context, cli_args=[
        '--ros-args', '-r', '__ns:=/robot1', '--params-file', str(params_file)]))
    assert node.get_parameter('clarification_threshold').value == 0.8
    assert tuple(node.get_parameter('task_names').value) == ('usage', 'transfer', 'handover')
    v_msgs = ros.subscribe(Float64MultiArray, '/robot1/intent/v')
    w_pub = ros.publisher(Float64MultiArray, '/robot1/intent/w')
    assert ros.publish_until(w_pub, w_msg([0.1, 0.3, 0.1]), lambda: v_msgs)  # P(none) = 0.567 < 0.8


def test_repo_params_file_matches_defaults(ros):
    node = ros.add(IntentInterpreter(context=ros.context, cli_args=[
        '--ros-args', '--params-file', str(REPO / 'config' / 'intent_interpreter.yaml')]))
    assert node.get_parameter('clarification_threshold').value == 0.5
    assert tuple(node.get_parameter('task_names').value) == ('usage', 'transfer', 'handover')


def test_invalid_initial_parameters_fail_construction(ros):
    with pytest.raises(ParameterError, match='clarification_threshold'):
        IntentInterpreter(context=ros.context,
                          parameter_overrides=[Parameter('clarification_threshold', value=0.0)])
    with pytest.raises(InvalidParameterValueException):
        IntentInterpreter(context=ros.context,
                          parameter_overrides=[Parameter('clarification_threshold', value=2.0)])


def _model_doc(name: str) -> String:
    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.ros.conversions import model_to_msg
    return model_to_msg(GraspModel.load(REPO / 'config' / 'models' / f'{name}.yaml'), name=name, version=1)


def test_active_model_zones_decide_whether_the_intent_can_be_served(ros, interpreter):
    from grasp_intent_ros.ros.qos import latched_qos
    node, w_pub, v_msgs, clarifications = interpreter
    statuses = ros.diagnostics()
    model_pub = ros.publisher(String, 'model/active', latched_qos())
    model_pub.publish(_model_doc('cup_4zone'))  # zones T, UT, TH, UTH: none without transfer
    values = lambda s: {kv.key: kv.value for kv in s.values}  # noqa: E731
    assert ros.wait_for(lambda: any('cup_4zone' in values(s).get('active model', '') for s in statuses))
    # usage only: P(no task) = 0.1 is below the threshold, but no zone of cup_4zone is possible
    assert ros.publish_until(w_pub, w_msg([0.9, 0.0, 0.0]), lambda: clarifications)
    assert ros.wait_for(lambda: any(s.message.startswith('clarification requested') for s in statuses))
    (msg,) = clarifications
    assert 'no zone of the model has non-zero probability' in msg.data and 'cup_4zone' in msg.data
    assert 'T,UT,TH,UTH' in msg.data and v_msgs == []
    status = [s for s in statuses if s.message.startswith('clarification requested')][-1]
    assert status.level == DiagnosticStatus.OK and values(status)[KEY_CLARIFICATIONS] == '1'
    assert values(status)['last outcome'] == f'clarification requested: {msg.data}'
    # with transfer possible the same model serves it: v over all zones, as before
    assert ros.publish_until(w_pub, w_msg([0.9, 0.9, 0.1]), lambda: v_msgs)
    assert_allclose(msg_to_array(v_msgs[-1]), interpret([0.9, 0.9, 0.1]).v, atol=1e-12)
    assert len(clarifications) == 1
    # the 7-zone model has a "U only" zone: the first w is served once it is active
    model_pub.publish(_model_doc('cup_7zone'))
    assert ros.wait_for(lambda: any('cup_7zone' in values(s).get('active model', '') for s in statuses))
    n_v = len(v_msgs)
    assert ros.publish_until(w_pub, w_msg([0.9, 0.0, 0.0]), lambda: len(v_msgs) > n_v)
    assert len(clarifications) == 1


def test_a_model_of_other_tasks_is_refused_and_every_intent_is_clarified_until_one_is_served(ros, interpreter):
    from grasp_intent_ros.ros.qos import latched_qos
    node, w_pub, v_msgs, clarifications = interpreter
    assert node.set_parameters([Parameter('task_names', value=['grasp', 'lift', 'give'])])[0].successful
    statuses = ros.diagnostics()
    ros.publisher(String, 'model/active', latched_qos()).publish(_model_doc('cup_4zone'))
    refused = "model/active: model 'cup_4zone' refused: its tasks [usage, transfer, handover] are not the " \
              'task_names [grasp, lift, give]'
    values = lambda s: {kv.key: kv.value for kv in s.values}  # noqa: E731
    assert ros.wait_for(lambda: any(s.level == DiagnosticStatus.ERROR and s.message == f'cannot serve: {refused}'
                                    for s in statuses)), [s.message for s in statuses]
    # every w gets one clarification with the reason, and no v
    for n in (1, 2):
        assert ros.publish_until(w_pub, w_msg([0.9, 0.9, 0.1]), lambda n=n: len(clarifications) >= n)
    assert [m.data for m in clarifications[:2]] == [f'cannot serve: {refused}'] * 2 and v_msgs == []
    assert values(statuses[-1])['active model'] == f'none: {refused}'
    # the suite's tasks again: the latched model is read again and served, the status recovers
    assert node.set_parameters([Parameter('task_names', value=['usage', 'transfer', 'handover'])])[0].successful
    assert ros.wait_for(lambda: values(node._diagnostics.status())['active model'].startswith('cup_4zone'))
    assert ros.publish_until(w_pub, w_msg([0.9, 0.9, 0.1]), lambda: v_msgs)
    assert ros.wait_for(lambda: node._diagnostics.status().level == DiagnosticStatus.OK)


def test_task_names_that_would_leave_the_model_unserved_are_refused_by_the_set(ros, interpreter):
    """``ros2 param set /intent_interpreter task_names "[a, b, c]"``: answered by the set, with the reason."""
    from grasp_intent_ros.ros.qos import latched_qos
    node, w_pub, v_msgs, clarifications = interpreter
    ros.publisher(String, 'model/active', latched_qos()).publish(_model_doc('cup_5zone'))
    assert ros.wait_for(lambda: node._models.current is not None)
    result = node.set_parameters([Parameter('task_names', value=['a', 'b', 'c'])])[0]
    assert not result.successful
    assert result.reason == ("the suite could not serve its active model 'cup_5zone': its tasks [usage, transfer, "
                             'handover] are not the task_names [a, b, c]')
    assert tuple(node.get_parameter('task_names').value) == ('usage', 'transfer', 'handover')
    assert ros.publish_until(w_pub, w_msg([0.9, 0.9, 0.1]), lambda: v_msgs) and clarifications == []


@pytest.mark.parametrize('kind', ['alias bomb', 'nested too deeply', 'oversized'])
def test_weaponised_model_document_is_rejected_and_the_model_kept(ros, interpreter, weaponised_model_documents,
                                                                   kind):
    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.ros.qos import latched_qos
    node, w_pub, v_msgs, clarifications = interpreter
    statuses = ros.diagnostics()
    model_pub = ros.publisher(String, 'model/active', latched_qos())
    model_pub.publish(_model_doc('cup_4zone'))
    values = lambda s: {kv.key: kv.value for kv in s.values}  # noqa: E731
    assert ros.wait_for(lambda: any('cup_4zone' in values(s).get('active model', '') for s in statuses))
    text, reason = weaponised_model_documents(GraspModel.load(REPO / 'config' / 'models' / 'cup_7zone.yaml'))[kind]
    model_pub.publish(String(data=text))
    assert ros.wait_for(lambda: [s for s in statuses if s.level == DiagnosticStatus.WARN and reason in s.message])
    status = [s for s in statuses if reason in s.message][-1]
    assert values(status)['messages rejected'] == '1' and 'cup_4zone' in values(status)['active model']
    # still the 4-zone model: usage alone cannot be served
    assert ros.publish_until(w_pub, w_msg([0.9, 0.0, 0.0]), lambda: clarifications)
    assert 'cup_4zone' in clarifications[-1].data and v_msgs == []
