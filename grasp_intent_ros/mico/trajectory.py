"""A joint trajectory by the joint_trajectory_controller's rules, ROS-free: checked, then sampled as its splines.

The mock arm's trajectory controller (:class:`~.mock_arm.MockArm` follows what :class:`TrajectoryExecution`
samples). :func:`check_trajectory` accepts what the controller's topic interface accepts and rejects the rest
with a :class:`~grasp_intent_ros.errors.CommandError` saying why:

- joint names non-empty, unique, each a controller joint; all controller joints unless
  ``allow_partial`` (the controller's ``allow_partial_joints_goal``, default false);
- every point has one position per joint; velocities and accelerations either absent from every point
  or one per joint in every point (accelerations only with velocities); all values finite;
- ``time_from_start`` strictly increasing from a first point later than 0 (a point at 0 would ask for a
  jump from the current state);
- the last point's velocities zero (``allow_nonzero_velocity_at_trajectory_end`` false, Jazzy's default);
- positions within the joint limits (the mock's stand-in for ros2_control's joint limits);
- a non-zero header stamp is the start time; a trajectory that would end before ``now`` is rejected.
  A zero stamp means "start now".

:class:`TrajectoryExecution` samples an accepted trajectory as the controller's spline interpolator does:
the first segment runs from the state at the start time (position and velocity, zero acceleration) to
the first point; each segment is linear when the points give positions only, a cubic Hermite spline with
velocities, a quintic with velocities and accelerations. Before the start time the state is held; after
the last point, its positions. A new trajectory replaces the one in progress (from the current state).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CommandError

__all__ = ['TrajectoryCommand', 'check_trajectory', 'TrajectoryExecution']


@dataclass(frozen=True)
class TrajectoryCommand:
    """A joint trajectory as received, before any check.

    Attributes
    ----------
    joint_names : tuple of str, length k
    times : sequence of float, length n
        ``time_from_start`` of each point (s).
    positions : list of n sequences
        Each point's positions (rad); lengths checked by :func:`check_trajectory`.
    velocities, accelerations : list of n sequences
        Each point's (possibly empty) velocities (rad/s) and accelerations (rad/s^2).
    start : float or None
        The header stamp (s, the controller's clock); None for a zero stamp ("start now").
    """

    joint_names: tuple[str, ...]
    times: Sequence[float]
    positions: Sequence[Sequence[float]]
    velocities: Sequence[Sequence[float]]
    accelerations: Sequence[Sequence[float]]
    start: float | None = None


@dataclass(frozen=True)
class _CheckedTrajectory:
    """An accepted trajectory: controller joint indices (k,), times (n,), arrays (n, k) or None, start (s)."""

    indices: NDArray[np.intp]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64] | None
    accelerations: NDArray[np.float64] | None
    start: float


def _point_array(rows: Sequence[Sequence[float]], k: int, what: str, *, optional: bool) -> NDArray[np.float64] | None:
    """The n rows as an (n, k) array; None when every row is empty and ``optional``."""
    sizes = {len(row) for row in rows}
    if optional and sizes == {0}:
        return None
    if sizes != {k}:
        bad = next(i for i, row in enumerate(rows) if len(row) != k)
        raise CommandError(f'trajectory point {bad} has {len(rows[bad])} {what} for {k} joints'
                           + (f' (give {what} in every point or in none)' if optional else ''))
    arr = np.array([list(row) for row in rows], dtype=np.float64).reshape(len(rows), k)
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise CommandError(f'trajectory point {bad} has a NaN or infinite {what[:-1]}')
    return arr


def check_trajectory(cmd: TrajectoryCommand, controller_joints: Sequence[str], lower: ArrayLike, upper: ArrayLike,
                     *, now: float, allow_partial: bool = False) -> _CheckedTrajectory:
    """The trajectory, checked by the rules of the module docstring, ready for :class:`TrajectoryExecution`.

    An empty trajectory (no points) is accepted: it stops the arm where it is.

    Parameters
    ----------
    cmd : TrajectoryCommand
    controller_joints : sequence of str, length N
    lower, upper : array_like, shape (N,)
        Position limits (rad).
    now : float
        The controller's time (s), the start of a trajectory stamped zero.
    allow_partial : bool
        Accept a trajectory for some of the controller's joints (the others hold).

    Raises
    ------
    CommandError
        Naming the first rule broken.
    """
    names = cmd.joint_names
    index = {name: i for i, name in enumerate(controller_joints)}
    if not names:
        raise CommandError('trajectory has no joint names')
    if len(set(names)) != len(names):
        raise CommandError(f'trajectory names a joint twice: {sorted({n for n in names if names.count(n) > 1})}')
    unknown = [name for name in names if name not in index]
    if unknown:
        raise CommandError(f'trajectory names joints this controller does not have: {unknown[:5]}')
    missing = [name for name in controller_joints if name not in names]
    if missing and not allow_partial:
        raise CommandError(f'trajectory lacks the controller joints {missing} (allow_partial_joints_goal is false)')
    indices = np.array([index[name] for name in names], dtype=np.intp)
    times = np.asarray(cmd.times, dtype=np.float64)
    start = now if cmd.start is None else cmd.start
    n, k = times.size, len(names)
    if n == 0:
        return _CheckedTrajectory(indices, times, np.empty((0, k)), None, None, start)
    if not (len(cmd.positions) == len(cmd.velocities) == len(cmd.accelerations) == n):
        raise CommandError('trajectory points and their fields differ in number')
    if not np.all(np.isfinite(times)):
        raise CommandError('trajectory has a NaN or infinite time_from_start')
    if times[0] <= 0.0:
        raise CommandError(f'the first trajectory point must come after time 0, got time_from_start {times[0]:g} s')
    if n > 1 and not np.all(np.diff(times) > 0.0):
        bad = int(np.flatnonzero(np.diff(times) <= 0.0)[0]) + 1
        raise CommandError(f'time_from_start must be strictly increasing: point {bad} at {times[bad]:g} s '
                           f'after point {bad - 1} at {times[bad - 1]:g} s')
    positions = _point_array(cmd.positions, k, 'positions', optional=False)
    assert positions is not None
    velocities = _point_array(cmd.velocities, k, 'velocities', optional=True)
    accelerations = _point_array(cmd.accelerations, k, 'accelerations', optional=True)
    if accelerations is not None and velocities is None:
        raise CommandError('trajectory gives accelerations without velocities')
    if velocities is not None and np.any(velocities[-1] != 0.0):
        raise CommandError('the last trajectory point must have zero velocities '
                           '(allow_nonzero_velocity_at_trajectory_end is false)')
    lo, hi = np.asarray(lower, dtype=np.float64)[indices], np.asarray(upper, dtype=np.float64)[indices]
    outside = (positions < lo) | (positions > hi)
    if np.any(outside):
        point, joint = (int(i) for i in np.argwhere(outside)[0])
        raise CommandError(f'trajectory point {point} puts {names[joint]} at {positions[point, joint]:.6g} rad, '
                           f'outside its limits [{lo[joint]:.6g}, {hi[joint]:.6g}]')
    if start + times[-1] < now:
        raise CommandError(f'trajectory stamped {start:.3f} s ends {now - start - times[-1]:.3f} s in the past')
    return _CheckedTrajectory(indices, times, positions, velocities, accelerations, start)


def _segment(t: float, duration: float, p0: NDArray[np.float64], v0: NDArray[np.float64], a0: NDArray[np.float64],
             p1: NDArray[np.float64], v1: NDArray[np.float64] | None, a1: NDArray[np.float64] | None
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position and velocity at ``t`` in [0, duration] of the spline from (p0, v0, a0) to (p1, v1, a1).

    Linear when ``v1`` is None, cubic Hermite when ``a1`` is None, else quintic.
    """
    T = duration
    if v1 is None:
        return p0 + (p1 - p0) * (t / T), (p1 - p0) / T
    if a1 is None:  # cubic: p(0) = p0, p'(0) = v0, p(T) = p1, p'(T) = v1
        c2 = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / T**2
        c3 = (-2.0 * (p1 - p0) + (v0 + v1) * T) / T**3
        return p0 + v0 * t + c2 * t**2 + c3 * t**3, v0 + 2.0 * c2 * t + 3.0 * c3 * t**2
    # quintic: p, p', p'' given at both ends
    c2 = a0 / 2.0
    d = p1 - p0 - v0 * T - c2 * T**2
    dv = v1 - v0 - a0 * T
    da = a1 - a0
    c3 = (20.0 * d - 8.0 * dv * T + da * T**2) / (2.0 * T**3)
    c4 = (-30.0 * d + 14.0 * dv * T - 2.0 * da * T**2) / (2.0 * T**4)
    c5 = (12.0 * d - 6.0 * dv * T + da * T**2) / (2.0 * T**5)
    position = p0 + v0 * t + c2 * t**2 + c3 * t**3 + c4 * t**4 + c5 * t**5
    velocity = v0 + 2.0 * c2 * t + 3.0 * c3 * t**2 + 4.0 * c4 * t**3 + 5.0 * c5 * t**4
    return position, velocity


class TrajectoryExecution:
    """An accepted trajectory from the state its controller had when it arrived (module docstring).

    Parameters
    ----------
    trajectory : result of :func:`check_trajectory`
    q0, v0 : ndarray, shape (N,)
        The controller joints' positions and velocities when the trajectory arrived.
    """

    def __init__(self, trajectory: _CheckedTrajectory, q0: NDArray[np.float64], v0: NDArray[np.float64]) -> None:
        self.trajectory = trajectory
        self._q0, self._v0 = q0[trajectory.indices].copy(), v0[trajectory.indices].copy()

    @property
    def end_time(self) -> float:
        """When the last point is reached (s, the controller's clock)."""
        t = self.trajectory
        return t.start + (float(t.times[-1]) if t.times.size else 0.0)

    def sample(self, now: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference positions and velocities of the trajectory's joints at time ``now`` (s), shape (k,) each."""
        traj = self.trajectory
        t = now - traj.start
        k = traj.indices.size
        if traj.times.size == 0 or t <= 0.0:
            return self._q0.copy(), np.zeros(k) if traj.times.size == 0 else self._v0.copy()
        if t >= traj.times[-1]:
            last_v = np.zeros(k) if traj.velocities is None else traj.velocities[-1]
            return traj.positions[-1].copy(), last_v.copy()
        i = int(np.searchsorted(traj.times, t, side='right'))  # t lies in segment i: (times[i-1], times[i]]
        zero = np.zeros(k)
        vel, acc = traj.velocities, traj.accelerations
        if i == 0:
            t0, p0, v0, a0 = 0.0, self._q0, self._v0, zero
        else:
            t0, p0 = float(traj.times[i - 1]), traj.positions[i - 1]
            v0 = zero if vel is None else vel[i - 1]
            a0 = zero if acc is None else acc[i - 1]
        return _segment(t - t0, float(traj.times[i]) - t0, p0, v0, a0, traj.positions[i],
                        None if vel is None else vel[i], None if acc is None else acc[i])
