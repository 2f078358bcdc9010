r"""A prior over task sets from independent task probabilities: a classifier's w as the intent estimator's prior.

Given task probabilities ``w`` from another source (the paper's per-task classifiers, each task inferred
independently), the prior over the task sets the goals serve is that independent-task model's, conditioned on the
set being one some goal serves, then uniform over the goals of a set:

.. math::

    \pi(S) \propto \prod_i w_i^{s_i} (1 - w_i)^{1 - s_i}, \qquad \pi_g = \pi(S_g) / n_{S_g},

``s_i`` 1 when task i is in S, ``n_S`` the number of goals serving S. The estimator clips ``w`` to
``[w_floor, 1 - w_floor]`` first, so that no set is ruled out for good (the motion can always recover it).
``w = (1/2, ..., 1/2)`` gives the estimator's default prior, uniform over the served sets (up to rounding).
The estimator keeps its evidence ``E_g`` apart from the prior, so a new ``w`` re-weights the motion seen so far at
once: the posterior is always ``pi_g(w) exp(E_g)``. The motion's ``|E_g|`` reaches ``beta L`` (100 nats by
default), far beyond the prior's log-ratios (2.2 per task at 0.9 against 0.1): the motion decides among the goals
it tells apart, ``w`` among those it cannot (goals at one pose that differ in the fingers, and every goal near a
shown grasp, which the motion credits alike). docs/intent_estimation.md, "A classifier's w as the prior".
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.intent import MAX_TASKS
from ..method.log_space import log_sum_exp

__all__ = ['check_task_prior', 'task_log_prior']


def check_task_prior(w: ArrayLike, n_tasks: int | None = None) -> NDArray[np.float64]:
    """``w`` as a task prior's probabilities (a new float array): finite, each in [0, 1], 1..MAX_TASKS of them.

    Raises InvalidIntentError for anything else, or for a length other than ``n_tasks`` when it is given.
    """
    values = np.array(w, dtype=np.float64)
    if values.ndim != 1 or not 1 <= values.size <= MAX_TASKS:
        raise InvalidIntentError(f'a task prior is 1 to {MAX_TASKS} probabilities, got shape {values.shape}')
    if n_tasks is not None and values.size != n_tasks:
        raise InvalidIntentError(f'a task prior needs {n_tasks} probabilities (the model\'s tasks), got {values.size}')
    if not np.all(np.isfinite(values)) or np.any(values < 0.0) or np.any(values > 1.0):
        raise InvalidIntentError(f'task prior probabilities must lie in [0, 1], got {values.tolist()}')
    return values


def task_log_prior(task_sets: NDArray[np.int64], membership: NDArray[np.float64],
                   w: NDArray[np.float64]) -> NDArray[np.float64]:
    """The log prior log pi_g (module docstring), read-only, shape (N,).

    For goals serving ``task_sets`` (shape (N,); ``membership`` (N, m): 1.0 where goal g's set holds task i), from
    ``w`` (shape (m,), strictly inside (0, 1): the caller clips it).
    """
    log_set = membership @ np.log(w) + (1.0 - membership) @ np.log1p(-w)  # log prod, per goal's set
    _, first, inverse, counts = np.unique(task_sets, return_index=True, return_inverse=True, return_counts=True)
    per_set = log_set[first]
    out: NDArray[np.float64] = (per_set - log_sum_exp(per_set))[inverse] - np.log(counts[inverse].astype(np.float64))
    out.flags.writeable = False
    return out
