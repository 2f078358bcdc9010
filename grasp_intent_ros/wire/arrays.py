"""Float64MultiArray layouts: labelled arrays, stamped arrays, the grasp posterior and features, and the CDR fast path.

ROS-free: the writers return plain values and the readers take any object with the message's fields
(rclpy messages and rosbags-decoded ones alike).

Labelled arrays (std_msgs/Float64MultiArray)
--------------------------------------------
An n-D array is published row-major with one ``MultiArrayDimension`` per axis. Each dimension's
``label`` names the entries along that axis, joined by commas: a vector over the 7 zones of three tasks
has one dimension labelled ``"U,T,H,UT,UH,TH,UTH"``; a task-by-task matrix has two dimensions, each
labelled ``"usage,transfer,handover"`` (axis 0 = rows). ``size`` is the axis length and ``stride`` the
number of values spanned by one step along the previous axis (ROS convention: ``dim[0].stride`` is the
total count). A message without dimensions (what ``ros2 topic pub "{data: [...]}"`` sends) is a flat
vector. :func:`array_layout` writes the dimensions, :func:`msg_to_array` reads the values;
:func:`serialized_vector` reads such a flat vector straight from its serialized (CDR) bytes, without
building a message (the interpreter's 1 kHz input), and :class:`RepeatedLayout` the values of a stream
whose layout repeats.

Stamped arrays
--------------
std_msgs/Float64MultiArray has no header. An output array that must be paired with stamped outputs of
the same computation gets a leading axis of size 1 whose label is the stamp,
``"stamp=<sec>.<nanosec, 9 digits>"`` (:func:`stamp_label`); the second axis holds the values, labelled
with their names: ``dim[0] = (label "stamp=...", size 1, stride n)``, ``dim[1] = (names, size n,
stride n)``, and the data are the n values (read by :func:`stamped_values`).

Grasp posterior (``grasp/posterior``)
-------------------------------------
A stamped array whose n = K + m values are P(zone | x) over the model's K zones followed by the m
principal-task probabilities w reconstructed from P. The values' label is the comma-joined zone labels,
``|``, the comma-joined task names: ``"U,T,H,UT,UH,TH,UTH|usage,transfer,handover"``
(:func:`posterior_label`, :func:`read_posterior`). ``grasp/features`` is a stamped array of the grasp's
features, labelled with their names (:func:`read_features`).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final, Generic, NamedTuple, TypeVar, cast

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..method.features import MICO_3F

__all__ = [
    'MAX_ARRAY_SIZE', 'join_labels', 'split_labels', 'array_layout', 'msg_to_array', 'serialized_vector',
    'RepeatedLayout', 'msg_labels',
    'Stamp', 'stamp_label', 'stamped_values', 'posterior_label', 'split_posterior', 'Posterior',
    'read_posterior', 'read_features', 'read_object_probabilities',
]

MAX_ARRAY_SIZE: Final = 65536
"""Default limit on the number of values accepted from an incoming array."""


def join_labels(names: Sequence[str]) -> str:
    """Comma-joined label of one dimension.

    Raises
    ------
    ValueError
        For a name containing a comma.
    """
    bad = [n for n in names if ',' in n]
    if bad:
        raise ValueError(f'labels must not contain commas: {bad}')
    return ','.join(names)


def split_labels(label: str) -> tuple[str, ...]:
    """Inverse of :func:`join_labels` ('' -> ())."""
    return tuple(label.split(',')) if label else ()


def array_layout(shape: Sequence[int], labels: Sequence[str | Sequence[str]]) -> list[tuple[str, int, int]]:
    """The dimensions ``(label, size, stride)`` of a row-major array of ``shape``.

    Parameters
    ----------
    shape : sequence of int, length k
    labels : sequence of length k
        Per axis, the entry names (a sequence of n_i strings, joined with commas) or a ready label
        string (used as is).

    Raises
    ------
    ValueError
        If the number of labels differs from the number of axes, or a name list has the wrong length.
    """
    if len(labels) != len(shape):
        raise ValueError(f'{len(labels)} labels for an array with {len(shape)} axes')
    dims = []
    stride = int(np.prod(shape))
    for size, label in zip(shape, labels):
        if not isinstance(label, str):
            if len(label) != size:
                raise ValueError(f'{len(label)} names for an axis of size {size}')
            label = join_labels(label)
        dims.append((label, int(size), stride))
        stride = stride // size if size else 0
    return dims


def msg_to_array(msg: Any, *, max_size: int = MAX_ARRAY_SIZE, ndim: int | None = 1,
                 error: type[GraspIntentError] = GraspIntentError, what: str = 'array'
                 ) -> NDArray[np.float64]:
    """Validated values of an incoming Float64MultiArray, shaped by its layout.

    Parameters
    ----------
    msg : Float64MultiArray
        Or any object with ``.layout.dim[i].size``, ``.layout.data_offset`` and ``.data``.
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
    _check_size(n, max_size, error, what)
    dims = msg.layout.dim
    shape = tuple(int(d.size) for d in dims) if dims else (n,)
    if int(np.prod(shape)) != n:
        raise error(f'{what} has a malformed layout: dimension sizes {list(shape)} do not match '
                    f'{n} values')
    if ndim is not None and len(shape) != ndim:
        raise error(f'{what} must have {ndim} dimension(s), got {len(shape)}')
    arr = np.array(msg.data, dtype=np.float64)[offset:]  # array.array: read through the buffer protocol
    _check_finite(arr, error, what)
    return arr.reshape(shape)


def _check_size(n: int, max_size: int, error: type[GraspIntentError], what: str) -> None:
    if n <= 0:
        raise error(f'{what} is empty')
    if n > max_size:
        raise error(f'{what} is oversized: {n} values, the limit is {max_size}')


def _check_finite(arr: NDArray[np.float64], error: type[GraspIntentError], what: str) -> None:
    if not np.isfinite(arr).all():
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise error(f'{what} contains NaN or infinity (first at index {bad}: {arr[bad]})')


_CDR_LE = b'\x00\x01'
"""Encapsulation id of little-endian plain CDR, the first two bytes of a serialized ROS 2 message."""
_FLAT_VECTOR = struct.Struct('<III')
"""After the 4-byte encapsulation header: dimension count, data_offset, number of values."""


def serialized_vector(data: bytes, *, max_size: int = MAX_ARRAY_SIZE,
                      error: type[GraspIntentError] = GraspIntentError, what: str = 'array'
                      ) -> NDArray[np.float64] | None:
    """The values of a serialized flat Float64MultiArray, read in place; None for any other layout.

    A flat vector (no dimensions, ``data_offset`` 0, at least one value) in little-endian CDR is: the
    encapsulation header (4 bytes), the dimension count 0, ``data_offset`` 0 and the value count n (uint32
    each), 4 bytes of padding (doubles align to 8 from the end of the header), n doubles. Its values are
    exactly those of :func:`msg_to_array` on the decoded message, with the same checks.

    Parameters
    ----------
    data : bytes
        A serialized std_msgs/Float64MultiArray.
    max_size, error, what
        As for :func:`msg_to_array`.

    Returns
    -------
    ndarray, shape (n,), read-only, or None
        None when ``data`` is not a flat vector in little-endian CDR (dimensions, an offset, no value,
        another encoding, or a length that does not match n): decode the message and use
        :func:`msg_to_array` instead, which reads and checks every layout.

    Raises
    ------
    error
        If the vector holds more than ``max_size`` values, or a NaN or infinity.
    """
    if len(data) < 28 or data[:2] != _CDR_LE:  # 28: header, three counts, padding, one value
        return None
    dims, offset, n = _FLAT_VECTOR.unpack_from(data, 4)
    if dims or offset or n == 0 or len(data) != 20 + 8 * n:
        return None
    _check_size(n, max_size, error, what)
    arr: NDArray[np.float64] = np.frombuffer(data, dtype='<f8', count=n, offset=20)
    _check_finite(arr, error, what)
    return arr


L = TypeVar('L')


class RepeatedLayout(Generic[L]):
    """The values of serialized 1-D Float64MultiArrays whose layout repeats, read in place.

    A stream from one publisher (the interpreter's ``intent/v``) repeats the same layout (dimension, label,
    ``data_offset``) with every message; only the values change. After :meth:`learn` has seen one message
    decoded, :meth:`read` takes the values of every later message whose bytes before its values are the same,
    with what was decoded from them (``info``, e.g. the labels), instead of decoding the message again. Equal
    bytes decode to the same layout; a message whose padding bytes differ (CDR leaves them uninitialised) is
    merely decoded again. The values are checked as :func:`msg_to_array` checks those of a message of the
    learnt layout (finite; its size and shape were checked when it was learnt).
    """

    def __init__(self) -> None:
        self._head = b''
        self._n = 0
        self._info: L | None = None

    def read(self, data: bytes, *, error: type[GraspIntentError] = GraspIntentError, what: str = 'array'
             ) -> tuple[NDArray[np.float64], L] | None:
        """(values, shape (n,), read-only; the learnt ``info``) if ``data`` has the learnt layout, else None.

        Raises
        ------
        error
            If a value is NaN or infinite (as :func:`msg_to_array`, ``what`` naming the values).
        """
        n, head = self._n, self._head
        if n and len(data) == len(head) + 8 * n and data.startswith(head):
            values: NDArray[np.float64] = np.frombuffer(data, dtype='<f8', count=n, offset=len(head))
            _check_finite(values, error, what)
            return values, cast(L, self._info)  # learnt with the layout
        return None

    def learn(self, data: bytes, values: NDArray[np.float64], info: L) -> None:
        """Learn the layout of ``data``, whose decoded values are ``values`` (shape (n,)), with ``info``.

        Only when the values are the last 8 n bytes of ``data``, little-endian CDR, as rclpy writes them;
        else :meth:`read` keeps returning None for such messages.
        """
        n = values.size
        if values.ndim == 1 and 0 < 8 * n < len(data) and data[:2] == _CDR_LE and np.array_equal(
                np.frombuffer(data, dtype='<f8', count=n, offset=len(data) - 8 * n), values):
            self._head, self._n, self._info = data[:len(data) - 8 * n], n, info


def msg_labels(msg: Any) -> tuple[tuple[str, ...], ...]:
    """Entry names per axis of a Float64MultiArray, from the dimension labels."""
    return tuple(split_labels(str(d.label)) for d in msg.layout.dim)


class Stamp(NamedTuple):
    """A ``builtin_interfaces/Time`` as plain integers (also compares equal to ``(sec, nanosec)``)."""

    sec: int
    nanosec: int


def stamp_label(stamp: Any) -> str:
    """``"stamp=<sec>.<nanosec>"`` with 9 nanosecond digits, of anything with ``.sec`` and ``.nanosec``."""
    return f'stamp={int(stamp.sec)}.{int(stamp.nanosec):09d}'


def _parse_stamp_label(label: str) -> Stamp:
    sec, dot, nanosec = label.removeprefix('stamp=').partition('.')
    if not label.startswith('stamp=') or not dot or not sec.isdigit() or not nanosec.isdigit() \
            or len(nanosec) != 9:
        raise GraspIntentError(f'expected a stamp label "stamp=<sec>.<9-digit nanosec>", got {label!r}')
    return Stamp(int(sec), int(nanosec))


def stamped_values(msg: Any, *, max_size: int = MAX_ARRAY_SIZE, what: str = 'array',
                   require_stamp: bool = True) -> tuple[NDArray[np.float64], str, Stamp | None]:
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
    stamp : Stamp or None

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


def posterior_label(zone_labels: Sequence[str], task_names: Sequence[str]) -> str:
    """The values label of a grasp posterior: ``"<zones>|<tasks>"``. Raises ValueError for a comma in a name."""
    return f'{join_labels(zone_labels)}|{join_labels(task_names)}'


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


S = TypeVar('S')


@dataclass(frozen=True)
class Posterior(Generic[S]):
    """The content of ``grasp/posterior``.

    Attributes
    ----------
    stamp : S
        Stamp of the plan (:class:`Stamp`, None for an unstamped array, or a ``builtin_interfaces/Time``
        from :func:`grasp_intent_ros.ros.conversions.posterior_from_msg`).
    zone_labels : tuple of str, length K
    p : ndarray, shape (K,)
        P(zone | x) of the planned grasp.
    task_names : tuple of str, length m
    w : ndarray, shape (m,)
        Principal-task probabilities reconstructed from p.
    """

    stamp: S
    zone_labels: tuple[str, ...]
    p: NDArray[np.float64]
    task_names: tuple[str, ...]
    w: NDArray[np.float64]


def read_posterior(msg: Any, *, require_stamp: bool = False, what: str = 'grasp/posterior'
                   ) -> Posterior[Stamp | None]:
    """Parse a ``grasp/posterior`` Float64MultiArray (layout in the module docstring).

    Raises
    ------
    GraspIntentError
        Wrong shape, NaN/Inf, a malformed stamp label, or a values label other than "<zones>|<tasks>"
        naming all values.
    """
    values, label, stamp = stamped_values(msg, what=what, require_stamp=require_stamp)
    zones, p, tasks, w = split_posterior(values, label, what=what)
    return Posterior(stamp, zones, p, tasks, w)


def read_features(msg: Any, *, what: str = 'grasp/features') -> tuple[NDArray[np.float64], Stamp | None]:
    """(x, stamp) of a ``grasp/features`` array: x in :data:`~grasp_intent_ros.method.features.MICO_3F` order.

    The values are reordered by their labels when these name every feature; unlabelled (or 1-D) values are
    taken by position. The stamp is None for an unstamped array.

    Raises
    ------
    GraspIntentError
        Malformed values (see :func:`stamped_values`), or not :data:`MICO_3F.dim` values when unlabelled.
    """
    x, label, stamp = stamped_values(msg, what=what, require_stamp=False)
    names = split_labels(label)
    if set(MICO_3F.names) <= set(names) and len(names) == x.size:
        x = x[[names.index(n) for n in MICO_3F.names]]
    elif x.size != MICO_3F.dim:
        raise GraspIntentError(f'{what} must have {MICO_3F.dim} values, got {x.size}')
    return x, stamp


def read_object_probabilities(msg: Any, names: Sequence[str]) -> dict[str, float]:
    """P(o) by object name from an ``intent/objects`` message (one value per label) of a scene of objects ``names``.

    Raises
    ------
    GraspIntentError
        Unless the values are one dimension labelled with as many object names, each in [0, 1] and each in ``names``.
    """
    values = msg_to_array(msg, what='intent/objects')
    labels = msg_labels(msg)
    if len(labels) != 1 or len(labels[0]) != values.size:
        raise GraspIntentError(f'intent/objects: {values.size} values need one dimension labelled with as many '
                               f'object names (got {list(labels)})')
    if np.any((values < 0.0) | (values > 1.0)):
        raise GraspIntentError(f'intent/objects: probabilities outside [0, 1]: {values.tolist()}')
    unknown = [name for name in labels[0] if name not in names]
    if unknown:
        raise GraspIntentError(f'intent/objects names objects not in this scene: {unknown} (the scene: {list(names)})')
    return dict(zip(labels[0], values.tolist()))
