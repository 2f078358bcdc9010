r"""The mock MICO's motion, ROS-free: joint trajectories and twists executed within the joint limits.

A stand-in for ros2_control's mock hardware (``mock_components/GenericSystem``: the commanded positions
become the state) driven by a joint_trajectory_controller and a servo (MoveIt Servo). Not a dynamics
simulation: the state is the commanded position, moved at most by the velocity limits per step.

Joint trajectories (the joint_trajectory_controller's topic interface)
----------------------------------------------------------------------
Checked and sampled by :mod:`.trajectory` (:func:`~.trajectory.check_trajectory`,
:class:`~.trajectory.TrajectoryExecution`): the controller's rules and its spline interpolation.

Twists (a servo's input)
------------------------
:func:`dls_joint_velocities` maps an EE twist to joint speeds by damped least squares:

.. math::

    \dot q = \arg\min_{\dot q} \lVert J \dot q - \xi \rVert^2 + \lambda^2 \lVert \dot q \rVert^2
           = J^T (J J^T + \lambda^2 I)^{-1} \xi,
    \qquad \lambda^2 = \lambda_{max}^2 \, (1 - (\sigma_{min} / \epsilon)^2) \text{ if } \sigma_{min} < \epsilon
    \text{ else } 0,

with damping only near a singularity (Chiaverini's rule: :math:`\sigma_{min}` the smallest singular
value of J, :math:`\epsilon` the threshold), so that the twist is tracked exactly elsewhere; unique
for :math:`\lambda > 0` and for a full-rank J. The answer is then scaled as a whole (the direction kept)
so that no joint exceeds its velocity limit. :class:`MockArm` integrates it for one step and keeps the positions
within the limits by its ``twist_joint_limit`` rule (:data:`TWIST_JOINT_LIMITS`):

- ``'clip'`` (the default): each joint clipped to its limits on its own. A joint at its limit stops while the
  others go on, so the hand leaves the commanded direction (it may move against it).
- ``'stop'``: the arm's step scaled as a whole to stop where the first joint reaches its limit
  (:func:`joint_limit_scale`), so the hand keeps the commanded direction and halts when a joint at its limit is
  driven further out; a command that moves that joint inward moves the arm again. This is MoveIt Servo's rule
  for twists (Jazzy, ``moveit_servo``: ``jointVariablesToHalt`` in ``src/utils/common.cpp`` finds the joints whose
  next position passes a limit less ``joint_limit_margins`` while moving outward, and ``Servo::haltJoints`` in
  ``src/servo.cpp`` then holds *every* joint at its current position, ``halt_all_joints_in_cartesian_mode``
  being true by default), with a margin of 0 and the last part of the step taken: the mock's state is its
  commanded position (no tracking error or overshoot for a margin to absorb), its limits are the ones the
  planner's IK and :func:`~.trajectory.check_trajectory` use, and the arm stops at the limit whatever the step length
  ``dt`` (Servo's halt stops up to one step short, by a distance that depends on its period).

Joint trajectories are not affected by the rule: their steps are clipped per joint (a trajectory within the
limits only leaves them where a cubic or quintic segment overshoots between two points, and there each joint
stops at its limit, as ros2_control's position limits would hold it). The fingers are clipped per finger under
either rule.

State and steps
---------------
:class:`MockArm` holds the positions of the 6 arm joints and 3 fingers (:data:`~.grasp.JOINT_NAMES`
order) and their velocities; :meth:`MockArm.step` advances it by ``dt`` under the active command: a
trajectory (each joint moves towards the sampled reference by at most its velocity limit times ``dt``),
a twist (until it is older than the command timeout, then the arm stops), or none (hold). Closing the
fingers (:meth:`MockArm.close_fingers`, the hand's grasp command) moves only the fingers, toward their
closures at the finger speed limit, under any arm command but a trajectory that arrives later.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CommandError, KinematicsError
from ..method.features import FINGERS, MICO_3F
from .frames import check_vector
from .grasp import JOINT_NAMES
from .kinematics import BASE_FRAME, EE_FRAME, MicoKinematics
from .trajectory import TrajectoryCommand, TrajectoryExecution, check_trajectory

__all__ = ['FINGER_VELOCITY_LIMIT', 'TWIST_JOINT_LIMITS', 'JOINT_LIMIT_TOLERANCE', 'dls_joint_velocities',
           'joint_limit_scale', 'TwistCommand', 'check_twist', 'MockArm']

FINGER_VELOCITY_LIMIT = 1.0
"""Finger joint speed limit (rad/s), the URDF's."""
TWIST_JOINT_LIMITS = ('clip', 'stop')
"""What a twist's step does at a joint limit (module docstring): each joint clipped, or the arm stopped as a whole."""
JOINT_LIMIT_TOLERANCE = 1e-9
"""rad: a joint stops the arm (:func:`joint_limit_scale`) only when the step would take it more than this past
its limit. Far above the rounding of a joint angle or of a DLS step (about 1e-15 rad), far below any motion
that matters (1 nm at 1 m), so that which joints stop the arm is never decided by a last bit."""


def dls_joint_velocities(jacobian: NDArray[np.float64], twist: NDArray[np.float64], damping: float,
                         velocity_limits: NDArray[np.float64], *, threshold: float = 0.05) -> NDArray[np.float64]:
    """Joint speeds (rad/s) for an EE twist by damped least squares, scaled into the velocity limits.

    Parameters
    ----------
    jacobian : ndarray, shape (6, 6)
        :meth:`~.kinematics.MicoKinematics.jacobian`.
    twist : ndarray, shape (6,)
        Linear (m/s) then angular (rad/s) velocity of the EE, in the Jacobian's frame.
    damping : float
        lambda_max (> 0), reached at a singularity.
    velocity_limits : ndarray, shape (6,)
        (> 0). The DLS answer is scaled by one factor (<= 1) so that every joint is within its limit.
    threshold : float
        epsilon (> 0): the smallest singular value of J below which damping sets in.

    Returns
    -------
    ndarray, shape (6,)
        ``s V diag(sigma / (sigma^2 + lambda^2)) U^T twist`` (J = U diag(sigma) V^T), which equals
        ``s J^T (J J^T + lambda^2 I)^{-1} twist``, times the scale s.
    """
    size = float(np.max(np.abs(twist)))
    if size == 0.0:
        return np.zeros(jacobian.shape[1])
    u, sigma, vt = np.linalg.svd(jacobian)
    lam2 = damping**2 * (1.0 - (sigma[-1] / threshold) ** 2) if sigma[-1] < threshold else 0.0
    # solved for the twist scaled to a largest entry of 1 (linear in the twist): no overflow for any finite twist
    unit: NDArray[np.float64] = vt.T @ ((sigma / (sigma**2 + lam2)) * (u.T @ (twist / size)))
    peak = float(np.max(np.abs(unit) / velocity_limits))
    return unit / peak if peak * size > 1.0 else unit * size


def joint_limit_scale(q: NDArray[np.float64], step: NDArray[np.float64], lower: NDArray[np.float64],
                      upper: NDArray[np.float64], *, tolerance: float = JOINT_LIMIT_TOLERANCE) -> float:
    """The share s of ``step`` the arm takes so that no joint passes its limit: the ``'stop'`` rule's scale.

    ``s = min(1, min_i (limit_i - q_i) / step_i)`` over the joints i whose full step would end more than
    ``tolerance`` past their limit (``q_i + step_i > upper_i + tolerance``, or below ``lower_i - tolerance``),
    ``limit_i`` the limit passed. That is the largest s in [0, 1] (so ``q + s step`` the point of the segment from
    ``q`` to ``q + step`` nearest the full step) for which each of those joints ends within its limits, every other
    joint ending within ``tolerance`` of them: the step's direction is kept (so the hand's, to first order), its
    length shortened. Ties: a joint exactly at its limit stops the arm (s = 0) when its step leads outward by more
    than ``tolerance``; one moving inward, not at all, or outward by at most ``tolerance`` does not (the caller then
    clips that joint back to the limit, a motion of at most ``tolerance``). Of several joints the first to reach its
    limit sets s.

    Parameters
    ----------
    q : ndarray, shape (n,)
        Positions (rad), within ``[lower, upper]``.
    step : ndarray, shape (n,)
        The full step (rad).
    lower, upper : ndarray, shape (n,)
        Position limits (rad).
    tolerance : float
        (>= 0, rad) :data:`JOINT_LIMIT_TOLERANCE`.

    Returns
    -------
    float
        s in [0, 1]; 1 when no joint would pass its limit by more than ``tolerance``.
    """
    high, low = q + step > upper + tolerance, q + step < lower - tolerance
    shares = np.concatenate([(upper[high] - q[high]) / step[high], (lower[low] - q[low]) / step[low]])
    return float(np.clip(shares.min(), 0.0, 1.0)) if shares.size else 1.0


@dataclass(frozen=True)
class TwistCommand:
    """An EE twist command: linear (m/s) and angular (rad/s) velocity, shape (3,) each, in ``frame``."""

    linear: NDArray[np.float64]
    angular: NDArray[np.float64]
    frame: str

    def in_base(self, base_T_ee: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """(linear, angular), shape (6,), in the base frame: one in the EE frame turned by ``base_T_ee``.

        Raises
        ------
        CommandError
            For a twist in the EE frame without ``base_T_ee`` (no joint state yet).
        """
        if self.frame != EE_FRAME:
            return np.concatenate([self.linear, self.angular])
        if base_T_ee is None:
            raise CommandError(f'an operator twist in {EE_FRAME} needs a joint state first')
        return np.concatenate([base_T_ee[:3, :3] @ self.linear, base_T_ee[:3, :3] @ self.angular])


def check_twist(linear: ArrayLike, angular: ArrayLike, frame: str, *, default_frame: str = BASE_FRAME
                ) -> TwistCommand:
    """A finite twist in the base or the EE frame (``''`` means ``default_frame``).

    Raises
    ------
    CommandError
        For a NaN or infinite value, or another frame (there is no TF here).
    """
    frame = frame or default_frame
    if frame not in (BASE_FRAME, EE_FRAME):
        raise CommandError(f'twist must be given in {BASE_FRAME!r} or {EE_FRAME!r} (no TF lookup), '
                           f'got frame_id {frame[:80]!r}')
    lin, ang = np.asarray(linear, dtype=np.float64), np.asarray(angular, dtype=np.float64)
    if not (np.all(np.isfinite(lin)) and np.all(np.isfinite(ang))):
        raise CommandError(f'twist must be finite, got linear {lin.tolist()}, angular {ang.tolist()}')
    return TwistCommand(lin, ang, frame)


class MockArm:
    """The state of the mock MICO and its controllers (module docstring).

    Parameters
    ----------
    kin : MicoKinematics
    q0 : array_like, shape (9,)
        Initial positions in :data:`~.grasp.JOINT_NAMES` order (rad), within the limits.
    damping, singular_threshold : float
        DLS lambda_max and epsilon for twists (> 0; :func:`dls_joint_velocities`).
    command_timeout : float
        A twist older than this (s) stops the arm (MoveIt Servo's ``incoming_command_timeout``).
    finger_velocity_limit : float
        rad/s.
    twist_joint_limit : str
        One of :data:`TWIST_JOINT_LIMITS`: what a twist's step does at a joint limit (module docstring), ``'clip'``
        each joint on its own, ``'stop'`` the arm as a whole (:func:`joint_limit_scale`).

    Raises
    ------
    KinematicsError
        For a ``q0`` of the wrong shape, not finite, or outside the limits.
    ValueError
        For a ``twist_joint_limit`` not in :data:`TWIST_JOINT_LIMITS`.
    """

    joint_names: tuple[str, ...] = JOINT_NAMES

    def __init__(self, kin: MicoKinematics, q0: ArrayLike, *, damping: float = 0.05, singular_threshold: float = 0.05,
                 command_timeout: float = 0.1, finger_velocity_limit: float = FINGER_VELOCITY_LIMIT,
                 twist_joint_limit: str = 'clip') -> None:
        if twist_joint_limit not in TWIST_JOINT_LIMITS:
            raise ValueError(f'twist_joint_limit must be one of {TWIST_JOINT_LIMITS}, got {twist_joint_limit!r}')
        self.twist_joint_limit = twist_joint_limit
        self.kin = kin
        self.lower = np.concatenate([kin.lower, MICO_3F.lower[FINGERS]])
        self.upper = np.concatenate([kin.upper, MICO_3F.upper[FINGERS]])
        self.velocity_limits = np.concatenate([kin.velocity_limits, np.full(3, finger_velocity_limit)])
        self.damping, self.singular_threshold, self.command_timeout = damping, singular_threshold, command_timeout
        self.reset(q0)

    def reset(self, q0: ArrayLike) -> None:
        """Put the arm at ``q0`` (shape (9,)), at rest, without a command. Raises KinematicsError as the constructor."""
        q = check_vector(q0, len(self.joint_names), 'initial positions')
        outside = (q < self.lower) | (q > self.upper)
        if np.any(outside):
            raise KinematicsError('initial positions outside the joint limits: ' + ', '.join(
                f'{n} = {v:.6g}' for n, v, o in zip(self.joint_names, q, outside) if o))
        self.q, self.qd = q.copy(), np.zeros_like(q)
        self._trajectory: TrajectoryExecution | None = None
        self._twist: tuple[TwistCommand, float] | None = None
        self._fingers: NDArray[np.float64] | None = None

    def close_fingers(self, closures: ArrayLike) -> NDArray[np.float64]:
        """Move the three fingers to ``closures`` (rad), at their speed limit, whatever the arm follows.

        The closures are clipped to the fingers' limits; the clipped target is returned. A trajectory that
        arrives later commands the fingers again (it replaces this).

        Raises
        ------
        KinematicsError
            For closures of the wrong shape or not finite.
        """
        target = np.clip(check_vector(closures, 3, 'finger closures'), self.lower[6:], self.upper[6:])
        self._fingers = target
        return target.copy()

    @property
    def mode(self) -> str:
        """'trajectory', 'twist' or 'hold': what the arm follows now."""
        return 'trajectory' if self._trajectory is not None else 'twist' if self._twist is not None else 'hold'

    def twist_live(self, now: float) -> bool:
        """Whether a twist newer than the command timeout is being followed at time ``now`` (s)."""
        return self._twist is not None and now - self._twist[1] <= self.command_timeout

    def command_trajectory(self, cmd: TrajectoryCommand, now: float, *, allow_partial: bool = False) -> None:
        """Follow ``cmd`` from the current state, replacing any trajectory or twist.

        Raises
        ------
        CommandError
            If the trajectory breaks a rule (:func:`~.trajectory.check_trajectory`); the arm goes on as before.
        """
        checked = check_trajectory(cmd, self.joint_names, self.lower, self.upper, now=now, allow_partial=allow_partial)
        self._trajectory = TrajectoryExecution(checked, self.q, self.qd)
        self._twist, self._fingers = None, None

    def command_twist(self, twist: TwistCommand, now: float) -> None:
        """Follow ``twist`` (from :func:`check_twist`) from now on, replacing a trajectory in progress."""
        self._twist = (twist, now)
        self._trajectory = None

    def step(self, now: float, dt: float) -> None:
        """Advance the state by ``dt`` (s) to time ``now`` (s) under the active command, within the position limits.

        A twist's step is kept within them by ``twist_joint_limit`` (module docstring), a trajectory's and the
        fingers' by clipping each joint.
        """
        if dt <= 0.0:
            return
        if self._trajectory is not None:
            target = self.q.copy()
            indices = self._trajectory.trajectory.indices
            target[indices] = self._trajectory.sample(now)[0]
            step = np.clip(target - self.q, -self.velocity_limits * dt, self.velocity_limits * dt)
        elif self._twist is not None and now - self._twist[1] <= self.command_timeout:
            twist, _ = self._twist
            xi = np.concatenate([twist.linear, twist.angular])
            if twist.frame == EE_FRAME:
                base_R_ee = self.kin.fk(self.q[:6])[:3, :3]
                xi = np.concatenate([base_R_ee @ twist.linear, base_R_ee @ twist.angular])
            step = np.zeros_like(self.q)
            step[:6] = dls_joint_velocities(self.kin.jacobian(self.q[:6]), xi, self.damping,
                                            self.velocity_limits[:6], threshold=self.singular_threshold) * dt
            if self.twist_joint_limit == 'stop':
                step[:6] *= joint_limit_scale(self.q[:6], step[:6], self.lower[:6], self.upper[:6])
        else:
            step = np.zeros_like(self.q)
        if self._fingers is not None:
            limit = self.velocity_limits[6:] * dt
            step[6:] = np.clip(self._fingers - self.q[6:], -limit, limit)
        q = np.clip(self.q + step, self.lower, self.upper)
        self.qd = (q - self.q) / dt
        self.q = q
        if self._trajectory is not None and now >= self._trajectory.end_time and not np.any(self.qd):
            self._trajectory = None  # reached: hold
        elif self._twist is not None and now - self._twist[1] > self.command_timeout:
            self._twist = None  # timed out: hold


