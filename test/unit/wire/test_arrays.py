"""grasp_intent_ros.wire.arrays: array layouts, stamped arrays, the grasp posterior, repeated layouts read in place.

Messages are plain objects with the message's fields (:class:`types.SimpleNamespace`): the readers take
rclpy and rosbags messages alike and need neither.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from grasp_intent_ros.errors import InvalidFeaturesError
from grasp_intent_ros.method.intent import reconstruct_w
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.wire import arrays
from grasp_intent_ros.wire.arrays import read_posterior, stamped_values

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


def test_array_layout_and_reading() -> None:
    assert arrays.array_layout((2, 3), [('a', 'b'), 'x,y,z']) == [('a,b', 2, 6), ('x,y,z', 3, 3)]
    with pytest.raises(ValueError, match='3 names for an axis of size 2'):
        arrays.array_layout((2,), [('a', 'b', 'c')])
    with pytest.raises(ValueError, match='must not contain commas'):
        arrays.join_labels(['a,b'])
    msg = array([9.0, 1.0, 2.0, 3.0, 4.0], ('r', 2, 4), ('c', 2, 2), offset=1)
    assert arrays.msg_to_array(msg, ndim=2).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert arrays.msg_labels(msg) == (('r',), ('c',))
    for bad, match in ((array([]), 'empty'), (array([1.0, np.nan]), 'NaN'), (array([1.0, 2.0], ('a', 3, 3)),
                       'malformed layout'), (array([1.0] * 5), 'oversized')):
        with pytest.raises(InvalidFeaturesError, match=match):
            arrays.msg_to_array(bad, max_size=4, error=InvalidFeaturesError, what='x')


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


def test_repeated_layout_reads_only_the_bytes_it_learnt() -> None:
    layout: arrays.RepeatedLayout[str] = arrays.RepeatedLayout()
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
