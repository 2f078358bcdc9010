"""In-process tests of the model server node (private Context per test, tiny models from test/conftest.py)."""

from __future__ import annotations

import math
import re

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from numpy.testing import assert_allclose
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, String

from grasp_intent_ros.method import ambiguity
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.nodes.model_server import ModelServer
from grasp_intent_ros.ros.conversions import model_from_msg
from grasp_intent_ros.ros.params import ParameterError
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.wire.arrays import msg_labels, msg_to_array

TASKS = ('usage', 'transfer', 'handover')


@pytest.fixture
def server(ros, tiny_models):
    models_dir, _ = tiny_models
    return ros.add(ModelServer(context=ros.context, parameter_overrides=[
        Parameter('models_dir', value=str(models_dir))]))


def latched(ros, msg_type, topic):
    return ros.subscribe(msg_type, topic, latched_qos())


def assert_same_model(a: GraspModel, b: GraspModel) -> None:
    assert a.zones == b.zones and a.task_names == b.task_names
    assert_allclose(a.means, b.means, atol=1e-12)
    assert_allclose(a.covariances, b.covariances, atol=1e-12)
    assert_allclose(a.priors, b.priors, atol=1e-12)


def test_late_subscriber_receives_latched_model_and_ambiguity(ros, server, tiny_models):
    model = tiny_models[1]['cup_7zone']
    # the server published while nobody listened: let it run first, then subscribe
    statuses = ros.diagnostics()
    assert ros.wait_for(lambda: statuses, timeout=3.0)
    active = latched(ros, String, 'model/active')
    matrices = {t: latched(ros, Float64MultiArray, f'model/ambiguity{t}')
                for t in ('', '/symmetric', '/pinsker')}
    assert ros.wait_for(lambda: active and all(matrices.values()))
    doc = model_from_msg(active[0])
    assert (doc.name, doc.version) == ('cup_7zone', 1)
    assert_same_model(doc.model, model)
    assert_same_model(GraspModel.from_yaml(active[0].data), model)  # header lines are YAML comments
    report = ambiguity.report(model)
    for suffix, expected in (('', report.kl), ('/symmetric', report.symmetric), ('/pinsker', report.pinsker)):
        msg = matrices[suffix][0]
        assert msg_labels(msg) == (TASKS, TASKS)
        assert [(d.size, d.stride) for d in msg.layout.dim] == [(3, 9), (3, 3)]
        assert_allclose(msg_to_array(msg, ndim=2), expected, rtol=0, atol=1e-12)


def test_query_posterior_equals_core(ros, server, tiny_models):
    model = tiny_models[1]['cup_7zone']
    posteriors = ros.subscribe(Float64MultiArray, 'model/posterior')
    query = ros.publisher(Float64MultiArray, 'model/query')
    x = model.means[3]
    assert ros.publish_until(query, Float64MultiArray(data=list(x)), lambda: posteriors)
    assert msg_labels(posteriors[0]) == (model.zone_labels,)
    assert_allclose(msg_to_array(posteriors[0]), model.posterior(x), rtol=0, atol=1e-12)


BAD_X = {
    'wrong length': ([0.1] * 9, 'x must have shape (10,)'),
    'NaN': ([0.1] * 9 + [math.nan], 'NaN or infinity'),
    'Inf': ([-math.inf] + [0.1] * 9, 'NaN or infinity'),
    'empty': ([], 'x is empty'),
    'oversized': ([0.1] * 5000, 'oversized'),
    'finite but too far for a finite posterior': ([1e308] * 10, 'too far from every zone'),
    'oversized message': ([0.1] * 10_000, 'model/query: oversized message'),
}


@pytest.mark.parametrize('kind', list(BAD_X))
def test_bad_query_is_rejected_with_warn_and_server_keeps_serving(ros, server, tiny_models, kind):
    model = tiny_models[1]['cup_7zone']
    statuses = ros.diagnostics()
    posteriors = ros.subscribe(Float64MultiArray, 'model/posterior')
    query = ros.publisher(Float64MultiArray, 'model/query')
    bad, reason = BAD_X[kind]
    assert ros.publish_until(query, Float64MultiArray(data=bad), lambda: [
        s for s in statuses if s.level == DiagnosticStatus.WARN and reason in s.message]), reason
    assert posteriors == []
    assert ros.publish_until(query, Float64MultiArray(data=list(model.means[0])), lambda: posteriors)
    assert_allclose(msg_to_array(posteriors[-1]), model.posterior(model.means[0]), atol=1e-12)


def test_model_switch_at_run_time_republishes(ros, server, tiny_models):
    models = tiny_models[1]
    active = latched(ros, String, 'model/active')
    kl = latched(ros, Float64MultiArray, 'model/ambiguity')
    assert ros.wait_for(lambda: active and kl)
    assert server.set_parameters([Parameter('model', value='cup_5zone')])[0].successful
    assert ros.wait_for(lambda: len(active) >= 2 and len(kl) >= 2)
    doc = model_from_msg(active[-1])
    assert (doc.name, doc.version) == ('cup_5zone', 2)
    assert doc.sha256 != model_from_msg(active[0]).sha256
    assert_same_model(doc.model, models['cup_5zone'])
    assert_allclose(msg_to_array(kl[-1], ndim=2), ambiguity.kl_matrix(models['cup_5zone']), atol=1e-12)
    # queries are now answered by the new model, over its five zones
    posteriors = ros.subscribe(Float64MultiArray, 'model/posterior')
    query = ros.publisher(Float64MultiArray, 'model/query')
    x = models['cup_5zone'].means[1]
    assert ros.publish_until(query, Float64MultiArray(data=list(x)), lambda: posteriors)
    assert posteriors[-1].layout.dim[0].label == 'U,T,UT,TH,UTH'
    assert_allclose(msg_to_array(posteriors[-1]), models['cup_5zone'].posterior(x), atol=1e-12)


def test_unknown_or_malformed_model_is_rejected(ros, server):
    active = latched(ros, String, 'model/active')
    assert ros.wait_for(lambda: active)
    result = server.set_parameters([Parameter('model', value='cup_9zone')])[0]
    assert not result.successful
    assert "unknown model 'cup_9zone'" in result.reason and 'broken, cup_5zone, cup_7zone' in result.reason
    result = server.set_parameters([Parameter('model', value='broken')])[0]
    assert not result.successful and 'broken.yaml' in result.reason and 'lacks field' in result.reason
    result = server.set_parameters([Parameter('models_dir', value='/tmp')])[0]
    assert not result.successful and 'read-only' in result.reason
    assert server.get_parameter('model').value == 'cup_7zone'
    # an accepted change is the marker: whatever a rejected change published would arrive before it
    assert server.set_parameters([Parameter('model', value='cup_5zone')])[0].successful
    assert ros.wait_for(lambda: len(active) > 1)
    assert len(active) == 2 and model_from_msg(active[-1]).version == 2, 'a rejected change must not republish'


def test_unknown_initial_model_fails_construction(ros, tiny_models):
    with pytest.raises(ParameterError, match='known: broken, cup_5zone, cup_7zone'):
        ModelServer(context=ros.context, parameter_overrides=[
            Parameter('models_dir', value=str(tiny_models[0])), Parameter('model', value='mug')])


def test_a_model_the_suite_cannot_serve_is_never_published(ros, tiny_models, tmp_path):
    """A model of other tasks is refused at start and on a change; task_names and the model change together."""
    cup = tiny_models[1]['cup_7zone']
    doc = cup.to_document()
    doc['task_names'] = ['use', 'throw', 'hold']  # the same zone labels, other tasks
    GraspModel.from_document(doc).save(tmp_path / 'other_tasks.yaml')
    cup.save(tmp_path / 'cup_7zone.yaml')
    refused = ("model 'other_tasks' refused: its tasks [use, throw, hold] are not the task_names "
               '[usage, transfer, handover]')
    with pytest.raises(ParameterError, match=re.escape(refused)):
        ModelServer(context=ros.context, parameter_overrides=[
            Parameter('models_dir', value=str(tmp_path)), Parameter('model', value='other_tasks')])
    server = ros.add(ModelServer(context=ros.context, parameter_overrides=[
        Parameter('models_dir', value=str(tmp_path))]))
    active = latched(ros, String, 'model/active')
    assert ros.wait_for(lambda: active)
    result = server.set_parameters([Parameter('model', value='other_tasks')])[0]
    assert not result.successful and refused in result.reason
    result = server.set_parameters([Parameter('task_names', value=['use', 'throw', 'hold'])])[0]
    assert not result.successful and "model 'cup_7zone' refused" in result.reason, 'the active model must fit'
    assert server.set_parameters_atomically([Parameter('task_names', value=['use', 'throw', 'hold']),
                                             Parameter('model', value='other_tasks')]).successful
    assert ros.wait_for(lambda: len(active) > 1)
    assert [model_from_msg(m).name for m in active] == ['cup_7zone', 'other_tasks']


def test_describe_lists_the_available_models_and_follows_the_directory(ros, tiny_models, tmp_path):
    """What ``ros2 param describe /model_server model`` shows.

    Through the node's describe_parameters service: the models in models_dir, read anew at every call.
    """
    import shutil

    from rcl_interfaces.srv import DescribeParameters
    source, _ = tiny_models
    for name in ('cup_7zone', 'cup_5zone'):
        shutil.copy(source / f'{name}.yaml', tmp_path / f'{name}.yaml')
    ros.add(ModelServer(context=ros.context, parameter_overrides=[Parameter('models_dir', value=str(tmp_path))]))
    client = ros.node.create_client(DescribeParameters, 'model_server/describe_parameters')
    assert ros.wait_for(client.service_is_ready, timeout=10.0)

    def describe() -> str:
        future = client.call_async(DescribeParameters.Request(names=['model', 'models_dir']))
        assert ros.wait_for(future.done, timeout=10.0)
        model, models_dir = future.result().descriptors
        assert models_dir.read_only and 'models_dir' in models_dir.name
        assert model.name == 'model' and 'stem of a model YAML' in model.description
        return model.additional_constraints

    assert describe() == f'one of cup_5zone, cup_7zone: the *.yaml files in {tmp_path}'
    shutil.copy(source / 'cup_5zone.yaml', tmp_path / 'cup_4zone.yaml')  # a model trained meanwhile
    assert describe().startswith('one of cup_4zone, cup_5zone, cup_7zone:')
    (tmp_path / 'cup_5zone.yaml').unlink()
    assert describe().startswith('one of cup_4zone, cup_7zone:')


def test_outputs_carry_no_event_handlers(server):
    """As every node's outputs (ros.qos.output_publisher): the latched ones keep their transient-local QoS."""
    from rclpy.qos import DurabilityPolicy

    outputs = {pub.topic_name: pub for pub in server.publishers if pub.topic_name != '/parameter_events'}
    latched_topics = {'/model/active', '/model/ambiguity', '/model/ambiguity/symmetric', '/model/ambiguity/pinsker'}
    assert latched_topics | {'/model/posterior', '/diagnostics'} <= set(outputs)
    assert all(not pub.event_handlers for pub in outputs.values())
    assert all((pub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL) == (topic in latched_topics)
               for topic, pub in outputs.items())
