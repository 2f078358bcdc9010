r"""Kinematics of the 3-finger Kinova MICO (m1n6s300): forward and inverse kinematics with Pinocchio.

The grasp-frame maths (features <-> end-effector pose, poses <-> matrices) is :mod:`.frames`.

Frames
------
``base`` (:data:`BASE_FRAME`, ``m1n6s300_link_base``)
    Origin on the bottom plane of the arm's base, +z up.
``ee`` (:data:`EE_FRAME`, ``m1n6s300_end_effector``)
    The tool frame, i.e. the last frame of Kinova's DH table: origin at the palm centre, +z along the hand
    axis pointing out of the palm (the approach direction), +x towards finger 1 (the thumb side); fingers 2
    and 3 sit at -x, +-y.
``obj``
    The object frame of :mod:`grasp_intent_ros.method.features` (origin at the centre of the object's base,
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

This module is the arm's model: its joints, frames and limits, forward kinematics and the Jacobian, the checks
of joint angles and their 2 pi branches. The IK is :mod:`.ik` (:meth:`MicoKinematics.ik` checks and calls it),
the planner's reachability constraint :mod:`.reachability`.
"""

from __future__ import annotations

import math
import os
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from ..resources import config_dir
from .frames import check_transform, check_vector
from .ik import IK_MAX_ITER, IK_POS_TOL, IK_ROT_TOL, IkResult, chain_arrays, solve_ik

__all__ = [
    'JOINT_LIMIT_MARGIN',
    'ARM_JOINTS',
    'FINGER_JOINTS',
    'BASE_FRAME',
    'EE_FRAME',
    'HOME_Q',
    'URDF_FILENAME',
    'default_urdf_path',
    'MicoKinematics',
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

JOINT_LIMIT_MARGIN = 0.1
"""How far (rad) a joint reading may lie outside the joint limits (sensor noise, a controller's overshoot)
and still be used as an IK seed: :meth:`MicoKinematics.check_limits`."""

_WIDE_JOINTS = np.array([True, False, False, True, True, True])
"""Joints without end stops on the robot (1, 4, 5, 6): IK answers are wrapped by 2 pi towards the seed."""
_TWO_PI = 2.0 * math.pi


def default_urdf_path() -> Path:
    """Path of ``config/mico_3f.urdf`` (see :func:`grasp_intent_ros.resources.config_dir`).

    Raises
    ------
    FileNotFoundError
        If no config directory is found or it holds no ``mico_3f.urdf``.
    """
    path = config_dir() / URDF_FILENAME
    if not path.is_file():
        raise FileNotFoundError(f'{URDF_FILENAME} not found in {path.parent}')
    return path


class MicoKinematics:
    """The MICO arm from the project URDF (Pinocchio): forward kinematics, the Jacobian, joint limits and IK.

    The Pinocchio model (arm joints only; the fingers are locked open since they do not move the EE)
    is built once and never modified; each thread has its own ``pinocchio.Data`` (made at its first
    :meth:`fk`), so one instance can serve several threads.

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
    world_T_base : ndarray, shape (4, 4)
        The base frame's placement in the URDF's root frame (Pinocchio's world), read-only.
    ik_chain : tuple of ndarray
        The joint chain as the compiled IK takes it (:func:`~.ik.chain_arrays`). Treat as read-only.

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
        self._lower, self._upper = self.lower.tolist(), self.upper.tolist()  # for per-joint Python arithmetic
        self._wide = tuple(int(j) for j in np.flatnonzero(_WIDE_JOINTS))
        self._wide_full_turn = tuple(j for j in self._wide if self._upper[j] - self._lower[j] >= _TWO_PI)
        self._ee_id: int = model.getFrameId(EE_FRAME)
        self._base_M_world = model.frames[base_id].placement.inverse()
        self.world_T_base: NDArray[np.float64] = np.array(model.frames[base_id].placement.homogeneous)
        self.world_T_base.setflags(write=False)
        self.ik_chain = chain_arrays(model, self._ee_id)  # writable: the types the IK's kernel is warmed up with
        self._data = threading.local()  # a pinocchio.Data per thread, made at its first use

    # -- forward kinematics ---------------------------------------------------------------------------

    def check_q(self, q: ArrayLike, what: str = 'q') -> NDArray[np.float64]:
        """``q`` as an array of shape (6,) (float64; an array of that type as given, not copied).

        Raises
        ------
        KinematicsError
            Naming ``what``, if ``q`` is not a finite numeric vector of shape (6,).
        """
        return check_vector(q, 6, what)

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
        q = self.check_q(q)
        data = self._thread_data()
        pin.forwardKinematics(self.model, data, q)
        world_M_ee = pin.updateFramePlacement(self.model, data, self._ee_id)
        return np.array((self._base_M_world * world_M_ee).homogeneous)

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Geometric Jacobian of the end effector in the base frame at joint angles ``q``.

        ``J @ qd`` is the EE twist for joint speeds ``qd``: rows 0-2 the linear velocity of the EE origin,
        rows 3-5 the angular velocity, both in base-frame coordinates (m/s, rad/s per rad/s).

        Parameters
        ----------
        q : array_like, shape (6,)

        Returns
        -------
        ndarray, shape (6, 6)

        Raises
        ------
        KinematicsError
            If ``q`` is not a finite vector of shape (6,).
        """
        q = self.check_q(q)
        world_J = pin.computeFrameJacobian(self.model, self._thread_data(), q, self._ee_id,
                                           pin.LOCAL_WORLD_ALIGNED)
        base_R_world = self._base_M_world.rotation
        return np.vstack([base_R_world @ world_J[:3], base_R_world @ world_J[3:]])

    def _thread_data(self) -> Any:
        """This thread's ``pinocchio.Data`` (made at its first use)."""
        data = getattr(self._data, 'data', None)
        if data is None:
            data = self._data.data = self.model.createData()
        return data

    def check_limits(self, q: ArrayLike, *, margin: float = 0.0, what: str = 'q') -> NDArray[np.float64]:
        """``q`` as an array of shape (6,), when every joint lies within its limits widened by ``margin`` (rad).

        Raises
        ------
        KinematicsError
            If ``q`` is not a finite vector of shape (6,), or naming the joints outside
            ``[lower - margin, upper + margin]``.
        """
        q = self.check_q(q, what)
        outside = (q < self.lower - margin) | (q > self.upper + margin)
        if np.any(outside):
            bad = ', '.join(f'{name} = {value:.6g}' for name, value, out in zip(self.joint_names, q, outside)
                            if out)
            raise KinematicsError(f'{what} outside the joint limits (margin {margin:g} rad): {bad} rad')
        return q

    # -- inverse kinematics ---------------------------------------------------------------------------

    def nearest_branch(self, q: ArrayLike, q_ref: ArrayLike) -> NDArray[np.float64]:
        """``q`` with joints 1, 4, 5, 6 shifted by multiples of 2 pi towards ``q_ref``, within the limits.

        The pose is unchanged. Joints 2 and 3 (range < 2 pi) are returned as given.

        Raises
        ------
        KinematicsError
            If either argument is not a finite vector of shape (6,).
        """
        # per joint in Python floats: numpy's masked updates of six values cost more (run once per plan)
        out, refs = self.check_q(q).tolist(), self.check_q(q_ref, 'q_ref').tolist()
        for j in self._wide:
            ref, lo, hi = refs[j], self._lower[j], self._upper[j]
            value = out[j] + _TWO_PI * round((ref - out[j]) / _TWO_PI)
            if value > hi:
                value -= _TWO_PI * math.ceil((value - hi) / _TWO_PI)
            if value < lo:
                value += _TWO_PI * math.ceil((lo - value) / _TWO_PI)
            out[j] = value
        return np.array(out)

    def into_limits(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """``q`` (shape (6,), rad) within the limits, as a new array.

        Joints 1, 4, 5, 6 whose range spans a whole turn are wrapped by 2 pi into it (the pose kept), then every
        joint is clipped to its limits.
        """
        out = q.tolist()
        for j in self._wide_full_turn:
            lo, hi = self._lower[j], self._upper[j]
            if out[j] < lo or out[j] > hi:
                out[j] = (out[j] - lo) % _TWO_PI + lo
        clipped: NDArray[np.float64] = np.clip(out, self.lower, self.upper)
        return clipped

    def restart_seed(self, q_ref: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        """A random IK start near ``q_ref`` (shape (6,), rad): the seed of each of :meth:`ik`'s restarts.

        Joints 2 and 3 uniform within their limits, joints 1, 4, 5, 6 uniform in ``q_ref`` +- pi, then wrapped
        by 2 pi into the limits (the pose-keeping wrap of wide joints; anything still outside is clipped).
        Draws, in this order: six values uniform within the limits (the wide joints' are discarded), then
        four in (-pi, pi), so one generator state gives one seed.
        """
        q_start = rng.uniform(self.lower, self.upper)
        q_start[_WIDE_JOINTS] = q_ref[_WIDE_JOINTS] + rng.uniform(-math.pi, math.pi, int(_WIDE_JOINTS.sum()))
        return self.into_limits(q_start)

    def ik(self, base_T_ee_target: ArrayLike, q_seed: ArrayLike | None = None, *, restarts: int = 8,
           pos_tol: float = IK_POS_TOL, rot_tol: float = IK_ROT_TOL, max_iter: int = IK_MAX_ITER,
           rng: np.random.Generator | int | None = None) -> IkResult:
        """Joint angles that put the EE at ``base_T_ee_target``: :func:`~.ik.solve_ik` on the arguments checked.

        The first attempt starts from ``q_seed``, the restarts from :meth:`restart_seed` about it, and the answer
        is on the 2 pi branch nearest it (:meth:`nearest_branch`). Never raises for an unreachable target:
        ``success`` is then False.

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
        base_T_target = check_transform(base_T_ee_target, 'base_T_ee_target')
        q_ref = np.array(HOME_Q) if q_seed is None else self.check_q(q_seed, 'q_seed')
        if restarts < 0 or max_iter < 1 or not (pos_tol > 0.0 and rot_tol > 0.0):
            raise KinematicsError(
                f'need restarts >= 0, max_iter >= 1, tolerances > 0; got {restarts}, {max_iter}, '
                f'{pos_tol}, {rot_tol}')
        return solve_ik(self, base_T_target, q_ref, restarts=restarts, pos_tol=pos_tol, rot_tol=rot_tol,
                        max_iter=max_iter, rng=rng)
