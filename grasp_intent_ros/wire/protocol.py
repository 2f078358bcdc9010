"""The node suite's wire formats, once.

Topics and their message types, array layouts, the model document, diagnostics keys and levels.

ROS-free: the writers return plain values and the readers take any object with the message's fields
(rclpy messages and rosbags-decoded ones alike), so :mod:`grasp_intent_ros.ros`, the session tools, the
report and the tests all read and write through this module. Never imports rclpy or
:mod:`grasp_intent_ros.ros`.

Topics
------
:data:`MSGTYPES` maps every topic of the suite (relative names; ``/diagnostics`` is absolute) to its
message type. :data:`INPUT_TOPICS` are the inputs a replay publishes again, :data:`PLAN_TOPICS` the
outputs of one plan (one stamp), :data:`OUTPUT_TOPICS` the outputs a replay compares.

Input caps
----------
:data:`MAX_MESSAGE_BYTES` caps the serialized size of a message on each input topic (checked before the
message is decoded, :func:`check_message_size`); :data:`MAX_JOINTS` and :data:`MAX_NAME_LENGTH` bound a
joint state's names (:func:`check_names`), :data:`MAX_FEATURES` a feature vector.

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
building a message (the interpreter's 1 kHz input).

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
(:func:`posterior_label`, :func:`read_posterior`).

Model document (``model/active``, std_msgs/String)
--------------------------------------------------
Three header lines (model name, version, sha256 of the YAML that follows), then the YAML of
:meth:`~grasp_intent_ros.method.model.GraspModel.to_yaml` (:func:`model_document`). ``model_version``
counts activations in one model server (1 = the first model it published); it restarts at 1 when the
server restarts. ``model_sha256`` identifies the content: a consumer that must know whether the model
changed compares (name, sha256); to order documents from one server it compares versions.
A document holds at most :data:`~grasp_intent_ros.method.safe_yaml.MAX_DOCUMENT_CHARS` characters (checked on
the raw text before the header is matched or the body hashed) and its YAML no alias (``*name``): readers
reject both (:meth:`~grasp_intent_ros.method.model.GraspModel.from_yaml`).

Diagnostics (``/diagnostics``, diagnostic_msgs/DiagnosticArray)
---------------------------------------------------------------
Each node component publishes one status named ``"<node fully-qualified name>: <component>"`` whose
values carry the keys ``KEY_*`` below; levels are :data:`OK`, :data:`WARN`, :data:`ERROR`, :data:`STALE`
(rclpy gives them as a 1-byte ``bytes``: :func:`level_value`).

One module by design: every wire format once, in the order of this specification, so that a change to one
is read beside the others it must agree with (each section below is short).
"""

from __future__ import annotations

import hashlib
import math
import re
import struct
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final, Generic, NamedTuple, TypeVar, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GraspIntentError, KinematicsError, ModelError, ModelFormatError
from ..method.features import MICO_3F
from ..method.model import GraspModel, ModelRequirements
from ..method.safe_yaml import MAX_DOCUMENT_CHARS, check_document_size
from ..mico.frames import pose_to_matrix

__all__ = [
    'INTENT_W', 'INTENT_V', 'INTENT_CLARIFICATION', 'MODEL_ACTIVE', 'MODEL_AMBIGUITY',
    'MODEL_AMBIGUITY_SYMMETRIC', 'MODEL_AMBIGUITY_PINSKER', 'MODEL_QUERY', 'MODEL_POSTERIOR',
    'OBJECT_POSE', 'JOINT_STATES', 'GRASP_POSE', 'GRASP_JOINT_TARGETS', 'GRASP_TRAJECTORY',
    'GRASP_POSTERIOR', 'GRASP_FEATURES', 'GRASP_MARKERS', 'OPERATOR_TWIST', 'ASSISTANCE_TWIST', 'ASSISTANCE_ALPHA',
    'ARM_TRAJECTORY_COMMAND', 'ARM_TWIST_COMMAND', 'DIAGNOSTICS',
    'MSGTYPES', 'SHARED_CONTROL_TOPICS', 'INPUT_TOPICS', 'PLAN_TOPICS', 'OUTPUT_TOPICS',
    'MAX_ARRAY_SIZE', 'MAX_FEATURES', 'MAX_NAME_LENGTH', 'MAX_JOINTS', 'MAX_MESSAGE_BYTES', 'check_message_size',
    'check_names', 'join_labels', 'split_labels', 'array_layout', 'msg_to_array', 'serialized_vector',
    'RepeatedLayout', 'msg_labels',
    'Stamp', 'stamp_label', 'stamped_values', 'posterior_label', 'split_posterior', 'Posterior',
    'read_posterior', 'read_features',
    'QUATERNION_NORM_TOL', 'check_unit_quaternion', 'pose_msg_to_matrix', 'joint_positions',
    'ModelHeader', 'ModelDocument', 'model_document', 'parse_model_document', 'read_model_document',
    'OK', 'WARN', 'ERROR', 'STALE', 'LEVEL_NAMES', 'level_value', 'status_name', 'status_values',
    'KEY_RECEIVED', 'KEY_REJECTED', 'KEY_LAST_ERROR', 'KEY_PROCESSING_TIME', 'KEY_DROPPED', 'KEY_PLANS',
    'KEY_PLANNING_TIME', 'KEY_PLAN_STATUS', 'KEY_MODEL', 'KEY_CLARIFICATIONS', 'KEY_LAST_OUTCOME',
    'KEY_KERNELS_LOAD_TIME', 'KEY_KERNELS_LOADED_LATE', 'KEY_GOALS', 'ESTIMATOR_COMPONENT',
]

# ------------------------------------------------------------------------------------------ topics
INTENT_W: Final = 'intent/w'
INTENT_V: Final = 'intent/v'
INTENT_CLARIFICATION: Final = 'intent/clarification'
MODEL_ACTIVE: Final = 'model/active'
MODEL_AMBIGUITY: Final = 'model/ambiguity'
MODEL_AMBIGUITY_SYMMETRIC: Final = 'model/ambiguity/symmetric'
MODEL_AMBIGUITY_PINSKER: Final = 'model/ambiguity/pinsker'
MODEL_QUERY: Final = 'model/query'
MODEL_POSTERIOR: Final = 'model/posterior'
OBJECT_POSE: Final = 'object/pose'
JOINT_STATES: Final = 'joint_states'
GRASP_POSE: Final = 'grasp/pose'
GRASP_JOINT_TARGETS: Final = 'grasp/joint_targets'
GRASP_TRAJECTORY: Final = 'grasp/trajectory'
GRASP_POSTERIOR: Final = 'grasp/posterior'
GRASP_FEATURES: Final = 'grasp/features'
GRASP_MARKERS: Final = 'grasp/markers'
DIAGNOSTICS: Final = '/diagnostics'
OPERATOR_TWIST: Final = 'operator/twist'
"""The operator's twist (e.g. a spacemouse or joystick teleop), the assistance node's input."""
ASSISTANCE_TWIST: Final = 'assistance/twist'
"""The blended twist, for a servo (remap it to e.g. ``/servo_node/delta_twist_cmds``)."""
ASSISTANCE_ALPHA: Final = 'assistance/alpha'
"""The arbitration weight of each blended twist."""
ARM_TRAJECTORY_COMMAND: Final = 'arm_controller/joint_trajectory'
"""The mock arm's trajectory input (a joint_trajectory_controller's topic); the suite remaps it to grasp/trajectory."""
ARM_TWIST_COMMAND: Final = 'servo/delta_twist_cmds'
"""The mock arm's twist input (MoveIt Servo's topic); the suite remaps it to assistance/twist."""

_F64MA, _STRING = 'std_msgs/msg/Float64MultiArray', 'std_msgs/msg/String'
MSGTYPES: Final[Mapping[str, str]] = {
    INTENT_W: _F64MA,
    INTENT_V: _F64MA,
    INTENT_CLARIFICATION: _STRING,
    MODEL_ACTIVE: _STRING,
    MODEL_AMBIGUITY: _F64MA,
    MODEL_AMBIGUITY_SYMMETRIC: _F64MA,
    MODEL_AMBIGUITY_PINSKER: _F64MA,
    MODEL_QUERY: _F64MA,
    MODEL_POSTERIOR: _F64MA,
    OBJECT_POSE: 'geometry_msgs/msg/PoseStamped',
    JOINT_STATES: 'sensor_msgs/msg/JointState',
    GRASP_POSE: 'geometry_msgs/msg/PoseStamped',
    GRASP_JOINT_TARGETS: 'sensor_msgs/msg/JointState',
    GRASP_TRAJECTORY: 'trajectory_msgs/msg/JointTrajectory',
    GRASP_POSTERIOR: _F64MA,
    GRASP_FEATURES: _F64MA,
    GRASP_MARKERS: 'visualization_msgs/msg/MarkerArray',
    DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray',
    OPERATOR_TWIST: 'geometry_msgs/msg/TwistStamped',
    ASSISTANCE_TWIST: 'geometry_msgs/msg/TwistStamped',
    ASSISTANCE_ALPHA: 'std_msgs/msg/Float64',
    ARM_TRAJECTORY_COMMAND: 'trajectory_msgs/msg/JointTrajectory',
    ARM_TWIST_COMMAND: 'geometry_msgs/msg/TwistStamped',
}
"""Message type of every topic of the suite, by relative name (``/diagnostics`` is absolute)."""

INPUT_TOPICS: Final = (INTENT_W, OBJECT_POSE, JOINT_STATES)
"""Inputs a replay publishes again (relative names)."""
PLAN_TOPICS: Final = (GRASP_POSE, GRASP_JOINT_TARGETS, GRASP_TRAJECTORY, GRASP_POSTERIOR, GRASP_FEATURES)
"""The outputs of one plan (all carry the same stamp)."""
OUTPUT_TOPICS: Final = (INTENT_V, INTENT_CLARIFICATION, *PLAN_TOPICS)
"""Outputs compared by a replay (relative names), besides ``model/active`` and rejections."""
SHARED_CONTROL_TOPICS: Final = (OPERATOR_TWIST, ASSISTANCE_TWIST, ASSISTANCE_ALPHA)
"""The shared-control loop's topics (the assistance node's input and outputs), recorded with the suite's."""

# ------------------------------------------------------------------------------------------ input caps
MAX_NAME_LENGTH: Final = 256
"""Longest accepted name (characters): a joint name, a frame id."""
MAX_JOINTS: Final = 64
"""Most joints accepted in one ``joint_states`` message."""
MAX_FEATURES: Final = 1024
"""Largest feature vector accepted on ``model/query`` (values)."""

MAX_MESSAGE_BYTES: Final[Mapping[str, int]] = {
    INTENT_W: 16 << 10,        # 10 tasks; labels of up to 10 task names
    INTENT_V: 64 << 10,        # 1023 zones and their labels
    MODEL_QUERY: 64 << 10,     # MAX_FEATURES values and their labels
    OBJECT_POSE: 4 << 10,      # a pose and a frame id of MAX_NAME_LENGTH
    JOINT_STATES: 64 << 10,    # MAX_JOINTS names of MAX_NAME_LENGTH, positions, velocities, efforts
    MODEL_ACTIVE: 4 * MAX_DOCUMENT_CHARS + 64,  # a document of at most MAX_DOCUMENT_CHARS UTF-8 characters
    INTENT_CLARIFICATION: 64 << 10,  # a reason naming a model's zones
    GRASP_POSE: 4 << 10,       # as OBJECT_POSE
    GRASP_POSTERIOR: 64 << 10,  # 1023 zones, 10 tasks and their labels
    GRASP_FEATURES: 64 << 10,  # MAX_FEATURES values, their labels and a stamp label
    GRASP_JOINT_TARGETS: 64 << 10,  # as JOINT_STATES
    OPERATOR_TWIST: 4 << 10,   # a twist and a frame id of MAX_NAME_LENGTH
    ARM_TWIST_COMMAND: 4 << 10,
    ARM_TRAJECTORY_COMMAND: 1 << 20,  # e.g. 4,000 points of 9 joints with positions, velocities, accelerations
}
"""Largest serialized (CDR) message accepted on each input topic, bytes.

A node reads its inputs serialized and rejects a larger message before decoding it (so an oversized
message never becomes Python objects); each cap leaves ample room for the largest valid message.
"""


def check_message_size(topic: str, size: int) -> None:
    """Reject a serialized message of ``size`` bytes larger than the cap of ``topic``.

    Raises
    ------
    GraspIntentError
        If ``size`` exceeds :data:`MAX_MESSAGE_BYTES` ``[topic]``.
    KeyError
        For a topic without a cap (not an input of the suite).
    """
    cap = MAX_MESSAGE_BYTES[topic]
    if size > cap:
        raise GraspIntentError(f'{topic}: oversized message of {size} bytes, the limit is {cap} bytes')


def check_names(names: Sequence[str], *, max_count: int, what: str) -> None:
    """At most ``max_count`` names of at most :data:`MAX_NAME_LENGTH` characters each.

    Raises
    ------
    GraspIntentError
        Naming the count or the first name that is too long (abbreviated).
    """
    if len(names) > max_count:
        raise GraspIntentError(f'{what}: {len(names)} names, the limit is {max_count}')
    for i, name in enumerate(names):
        if len(name) > MAX_NAME_LENGTH:
            raise GraspIntentError(f'{what}: name {i} has {len(name)} characters, the limit is '
                                   f'{MAX_NAME_LENGTH} ({name[:40]!r}...)')

# ------------------------------------------------------------------------------------------ arrays
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
        from :func:`grasp_intent_ros.ros.robot.posterior_from_msg`).
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


# ------------------------------------------------------------------------------------------ model document
@dataclass(frozen=True)
class ModelHeader:
    """The header of a model document.

    Attributes
    ----------
    name : str
        The model's name (the model server's ``model`` parameter).
    version : int
        Activation count in the publishing model server, >= 1.
    sha256 : str
        Hex digest of the YAML body.
    """

    name: str
    version: int
    sha256: str


@dataclass(frozen=True)
class ModelDocument(ModelHeader):
    """A model as published on ``model/active``: its header (name, version, content hash) and the model."""

    model: GraspModel


_HEADER = re.compile(r'# model_name: (?P<name>[^\n]*)\n# model_version: (?P<version>[0-9]+)\n'
                     r'# model_sha256: (?P<sha>[0-9a-f]{64})\n')


def model_document(model: GraspModel, *, name: str, version: int) -> str:
    """The versioned model document: three header lines, then :meth:`GraspModel.to_yaml`.

    ::

        # model_name: cup_7zone
        # model_version: 3
        # model_sha256: <sha256 of the YAML text that follows, hex>
        <GraspModel YAML>

    The header lines are YAML comments, so :meth:`GraspModel.from_yaml` also reads the whole text.

    Raises
    ------
    ValueError
        If ``name`` spans several lines or ``version < 1``.
    """
    if '\n' in name or version < 1:
        raise ValueError('name must be one line and version >= 1')
    body = model.to_yaml()
    sha = hashlib.sha256(body.encode()).hexdigest()
    return f'# model_name: {name}\n# model_version: {version}\n# model_sha256: {sha}\n{body}'


def parse_model_document(text: str, *, check_sha256: bool = True) -> tuple[ModelHeader, str]:
    """Split a document written by :func:`model_document` into its header and YAML body.

    The body is not parsed (see :func:`read_model_document`). ``check_sha256=False`` reads the header
    alone, without hashing the body.

    Raises
    ------
    ModelFormatError
        If the text is oversized (:data:`~grasp_intent_ros.method.safe_yaml.MAX_DOCUMENT_CHARS`, checked
        first), the header lines are missing or malformed, ``model_version < 1``, or (when checked) the
        body's sha256 differs from the header's.
    """
    check_document_size(text)
    header = _HEADER.match(text)
    if header is None:
        raise ModelFormatError('model document lacks the header lines "# model_name: ...", '
                               '"# model_version: <n>", "# model_sha256: <hex>"')
    body = text[header.end():]
    if check_sha256:
        sha = hashlib.sha256(body.encode()).hexdigest()
        if sha != header['sha']:
            raise ModelFormatError(f'model document is corrupted: sha256 {sha} does not match the header')
    version = int(header['version'])
    if version < 1:
        raise ModelFormatError(f'model_version must be >= 1, got {version}')
    return ModelHeader(header['name'], version, header['sha']), body


def read_model_document(text: str, *, previous: ModelDocument | None = None,
                        requires: ModelRequirements | None = None) -> ModelDocument:
    """Parse a whole model document: header checked, body read by :meth:`GraspModel.from_yaml`.

    When ``previous`` has the same name and sha256 as ``text`` (a model re-latched, e.g. by a restarted
    model server), its model is reused: the body is hashed, not parsed again. ``requires`` refuses a valid
    model the reader cannot serve, by its declaration, before the document's arrays are parsed.

    Raises
    ------
    ModelError
        If ``requires`` refuses the model (the message names the model).
    ModelFormatError
        If the text is oversized, the header is missing or malformed, the hash does not match the YAML,
        or the YAML is not a valid model (an alias or too deep a nesting included).
    """
    header, body = parse_model_document(text)
    same = previous is not None and (previous.name, previous.sha256) == (header.name, header.sha256)
    try:
        if previous is not None and same:
            model = previous.model
            if requires is not None:
                requires.check(model.task_names, model.feature_names)
        else:
            model = GraspModel.from_yaml(body, requires=requires)
    except ModelFormatError:
        raise
    except ModelError as exc:
        raise ModelError(f'model {header.name[:64]!r} refused: {exc}') from None
    return ModelDocument(header.name, header.version, header.sha256, model)


# ------------------------------------------------------------------------------------------ diagnostics
OK: Final = 0
WARN: Final = 1
ERROR: Final = 2
STALE: Final = 3
LEVEL_NAMES: Final[Mapping[int, str]] = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR', STALE: 'STALE'}

KEY_RECEIVED: Final = 'messages received'
KEY_REJECTED: Final = 'messages rejected'
KEY_LAST_ERROR: Final = 'last error'
KEY_PROCESSING_TIME: Final = 'last processing time [ms]'
KEY_DROPPED: Final = 'messages dropped'
"""Messages of the tracked inputs the node never took: gaps in their publishers' sequence numbers."""
KEY_PLANS: Final = 'plans'
"""The planner's count of plans made."""
KEY_PLANNING_TIME: Final = 'last planning time [ms]'
KEY_PLAN_STATUS: Final = 'last plan status'
"""What the planner's last plan led to (``grasp published (...)``, ``clarification requested: ...``)."""
KEY_MODEL: Final = 'active model'
"""A node's active model: ``"<name> (version <n>, zones <labels>)"`` (the planner), the name (the model
server), the name and its zones or why it was refused (the interpreter)."""
KEY_CLARIFICATIONS: Final = 'clarifications requested'
"""How many clarification requests a node (the interpreter, the planner) has published."""
KEY_LAST_OUTCOME: Final = 'last outcome'
"""What the interpreter's last w led to (``v published``, ``clarification requested: ...``)."""
KEY_KERNELS_LOAD_TIME: Final = 'compiled kernels load time [ms]'
"""How long the planner's planning thread took at start, before it was ready, to load (or, with an empty
cache, compile) every compiled kernel."""
KEY_KERNELS_LOADED_LATE: Final = 'compiled kernels loaded after ready'
"""How many kernel signatures the planner compiled or loaded after it was ready (0: no plan waited on one)."""
KEY_GOALS: Final = 'goals'
"""How many of the model's demonstrations the intent estimator has as goals (reachable); set once they are ready."""
ESTIMATOR_COMPONENT: Final = 'intent estimator'
"""The intent estimator node's status component (:func:`status_name`); a closed-loop session holding it had
its w from the estimator."""


def level_value(level: Any) -> int:
    """A DiagnosticStatus level as an int (rclpy gives a 1-byte ``bytes``, rosbags an int)."""
    return level[0] if isinstance(level, (bytes, bytearray)) else int(level)


def status_name(node: str, component: str) -> str:
    """The status name of a node component: ``"<node fully-qualified name>: <component>"``."""
    return f'{node}: {component}'


def status_values(status: Any) -> dict[str, str]:
    """The key/value pairs of a DiagnosticStatus as a dict."""
    return {str(kv.key): str(kv.value) for kv in status.values}


# --- robot-side messages read as values (ROS-free: attribute access only; also on rosbags' message classes) ---

QUATERNION_NORM_TOL = 1e-3
"""Largest accepted deviation of an incoming quaternion's norm from 1."""


def check_unit_quaternion(xyzw: ArrayLike, *, tol: float = QUATERNION_NORM_TOL) -> NDArray[np.float64]:
    """A finite quaternion (x, y, z, w) of unit norm within ``tol``, as an array of shape (4,).

    Raises
    ------
    KinematicsError
        For a wrong shape, a NaN or infinity, or a norm further than ``tol`` from 1.
    """
    try:
        q = np.asarray(xyzw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'quaternion must be numeric: {exc}') from None
    if q.shape != (4,):
        raise KinematicsError(f'quaternion must have 4 entries (x, y, z, w), got shape {q.shape}')
    if not np.all(np.isfinite(q)):
        raise KinematicsError(f'quaternion must be finite, got {q.tolist()}')
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > tol:
        raise KinematicsError(f'quaternion must have unit norm (within {tol:g}), got norm {norm:.6g} '
                              f'for (x, y, z, w) = {q.tolist()}')
    return q


def pose_msg_to_matrix(msg: Any, *, frame_id: str,
                       quat_tol: float = QUATERNION_NORM_TOL) -> NDArray[np.float64]:
    """``frame_T_pose``, shape (4, 4), of a geometry_msgs/PoseStamped given in ``frame_id`` (no TF lookup).

    Raises
    ------
    KinematicsError
        If the header names another frame, the position is not finite, or the quaternion is not a
        unit quaternion (see :func:`check_unit_quaternion`).
    """
    if msg.header.frame_id != frame_id:
        raise KinematicsError(f'pose must be given in frame {frame_id!r} (no TF lookup), '
                              f'got frame_id {msg.header.frame_id[:MAX_NAME_LENGTH]!r}')
    p, o = msg.pose.position, msg.pose.orientation
    position = np.array([p.x, p.y, p.z], dtype=np.float64)
    if not np.all(np.isfinite(position)):
        raise KinematicsError(f'pose position must be finite, got {position.tolist()}')
    return pose_to_matrix(position, check_unit_quaternion([o.x, o.y, o.z, o.w], tol=quat_tol))


def joint_positions(msg: Any, names: Sequence[str]) -> NDArray[np.float64] | None:
    """Positions of ``names`` (in that order) from a sensor_msgs/JointState whose names may come in any order.

    Returns
    -------
    ndarray, shape (len(names),), or None when the message lacks one of ``names`` (e.g. a
    finger-only message from another publisher).

    Raises
    ------
    KinematicsError
        If the message has duplicate names, a different number of names and positions, or a wanted
        position that is NaN or infinite.
    GraspIntentError
        For more than :data:`~grasp_intent_ros.wire.protocol.MAX_JOINTS` names or a name longer than
        :data:`~grasp_intent_ros.wire.protocol.MAX_NAME_LENGTH`.
    """
    check_names(msg.name, max_count=MAX_JOINTS, what='joint state')
    if len(msg.position) != len(msg.name):
        raise KinematicsError(f'joint state has {len(msg.name)} names but {len(msg.position)} positions')
    index = {name: i for i, name in enumerate(msg.name)}
    if len(index) != len(msg.name):
        duplicates = sorted(name for name, count in Counter(msg.name).items() if count > 1)
        raise KinematicsError(f'joint state has duplicate names: {duplicates}')
    if any(name not in index for name in names):
        return None
    q = np.array([msg.position[index[name]] for name in names], dtype=np.float64)
    if not np.all(np.isfinite(q)):
        bad = [name for name, value in zip(names, q) if not math.isfinite(value)]
        raise KinematicsError(f'joint state positions must be finite; NaN or infinity for {bad}')
    return q
