"""grasp_intent_ros.wire.protocol: topics, array layouts, the grasp posterior, the model document, diagnostics.

Messages are plain objects with the message's fields (:class:`types.SimpleNamespace`): the protocol reads
rclpy and rosbags messages alike and needs neither.
"""

from __future__ import annotations

import hashlib
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from grasp_intent_ros.errors import GraspIntentError, InvalidFeaturesError, ModelFormatError
from grasp_intent_ros.method.intent import reconstruct_w
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.safe_yaml import MAX_DOCUMENT_CHARS
from grasp_intent_ros.wire import protocol
from grasp_intent_ros.wire.protocol import (
    ModelHeader,
    model_document,
    parse_model_document,
    read_model_document,
    read_posterior,
    stamped_values,
)

T0 = 1_700_000_000_000_000_000  # ns
S = 1_000_000_000  # ns per s


def array(values: Any, *dims: tuple[str, int, int], offset: int = 0) -> SimpleNamespace:
    """A Float64MultiArray-like object: dims as (label, size, stride)."""
    return SimpleNamespace(data=list(np.asarray(values, dtype=np.float64).ravel()), layout=SimpleNamespace(
        dim=[SimpleNamespace(label=label, size=size, stride=stride) for label, size, stride in dims],
        data_offset=offset))


def stamped(values: Any, label: str, stamp_ns: int) -> SimpleNamespace:
    """A (1, n) array with the planner's stamp axis."""
    n = np.asarray(values).size
    return array(values, (f'stamp={stamp_ns // S}.{stamp_ns % S:09d}', 1, n), (label, n, 1))


def test_every_topic_has_a_type_and_the_groups_are_the_suite_s() -> None:
    constants = protocol.__all__[:protocol.__all__.index('DIAGNOSTICS') + 1]  # the topic names
    assert {getattr(protocol, name) for name in constants} == set(protocol.MSGTYPES)
    assert set(protocol.INPUT_TOPICS) | set(protocol.OUTPUT_TOPICS) <= set(protocol.MSGTYPES)
    assert set(protocol.PLAN_TOPICS) < set(protocol.OUTPUT_TOPICS)
    assert protocol.DIAGNOSTICS.startswith('/') and not any(t.startswith('/') for t in protocol.INPUT_TOPICS)


def test_array_layout_and_reading() -> None:
    assert protocol.array_layout((2, 3), [('a', 'b'), 'x,y,z']) == [('a,b', 2, 6), ('x,y,z', 3, 3)]
    with pytest.raises(ValueError, match='3 names for an axis of size 2'):
        protocol.array_layout((2,), [('a', 'b', 'c')])
    with pytest.raises(ValueError, match='must not contain commas'):
        protocol.join_labels(['a,b'])
    msg = array([9.0, 1.0, 2.0, 3.0, 4.0], ('r', 2, 4), ('c', 2, 2), offset=1)
    assert protocol.msg_to_array(msg, ndim=2).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert protocol.msg_labels(msg) == (('r',), ('c',))
    for bad, match in ((array([]), 'empty'), (array([1.0, np.nan]), 'NaN'), (array([1.0, 2.0], ('a', 3, 3)),
                       'malformed layout'), (array([1.0] * 5), 'oversized')):
        with pytest.raises(InvalidFeaturesError, match=match):
            protocol.msg_to_array(bad, max_size=4, error=InvalidFeaturesError, what='x')


def test_diagnostics_levels_and_values() -> None:
    assert [protocol.level_value(b) for b in (b'\x00', b'\x01', b'\x02', 3)] == [0, 1, 2, 3]
    assert protocol.LEVEL_NAMES[protocol.WARN] == 'WARN'
    status = SimpleNamespace(values=[SimpleNamespace(key=protocol.KEY_REJECTED, value='2')])
    assert protocol.status_values(status) == {'messages rejected': '2'}
    assert protocol.status_name('/robot1/grasp_planner', 'planning') == '/robot1/grasp_planner: planning'


def test_posterior_layout_is_split_into_p_and_w(toy_model: GraspModel) -> None:
    p = toy_model.posterior(toy_model.means[0])
    w = reconstruct_w(p, toy_model.zones, 3)
    label = f'{",".join(toy_model.zone_labels)}|{",".join(toy_model.task_names)}'
    post = read_posterior(stamped(np.r_[p, w], label, T0))
    assert post.zone_labels == toy_model.zone_labels and post.task_names == toy_model.task_names
    np.testing.assert_array_equal(post.p, p)
    np.testing.assert_array_equal(post.w, w)
    for bad in ('U,T,H,UT,UH,TH,UTH,usage,transfer,handover', 'U,T,H|usage,transfer,handover', ''):
        with pytest.raises(ValueError, match='grasp/posterior label'):
            read_posterior(stamped(np.r_[p, w], bad, T0))


def test_stamped_values_reads_any_message_object() -> None:
    values, label, stamp = stamped_values(stamped([0.25, 0.75], 'a,b', T0 + 34))
    np.testing.assert_array_equal(values, [0.25, 0.75])
    assert (label, stamp) == ('a,b', (T0 // S, 34))
    bad = stamped([0.25, 0.75], 'a,b', T0)
    bad.layout.dim[0].label = 'stamp=12.34'
    with pytest.raises(ValueError, match='9-digit nanosec'):
        stamped_values(bad)


def test_model_document_round_trip(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='cup_7zone', version=3)
    body = toy_model.to_yaml()
    sha = hashlib.sha256(body.encode()).hexdigest()
    assert text == f'# model_name: cup_7zone\n# model_version: 3\n# model_sha256: {sha}\n{body}'
    assert parse_model_document(text) == (ModelHeader('cup_7zone', 3, sha), body)
    assert GraspModel.from_yaml(text).to_yaml() == body  # the header lines are YAML comments
    for name, version in (('two\nlines', 1), ('m', 0)):
        with pytest.raises(ValueError, match='one line'):
            model_document(toy_model, name=name, version=version)


def test_malformed_model_documents_raise(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='m', version=1)
    with pytest.raises(ModelFormatError, match='lacks the header lines'):
        parse_model_document(toy_model.to_yaml())
    with pytest.raises(ModelFormatError, match='lacks the header lines'):
        parse_model_document(text.replace('# model_version: 1', '# model_version: one'))
    corrupted = text.replace('prior: 0.', 'prior: 1.', 1)
    with pytest.raises(ModelFormatError, match='corrupted'):
        parse_model_document(corrupted)
    assert parse_model_document(corrupted, check_sha256=False)[0] == parse_model_document(text)[0]
    with pytest.raises(ModelFormatError, match='model_version must be >= 1'):
        parse_model_document(text.replace('# model_version: 1', '# model_version: 0'))


def test_whole_document_is_read_into_a_model(toy_model: GraspModel) -> None:
    doc = read_model_document(model_document(toy_model, name='toy', version=2))
    assert (doc.name, doc.version) == ('toy', 2) and isinstance(doc, ModelHeader)
    assert doc.model.to_yaml() == toy_model.to_yaml()
    again = read_model_document(model_document(toy_model, name='toy', version=3), previous=doc)
    assert (again.version, again.sha256) == (3, doc.sha256) and again.model is doc.model  # not parsed again
    renamed = read_model_document(model_document(toy_model, name='toy2', version=4), previous=doc)
    assert renamed.model is not doc.model and renamed.model.to_yaml() == toy_model.to_yaml()
    with pytest.raises(ModelFormatError, match='corrupted'):  # the reuse still checks the hash
        read_model_document(model_document(toy_model, name='toy', version=5).replace('prior: 0.', 'prior: 1.', 1),
                            previous=doc)


def test_oversized_document_is_rejected_before_the_header_is_read(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='toy', version=1)
    oversized = text + '#' * (MAX_DOCUMENT_CHARS + 1 - len(text))
    for reader in (parse_model_document, read_model_document):
        with pytest.raises(ModelFormatError, match='oversized'):
            reader(oversized)
        with pytest.raises(ModelFormatError, match='oversized'):
            reader('no header' + ' ' * MAX_DOCUMENT_CHARS)


def test_message_size_caps_and_name_bounds() -> None:
    for topic, cap in protocol.MAX_MESSAGE_BYTES.items():
        assert topic in protocol.MSGTYPES
        protocol.check_message_size(topic, cap)
        with pytest.raises(GraspIntentError, match=f'{topic}: oversized message of {cap + 1} bytes'):
            protocol.check_message_size(topic, cap + 1)
    with pytest.raises(KeyError):
        protocol.check_message_size(protocol.GRASP_MARKERS, 1)
    protocol.check_names(['a' * protocol.MAX_NAME_LENGTH] * 3, max_count=3, what='joint state')
    with pytest.raises(GraspIntentError, match='joint state: 4 names, the limit is 3'):
        protocol.check_names(['a'] * 4, max_count=3, what='joint state')
    with pytest.raises(GraspIntentError, match='name 1 has 5000 characters'):
        protocol.check_names(['a', 'b' * 5000], max_count=3, what='joint state')


def test_repeated_layout_reads_only_the_bytes_it_learnt() -> None:
    layout: protocol.RepeatedLayout[str] = protocol.RepeatedLayout()
    head = b'\x00\x01\x00\x00' + bytes(range(20))  # little-endian CDR, then a layout's bytes
    values = np.array([0.25, 0.75])
    assert layout.read(head + values.tobytes()) is None, 'nothing learnt yet'
    layout.learn(head + values.astype('>f8').tobytes(), values, 'big-endian values')  # not as rclpy writes
    layout.learn(b'\x00\x00\x00\x00' + head[4:] + values.tobytes(), values, 'big-endian CDR')
    assert layout.read(head + values.tobytes()) is None, 'neither learnt'
    layout.learn(head + values.tobytes(), values, 'labels')
    read = layout.read(head + np.array([0.5, 0.5]).tobytes())
    assert read is not None and read[0].tolist() == [0.5, 0.5] and read[1] == 'labels'
    for other in (head[:-1] + b'\xff' + values.tobytes(), head + values.tobytes() + bytes(8), head + bytes(8)):
        assert layout.read(other) is None, 'another layout or length'
    with pytest.raises(InvalidFeaturesError, match='x contains NaN or infinity'):
        layout.read(head + np.array([np.inf, 0.5]).tobytes(), error=InvalidFeaturesError, what='x')
