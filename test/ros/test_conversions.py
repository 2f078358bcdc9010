"""grasp_intent_ros.ros.conversions: rclpy messages built from, and read through, the wire layouts."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from numpy.testing import assert_allclose
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from grasp_intent_ros.errors import GraspIntentError, InvalidIntentError, ModelFormatError
from grasp_intent_ros.ros.conversions import (
    SerializedArrays,
    SerializedTargets,
    array_to_msg,
    message_class,
    model_from_msg,
    model_to_msg,
    posterior_from_msg,
    posterior_to_msg,
    stamped_array_from_msg,
    stamped_array_to_msg,
    target_from_msg,
)
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.arrays import msg_labels, msg_to_array, serialized_vector


def test_every_suite_topic_has_its_message_class() -> None:
    for topic, msgtype in topics.MSGTYPES.items():
        cls = message_class(topic)
        package, _, name = msgtype.split('/')
        assert (cls.__module__.split('.')[0], cls.__name__) == (package, name), topic
    with pytest.raises(KeyError):
        message_class('intent/typo')


def test_labelled_array_round_trip() -> None:
    kl = np.arange(6.0).reshape(2, 3)
    msg = array_to_msg(kl, [('a', 'b'), 'x,y,z'])
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [('a,b', 2, 6), ('x,y,z', 3, 3)]
    assert_allclose(msg_to_array(msg, ndim=2), kl)
    assert msg_labels(msg) == (('a', 'b'), ('x', 'y', 'z'))
    with pytest.raises(ValueError, match='2 labels for an array with 1 axes'):
        array_to_msg([1.0], ['a', 'b'])


@pytest.mark.parametrize('bad', [np.nan, np.inf, -np.inf])
def test_no_array_with_nan_or_infinity_becomes_a_message(bad: float) -> None:
    with pytest.raises(GraspIntentError, match='not published: 1 of 2 output values are NaN or infinite'):
        array_to_msg([0.5, bad], ['U,T'])
    for p, w in (([0.5, bad], [0.5, 0.5]), ([0.5, 0.5], [bad, 1.0])):
        with pytest.raises(GraspIntentError, match='not published: 1 of 4 output values'):
            posterior_to_msg(p, w, ['U', 'T'], ['a', 'b'], stamp=Time(sec=1))


@pytest.mark.parametrize('values', [[0.25], [0.9, 0.9, 0.1], list(np.linspace(0.0, 1.0, 10)), [-1e308, 5e-324, 1e308]])
def test_a_flat_vector_is_read_from_its_serialized_bytes_as_from_the_message(values: list[float]) -> None:
    data = serialize_message(Float64MultiArray(data=values))
    got = serialized_vector(data, max_size=10)
    assert got is not None
    assert_allclose(got, msg_to_array(deserialize_message(data, Float64MultiArray), max_size=10), rtol=0)
    with pytest.raises(InvalidIntentError, match=f'w is oversized: {len(values)} values, the limit is 0'):
        serialized_vector(data, max_size=0, error=InvalidIntentError, what='w')


def test_only_a_flat_vector_is_read_from_serialized_bytes() -> None:
    """Any other layout is left to the message decoder (None), and bad values are rejected as msg_to_array does."""
    dims = Float64MultiArray(data=[0.5, 0.5])
    dims.layout.dim = [MultiArrayDimension(label='a,b', size=2, stride=2)]
    offset = Float64MultiArray(data=[0.0, 0.5])
    offset.layout.data_offset = 1
    for msg in (dims, offset, Float64MultiArray()):
        assert serialized_vector(serialize_message(msg)) is None
    data = serialize_message(Float64MultiArray(data=[0.5, 0.5]))
    for other in (data[:-1], data + bytes(8), b'\x00\x00' + data[2:], data[:20]):  # truncated, long, big-endian
        assert serialized_vector(other) is None
    for bad in (np.nan, np.inf):
        data = serialize_message(Float64MultiArray(data=[0.5, bad]))
        with pytest.raises(InvalidIntentError, match='w contains NaN or infinity \\(first at index 1'):
            serialized_vector(data, error=InvalidIntentError, what='w')


def test_serialized_arrays_decode_as_array_to_msg() -> None:
    labels = ['U,T,H,UT,UH,TH,UTH']
    arrays = SerializedArrays((7,), labels)
    values = np.random.default_rng(0).dirichlet(np.ones(7))
    msg, expected = deserialize_message(arrays.serialize(values), Float64MultiArray), array_to_msg(values, labels)
    assert msg.layout == expected.layout
    assert_allclose(msg.data, values, rtol=0)
    with pytest.raises(GraspIntentError, match='not published: 1 of 7 output values are NaN or infinite'):
        arrays.serialize(np.r_[values[:6], np.nan])
    with pytest.raises(ValueError, match='shape'):
        arrays.serialize(values[:6])


def test_target_vector_is_validated_where_it_is_read() -> None:
    v, labels = target_from_msg(array_to_msg([0.25, 0.75, 0.0], ['U,T,UT']))
    assert labels == ('U', 'T', 'UT') and v.tolist() == [0.25, 0.75, 0.0]
    v, labels = target_from_msg(Float64MultiArray(data=[0.5, 0.5, 0.0]))
    assert labels is None and v.size == 3
    with pytest.raises(InvalidIntentError, match='sum to 1'):
        target_from_msg(Float64MultiArray(data=[0.5, 0.6, 0.0]))
    with pytest.raises(InvalidIntentError, match='label names 2 zones'):
        target_from_msg(array_to_msg([0.25, 0.75, 0.0], ['U,T']))
    with pytest.raises(InvalidIntentError, match='oversized'):
        target_from_msg(Float64MultiArray(data=[1.0] + [0.0] * 1023))


def test_serialized_targets_read_a_repeated_layout_in_place_with_the_same_checks() -> None:
    decoded: list[bytes] = []

    def decode(data: bytes) -> Float64MultiArray:
        decoded.append(data)
        return deserialize_message(data, Float64MultiArray)
    targets = SerializedTargets(decode)
    labels = ['U,T,H,UT,UH,TH,UTH']
    stream = SerializedArrays((7,), labels)  # as the interpreter publishes v
    rng = np.random.default_rng(2)
    for k in range(5):
        data = stream.serialize(rng.dirichlet(np.ones(7)))
        v, names = targets(data)
        assert (v.tolist(), names) == (lambda t: (t[0].tolist(), t[1]))(target_from_msg(decode(data)))
    assert len(decoded) == 1 + 5, 'the layout decoded once (and once per comparison above)'
    other = [(serialize_message(array_to_msg([0.25, 0.75, 0.0], ['U,T,UT'])), ('U', 'T', 'UT')),
             (serialize_message(Float64MultiArray(data=[0.5, 0.5, 0.0])), None)]
    for data, expected in other * 2:  # another layout: decoded, then learnt
        assert targets(data)[1] == expected
    assert targets(stream.serialize(np.full(7, 1 / 7)))[1] == tuple('U,T,H,UT,UH,TH,UTH'.split(','))
    for bad, reason in (([0.5, 0.6, 0, 0, 0, 0, 0], 'sum to 1'), ([1.5, -0.5, 0, 0, 0, 0, 0], 'non-negative'),
                        ([np.nan, 1.0, 0, 0, 0, 0, 0], 'NaN or infinity')):  # the checks of target_from_msg
        data = stream.serialize(np.zeros(7))[:-56] + np.array(bad, dtype='<f8').tobytes()
        for read in (targets, lambda d: target_from_msg(deserialize_message(d, Float64MultiArray))):
            with pytest.raises(InvalidIntentError, match=reason):
                read(data)


def test_stamped_array_and_posterior_round_trip() -> None:
    stamp = Time(sec=12, nanosec=34)
    back = stamped_array_from_msg(stamped_array_to_msg([1.0, 2.0], ['a', 'b'], stamp=stamp))
    assert (back[0], back[1], back[2].tolist()) == (stamp, 'a,b', [1.0, 2.0])
    msg = posterior_to_msg([0.25, 0.75], [0.5], ('U', 'T'), ('usage',), stamp=stamp)
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [('stamp=12.000000034', 1, 3), ('U,T|usage', 3, 3)]
    parsed = posterior_from_msg(msg)
    assert (parsed.stamp, parsed.zone_labels, parsed.task_names) == (stamp, ('U', 'T'), ('usage',))
    assert_allclose(np.concatenate([parsed.p, parsed.w]), [0.25, 0.75, 0.5])
    msg.layout.dim[1].label = 'U,T,usage'
    with pytest.raises(GraspIntentError, match='<zones>|<tasks>'):
        posterior_from_msg(msg)
    with pytest.raises(GraspIntentError, match='2 dimension'):
        posterior_from_msg(array_to_msg([0.5, 0.5], ['U,T']))
    with pytest.raises(ValueError, match='do not match'):
        posterior_to_msg([0.25, 0.75], [0.5, 0.5], ('U', 'T'), ('usage',), stamp=stamp)


def test_model_document_parsing_rejects_malformed_documents(tiny_models):
    model = tiny_models[1]['cup_5zone']
    text = model_to_msg(model, name='cup_5zone', version=4).data
    doc = model_from_msg(String(data=text))
    assert (doc.name, doc.version) == ('cup_5zone', 4)
    assert doc.model.zones == model.zones and doc.model.task_names == model.task_names
    assert_allclose(doc.model.means, model.means, atol=1e-12)
    with pytest.raises(ModelFormatError, match='header'):
        model_from_msg(String(data=model.to_yaml()))
    with pytest.raises(ModelFormatError, match='corrupted'):
        model_from_msg(String(data=text.replace('prior: 0.', 'prior: 1.', 1)))
    header = text.split('\n')[:2]
    body = 'zones: [U\n'
    header.append(f'# model_sha256: {hashlib.sha256(body.encode()).hexdigest()}')
    with pytest.raises(ModelFormatError, match='not valid YAML'):
        model_from_msg(String(data='\n'.join(header) + '\n' + body))
