"""Intent interpretation (paper eqs. 3-4): task probabilities w -> joint events u -> target vector v.

Tasks are indexed 0..m-1. A *zone* is a non-empty set of tasks, written as a bitmask (bit i set means
task i is satisfied). Zones are ordered by (number of tasks, bitmask): for m = 3 with tasks
(usage, transfer, handover) the order is U, T, H, UT, UH, TH, UTH, the row order of the paper's tables.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError

__all__ = [
    'MAX_TASKS',
    'DEFAULT_TASKS',
    'DEFAULT_CLARIFICATION_THRESHOLD',
    'Interpretation',
    'NeedsClarification',
    'IntentResult',
    'ZoneInterpreter',
    'all_zones',
    'zone_label',
    'zone_labels',
    'parse_zones',
    'match_zones',
    'validate_v',
    'default_task_names',
    'validate_w',
    'event_probabilities',
    'interpret',
    'reconstruct_w',
    'TASK_TIE',
    'most_likely_task',
    'single_task_v',
    'restrict',
    'support_zones',
]

MAX_TASKS = 10
"""Largest number of principal tasks m (2^m - 1 = 1023 zones)."""

DEFAULT_TASKS = ('usage', 'transfer', 'handover')
DEFAULT_CLARIFICATION_THRESHOLD = 0.5


def _check_m(m: int) -> None:
    if not 1 <= m <= MAX_TASKS:
        raise InvalidIntentError(f'number of tasks must be 1..{MAX_TASKS}, got {m}')


@functools.lru_cache(maxsize=MAX_TASKS)
def all_zones(m: int) -> tuple[int, ...]:
    """All 2^m - 1 non-empty task subsets as bitmasks, ordered by (number of tasks, bitmask)."""
    _check_m(m)
    return tuple(sorted(range(1, 1 << m), key=lambda z: (bin(z).count('1'), z)))


def default_task_names(m: int) -> tuple[str, ...]:
    """('usage', 'transfer', 'handover') for m = 3, else ('task1', ..., 'task<m>')."""
    _check_m(m)
    return DEFAULT_TASKS if m == 3 else tuple(f'task{i + 1}' for i in range(m))


def _symbols(task_names: Sequence[str]) -> tuple[list[str], str]:
    initials = [name[:1].upper() for name in task_names]
    if all(initials) and len(set(initials)) == len(initials):
        return initials, ''
    return [str(i + 1) for i in range(len(task_names))], '+'


def zone_label(zone: int, task_names: Sequence[str]) -> str:
    """Short label of a zone: task initials ('UT') when they are unique, else task numbers ('1+3')."""
    symbols, sep = _symbols(task_names)
    if not 0 < zone < (1 << len(task_names)):
        raise InvalidIntentError(f'zone {zone} is not a non-empty subset of {len(task_names)} tasks')
    return sep.join(s for i, s in enumerate(symbols) if zone >> i & 1)


def zone_labels(zones: Sequence[int], task_names: Sequence[str]) -> tuple[str, ...]:
    """Labels of several zones, in the given order."""
    return tuple(zone_label(z, task_names) for z in zones)


def parse_zones(labels: Sequence[str], task_names: Sequence[str]) -> tuple[int, ...]:
    """Bitmasks of zones given by label (as produced by :func:`zone_label`).

    Raises
    ------
    InvalidIntentError
        For an unknown label.
    """
    known = {zone_label(z, task_names): z for z in all_zones(len(task_names))}
    out = []
    for label in labels:
        if label not in known:
            raise InvalidIntentError(
                f'unknown zone {label!r} for tasks {list(task_names)}; known: {", ".join(known)}')
        out.append(known[label])
    return tuple(out)


def match_zones(n_values: int, labels: Sequence[str] | None, task_names: Sequence[str]) -> tuple[int, ...]:
    """Zone bitmasks of the entries of a target vector v over all zones of ``task_names``.

    Parameters
    ----------
    n_values : int
        Length of v.
    labels : sequence of str or None
        v's zone labels, in v's order; None means the core zone order (:func:`all_zones`).
    task_names : sequence of str
        The tasks of the model v is meant for.

    Returns
    -------
    tuple of int, length ``n_values``
        In label (or core) order.

    Raises
    ------
    InvalidIntentError
        If v does not name each zone of the tasks exactly once (or, unlabelled, has another length).
    """
    return _match_zones(n_values, None if labels is None else tuple(labels), tuple(task_names))


@functools.lru_cache(maxsize=64)  # a planner matches the same labels to the same model for every v
def _match_zones(n_values: int, labels: tuple[str, ...] | None, task_names: tuple[str, ...]) -> tuple[int, ...]:
    expected = all_zones(len(task_names))
    if labels is None:
        if n_values != len(expected):
            raise InvalidIntentError(f'v must have {len(expected)} entries (all zones of the model\'s '
                                     f'{len(task_names)} tasks), got {n_values}')
        return expected
    try:
        zones = parse_zones(labels, task_names)
    except InvalidIntentError as exc:
        raise InvalidIntentError(f'v labels do not match the model\'s {len(task_names)} tasks: {exc}') from None
    if sorted(zones) != sorted(expected):
        raise InvalidIntentError(f'v labels {",".join(labels)} must name each of the {len(expected)} zones of '
                                 f'the model\'s tasks once ({",".join(zone_labels(expected, task_names))})')
    return zones


def validate_v(v: ArrayLike, labels: Sequence[str] | None = None) -> NDArray[np.float64]:
    """A target vector as received: finite, non-negative, summing to 1 within 1e-6, one label per entry.

    Raises
    ------
    InvalidIntentError
        Otherwise, with the reason.
    """
    arr = np.asarray(v, dtype=np.float64)
    if arr.ndim != 1 or not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or abs(float(arr.sum()) - 1.0) > 1e-6:
        raise InvalidIntentError(f'v must be non-negative and sum to 1 (within 1e-6); sum '
                                 f'{float(arr.sum()):.9g}, min {float(arr.min()) if arr.size else math.nan:.6g}')
    if labels is not None and len(labels) != arr.size:
        raise InvalidIntentError(f'v has {arr.size} values but its label names {len(labels)} zones')
    return arr


def validate_w(w: ArrayLike, m: int | None = None) -> NDArray[np.float64]:
    """Check a task-probability vector and return it as a float array of shape (m,).

    Raises
    ------
    InvalidIntentError
        If w is not 1-D, has the wrong length (or more than MAX_TASKS entries), holds a NaN or
        infinity, or has a value outside [0, 1].
    """
    try:
        arr = np.asarray(w, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidIntentError(f'w must be a vector of numbers: {exc}') from None
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidIntentError(f'w must be a non-empty 1-D vector, got shape {arr.shape}')
    if m is not None and arr.size != m:
        raise InvalidIntentError(f'w must have {m} entries (one per task), got {arr.size}')
    if arr.size > MAX_TASKS:
        raise InvalidIntentError(f'w has {arr.size} entries; at most {MAX_TASKS} tasks are supported')
    if not (arr.min() >= 0.0 and arr.max() <= 1.0):  # NaN fails too: one test for the valid w
        if not np.all(np.isfinite(arr)):
            raise InvalidIntentError(f'w must be finite, got {arr.tolist()}')
        raise InvalidIntentError(f'every entry of w must lie in [0, 1], got {arr.tolist()}')
    return arr


def event_probabilities(w: ArrayLike) -> NDArray[np.float64]:
    """Joint event probabilities u (eq. 3), shape (2^m,), indexed by event bitmask.

    u[Y] = prod_{i in Y} w_i * prod_{j not in Y} (1 - w_j); u[0] is the "no task" event.
    """
    return _event_probabilities(validate_w(w))


@functools.lru_cache(maxsize=MAX_TASKS)
def _event_table(m: int) -> NDArray[np.bool_]:
    """Whether event Y (row, bitmask) includes task i (column): shape (2^m, m), read-only."""
    masks = np.arange(1 << m)
    table: NDArray[np.bool_] = ((masks[:, None] >> np.arange(m)[None, :]) & 1) == 1
    table.flags.writeable = False
    return table


def _event_probabilities(w_arr: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`event_probabilities` of a w already checked by :func:`validate_w`."""
    u: NDArray[np.float64] = np.where(_event_table(w_arr.size), w_arr, 1.0 - w_arr).prod(axis=1)
    return u


@dataclass(frozen=True)
class IntentResult:
    """What :func:`interpret` found for one w.

    Attributes
    ----------
    w : ndarray, shape (m,)
    u : ndarray, shape (2^m,)
        Joint event probabilities indexed by bitmask.
    zones : tuple of int, length K
        The zones v is expressed over.
    p_none : float
        Probability that no task is intended, u[0].
    """

    w: NDArray[np.float64]
    u: NDArray[np.float64]
    zones: tuple[int, ...]
    p_none: float

    @property
    def needs_clarification(self) -> bool:
        """True when no target vector could be formed and the operator should be asked."""
        return isinstance(self, NeedsClarification)


@dataclass(frozen=True)
class Interpretation(IntentResult):
    """A usable target vector v over ``zones`` (eq. 4). ``v`` sums to 1."""

    v: NDArray[np.float64]


@dataclass(frozen=True)
class NeedsClarification(IntentResult):
    """No target vector: "no task" is too likely, or the model has no zone the intent supports."""

    reason: str

    @property
    def v(self) -> None:
        """Always None: there is no target vector to plan for."""
        return None


def interpret(w: ArrayLike, zones: Sequence[int] | None = None, *,
              clarification_threshold: float = DEFAULT_CLARIFICATION_THRESHOLD,
              support: Sequence[int] | None = None,
              ) -> Interpretation | NeedsClarification:
    """Turn task probabilities into a target vector over a model's zones.

    Parameters
    ----------
    w : array_like, shape (m,)
        Independent probability of each principal task, in [0, 1].
    zones : sequence of int, optional
        The model's zones (bitmasks over the m tasks). Default: all 2^m - 1 zones in core order.
    clarification_threshold : float in (0, 1]
        Ask for clarification when P(no task) >= this value.
    support : sequence of int, optional
        The zones of the model that will serve the intent, when v is expressed over more zones than the
        model has (the ROS interpreter publishes v over all zones; the planner renormalises it over its
        model's zones with :func:`restrict`). Ask for clarification when u gives none of them any
        probability, i.e. when ``restrict(v, zones, support)`` would be None. Default: ``zones``.

    Returns
    -------
    Interpretation or NeedsClarification
        Reasons, in the order checked: P(no task) too high; no zone of ``support`` (or ``zones``)
        with non-zero probability.

    Raises
    ------
    InvalidIntentError
        For a malformed w, zones (or support) that are not non-empty subsets of m tasks, or a threshold
        outside (0, 1].
    """
    w_arr = validate_w(w)
    return ZoneInterpreter(w_arr.size, zones, clarification_threshold=clarification_threshold,
                           support=support).interpret_checked(w_arr)


class ZoneInterpreter:
    """:func:`interpret` for one number of tasks, zone set, support and threshold, checked once.

    For a stream of w (the ROS interpreter): the zones, support and threshold are checked when it is built,
    and each call checks only w. ``ZoneInterpreter(m, zones, ...)(w)`` equals
    ``interpret(w, zones, ...)`` for every w of m entries.

    Parameters
    ----------
    m : int
        Number of tasks (entries of w).
    zones, clarification_threshold, support
        As for :func:`interpret`.

    Raises
    ------
    InvalidIntentError
        As :func:`interpret` does for the zones, the support and the threshold, and for m outside
        1..MAX_TASKS.
    """

    def __init__(self, m: int, zones: Sequence[int] | None = None, *,
                 clarification_threshold: float = DEFAULT_CLARIFICATION_THRESHOLD,
                 support: Sequence[int] | None = None) -> None:
        if not (isinstance(clarification_threshold, (int, float, np.floating))
                and 0.0 < float(clarification_threshold) <= 1.0):
            raise InvalidIntentError(
                f'clarification_threshold must lie in (0, 1], got {clarification_threshold!r}')
        _check_m(m)
        self.m = m
        self.zones = _check_zones(all_zones(m) if zones is None else zones, m, 'zones')
        self.support = self.zones if support is None else _check_zones(support, m, 'support')
        self.clarification_threshold = float(clarification_threshold)
        self._zone_index, self._support_index = np.asarray(self.zones), np.asarray(self.support)

    def __call__(self, w: ArrayLike) -> Interpretation | NeedsClarification:
        """:func:`interpret` of ``w``. Raises InvalidIntentError for a malformed w or one of another length."""
        return self.interpret_checked(validate_w(w, self.m))

    def interpret_checked(self, w_arr: NDArray[np.float64]) -> Interpretation | NeedsClarification:
        """:meth:`__call__` of a w already checked by :func:`validate_w` (m entries)."""
        u = _event_probabilities(w_arr)
        p_none = float(u[0])
        if p_none >= self.clarification_threshold:
            return NeedsClarification(w=w_arr, u=u, zones=self.zones, p_none=p_none,
                                      reason=f'P(no task) = {p_none:.4f} >= threshold '
                                             f'{self.clarification_threshold:.4f}')
        supported = float(u[self._support_index].sum())
        u_zones = u[self._zone_index]
        total = float(u_zones.sum())
        if not (supported > 0.0 and total > 0.0 and math.isfinite(total)):
            return NeedsClarification(w=w_arr, u=u, zones=self.zones, p_none=p_none,
                                      reason='no zone of the model has non-zero probability under this w')
        return Interpretation(w=w_arr, u=u, zones=self.zones, p_none=p_none, v=u_zones / total)


def _check_zones(zones: Sequence[int], m: int, what: str) -> tuple[int, ...]:
    zone_tuple = tuple(int(z) for z in zones)
    if not zone_tuple:
        raise InvalidIntentError(f'{what} must not be empty')
    bad = [z for z in zone_tuple if not 0 < z < (1 << m)]
    if bad:
        raise InvalidIntentError(f'{what} {bad} are not non-empty subsets of {m} tasks')
    if len(set(zone_tuple)) != len(zone_tuple):
        raise InvalidIntentError(f'{what} contain duplicates: {list(zone_tuple)}')
    return zone_tuple


def reconstruct_w(p: ArrayLike, zones: Sequence[int], m: int) -> NDArray[np.float64]:
    """Principal-task probabilities implied by a zone posterior: w_i = sum of p_k over zones containing i.

    Parameters
    ----------
    p : array_like, shape (K,) or (N, K)
    zones : sequence of int, length K
    m : int
        Number of tasks.

    Returns
    -------
    ndarray, shape (m,) or (N, m)
    """
    p_arr = np.asarray(p, dtype=np.float64)
    membership = _task_membership(tuple(int(z) for z in zones), m)
    if p_arr.shape[-1] != membership.shape[0]:
        raise InvalidIntentError(f'p has {p_arr.shape[-1]} entries but there are {membership.shape[0]} zones')
    out: NDArray[np.float64] = p_arr @ membership
    return out


TASK_TIE = 1e-12
"""Task probabilities (:func:`most_likely_task`) at most this far apart are tied: far above the few ulp by which
v's sums separate the tasks of an exact tie of w, far below any difference a w rounded to 12 digits makes."""


def most_likely_task(v: ArrayLike, zones: Sequence[int], m: int) -> int:
    """The single most likely task under the target vector ``v``: the one separate per-task classifiers would pick.

    P(task i) = sum of v_k over the zones k containing task i (:func:`reconstruct_w`); for v = interpret(w).v over
    all zones it is w_i / (1 - P(no task)), so the answer is argmax_i w_i (over a model's zones alone, the task most
    likely given them: w = (0.2, 0.3, 0.9) over zones U, T, UT, TH, UTH gives transfer). Ties: the lowest index i
    whose P(task i) is within :data:`TASK_TIE` of the largest (an exact tie of w must not be decided by the rounding
    of v's sums).

    Parameters
    ----------
    v : array_like, shape (K,)
        A target vector over ``zones`` (finite, non-negative).
    zones : sequence of int, length K
    m : int
        Number of tasks.

    Raises
    ------
    InvalidIntentError
        For a v of another length than ``zones``, or one that is not finite and non-negative.
    """
    arr = np.asarray(v, dtype=np.float64)
    if arr.ndim != 1 or not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise InvalidIntentError(f'v must be a finite, non-negative vector, got {arr.tolist()}')
    p_task = reconstruct_w(arr, zones, m)
    return int(np.flatnonzero(p_task >= p_task.max() - TASK_TIE)[0])


def single_task_v(v: ArrayLike, zones: Sequence[int], m: int) -> NDArray[np.float64] | None:
    """The target on the zone of the single most likely task alone: one-hot over ``all_zones(m)``, core order.

    What a planner fed by separate per-task classifiers plans for: v on the zone {i} of
    :func:`most_likely_task` (arguments and errors as there). None when ``v`` gives no zone any probability (the
    intent-aware target asks for clarification then too).
    """
    task = most_likely_task(v, zones, m)
    if not float(np.sum(np.asarray(v, dtype=np.float64))) > 0.0:
        return None
    out = np.zeros(len(all_zones(m)))
    out[all_zones(m).index(1 << task)] = 1.0
    return out


@functools.lru_cache(maxsize=64)
def _task_membership(zones: tuple[int, ...], m: int) -> NDArray[np.float64]:
    """(K, m) read-only: 1 where zone k contains task i (computed once per zone structure)."""
    _check_m(m)
    zone_arr = np.asarray(zones, dtype=np.int64)
    membership = ((zone_arr[:, None] >> np.arange(m)[None, :]) & 1).astype(np.float64)
    membership.flags.writeable = False
    return membership


def restrict(v: ArrayLike, zones: Sequence[int], model_zones: Sequence[int]) -> NDArray[np.float64] | None:
    """Re-express a target vector over a model's zones: keep the model's zones, renormalise.

    For v = interpret(w).v over all zones this equals interpret(w, model_zones).v.

    Parameters
    ----------
    v : array_like, shape (K,)
        Target vector over ``zones``.
    zones : sequence of int, length K
    model_zones : sequence of int
        Must all be among ``zones``.

    Returns
    -------
    ndarray over ``model_zones`` summing to 1, or None when v gives those zones no probability
    (the operator must be asked for clarification).

    Raises
    ------
    InvalidIntentError
        For a v that is not a finite, non-negative vector with one entry per zone, or a model zone
        that v does not cover.
    """
    arr = np.asarray(v, dtype=np.float64)
    zone_list = [int(z) for z in zones]
    if arr.shape != (len(zone_list),) or not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise InvalidIntentError(f'v must be a finite, non-negative vector with {len(zone_list)} entries, '
                                 f'got {arr.tolist()}')
    index = {z: i for i, z in enumerate(zone_list)}
    missing = [z for z in model_zones if z not in index]
    if missing:
        raise InvalidIntentError(f'v does not cover the model zones {missing}')
    sub = arr[[index[int(z)] for z in model_zones]]
    total = float(sub.sum())
    if not total > 0.0:
        return None
    out: NDArray[np.float64] = sub / total
    return out


def support_zones(task_names: Sequence[str], model_task_names: Sequence[str],
                  model_zones: Sequence[int]) -> tuple[int, ...] | None:
    """A model's zones as zones over ``task_names``, for :func:`interpret`'s ``support``.

    Zones are bitmasks over task indices, so they carry over only when the model has the same tasks in
    the same order; returns None otherwise (the model cannot tell which intents it serves).
    """
    if tuple(task_names) != tuple(model_task_names):
        return None
    return tuple(int(z) for z in model_zones)
