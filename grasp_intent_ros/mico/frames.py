r"""Grasp-frame maths: grasp features <-> end-effector pose, poses <-> 4x4 transforms, the drawn gripper.

Frames and units as in :mod:`grasp_intent_ros.mico.kinematics` (``a_T_b`` maps coordinates in ``b`` to
coordinates in ``a``; metres, radians).

Grasp features -> end-effector pose
-----------------------------------
A grasp feature vector ``x`` (shape (10,), see :mod:`~grasp_intent_ros.method.features`) holds the palm
centre ``p = x[PALM]`` (m, object frame), the approach ``a = x[APPROACH]`` and the roll ``r = x[ROLL]``
(rad); the finger closures ``x[FINGERS]`` do not affect the pose. :func:`features_to_obj_T_ee` returns

.. math::

    {}^{obj}T_{ee} = \begin{pmatrix} R_{min}(\hat a)\, R_z(r)\, R_{top} & p \\ 0 & 1 \end{pmatrix},
    \qquad \hat a = a / \lVert a \rVert,

* ``R_top = diag(1, -1, -1)``: the top-down grasp with roll 0 (EE z = -z_obj, EE x = +x_obj);
* ``R_z(r)``: rotation by r about the object's z axis, applied to ``R_top``. Since EE z = -z_obj there,
  r is a rotation by -r about the EE's own z axis: ``R_z(r) R_top = R_top R_z(-r)``;
* ``R_min(a)``: the smallest rotation taking the downward direction (0, 0, -1) to ``a`` (Rodrigues, about
  the horizontal axis (0, 0, -1) x a). It is undefined only for ``a = +z`` (approach from below the
  table); there ``R_min = R_x(pi)`` by definition, and it is discontinuous next to ``+z``.

Hence the EE origin is the palm centre ``p`` and the EE z axis equals ``a``. For a horizontal approach
``a = (ax, ay, 0)`` with roll 0 the thumb (EE x) points along ``(ay^2, -ax ay, ax)``: up for an approach
along +x_obj, horizontal (+x_obj) for an approach along +-y_obj.

:func:`obj_T_ee_to_features` inverts this: ``a`` = EE z axis, and r is wrapped into
``[MICO_3F.lower[ROLL], MICO_3F.lower[ROLL] + 2 pi)`` = [-pi/2, 3pi/2).
Drawn gripper
-------------
:func:`finger_segments` is the schematic of the three fingers that the RViz markers and the session
report both draw (base on a circle around the approach axis, bent inwards by the closure; not the finger
kinematics).
"""

from __future__ import annotations

import math
from itertools import chain
from typing import Final

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidFeaturesError, KinematicsError
from ..method.features import APPROACH, FINGERS, MICO_3F, PALM, ROLL

__all__ = [
    'check_vector',
    'check_transform',
    'QUATERNION_NORM_TOL',
    'check_unit_quaternion',
    'ORTHONORMAL_TOL',
    'features_to_obj_T_ee',
    'obj_T_ee_to_features',
    'pose_to_matrix',
    'matrix_to_pose',
    'DEFAULT_OBJECT_POSITION',
    'DEFAULT_OBJECT_ORIENTATION',
    'default_base_T_obj',
    'PRE_GRASP_STANDOFF',
    'pre_grasp',
    'pose_error',
    'REACH_POS',
    'REACH_ROT',
    'offset',
    'rotation_angle',
    'rotation_angles',
    'reached',
    'finger_segments',
    'FINGER_LENGTH',
]

_TWO_PI = 2.0 * math.pi
_R_TOP = np.diag([1.0, -1.0, -1.0])
_ROLL_MIN = float(MICO_3F.lower[ROLL])

FINGER_LENGTH = 0.08
"""Length of a drawn finger (m)."""
_FINGER_BASE_RADIUS = 0.03
_FINGER_ANGLES = (0.0, math.radians(140.6), -math.radians(140.6))
"""Azimuth of fingers 1 (thumb, +x of the EE frame), 2 and 3 around the approach axis (rad)."""
_FINGER_SPLAY = 0.35
"""Outward tilt of an open finger (rad); closure c tilts it inwards by c - splay."""


def check_vector(value: ArrayLike, n: int, what: str) -> NDArray[np.float64]:
    """A finite vector of shape (n,). Raises KinematicsError naming ``what``."""
    try:
        vec = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'{what} must be numeric: {exc}') from None
    if vec.shape != (n,):
        raise KinematicsError(f'{what} must have shape ({n},), got {vec.shape}')
    if not np.isfinite(vec).all():
        raise KinematicsError(f'{what} must be finite, got {vec}')
    return vec


ORTHONORMAL_TOL = 1e-12
"""Largest entry of ``|R^T R - I|`` for which :func:`check_transform` keeps a rotation as it is."""


def check_transform(value: ArrayLike, what: str, *, tol: float = 1e-6) -> NDArray[np.float64]:
    """A validated 4x4 rigid transform; its rotation is projected onto SO(3) (deviations < tol allowed).

    The tolerance test is ``np.allclose(R.T @ R, I, atol=tol)`` (and ``det R > 0``), the last row's
    ``np.allclose(T[3], (0, 0, 0, 1), atol=tol)``. A rotation already orthonormal within
    :data:`ORTHONORMAL_TOL` (one built from a unit quaternion or composed of such, off by rounding only) is
    returned as given: the projection (SVD) would move it by as little. The tests run on Python floats:
    a planner checks three transforms per plan, each right after the thread was idle, when numpy's
    machinery for a 4x4 array costs several times its warm time.
    """
    try:
        T = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'{what} must be numeric: {exc}') from None
    if T.shape != (4, 4):
        raise KinematicsError(f'{what} must have shape (4, 4), got {T.shape}')
    (a, b, c, _), (d, e, f, _), (g, h, i, _), last = rows = T.tolist()
    if not all(map(math.isfinite, chain.from_iterable(rows))):
        raise KinematicsError(f'{what} must be finite')
    if not (abs(last[0]) <= tol and abs(last[1]) <= tol and abs(last[2]) <= tol and abs(last[3] - 1.0) <= tol + 1e-5):
        raise KinematicsError(f'{what} must have last row (0, 0, 0, 1), got {T[3]}')
    # R^T R: the columns' dot products
    off = max(abs(a * b + d * e + g * h), abs(a * c + d * f + g * i), abs(b * c + e * f + h * i))
    diag = max(abs(a * a + d * d + g * g - 1.0), abs(b * b + e * e + h * h - 1.0), abs(c * c + f * f + i * i - 1.0))
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if not (off <= tol and diag <= tol + 1e-5 and det > 0.0):
        raise KinematicsError(f'{what} rotation is not a rotation matrix (tolerance {tol})')
    if max(off, diag) > ORTHONORMAL_TOL:
        u, _, vt = np.linalg.svd(T[:3, :3])
        T[:3, :3] = u @ vt
    T[3] = (0.0, 0.0, 0.0, 1.0)
    return T


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


# -- grasp features <-> end-effector pose -------------------------------------------------------------

_Rows = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


def _min_rotation_from_down(ax: float, ay: float, az: float) -> _Rows:
    """The smallest rotation (rows) taking (0, 0, -1) to the unit vector a; R_x(pi) for a = +z."""
    s2 = ax * ax + ay * ay
    if s2 == 0.0 and az > 0.0:
        return (1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)
    # Rodrigues with w = (0, 0, -1) x a = (ay, -ax, 0), cos = -az: R = -az I + [w]x + w w^T / (1 - az).
    # 1 - az is computed as s2 / (1 + az) when az > 0 to avoid cancellation near +z.
    h = (1.0 + az) / s2 if az > 0.0 else 1.0 / (1.0 - az)
    hxy = -h * ax * ay
    return (-az + h * ay * ay, hxy, -ax), (hxy, -az + h * ax * ax, -ay), (ax, ay, -az)


def features_to_obj_T_ee(x: ArrayLike) -> NDArray[np.float64]:
    """End-effector pose ``obj_T_ee`` of a grasp feature vector (convention in the module docstring).

    Parameters
    ----------
    x : array_like, shape (10,)
        Grasp features (:data:`~grasp_intent_ros.method.features.MICO_3F` layout); the approach need not be
        normalised, the finger closures are ignored.

    Returns
    -------
    ndarray, shape (4, 4)

    Raises
    ------
    InvalidFeaturesError
        If ``x`` has the wrong shape, non-finite entries, or a zero approach vector.
    """
    try:
        vec = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidFeaturesError(f'x must be numeric: {exc}') from None
    if vec.shape != (MICO_3F.dim,):
        raise InvalidFeaturesError(f'x must have shape ({MICO_3F.dim},), got {vec.shape}')
    values = vec.tolist()
    if not all(math.isfinite(v) for v in values):
        raise InvalidFeaturesError(f'x must be finite, got {vec}')
    ax, ay, az = values[APPROACH]
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    if norm < 1e-9:
        raise InvalidFeaturesError(f'approach vector x[3:6] must be non-zero, got {vec[APPROACH]}')
    # R_min(a_hat) R_z(roll) R_top, R_z(roll) R_top = ((c, s, 0), (s, -c, 0), (0, 0, -1)); Python floats
    # (numpy's machinery for 3x3 products costs more than the arithmetic, several times over in a planner)
    c, s = math.cos(values[ROLL]), math.sin(values[ROLL])
    px, py, pz = values[PALM]
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = _min_rotation_from_down(ax / norm, ay / norm, az / norm)
    return np.array([[r00 * c + r01 * s, r00 * s - r01 * c, -r02, px],
                     [r10 * c + r11 * s, r10 * s - r11 * c, -r12, py],
                     [r20 * c + r21 * s, r20 * s - r21 * c, -r22, pz],
                     [0.0, 0.0, 0.0, 1.0]])


def obj_T_ee_to_features(obj_T_ee: ArrayLike, fingers: ArrayLike) -> NDArray[np.float64]:
    """Grasp feature vector of an end-effector pose and finger closures (inverse of features_to_obj_T_ee).

    Parameters
    ----------
    obj_T_ee : array_like, shape (4, 4)
        End-effector pose in the object frame.
    fingers : array_like, shape (3,)
        Finger closures (rad), copied to ``x[7:10]`` unchanged.

    Returns
    -------
    ndarray, shape (10,)
        Unit approach, roll wrapped into [-pi/2, 3pi/2).

    Raises
    ------
    KinematicsError
        If ``obj_T_ee`` is not a rigid 4x4 transform.
    InvalidFeaturesError
        If ``fingers`` is not a finite vector of shape (3,).
    """
    T = check_transform(obj_T_ee, 'obj_T_ee')
    try:
        closures = check_vector(fingers, 3, 'fingers')
    except KinematicsError as exc:
        raise InvalidFeaturesError(str(exc)) from None
    obj_R_ee = T[:3, :3]
    approach = obj_R_ee[:, 2]
    r_min = np.array(_min_rotation_from_down(*approach.tolist()))
    roll_R = r_min.T @ obj_R_ee @ _R_TOP  # = R_z(roll); R_TOP is involutive
    roll = math.atan2(float(roll_R[1, 0]), float(roll_R[0, 0]))
    roll = (roll - _ROLL_MIN) % _TWO_PI + _ROLL_MIN
    if roll >= _ROLL_MIN + _TWO_PI:  # a tiny negative offset wraps to exactly 2 pi in floating point
        roll -= _TWO_PI
    x = np.empty(MICO_3F.dim)
    x[PALM] = T[:3, 3]
    x[APPROACH] = approach
    x[ROLL] = roll
    x[FINGERS] = closures
    return x


# -- poses ----------------------------------------------------------------------------------------------

PRE_GRASP_STANDOFF = 0.08
"""Distance (m) of the pre-grasp behind the grasp along the approach axis: where the approach starts."""


def pre_grasp(a_T_grasp: NDArray[np.float64], standoff: float) -> NDArray[np.float64]:
    """The grasp pose (4x4, any frame ``a``) moved back by ``standoff`` (m) along its approach axis (the EE z axis)."""
    a_T_pre = a_T_grasp.copy()
    a_T_pre[:3, 3] -= standoff * a_T_grasp[:3, 2]
    return a_T_pre


def pose_to_matrix(position: ArrayLike, quat_xyzw: ArrayLike) -> NDArray[np.float64]:
    """4x4 transform of a position (m) and a quaternion in ROS order (x, y, z, w), normalised here.

    Raises
    ------
    KinematicsError
        On wrong shapes, non-finite values, or a zero quaternion.
    """
    p = check_vector(position, 3, 'position')
    xyzw = check_vector(quat_xyzw, 4, 'quat_xyzw')
    norm = float(np.linalg.norm(xyzw))
    if norm < 1e-12:
        raise KinematicsError('quat_xyzw must be non-zero')
    x, y, z, w = xyzw / norm
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).toRotationMatrix()  # Pinocchio takes w first
    T[:3, 3] = p
    return T


def pose_error(base_T_ee: NDArray[np.float64], base_T_target: NDArray[np.float64]) -> NDArray[np.float64]:
    """(p_t - p, log3(R_t R^T)), shape (6,): the target's offset (m) and rotation vector (rad), base frame."""
    dp = base_T_target[:3, 3] - base_T_ee[:3, 3]
    dr = pin.log3(base_T_target[:3, :3] @ base_T_ee[:3, :3].T)
    return np.concatenate([dp, np.asarray(dr, dtype=np.float64)])


REACH_POS: Final = 0.01
"""The hand has reached a grasp within this distance (m) ..."""
REACH_ROT: Final = 0.1
"""... and this rotation (rad): the closed-loop benchmarks' success and a scripted operator's grasp command."""


def offset(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[float, float]:
    """How far pose ``b`` is from pose ``a`` (4x4): (distance m, rotation angle rad), by :func:`pose_error`."""
    error = pose_error(a, b)
    return float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))


def rotation_angle(rotation_a: NDArray[np.float64], rotation_b: NDArray[np.float64]) -> float:
    """The angle (rad, in [0, pi]) of ``R_a^T R_b``: how far rotation ``b`` is turned from rotation ``a``.

    ``rotation_a``, ``rotation_b`` (3, 3), not checked. ``acos((tr(R_a^T R_b) - 1) / 2)``, the cosine clipped to
    [-1, 1]; the trace is the correctly rounded sum of the nine products ``R_a[i, j] R_b[i, j]``, so the angle is
    the same bits on every CPU (no BLAS kernel in it). Good to about 1e-8 rad near 0 and pi, like
    :func:`rotation_angles` (its vectorised sibling), which suits thresholds; :func:`offset` is accurate everywhere.
    """
    trace = math.fsum((np.asarray(rotation_a, dtype=np.float64) * rotation_b).ravel().tolist())
    return math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0))))


def rotation_angles(rotations: NDArray[np.float64], rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    """The angle (rad, in [0, pi]) of each ``R_n R^T``, shape (N,): each of ``rotations`` turned from ``rotation``.

    ``rotations`` (N, 3, 3), ``rotation`` (3, 3), not checked. ``arccos((tr(R_n R^T) - 1) / 2)``, the cosine clipped
    to [-1, 1]: vectorised for the estimator's hundreds of goals, and good to about 1e-8 rad near 0 and pi (the
    arccos of a cosine near +-1), which suits thresholds; :func:`offset` is accurate everywhere, one pose at a time.
    """
    r_rel = rotations @ rotation.T
    cos = np.clip(0.5 * (r_rel[:, 0, 0] + r_rel[:, 1, 1] + r_rel[:, 2, 2] - 1.0), -1.0, 1.0)
    out: NDArray[np.float64] = np.arccos(cos)
    return out


def reached(hand: NDArray[np.float64], goal: NDArray[np.float64]) -> bool:
    """Whether the hand is within :data:`REACH_POS` and :data:`REACH_ROT` of ``goal``."""
    distance, angle = offset(hand, goal)
    return distance <= REACH_POS and angle <= REACH_ROT


DEFAULT_OBJECT_POSITION = (0.3, -0.3, 0.0)
"""The object's default position (m) in the arm's base frame: on the table plane z = 0 of a table-mounted MICO,
within its reach (the planner's and the estimator's ``object_position`` default, the benchmarks' object pose)."""
DEFAULT_OBJECT_ORIENTATION = (0.0, 0.0, 1.0, 0.0)
"""The object's default orientation, a quaternion (x, y, z, w) in the base frame: half a turn about z, which turns
the cup's handle (+x of the object) towards the arm."""


def default_base_T_obj() -> NDArray[np.float64]:
    """``base_T_obj`` (4x4) of :data:`DEFAULT_OBJECT_POSITION` and :data:`DEFAULT_OBJECT_ORIENTATION`."""
    return pose_to_matrix(DEFAULT_OBJECT_POSITION, DEFAULT_OBJECT_ORIENTATION)


def matrix_to_pose(T: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position (m) and unit quaternion (x, y, z, w) with w >= 0 of a 4x4 rigid transform.

    Raises
    ------
    KinematicsError
        If ``T`` is not a rigid 4x4 transform.
    """
    M = check_transform(T, 'T')
    (a, b, c, px), (d, e, f, py), (g, h, i, pz), _ = M.tolist()
    # Shepperd's method (as Eigen's Quaternion from a rotation matrix) in Python floats: the planner converts
    # one pose per plan, and numpy's or Pinocchio's machinery for it costs more than the arithmetic.
    trace = a + e + i
    if trace > 0.0:
        t = 2.0 * math.sqrt(trace + 1.0)
        x, y, z, w = (h - f) / t, (c - g) / t, (d - b) / t, 0.25 * t
    elif a >= e and a >= i:
        t = 2.0 * math.sqrt(1.0 + a - e - i)
        x, y, z, w = 0.25 * t, (b + d) / t, (c + g) / t, (h - f) / t
    elif e >= i:
        t = 2.0 * math.sqrt(1.0 + e - a - i)
        x, y, z, w = (b + d) / t, 0.25 * t, (f + h) / t, (c - g) / t
    else:
        t = 2.0 * math.sqrt(1.0 + i - a - e)
        x, y, z, w = (c + g) / t, (f + h) / t, 0.25 * t, (d - b) / t
    xyzw = np.array([-x, -y, -z, -w] if w < 0.0 else [x, y, z, w])
    return np.array([px, py, pz]), xyzw


def finger_segments(closures: ArrayLike) -> NDArray[np.float64]:
    """Base and tip of each drawn finger in the EE frame (m), for closures (rad, 0 open .. 1.51 closed).

    Returns
    -------
    ndarray, shape (3, 2, 3)
        ``[finger, (base, tip), xyz]``.
    """
    out = np.empty((3, 2, 3))
    for k, (azimuth, closure) in enumerate(zip(_FINGER_ANGLES, np.asarray(closures, dtype=np.float64))):
        radial = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        tilt = float(closure) - _FINGER_SPLAY
        out[k, 0] = _FINGER_BASE_RADIUS * radial
        out[k, 1] = out[k, 0] + FINGER_LENGTH * (math.cos(tilt) * np.array([0.0, 0.0, 1.0]) - math.sin(tilt) * radial)
    return out
