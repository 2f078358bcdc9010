"""Messages <-> core types: labelled Float64MultiArray <-> numpy, and the versioned model document.

Labelled arrays
---------------
An n-D array is published row-major with one ``MultiArrayDimension`` per axis. Each dimension's
``label`` names the entries along that axis, joined by commas: a vector over the 7 zones of three tasks
has one dimension labelled ``"U,T,H,UT,UH,TH,UTH"``; a task-by-task matrix has two dimensions, each
labelled ``"usage,transfer,handover"`` (axis 0 = rows). ``size`` is the axis length and ``stride`` the
number of values spanned by one step along the previous axis (ROS convention: ``dim[0].stride`` is the
total count). A message without dimensions (what ``ros2 topic pub "{data: [...]}"`` sends) is a flat
vector.

Model document (``model/active``, std_msgs/String)
--------------------------------------------------
Three header lines, then the YAML of :meth:`GraspModel.to_yaml`::

    # model_name: cup_7zone
    # model_version: 3
    # model_sha256: <sha256 of the YAML text that follows, hex>
    <GraspModel YAML>

The header lines are YAML comments, so ``GraspModel.from_yaml(msg.data)`` also reads the whole
text. ``model_version`` counts activations in one model server (1 = the first model it published);
it restarts at 1 when the server restarts. ``model_sha256`` identifies the content: a consumer that
must know whether the model changed compares (name, sha256); to order documents from one server it
compares versions.
"""

from __future__ import annotations

import array
import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from ..core.errors import GraspIntentError, ModelFormatError
from ..core.model import GraspModel

__all__ = [
    'MAX_ARRAY_SIZE',
    'join_labels',
    'split_labels',
    'array_to_msg',
    'msg_to_array',
    'msg_labels',
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


@dataclass(frozen=True)
class ModelDocument:
    """A model as published on ``model/active``: the model plus its name, version and content hash."""

    name: str
    version: int
    sha256: str
    model: GraspModel


_HEADER = re.compile(r'# model_name: (?P<name>[^\n]*)\n# model_version: (?P<version>[0-9]+)\n'
                     r'# model_sha256: (?P<sha>[0-9a-f]{64})\n')


def model_to_msg(model: GraspModel, *, name: str, version: int) -> String:
    """The model document (see module docstring) for ``model`` as a std_msgs/String."""
    if '\n' in name or version < 1:
        raise ValueError('name must be one line and version >= 1')
    body = model.to_yaml()
    sha = hashlib.sha256(body.encode()).hexdigest()
    return String(data=f'# model_name: {name}\n# model_version: {version}\n# model_sha256: {sha}\n{body}')


def model_from_msg(msg: String) -> ModelDocument:
    """Parse a model document.

    Raises
    ------
    ModelFormatError
        If the header is missing or malformed, the hash does not match the YAML, or the YAML is not a
        valid model (the reason from :meth:`GraspModel.from_yaml`).
    """
    header = _HEADER.match(msg.data)
    if header is None:
        raise ModelFormatError('model document lacks the header lines "# model_name: ...", '
                               '"# model_version: <n>", "# model_sha256: <hex>"')
    body = msg.data[header.end():]
    sha = hashlib.sha256(body.encode()).hexdigest()
    if sha != header['sha']:
        raise ModelFormatError(f'model document is corrupted: sha256 {sha} does not match the header')
    version = int(header['version'])
    if version < 1:
        raise ModelFormatError(f'model_version must be >= 1, got {version}')
    return ModelDocument(name=header['name'], version=version, sha256=sha,
                         model=GraspModel.from_yaml(body))
