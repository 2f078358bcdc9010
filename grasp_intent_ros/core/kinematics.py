r"""Kinematics of the 3-finger Kinova MICO (m1n6s300): FK, IK, and grasp features <-> end-effector pose.

Frames
------
``base`` (:data:`BASE_FRAME`, ``m1n6s300_link_base``)
    Origin on the bottom plane of the arm's base, +z up.
``ee`` (:data:`EE_FRAME`, ``m1n6s300_end_effector``)
    The tool frame, i.e. the last frame of Kinova's DH table: origin at the palm centre, +z along the hand
    axis pointing out of the palm (the approach direction), +x towards finger 1 (the thumb side); fingers 2
    and 3 sit at -x, +-y.
``obj``
    The object frame of :mod:`grasp_intent_ros.core.features` (origin at the centre of the object's base,
    +z up).

Transforms are 4x4 homogeneous matrices named ``a_T_b`` (maps coordinates in ``b`` to coordinates in
``a``); compose them with ``@``: ``base_T_ee = base_T_obj @ obj_T_ee``. Lengths are in metres, angles in
radians.

Joint angles
------------
``q`` (shape (6,), rad) is Kinova's "classic" joint angle (the value the driver reports), related to the
DH angle by theta_i = s_i q_i + o_i with the standard DH table (T_i = Rz(theta_i) Tz(d_i) Tx(a_i)
Rx(alpha_i); k = sin 30deg / sin 60deg):

=  =====  ========================  =======  ===  ======
i  a (m)  d (m)                     alpha    s    o
=  =====  ========================  =======  ===  ======
1  0      D1 = 0.2755               pi/2     -1   0
2  0.29   0                         pi       +1   -pi/2
3  0      -e2 = -0.0070             pi/2     +1   +pi/2
4  0      -(D3 + k D4) = -0.16608   pi/3     +1   0
5  0      -k (D4 + D5) = -0.08556   pi/3     +1   -pi
6  0      -(k D5 + D6) = -0.20278   pi       +1   +pi/2
=  =====  ========================  =======  ===  ======

``config/mico_3f.urdf`` encodes this table with the URDF joint variable equal to q. Joints 1, 4, 5 and 6
turn without end stops on the robot; the URDF gives them +-4 pi limits so that Pinocchio keeps one plain
angle per joint. Joint 2 is limited to [50, 310] deg and joint 3 to [35, 325] deg.

Grasp features -> end-effector pose
-----------------------------------
A grasp feature vector ``x`` (shape (10,), see :mod:`~grasp_intent_ros.core.features`) holds the palm
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
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from .errors import InvalidFeaturesError, KinematicsError
from .features import APPROACH, FINGERS, MICO_3F, PALM, ROLL
from .resources import config_dir

__all__ = [
    'MAX_REACH',
    'Reachability',
    'ARM_JOINTS',
    'FINGER_JOINTS',
    'BASE_FRAME',
    'EE_FRAME',
    'HOME_Q',
    'URDF_FILENAME',
    'default_urdf_path',
    'IkResult',
    'MicoKinematics',
    'features_to_obj_T_ee',
    'obj_T_ee_to_features',
    'pose_to_matrix',
    'matrix_to_pose',
]

_PREFIX = 'm1n6s300'
ARM_JOINTS: tuple[str, ...] = tuple(f'{_PREFIX}_joint_{i}' for i in range(1, 7))
"""Arm joint names, in q order."""
FINGER_JOINTS: tuple[str, ...] = tuple(f'{_PREFIX}_joint_finger_{i}' for i in range(1, 4))
"""Finger joint names (0 open .. 1.51 rad closed)."""
BASE_FRAME = f'{_PREFIX}_link_base'
EE_FRAME = f'{_PREFIX}_end_effector'
URDF_FILENAME = 'mico_3f.urdf'

HOME_Q: NDArray[np.float64] = np.array([4.80469, 2.92482, 1.002, 4.20319, 1.4458, 1.3233])
"""kinova-ros "Home" (rad), tool at about (0.2149, -0.2036, 0.4187) m in the base frame. Read-only."""
HOME_Q.setflags(write=False)

_SHOULDER = np.array([0.0, 0.0, 0.2755])
"""Joint 2's axis point in the base frame (m): height D1 of the DH table."""

MAX_REACH = 0.7285
"""Upper bound on the distance from :data:`_SHOULDER` to the EE origin (m): the sum of the link lengths
D2 + D3 + D4 + D5 + D6 + e2; FK of 20,000 random joint vectors reaches at most 0.708 m. IK answers a
target beyond it at once instead of spending its restarts."""

_WIDE_JOINTS = np.array([True, False, False, True, True, True])
"""Joints without end stops on the robot (1, 4, 5, 6): IK answers are wrapped by 2 pi towards the seed."""
_TWO_PI = 2.0 * math.pi
_R_TOP = np.diag([1.0, -1.0, -1.0])
_ROLL_MIN = float(MICO_3F.lower[ROLL])


def default_urdf_path() -> Path:
    """Path of ``config/mico_3f.urdf`` (see :func:`grasp_intent_ros.core.resources.config_dir`).

    Raises
    ------
    FileNotFoundError
        If no config directory is found or it holds no ``mico_3f.urdf``.
    """
    path = config_dir() / URDF_FILENAME
    if not path.is_file():
        raise FileNotFoundError(f'{URDF_FILENAME} not found in {path.parent}')
    return path


@dataclass(frozen=True)
class IkResult:
    """Outcome of :meth:`MicoKinematics.ik`.

    Attributes
    ----------
    q : ndarray, shape (6,)
        Joint angles (rad) within the limits; the best attempt when ``success`` is False.
    success : bool
        True when both errors are within the requested tolerances.
    pos_error_m : float
        Distance between the reached and the target EE origin (m).
    rot_error_rad : float
        Angle of the rotation between the reached and the target EE orientation (rad).
    iterations : int
        Solver iterations summed over all attempts.
    attempts : int
        1 + number of random restarts used.
    message : str
        Human-readable summary.
    """

    q: NDArray[np.float64]
    success: bool
    pos_error_m: float
    rot_error_rad: float
    iterations: int
    attempts: int
    message: str


def _as_vector(value: ArrayLike, n: int, what: str) -> NDArray[np.float64]:
    try:
        vec = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'{what} must be numeric: {exc}') from None
    if vec.shape != (n,):
        raise KinematicsError(f'{what} must have shape ({n},), got {vec.shape}')
    if not np.all(np.isfinite(vec)):
        raise KinematicsError(f'{what} must be finite, got {vec}')
    return vec


def _as_transform(value: ArrayLike, what: str, *, tol: float = 1e-6) -> NDArray[np.float64]:
    """A validated 4x4 rigid transform; its rotation is projected onto SO(3) (deviations < tol allowed)."""
    try:
        T = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise KinematicsError(f'{what} must be numeric: {exc}') from None
    if T.shape != (4, 4):
        raise KinematicsError(f'{what} must have shape (4, 4), got {T.shape}')
    if not np.all(np.isfinite(T)):
        raise KinematicsError(f'{what} must be finite')
    if not np.allclose(T[3], (0.0, 0.0, 0.0, 1.0), atol=tol):
        raise KinematicsError(f'{what} must have last row (0, 0, 0, 1), got {T[3]}')
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=tol) or np.linalg.det(R) <= 0.0:
        raise KinematicsError(f'{what} rotation is not a rotation matrix (tolerance {tol})')
    u, _, vt = np.linalg.svd(R)
    T[:3, :3] = u @ vt
    T[3] = (0.0, 0.0, 0.0, 1.0)
    return T


class MicoKinematics:
    """Forward and inverse kinematics of the MICO arm from the project URDF (Pinocchio).

    The Pinocchio model (arm joints only; the fingers are locked open since they do not move the EE)
    is built once and never modified; every call allocates its own ``pinocchio.Data``, so one instance
    can serve several threads.

    Parameters
    ----------
    urdf_path : path-like, optional
        URDF to load; :func:`default_urdf_path` when None.

    Attributes
    ----------
    model : pinocchio.Model
        Arm-only model, nq = 6, joints in :data:`ARM_JOINTS` order. Treat as read-only.
    joint_names : tuple of str
        :data:`ARM_JOINTS`.
    lower, upper : ndarray, shape (6,)
        Joint position limits (rad), read-only.
    velocity_limits : ndarray, shape (6,)
        Joint speed limits (rad/s), read-only.

    Raises
    ------
    FileNotFoundError
        If the URDF does not exist.
    KinematicsError
        If the URDF cannot be parsed or lacks the MICO joints or frames.
    """

    def __init__(self, urdf_path: str | os.PathLike[str] | None = None) -> None:
        path = default_urdf_path() if urdf_path is None else Path(urdf_path)
        if not path.is_file():
            raise FileNotFoundError(f'URDF not found: {path}')
        try:
            full = pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError) as exc:
            raise KinematicsError(f'cannot build a model from {path}: {exc}') from None
        missing = [name for name in ARM_JOINTS if not full.existJointName(name)]
        if missing:
            raise KinematicsError(f'{path} lacks the arm joints {missing}')
        to_lock = [jid for jid in range(1, full.njoints) if full.names[jid] not in ARM_JOINTS]
        model = pin.buildReducedModel(full, to_lock, pin.neutral(full)) if to_lock else full
        names = tuple(model.names[jid] for jid in range(1, model.njoints))
        if names != ARM_JOINTS or model.nq != 6 or model.nv != 6:
            raise KinematicsError(
                f'{path}: expected six 1-dof arm joints {ARM_JOINTS}, got {names} with nq={model.nq} '
                '(use "revolute", not "continuous", arm joints)')
        for frame in (BASE_FRAME, EE_FRAME):
            if not model.existFrame(frame):
                raise KinematicsError(f'{path} has no frame {frame!r}')
        base_id = model.getFrameId(BASE_FRAME)
        if model.frames[base_id].parentJoint != 0:
            raise KinematicsError(f'{BASE_FRAME!r} must be fixed to the world (the URDF root)')

        self.model = model
        self.urdf_path = path
        self.joint_names: tuple[str, ...] = names
        self.lower: NDArray[np.float64] = np.array(model.lowerPositionLimit, dtype=np.float64)
        self.upper: NDArray[np.float64] = np.array(model.upperPositionLimit, dtype=np.float64)
        self.velocity_limits: NDArray[np.float64] = np.array(model.velocityLimit, dtype=np.float64)
        for arr in (self.lower, self.upper, self.velocity_limits):
            arr.setflags(write=False)
        self._ee_id: int = model.getFrameId(EE_FRAME)
        self._base_M_world = model.frames[base_id].placement.inverse()
        self._world_M_base = model.frames[base_id].placement

    # -- forward kinematics ---------------------------------------------------------------------------

    def _check_q(self, q: ArrayLike, what: str = 'q') -> NDArray[np.float64]:
        return _as_vector(q, 6, what)

    def fk(self, q: ArrayLike) -> NDArray[np.float64]:
        """End-effector pose ``base_T_ee`` for joint angles ``q``.

        Parameters
        ----------
        q : array_like, shape (6,)
            Classic joint angles (rad); need not be within the limits.

        Returns
        -------
        ndarray, shape (4, 4)

        Raises
        ------
        KinematicsError
            If ``q`` is not a finite vector of shape (6,).
        """
        q = self._check_q(q)
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        world_M_ee = pin.updateFramePlacement(self.model, data, self._ee_id)
        return np.array((self._base_M_world * world_M_ee).homogeneous)

    # -- inverse kinematics ---------------------------------------------------------------------------

    def nearest_branch(self, q: ArrayLike, q_ref: ArrayLike) -> NDArray[np.float64]:
        """``q`` with joints 1, 4, 5, 6 shifted by multiples of 2 pi towards ``q_ref``, within the limits.

        The pose is unchanged. Joints 2 and 3 (range < 2 pi) are returned as given.

        Raises
        ------
        KinematicsError
            If either argument is not a finite vector of shape (6,).
        """
        q = self._check_q(q).copy()
        q_ref = self._check_q(q_ref, 'q_ref')
        wide = _WIDE_JOINTS
        q[wide] += _TWO_PI * np.round((q_ref[wide] - q[wide]) / _TWO_PI)
        above = wide & (q > self.upper)
        q[above] -= _TWO_PI * np.ceil((q[above] - self.upper[above]) / _TWO_PI)
        below = wide & (q < self.lower)
        q[below] += _TWO_PI * np.ceil((self.lower[below] - q[below]) / _TWO_PI)
        return q

    def _into_limits(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Wide joints wrapped by 2 pi into the limits (pose kept), then everything clipped."""
        q = q.copy()
        wide = _WIDE_JOINTS
        span = self.upper - self.lower
        inside = (q - self.lower) % _TWO_PI + self.lower
        move = wide & ((q < self.lower) | (q > self.upper)) & (span >= _TWO_PI)
        q[move] = inside[move]
        return np.clip(q, self.lower, self.upper)

    def ik(self, base_T_ee_target: ArrayLike, q_seed: ArrayLike | None = None, *, restarts: int = 8,
           pos_tol: float = 1e-4, rot_tol: float = 1e-3, max_iter: int = 100,
           rng: np.random.Generator | int | None = None) -> IkResult:
        """Joint angles that put the EE at ``base_T_ee_target``.

        Levenberg-Marquardt (damped least squares with adaptive damping and step acceptance) on the
        Pinocchio ``log6`` error of the EE frame expressed in the EE (LOCAL) frame, iterates clipped to the
        joint limits. The first attempt starts from ``q_seed``; if it fails, up to ``restarts`` further
        attempts start from random joint angles (joints 2, 3 uniform within limits, the others uniform in
        seed +- pi). The answer is wrapped per joint to the 2 pi branch nearest ``q_seed``
        (:meth:`nearest_branch`). Never raises for an unreachable target: ``success`` is then False.

        Parameters
        ----------
        base_T_ee_target : array_like, shape (4, 4)
            Target pose of the EE in the base frame (rotation orthonormal within 1e-6).
        q_seed : array_like, shape (6,), optional
            Start and branch reference (rad), usually the current joint reading; :data:`HOME_Q` if None.
        restarts : int
            Maximum number of random restarts (>= 0).
        pos_tol, rot_tol : float
            Success tolerances on the position (m) and orientation (rad) errors (> 0).
        max_iter : int
            Iterations per attempt (>= 1).
        rng : numpy.random.Generator or int, optional
            Source of the restart seeds; an int seeds a new generator. None means seed 0, so equal calls
            give equal answers.

        Returns
        -------
        IkResult

        Raises
        ------
        KinematicsError
            On a malformed target, seed or option.
        """
        base_T_target = _as_transform(base_T_ee_target, 'base_T_ee_target')
        q_ref = np.array(HOME_Q) if q_seed is None else self._check_q(q_seed, 'q_seed')
        if restarts < 0 or max_iter < 1 or not (pos_tol > 0.0 and rot_tol > 0.0):
            raise KinematicsError(
                f'need restarts >= 0, max_iter >= 1, tolerances > 0; got {restarts}, {max_iter}, '
                f'{pos_tol}, {rot_tol}')
        generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(
            0 if rng is None else rng)

        shoulder_to_target = float(np.linalg.norm(base_T_target[:3, 3] - _SHOULDER))
        if shoulder_to_target > MAX_REACH + pos_tol:
            return IkResult(q=q_ref.copy(), success=False, pos_error_m=shoulder_to_target - MAX_REACH,
                            rot_error_rad=math.nan, iterations=0, attempts=0,
                            message=f'target {shoulder_to_target:.3f} m from the shoulder, beyond the arm\'s '
                                    f'reach of {MAX_REACH:.3f} m')
        world_M_target = self._world_M_base * pin.SE3(base_T_target[:3, :3], base_T_target[:3, 3])
        data = self.model.createData()
        q_start = self._into_limits(q_ref)
        best: tuple[float, NDArray[np.float64], float, float] | None = None
        iterations = 0
        for attempt in range(restarts + 1):
            if attempt > 0:
                q_start = generator.uniform(self.lower, self.upper)
                wide = _WIDE_JOINTS
                q_start[wide] = q_ref[wide] + generator.uniform(-math.pi, math.pi, int(wide.sum()))
                q_start = self._into_limits(q_start)
            q, pos_err, rot_err, used = self._solve(data, world_M_target, q_start, max_iter, pos_tol,
                                                    rot_tol)
            iterations += used
            score = pos_err / pos_tol + rot_err / rot_tol
            if best is None or score < best[0]:
                best = (score, q, pos_err, rot_err)
            if pos_err <= pos_tol and rot_err <= rot_tol:
                break
        assert best is not None
        _, q, pos_err, rot_err = best
        success = pos_err <= pos_tol and rot_err <= rot_tol
        message = (f'{"converged" if success else "did not converge"} after {attempt + 1} attempt(s), '
                   f'{iterations} iterations: position error {pos_err:.3g} m (tol {pos_tol:g}), '
                   f'rotation error {rot_err:.3g} rad (tol {rot_tol:g})')
        return IkResult(q=self.nearest_branch(q, q_ref), success=success, pos_error_m=pos_err,
                        rot_error_rad=rot_err, iterations=iterations, attempts=attempt + 1,
                        message=message)

    def _solve(self, data: Any, world_M_target: Any, q: NDArray[np.float64], max_iter: int,
               pos_tol: float, rot_tol: float) -> tuple[NDArray[np.float64], float, float, int]:
        """One Levenberg-Marquardt descent from q; returns (q, pos_err, rot_err, iterations)."""
        model, ee_id = self.model, self._ee_id
        lower, upper = self.lower, self.upper
        eye = np.eye(6)

        def residual(q_: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64]]:
            pin.forwardKinematics(model, data, q_)
            world_M_ee = pin.updateFramePlacement(model, data, ee_id)
            ee_M_target = world_M_ee.actInv(world_M_target)
            return ee_M_target, np.asarray(pin.log6(ee_M_target).vector)

        def jacobian(ee_M_target: Any) -> NDArray[np.float64]:
            pin.computeJointJacobians(model, data)  # uses the placements of the last residual() call
            ee_J = pin.getFrameJacobian(model, data, ee_id, pin.LOCAL)
            return np.asarray(-pin.Jlog6(ee_M_target.inverse()) @ ee_J)

        ee_M_target, err = residual(q)
        cost = float(err @ err)
        J = jacobian(ee_M_target)
        damping = 1e-3
        iterations = 0
        while True:
            pos_err = float(np.linalg.norm(ee_M_target.translation))
            rot_err = float(np.linalg.norm(err[3:]))
            if (pos_err <= pos_tol and rot_err <= rot_tol) or iterations >= max_iter:
                return q, pos_err, rot_err, iterations
            iterations += 1
            step = -np.linalg.solve(J.T @ J + damping * eye, J.T @ err)
            longest = float(np.max(np.abs(step)))
            if longest > 0.5:
                step *= 0.5 / longest
            q_try = np.clip(q + step, lower, upper)
            ee_M_try, err_try = residual(q_try)
            cost_try = float(err_try @ err_try)
            if cost_try < cost:
                q, ee_M_target, err, cost = q_try, ee_M_try, err_try, cost_try
                J = jacobian(ee_M_target)
                damping = max(damping * 0.2, 1e-9)
            else:
                damping *= 10.0
                if damping > 1e6:  # no descent direction left: a local minimum or a joint limit
                    return q, pos_err, rot_err, iterations


# -- grasp features <-> end-effector pose -------------------------------------------------------------

def _min_rotation_from_down(a_hat: NDArray[np.float64]) -> NDArray[np.float64]:
    """The smallest rotation taking (0, 0, -1) to the unit vector a_hat; R_x(pi) for a_hat = +z."""
    ax, ay, az = (float(v) for v in a_hat)
    s2 = ax * ax + ay * ay
    if s2 == 0.0 and az > 0.0:
        return np.diag([1.0, -1.0, -1.0])
    # Rodrigues with w = (0, 0, -1) x a = (ay, -ax, 0), cos = -az: R = -az I + [w]x + w w^T / (1 - az).
    # 1 - az is computed as s2 / (1 + az) when az > 0 to avoid cancellation near +z.
    h = (1.0 + az) / s2 if az > 0.0 else 1.0 / (1.0 - az)
    w = np.array([ay, -ax, 0.0])
    w_cross = np.array([[0.0, 0.0, -ax], [0.0, 0.0, -ay], [ax, ay, 0.0]])
    r_min: NDArray[np.float64] = -az * np.eye(3) + w_cross + h * np.outer(w, w)
    return r_min


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def features_to_obj_T_ee(x: ArrayLike) -> NDArray[np.float64]:
    """End-effector pose ``obj_T_ee`` of a grasp feature vector (convention in the module docstring).

    Parameters
    ----------
    x : array_like, shape (10,)
        Grasp features (:data:`~grasp_intent_ros.core.features.MICO_3F` layout); the approach need not be
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
    if not np.all(np.isfinite(vec)):
        raise InvalidFeaturesError(f'x must be finite, got {vec}')
    approach = vec[APPROACH]
    norm = float(np.linalg.norm(approach))
    if norm < 1e-9:
        raise InvalidFeaturesError(f'approach vector x[3:6] must be non-zero, got {approach}')
    obj_T_ee = np.eye(4)
    obj_T_ee[:3, :3] = _min_rotation_from_down(approach / norm) @ _rot_z(float(vec[ROLL])) @ _R_TOP
    obj_T_ee[:3, 3] = vec[PALM]
    return obj_T_ee


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
    T = _as_transform(obj_T_ee, 'obj_T_ee')
    try:
        closures = _as_vector(fingers, 3, 'fingers')
    except KinematicsError as exc:
        raise InvalidFeaturesError(str(exc)) from None
    obj_R_ee = T[:3, :3]
    approach = obj_R_ee[:, 2]
    roll_R = _min_rotation_from_down(approach).T @ obj_R_ee @ _R_TOP  # = R_z(roll); R_TOP is involutive
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

def pose_to_matrix(position: ArrayLike, quat_xyzw: ArrayLike) -> NDArray[np.float64]:
    """4x4 transform of a position (m) and a quaternion in ROS order (x, y, z, w), normalised here.

    Raises
    ------
    KinematicsError
        On wrong shapes, non-finite values, or a zero quaternion.
    """
    p = _as_vector(position, 3, 'position')
    xyzw = _as_vector(quat_xyzw, 4, 'quat_xyzw')
    norm = float(np.linalg.norm(xyzw))
    if norm < 1e-12:
        raise KinematicsError('quat_xyzw must be non-zero')
    x, y, z, w = xyzw / norm
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).toRotationMatrix()  # Pinocchio takes w first
    T[:3, 3] = p
    return T


def matrix_to_pose(T: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position (m) and unit quaternion (x, y, z, w) with w >= 0 of a 4x4 rigid transform.

    Raises
    ------
    KinematicsError
        If ``T`` is not a rigid 4x4 transform.
    """
    M = _as_transform(T, 'T')
    xyzw = np.array(pin.Quaternion(M[:3, :3]).coeffs(), dtype=np.float64)  # coeffs() is (x, y, z, w)
    if xyzw[3] < 0.0:
        xyzw = -xyzw
    return M[:3, 3].copy(), xyzw


class Reachability:
    """The MICO's reachability as a robot constraint for :func:`grasp_intent_ros.core.planner.plan`
    (``accept=``): grasp features x are reachable when IK of ``base_T_obj @ features_to_obj_T_ee(x)``
    converges from ``q_seed`` (then random restarts).

    Every IK answer is kept, so the accepted candidate's joint angles are not solved twice.

    Parameters
    ----------
    kin : MicoKinematics
    base_T_obj : array_like, shape (4, 4)
        Object pose in the base frame.
    q_seed : array_like, shape (6,), optional
        IK seed and branch reference (rad), e.g. the latest joint reading; :data:`HOME_Q` if None.
    restarts : int
        Random IK restarts after the seeded attempt fails.
    """

    def __init__(self, kin: MicoKinematics, base_T_obj: ArrayLike, q_seed: ArrayLike | None = None, *,
                 restarts: int = 8) -> None:
        self.kin = kin
        self.base_T_obj = _as_transform(base_T_obj, 'base_T_obj')
        self.q_seed = np.array(HOME_Q) if q_seed is None else kin._check_q(q_seed, 'q_seed')
        self.restarts = restarts
        self.answers: dict[bytes, IkResult] = {}
        """IK answer per candidate (key: ``x.tobytes()``)."""
        self.seconds = 0.0
        """Time spent in IK so far (s)."""

    def answer(self, x: NDArray[np.float64]) -> IkResult:
        """The IK answer for features x (solved on first use)."""
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key not in self.answers:
            start = time.perf_counter()
            self.answers[key] = self.kin.ik(self.base_T_obj @ features_to_obj_T_ee(x), self.q_seed,
                                            restarts=self.restarts)
            self.seconds += time.perf_counter() - start
        return self.answers[key]

    def __call__(self, x: NDArray[np.float64]) -> bool:
        """Whether the arm reaches the grasp x."""
        return self.answer(x).success
