"""Messages <-> core types: labelled Float64MultiArray <-> numpy, stamped arrays, the model document.

Labelled arrays
---------------
An n-D array is published row-major with one ``MultiArrayDimension`` per axis. Each dimension's
``label`` names the entries along that axis, joined by commas: a vector over the 7 zones of three tasks
has one dimension labelled ``"U,T,H,UT,UH,TH,UTH"``; a task-by-task matrix has two dimensions, each
labelled ``"usage,transfer,handover"`` (axis 0 = rows). ``size`` is the axis length and ``stride`` the
number of values spanned by one step along the previous axis (ROS convention: ``dim[0].stride`` is the
total count). A message without dimensions (what ``ros2 topic pub "{data: [...]}"`` sends) is a flat
vector.

Stamped arrays
--------------
std_msgs/Float64MultiArray has no header. An output array that must be paired with stamped outputs of
the same computation gets a leading axis of size 1 whose label is the stamp,
``"stamp=<sec>.<nanosec, 9 digits>"``; the second axis holds the values, labelled with their names.
The layout is then ``dim[0] = (label "stamp=...", size 1, stride n)``, ``dim[1] = (names, size n,
stride n)``, and the data are the n values (written by
:func:`grasp_intent_ros.ros.robot.stamped_array_to_msg`, read by :func:`stamped_values`).

Grasp posterior (``grasp/posterior``)
-------------------------------------
A stamped array whose n = K + m values are P(zone | x) over the model's K zones followed by the m
principal-task probabilities w reconstructed from P. The values' label is the comma-joined zone labels,
``|``, the comma-joined task names: ``"U,T,H,UT,UH,TH,UTH|usage,transfer,handover"``
(:func:`split_posterior`).

The readers here take any object with ``.layout.dim[i].label``/``.size``, ``.layout.data_offset`` and
``.data``: rclpy messages and rosbags-decoded ones alike.

Model document (``model/active``, std_msgs/String)
--------------------------------------------------
The text of :func:`grasp_intent_ros.core.model.model_document`: three header lines (model name, version,
sha256 of the YAML that follows), then the YAML of :meth:`GraspModel.to_yaml`. ``model_version`` counts
activations in one model server (1 = the first model it published); it restarts at 1 when the server
restarts. ``model_sha256`` identifies the content: a consumer that must know whether the model changed
compares (name, sha256); to order documents from one server it compares versions.
"""

from __future__ import annotations

import array
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from ..core.errors import GraspIntentError
from ..core.model import GraspModel, model_document, parse_model_document

__all__ = [
    'MAX_ARRAY_SIZE',
    'join_labels',
    'split_labels',
    'array_to_msg',
    'msg_to_array',
    'msg_labels',
    'stamped_values',
    'split_posterior',
    'ModelDocument',
    'model_to_msg',
    'model_from_msg',
]

MAX_ARRAY_SIZE = 65536
"""Default limit on the number of values accepted from an incoming array."""


def join_labels(names: Sequence[str]) -> str:
    """Comma-joined label of one dimension. Raises ValueError for a name containing a comma."""
    bad = [n for n in names if ',' in n]
    if bad:
        raise ValueError(f'labels must not contain commas: {bad}')
    return ','.join(names)


def split_labels(label: str) -> tuple[str, ...]:
    """Inverse of :func:`join_labels` ('' -> ())."""
    return tuple(label.split(',')) if label else ()


def array_to_msg(values: ArrayLike, labels: Sequence[str | Sequence[str]]) -> Float64MultiArray:
    """A labelled Float64MultiArray from an array.

    Parameters
    ----------
    values : array_like, shape (n_0, ..., n_{k-1})
    labels : sequence of length k
        Per axis, the entry names (a sequence of n_i strings, joined with commas) or a ready label
        string (used as is).

    Raises
    ------
    ValueError
        If the number of labels differs from the number of axes, or a name list has the wrong length.
    """
    arr = np.ascontiguousarray(values, dtype=np.float64)
    if len(labels) != arr.ndim:
        raise ValueError(f'{len(labels)} labels for an array with {arr.ndim} axes')
    msg = Float64MultiArray()
    stride = arr.size
    for size, label in zip(arr.shape, labels):
        if not isinstance(label, str):
            if len(label) != size:
                raise ValueError(f'{len(label)} names for an axis of size {size}')
            label = join_labels(label)
        msg.layout.dim.append(MultiArrayDimension(label=label, size=size, stride=stride))
        stride = stride // size if size else 0
    msg.layout.data_offset = 0
    data = array.array('d')
    data.frombytes(arr.tobytes())
    msg.data = data
    return msg


def msg_to_array(msg: Float64MultiArray, *, max_size: int = MAX_ARRAY_SIZE, ndim: int | None = 1,
                 error: type[GraspIntentError] = GraspIntentError, what: str = 'array'
                 ) -> NDArray[np.float64]:
    """Validated values of an incoming Float64MultiArray, shaped by its layout.

    Parameters
    ----------
    msg : Float64MultiArray
    max_size : int
        Largest number of values accepted.
    ndim : int or None
        Required number of axes (a message without dimensions counts as 1-D); None accepts any.
    error : subclass of GraspIntentError
        Raised for every problem, e.g. InvalidIntentError for w, InvalidFeaturesError for x.
    what : str
        Name of the quantity in error messages ('w', 'x').

    Returns
    -------
    ndarray, shape given by ``layout.dim`` sizes (or (n,) without dimensions)

    Raises
    ------
    error
        If the array is empty, holds more than ``max_size`` values, has a layout inconsistent with
        its data, has the wrong number of axes, or holds a NaN or infinity.
    """
    offset = int(msg.layout.data_offset)
    n = len(msg.data) - offset
    if n <= 0:
        raise error(f'{what} is empty')
    if n > max_size:
        raise error(f'{what} is oversized: {n} values, the limit is {max_size}')
    dims = msg.layout.dim
    shape = tuple(int(d.size) for d in dims) if dims else (n,)
    if int(np.prod(shape)) != n:
        raise error(f'{what} has a malformed layout: dimension sizes {list(shape)} do not match '
                    f'{n} values')
    if ndim is not None and len(shape) != ndim:
        raise error(f'{what} must have {ndim} dimension(s), got {len(shape)}')
    arr = np.array(msg.data, dtype=np.float64)[offset:]  # array.array: read through the buffer protocol
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise error(f'{what} contains NaN or infinity (first at index {bad}: {arr[bad]})')
    return arr.reshape(shape)


def msg_labels(msg: Float64MultiArray) -> tuple[tuple[str, ...], ...]:
    """Entry names per axis, from the dimension labels."""
    return tuple(split_labels(d.label) for d in msg.layout.dim)


def _parse_stamp_label(label: str) -> tuple[int, int]:
    sec, dot, nanosec = label.removeprefix('stamp=').partition('.')
    if not label.startswith('stamp=') or not dot or not sec.isdigit() or not nanosec.isdigit() \
            or len(nanosec) != 9:
        raise GraspIntentError(f'expected a stamp label "stamp=<sec>.<9-digit nanosec>", got {label!r}')
    return int(sec), int(nanosec)


def stamped_values(msg: Float64MultiArray, *, max_size: int = MAX_ARRAY_SIZE, what: str = 'array',
                   require_stamp: bool = True
                   ) -> tuple[NDArray[np.float64], str, tuple[int, int] | None]:
    """Values, values label and stamp of a stamped array (layout in the module docstring).

    Parameters
    ----------
    msg : Float64MultiArray (or a rosbags-decoded one)
    max_size, what
        As for :func:`msg_to_array`.
    require_stamp : bool
        False also accepts a 1-D array (its ``dim[0]`` label, '' without dimensions; stamp None).

    Returns
    -------
    values : ndarray, shape (n,)
    label : str
        Label of the values axis.
    stamp : (sec, nanosec) or None

    Raises
    ------
    GraspIntentError
        If the layout is not (stamp axis of size 1, values axis), the stamp label is malformed, or
        the values are malformed (see :func:`msg_to_array`).
    """
    arr = msg_to_array(msg, max_size=max_size, ndim=2 if require_stamp else None, what=what)
    if arr.ndim == 1:
        return arr, str(msg.layout.dim[0].label) if msg.layout.dim else '', None
    if arr.ndim != 2:
        raise GraspIntentError(f'{what} must have shape (1, n) or (n,), got {arr.shape}')
    if arr.shape[0] != 1:
        raise GraspIntentError(f'{what}: the stamp axis must have size 1, got shape {arr.shape}')
    return arr[0], str(msg.layout.dim[1].label), _parse_stamp_label(str(msg.layout.dim[0].label))


def split_posterior(values: NDArray[np.float64], label: str, *, what: str = 'grasp/posterior'
                    ) -> tuple[tuple[str, ...], NDArray[np.float64], tuple[str, ...], NDArray[np.float64]]:
    """(zone labels (K,), P shape (K,), task names (m,), w shape (m,)) of the values of a grasp posterior.

    Raises
    ------
    GraspIntentError
        If ``label`` is not "<zones>|<tasks>" naming all ``values``.
    """
    zones_part, bar, tasks_part = label.partition('|')
    zones, tasks = split_labels(zones_part), split_labels(tasks_part)
    if not bar or not zones or not tasks or len(zones) + len(tasks) != values.size:
        raise GraspIntentError(f'{what} label must be "<zones>|<tasks>" naming all {values.size} values, '
                               f'got {label!r}')
    return zones, values[:len(zones)], tasks, values[len(zones):]


@dataclass(frozen=True)
class ModelDocument:
    """A model as published on ``model/active``: the model plus its name, version and content hash."""

    name: str
    version: int
    sha256: str
    model: GraspModel


def model_to_msg(model: GraspModel, *, name: str, version: int) -> String:
    """The model document (:func:`~grasp_intent_ros.core.model.model_document`) as a std_msgs/String.

    Raises ValueError if ``name`` spans several lines or ``version < 1``.
    """
    return String(data=model_document(model, name=name, version=version))


def model_from_msg(msg: String) -> ModelDocument:
    """Parse a model document (:func:`~grasp_intent_ros.core.model.parse_model_document`).

    Raises
    ------
    ModelFormatError
        If the header is missing or malformed, the hash does not match the YAML, or the YAML is not a
        valid model (the reason from :meth:`GraspModel.from_yaml`).
    """
    header, body = parse_model_document(msg.data)
    return ModelDocument(name=header.name, version=header.version, sha256=header.sha256,
                         model=GraspModel.from_yaml(body))
