r"""The intent estimator's goals: the model's demonstrations placed at the object, the reachable ones, their prior.

Every labelled demonstration of the active model, placed at the object
(``base_T_g = base_T_obj @ features_to_obj_T_ee(x_g)``) and reachable by the arm, is a goal ``g`` serving its
task set ``S_g`` (:class:`Goals`); only its pose is used. The default prior is uniform over the task sets that
some goal serves, then uniform over the goals of a set: ``pi_g = 1 / (n_sets * n_{S_g})``. The method that
reads them: :mod:`.estimator` (its module docstring; docs/intent_estimation.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.intent import MAX_TASKS
from ..method.model import GraspModel
from ..mico.frames import check_transform, check_vector, features_to_obj_T_ee
from ..mico.kinematics import HOME_Q, MicoKinematics

__all__ = ['Goals', 'goals_from_poses', 'goals_at', 'reachable_goals']


@dataclass(frozen=True, eq=False)
class Goals:
    """The goals of one model at one object pose (module docstring), read-only arrays.

    Attributes
    ----------
    positions : ndarray, shape (N, 3)
        Palm centres in the base frame (m).
    rotations : ndarray, shape (N, 3, 3)
        Hand orientations in the base frame.
    task_sets : ndarray of int, shape (N,)
        Bitmask of the tasks each goal serves (the demonstration's label).
    log_prior : ndarray, shape (N,)
        log pi_g.
    membership : ndarray, shape (N, m)
        1.0 where goal g serves task i.
    demo_index : ndarray of int, shape (N,)
        Row of each goal in the model's demonstrations.
    """

    positions: NDArray[np.float64]
    rotations: NDArray[np.float64]
    task_sets: NDArray[np.int64]
    log_prior: NDArray[np.float64]
    membership: NDArray[np.float64]
    demo_index: NDArray[np.int64]

    @property
    def n_tasks(self) -> int:
        """m, the number of tasks."""
        return int(self.membership.shape[1])

    def __len__(self) -> int:
        return int(self.task_sets.shape[0])

    def set_posterior(self, goal_posterior: ArrayLike) -> dict[int, float]:
        """P(S) for each task set S served by a goal: the posterior summed over its goals."""
        p = np.asarray(goal_posterior, dtype=np.float64)
        return {int(s): float(p[self.task_sets == s].sum()) for s in np.unique(self.task_sets)}


def goals_from_poses(base_T_goals: ArrayLike, task_sets: ArrayLike, n_tasks: int,
                     demo_index: ArrayLike | None = None) -> Goals:
    """Goals at the given hand poses, each serving its task set, with the estimator's prior (module docstring).

    Parameters
    ----------
    base_T_goals : array_like, shape (N, 4, 4)
        Goal hand poses in the base frame (rigid transforms).
    task_sets : array_like of int, shape (N,)
        Bitmask of the tasks each goal serves, non-empty subsets of ``n_tasks`` tasks.
    n_tasks : int
        m, 1..MAX_TASKS.
    demo_index : array_like of int, shape (N,), optional
        Each goal's row in the model's demonstrations (default 0..N-1).

    Raises
    ------
    InvalidIntentError
        For no goal, mismatched shapes or task sets that are not non-empty subsets of the tasks.
    KinematicsError
        For a pose that is not a rigid transform.
    """
    if not 1 <= n_tasks <= MAX_TASKS:
        raise InvalidIntentError(f'the number of tasks must be 1..{MAX_TASKS}, got {n_tasks}')
    poses = np.asarray(base_T_goals, dtype=np.float64)
    sets = np.asarray(task_sets, dtype=np.int64)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4) or poses.shape[0] == 0 or sets.shape != (poses.shape[0],):
        raise InvalidIntentError(f'need poses of shape (N > 0, 4, 4) and N task sets, got {poses.shape} and '
                                 f'{sets.shape}')
    if np.any(sets <= 0) or np.any(sets >= 1 << n_tasks):
        raise InvalidIntentError(f'task sets must be non-empty subsets of {n_tasks} tasks')
    poses = np.stack([check_transform(T, 'goal pose') for T in poses])
    index = np.arange(sets.size, dtype=np.int64) if demo_index is None else np.asarray(demo_index, dtype=np.int64)
    unique, inverse, counts = np.unique(sets, return_inverse=True, return_counts=True)
    log_prior = -np.log(float(unique.size)) - np.log(counts[inverse].astype(np.float64))
    membership = ((sets[:, None] >> np.arange(n_tasks)[None, :]) & 1).astype(np.float64)
    arrays = (np.ascontiguousarray(poses[:, :3, 3]), np.ascontiguousarray(poses[:, :3, :3]), sets.copy(),
              log_prior, membership, index.copy())
    for arr in arrays:
        arr.flags.writeable = False
    return Goals(*arrays)


def goals_at(model: GraspModel, base_T_obj: ArrayLike, keep: ArrayLike | None = None) -> Goals:
    """The model's demonstrations placed at the object, those where ``keep`` is true (default all).

    Parameters
    ----------
    model : GraspModel
        MICO 3-finger features (the first seven: palm, approach, roll).
    base_T_obj : array_like, shape (4, 4)
        Object pose in the base frame.
    keep : array_like of bool, shape (N,), optional
        Which demonstrations are goals (e.g. :func:`reachable_goals`).

    Raises
    ------
    KinematicsError
        For a malformed pose.
    InvalidIntentError
        If ``keep`` has the wrong shape or keeps nothing, or the model has more than MAX_TASKS tasks.
    """
    base_T = check_transform(base_T_obj, 'base_T_obj')
    n = model.demo_x.shape[0]
    mask = np.ones(n, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    if mask.shape != (n,):
        raise InvalidIntentError(f'keep must have shape ({n},), got {mask.shape}')
    if not mask.any():
        raise InvalidIntentError('no goal: no demonstration of the model is kept (none reachable?)')
    index = np.flatnonzero(mask)
    obj_T = np.stack([features_to_obj_T_ee(model.demo_x[k]) for k in index])
    return goals_from_poses(np.einsum('ij,njk->nik', base_T, obj_T), model.demo_sets[index], len(model.task_names),
                            index)


def reachable_goals(model: GraspModel, base_T_obj: ArrayLike, kin: MicoKinematics, *,
                    q_seed: ArrayLike | None = None, restarts: int = 2,
                    stopping: Callable[[], bool] = lambda: False) -> NDArray[np.bool_]:
    """Which demonstrations placed at the object the arm reaches: IK from ``q_seed`` (Home if None), then restarts.

    Returns an array of bool, shape (N,). ``stopping()`` is polled between goals; when it turns true the rest
    are marked unreachable (the answer is then thrown away by the caller). Raises KinematicsError for a
    malformed pose or seed.
    """
    base_T = check_transform(base_T_obj, 'base_T_obj')
    seed = np.array(HOME_Q) if q_seed is None else check_vector(q_seed, 6, 'q_seed')
    out = np.zeros(model.demo_x.shape[0], dtype=bool)
    for k, x in enumerate(model.demo_x):
        if stopping():
            break
        out[k] = kin.ik(base_T @ features_to_obj_T_ee(x), seed, restarts=restarts).success
    return out
