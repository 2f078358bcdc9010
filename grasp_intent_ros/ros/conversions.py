"""Messages <-> core types: labelled and stamped Float64MultiArray, the grasp posterior, the model document.

The layouts are defined, written and read in :mod:`grasp_intent_ros.protocol` (ROS-free); this module
only builds the rclpy message objects from them. Readers need no message class: use
:func:`grasp_intent_ros.protocol.msg_to_array` and friends on rclpy messages directly.
"""

from __future__ import annotations

import array
import importlib
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import ArrayLike, NDArray
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from ..core.errors import GraspIntentError, InvalidIntentError
from ..core.intent import MAX_TASKS, validate_v
from ..core.model import GraspModel
from ..protocol import (
    MAX_ARRAY_SIZE,
    MSGTYPES,
    ModelDocument,
    Posterior,
    array_layout,
    model_document,
    msg_labels,
    msg_to_array,
    posterior_label,
    read_model_document,
    read_posterior,
    stamp_label,
    stamped_values,
)

__all__ = ['message_class', 'array_to_msg', 'target_from_msg', 'stamped_array_to_msg', 'stamped_array_from_msg',
           'posterior_to_msg', 'posterior_from_msg', 'model_to_msg', 'model_from_msg']


def message_class(topic: str) -> Any:
    """The rclpy message class of a suite topic (:data:`grasp_intent_ros.protocol.MSGTYPES`).

    Raises
    ------
    KeyError
        For a topic that is not the suite's.
    """
    package, _, name = MSGTYPES[topic].split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)


def array_to_msg(values: ArrayLike, labels: Sequence[str | Sequence[str]]) -> Float64MultiArray:
    """A labelled Float64MultiArray of ``values``: the one place the suite's arrays become messages.

    ``labels`` and their errors as for :func:`grasp_intent_ros.protocol.array_layout`.

    Raises
    ------
    GraspIntentError
        If a value is NaN or infinite: a node never publishes one as a result (its guard reports the
        rejection on ``/diagnostics`` and nothing of that output is published).
    """
    arr = np.ascontiguousarray(values, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise GraspIntentError(f'not published: {int(np.count_nonzero(~np.isfinite(arr)))} of {arr.size} '
                               f'output values are NaN or infinite')
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=label, size=size, stride=stride)
                      for label, size, stride in array_layout(arr.shape, labels)]
    msg.layout.data_offset = 0
    data = array.array('d')
    data.frombytes(arr.tobytes())
    msg.data = data
    return msg


def stamped_array_to_msg(values: ArrayLike, labels: str | Sequence[str], *, stamp: Time) -> Float64MultiArray:
    """A 1-D array as a stamped Float64MultiArray (layout in :mod:`grasp_intent_ros.protocol`).

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
    """The ``grasp/posterior`` message (layout in :mod:`grasp_intent_ros.protocol`)."""
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
        (:func:`grasp_intent_ros.core.intent.validate_v`).
    """
    labels = msg_labels(msg)[0] if msg.layout.dim and msg.layout.dim[0].label else None
    values = msg_to_array(msg, max_size=(1 << MAX_TASKS) - 1, error=InvalidIntentError, what='v')
    return validate_v(values, labels), labels


def model_to_msg(model: GraspModel, *, name: str, version: int) -> String:
    """The model document (:func:`grasp_intent_ros.protocol.model_document`) as a std_msgs/String.

    Raises
    ------
    ValueError
        If ``name`` spans several lines or ``version < 1``.
    """
    return String(data=model_document(model, name=name, version=version))


def model_from_msg(msg: String) -> ModelDocument:
    """Parse a model document (:func:`grasp_intent_ros.protocol.read_model_document`).

    Raises
    ------
    ModelFormatError
        If the header is missing or malformed, the hash does not match the YAML, or the YAML is not a
        valid model (the reason from :meth:`GraspModel.from_yaml`).
    """
    return read_model_document(msg.data)
