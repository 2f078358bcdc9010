"""Messages <-> core types: labelled and stamped Float64MultiArray, the grasp posterior, the model document.

The layouts are defined, written and read in :mod:`grasp_intent_ros.wire.arrays` and
:mod:`grasp_intent_ros.wire.model_document` (ROS-free); this module
only builds the rclpy message objects from them. Readers need no message class: use
:func:`grasp_intent_ros.wire.arrays.msg_to_array` and friends on rclpy messages directly.
"""

from __future__ import annotations

import array
import functools
import importlib
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import ArrayLike, NDArray
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from ..errors import GraspIntentError, InvalidIntentError
from ..method.intent import MAX_TASKS, validate_v
from ..method.model import GraspModel
from ..wire.arrays import (
    MAX_ARRAY_SIZE,
    Posterior,
    RepeatedLayout,
    array_layout,
    msg_labels,
    msg_to_array,
    posterior_label,
    read_posterior,
    stamp_label,
    stamped_values,
)
from ..wire.model_document import ModelDocument, model_document, read_model_document
from ..wire.topics import MSGTYPES

__all__ = ['type_class', 'message_class', 'array_to_msg', 'SerializedArrays', 'target_from_msg', 'SerializedTargets',
           'stamped_array_to_msg',
           'stamped_array_from_msg', 'posterior_to_msg', 'posterior_from_msg', 'model_to_msg', 'model_from_msg']


def type_class(msgtype: str) -> Any:
    """The rclpy message class of a type name 'pkg/msg/Name'. Raises ImportError, AttributeError, ValueError."""
    package, kind, name = msgtype.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


@functools.lru_cache(maxsize=None)  # per message on the nodes' inputs (ros.inputs.decode_input)
def message_class(topic: str) -> Any:
    """The rclpy message class of a suite topic (:data:`grasp_intent_ros.wire.topics.MSGTYPES`).

    Raises
    ------
    KeyError
        For a topic that is not the suite's.
    """
    return type_class(MSGTYPES[topic])


def array_to_msg(values: ArrayLike, labels: Sequence[str | Sequence[str]]) -> Float64MultiArray:
    """A labelled Float64MultiArray of ``values``: the one place the suite's arrays become messages.

    ``labels`` and their errors as for :func:`grasp_intent_ros.wire.arrays.array_layout`.

    Raises
    ------
    GraspIntentError
        If a value is NaN or infinite: a node never publishes one as a result (its guard reports the
        rejection on ``/diagnostics`` and nothing of that output is published).
    """
    arr = np.ascontiguousarray(values, dtype=np.float64)
    _check_output(arr)
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=label, size=size, stride=stride)
                      for label, size, stride in array_layout(arr.shape, labels)]
    msg.layout.data_offset = 0
    data = array.array('d')
    data.frombytes(arr.tobytes())
    msg.data = data
    return msg


def _check_output(arr: NDArray[np.float64]) -> None:
    if not np.isfinite(arr).all():
        raise GraspIntentError(f'not published: {int(np.count_nonzero(~np.isfinite(arr)))} of {arr.size} '
                               f'output values are NaN or infinite')


class SerializedArrays:
    """Serialized :func:`array_to_msg` messages of one shape and labels: the layout serialized once.

    For an output published at the rate of its input (the interpreter's v at up to 1 kHz): the message's
    serialized layout is kept, and each array is its values appended, ready for ``Publisher.publish``
    (which takes serialized bytes too). A subscriber decodes exactly ``array_to_msg(values, labels)``.

    Parameters
    ----------
    shape : tuple of int
    labels
        As for :func:`array_to_msg`.

    Raises
    ------
    ValueError
        As :func:`array_to_msg` for labels that do not fit ``shape``.
    """

    def __init__(self, shape: tuple[int, ...], labels: Sequence[str | Sequence[str]]) -> None:
        self.shape = shape
        probe = np.arange(1.0, 1.0 + int(np.prod(shape))).reshape(shape)  # no two values' bytes alike
        data = serialize_message(array_to_msg(probe, labels))
        tail = probe.astype('<f8').tobytes()
        if not data.endswith(tail):  # the values are last, little-endian (CDR_LE): so rclpy has always done
            raise RuntimeError('rclpy serialized a Float64MultiArray with its values not last or not little-endian')
        self._layout = data[:len(data) - len(tail)]

    def serialize(self, values: ArrayLike) -> bytes:
        """The serialized message of ``values`` (shape :attr:`shape`).

        Raises
        ------
        GraspIntentError
            If a value is NaN or infinite (as :func:`array_to_msg`).
        ValueError
            If ``values`` has another shape.
        """
        arr = np.asarray(values, dtype='<f8')
        if arr.shape != self.shape:
            raise ValueError(f'values of shape {arr.shape}, expected {self.shape}')
        _check_output(arr)
        return self._layout + arr.tobytes()


def stamped_array_to_msg(values: ArrayLike, labels: str | Sequence[str], *, stamp: Time) -> Float64MultiArray:
    """A 1-D array as a stamped Float64MultiArray (layout in :mod:`grasp_intent_ros.wire.arrays`).

    ``labels``: the value names (one per value) or a ready label string.
    """
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f'values must be 1-D, got shape {arr.shape}')
    return array_to_msg(arr[None, :], [stamp_label(stamp), labels])


def stamped_array_from_msg(msg: Float64MultiArray, *, max_size: int = MAX_ARRAY_SIZE,
                           what: str = 'array') -> tuple[Time, str, NDArray[np.float64]]:
    """(stamp, values label, values of shape (n,)) of a stamped array.

    Raises
    ------
    GraspIntentError
        If the layout is not (stamp axis of size 1, values axis) or the values are malformed.
    """
    values, label, stamp = stamped_values(msg, max_size=max_size, what=what)
    assert stamp is not None  # require_stamp=True
    return Time(sec=stamp[0], nanosec=stamp[1]), label, values


def posterior_to_msg(p: ArrayLike, w: ArrayLike, zone_labels: Sequence[str], task_names: Sequence[str], *,
                     stamp: Time) -> Float64MultiArray:
    """The ``grasp/posterior`` message (layout in :mod:`grasp_intent_ros.wire.arrays`)."""
    p_arr, w_arr = np.asarray(p, dtype=np.float64), np.asarray(w, dtype=np.float64)
    if p_arr.shape != (len(zone_labels),) or w_arr.shape != (len(task_names),):
        raise ValueError(f'p {p_arr.shape} / w {w_arr.shape} do not match {len(zone_labels)} zones / '
                         f'{len(task_names)} tasks')
    return stamped_array_to_msg(np.concatenate([p_arr, w_arr]), posterior_label(zone_labels, task_names),
                                stamp=stamp)


def posterior_from_msg(msg: Float64MultiArray) -> Posterior[Time]:
    """Parse a ``grasp/posterior`` message (stamp required). Raises GraspIntentError for another layout."""
    post = read_posterior(msg, require_stamp=True, what='posterior')
    assert post.stamp is not None  # require_stamp=True
    return Posterior(Time(sec=post.stamp.sec, nanosec=post.stamp.nanosec), post.zone_labels, post.p,
                     post.task_names, post.w)



def target_from_msg(msg: Float64MultiArray) -> tuple[NDArray[np.float64], tuple[str, ...] | None]:
    """A target vector v from ``intent/v``: its values and zone labels (None without a label).

    Raises
    ------
    InvalidIntentError
        For a malformed array, or a v that is not a probability vector naming each value once
        (:func:`grasp_intent_ros.method.intent.validate_v`).
    """
    labels = msg_labels(msg)[0] if msg.layout.dim and msg.layout.dim[0].label else None
    values = msg_to_array(msg, max_size=(1 << MAX_TASKS) - 1, error=InvalidIntentError, what='v')
    return validate_v(values, labels), labels


class SerializedTargets:
    """:func:`target_from_msg` of serialized ``intent/v`` messages, each layout decoded once.

    An ``intent/v`` stream repeats its layout (the zone labels) message after message: a message with the
    bytes of the last decoded layout is read in place (:class:`grasp_intent_ros.wire.arrays.RepeatedLayout`)
    and its values checked as :func:`target_from_msg` checks them; any other message is decoded by
    ``decode`` and read by :func:`target_from_msg`. The same v, labels and errors either way.

    Parameters
    ----------
    decode : callable
        ``decode(data) -> Float64MultiArray`` (e.g. :func:`grasp_intent_ros.ros.inputs.decode_input`).
    """

    def __init__(self, decode: Callable[[bytes], Float64MultiArray]) -> None:
        self._decode = decode
        self._layout: RepeatedLayout[tuple[str, ...] | None] = RepeatedLayout()

    def __call__(self, data: bytes) -> tuple[NDArray[np.float64], tuple[str, ...] | None]:
        """(v, zone labels or None) of a serialized ``intent/v``. Raises as :func:`target_from_msg` and ``decode``."""
        if (known := self._layout.read(data, error=InvalidIntentError, what='v')) is not None:
            values, labels = known  # a layout target_from_msg read: its size and labels fit
            return validate_v(values, labels), labels
        v, labels = target_from_msg(self._decode(data))
        self._layout.learn(data, v, labels)
        return v, labels


def model_to_msg(model: GraspModel, *, name: str, version: int) -> String:
    """The model document (:func:`grasp_intent_ros.wire.model_document.model_document`) as a std_msgs/String.

    Raises
    ------
    ValueError
        If ``name`` spans several lines or ``version < 1``.
    """
    return String(data=model_document(model, name=name, version=version))


def model_from_msg(msg: String) -> ModelDocument:
    """Parse a model document (:func:`grasp_intent_ros.wire.model_document.read_model_document`).

    Raises
    ------
    ModelFormatError
        If the header is missing or malformed, the hash does not match the YAML, or the YAML is not a
        valid model (the reason from :meth:`GraspModel.from_yaml`).
    """
    return read_model_document(msg.data)
