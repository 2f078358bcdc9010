"""What every planning method shares: the result types, the tolerances, v's check, the feasible set, the starts.

The feasible set X (:class:`Feasible`) is

    lower <= x <= upper,   |approach(x)| = 1,   distance(palm(x), body) >= margin

(the last only when the model carries the object's body, see :mod:`grasp_intent_ros.method.body`).
:func:`select_starts` gives Algorithm 1's starts, :func:`in_choice_order` the choice order of rule 6 of
:mod:`.lm` (also the scipy methods'), and :class:`Search` the bookkeeping of the methods that fit P to v
(their candidates, the ``accept`` hook asked in the choice order, the :class:`PlanResult`).

Machine independence: the screens, the scores and the choice sum in a fixed order (compiled kernels) and
take ``exp`` and ``log`` from the C library (:func:`c_log`), so they have the same bits under any BLAS.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PlanningError
from ..kernels import choice_order, distinct, feasible, score, select_demonstrations
from ..method.intent import reconstruct_w
from ..method.model import GraspModel

__all__ = [
    'Candidate', 'PlanResult', 'MATCH_TOL', 'F_RTOL', 'DISTANCE_TOL', 'WARM_BAND', 'check_v', 'objective', 'c_log',
    'zone_order', 'select_starts', 'feasible_demonstrations', 'Feasible', 'unique_rows', 'in_choice_order', 'Search',
    'exact',
]

MATCH_TOL = 1e-12
"""f within this of the best found (or 1e-6 relative, whichever is larger) counts as a match."""
F_RTOL = 1e-6
DISTANCE_TOL = 1e-6
"""Scaled distances to the reference within this of the nearest are a tie, broken by start order."""
WARM_BAND = 3e-3
"""With a warm start and no exact match, converged candidates whose residual |v - P| is within this of the
best one's tie with it (rule 6): a fifth of what v moves in a typical step of the benchmark's walk."""


class Candidate(NamedTuple):
    """One refined start (immutable; a named tuple, built faster than a dataclass: a plan makes dozens).

    Attributes
    ----------
    x : ndarray, shape (d,)
    posterior : ndarray, shape (K,)
    objective : float
        f(x) = 1/2 |v - P(x)|^2.
    distance : float
        Scaled distance |(x - x_ref) / s| to the plan's reference.
    start : ndarray, shape (d,)
        Where the refinement began.
    start_objective : float
    start_index : int
        Position of the start in the plan's start order (ties are broken by it); method 'task': the
        candidate's position in the ranking.
    success : bool
        The refinement converged (a KKT point or a stationary point of f), not stopped by its
        iteration limit; always True for method 'task' (a demonstration is not refined).
    message : str
        How the refinement ended; method 'task': the demonstration and the tier of the ranking it is in.
    iterations : int
        Solver iterations (0 for method 'task').
    demonstration : int or None
        Method 'task': the candidate's row in the model's demonstrations; None for the other methods.

    For method 'task' the candidate is a demonstration as it is: ``x`` is ``start`` and ``objective`` is
    ``start_objective``; ``distance`` is to the plan's reference.
    """

    x: NDArray[np.float64]
    posterior: NDArray[np.float64]
    objective: float
    distance: float
    start: NDArray[np.float64]
    start_objective: float
    start_index: int
    success: bool
    message: str
    iterations: int
    demonstration: int | None = None


@dataclass(frozen=True)
class PlanResult:
    """Outcome of :func:`plan`: the chosen candidate and what led to it.

    Attributes
    ----------
    chosen : Candidate
        The answer (see the method's module); ``x``, ``posterior`` and ``objective`` are its.
    w : ndarray, shape (m,)
        Principal-task probabilities reconstructed from the posterior.
    exact : bool
        The objective is at most :data:`MATCH_TOL`: P matches v.
    reference : ndarray, shape (d,)
        x_ref, the grasp the answer is nearest to.
    status : str
        'ok' (the chosen candidate's refinement converged), 'solver_failed' (it stopped before
        converging) or 'rejected' (no candidate passed ``accept``; x is then the first ranked).
    message : str
    iterations : int
        Solver iterations summed over all starts.
    wall_time_s : float
    method : str
    candidates : tuple of Candidate
        Every distinct refined start, in the choice order.
    rejected : int
        How many candidates ``accept`` turned down before the chosen one.
    """

    chosen: Candidate
    w: NDArray[np.float64]
    exact: bool
    reference: NDArray[np.float64]
    status: str
    message: str
    iterations: int
    wall_time_s: float
    method: str
    candidates: tuple[Candidate, ...]
    rejected: int

    @property
    def x(self) -> NDArray[np.float64]:
        """Planned grasp features, shape (d,)."""
        return self.chosen.x

    @property
    def posterior(self) -> NDArray[np.float64]:
        """P(k|x) over the model's zones, shape (K,)."""
        return self.chosen.posterior

    @property
    def objective(self) -> float:
        """1/2 |v - P(x)|^2."""
        return self.chosen.objective

    @property
    def success(self) -> bool:
        """True when the status is 'ok'."""
        return self.status == 'ok'


def check_v(model: GraspModel, v: ArrayLike) -> NDArray[np.float64]:
    try:  # a copy: a read-only v (e.g. read in place from a message) would be another type to the compiled kernels
        arr = np.array(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PlanningError(f'v must be numeric: {exc}') from None
    K = len(model.zones)
    if arr.shape != (K,):
        raise PlanningError(f'v must have one entry per model zone ({K}: {",".join(model.zone_labels)}), '
                            f'got shape {arr.shape}')
    total = float(arr.sum())  # not finite when an entry is not (or the entries overflow: then no probabilities either)
    if not math.isfinite(total) or float(arr.min()) < 0.0 or abs(total - 1.0) > 1e-6:
        raise PlanningError(f'v must be a probability vector (finite, >= 0, sum 1), got {arr.tolist()}')
    return arr


def objective(model: GraspModel, v: NDArray[np.float64], x: ArrayLike) -> NDArray[np.float64] | float:
    """f(x) = 1/2 |v - P(x)|^2 for x of shape (d,) (float) or (N, d) (array of N)."""
    r = v - model.posterior(x)
    out = 0.5 * np.einsum('...k,...k->...', r, r)
    return float(out) if np.ndim(out) == 0 else out


def c_log(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Natural logs by the C library's log, as the compiled kernels take them (numpy has vectorised logs of its own)."""
    return np.array([math.log(t) for t in values.tolist()])


def zone_order(v: NDArray[np.float64]) -> NDArray[np.intp]:
    """Zones from the most to the least likely; v compared at 1e-9, ties in zone order (never noise)."""
    return np.lexsort((np.arange(v.size), -np.rint(v * 1e9)))


def select_starts(model: GraspModel, v: NDArray[np.float64], n_starts: int = 3,
                  top_zones: int = 2) -> NDArray[np.float64]:
    """Algorithm 1's starts, shape (<= n_starts, d).

    The demonstration of the top-v zone with the lowest objective first, then the next best
    demonstrations of the ``top_zones`` most likely zones. A demonstration belongs to zone k when its
    task set contains k (inclusive labeling); when the top zone has none, the best demonstration overall
    comes first. Objectives are compared at 1e-12 relative, then by demonstration order (compiled:
    ``kernels.select_demonstrations``).
    """
    index = select_demonstrations(model.demo_posterior, v, model.zone_members, zone_order(v)[:max(1, top_zones)],
                                  n_starts - 1, MATCH_TOL)
    out: NDArray[np.float64] = model.demo_x[index]
    return out


def feasible_demonstrations(model: GraspModel) -> NDArray[np.float64]:
    """The demonstrations projected onto the feasible set X (N, d): method 'task''s candidates, bit for bit."""
    return Feasible(model).project(model.demo_x)


class Feasible:
    """Projection onto the feasible set X (compiled: :mod:`.kernels`) and the scale of the distance between grasps."""

    def __init__(self, model: GraspModel) -> None:
        self.model = model
        self.lower, self.upper = model.lower, model.upper
        self.a = model.features.approach
        self.scale = model.feature_scale
        self.body = model.body.kernel_arrays if model.body is not None else (
            np.zeros(0, dtype=np.int64), *np.zeros((3, 0, 3)), *np.zeros((2, 0)), np.zeros((0, 3)), 0.0)
        """The body as the compiled kernels take it (no primitive at all: no body)."""

    def project(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Clip to the bounds, normalise the approach, push the palm out of the body (N, d)."""
        return feasible(x, self.lower, self.upper, self.a.start, self.a.stop, self.body)


def unique_rows(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rows of x without exact repeats, in their first order (-0.0 and 0.0 are the same; compiled)."""
    out: NDArray[np.float64] = x[distinct(x, 0.0)]
    return out


def in_choice_order(candidates: list[Candidate], band: float) -> list[Candidate]:
    """The choice order (rule 6 of :mod:`.lm`, ``band`` its residual band: 0 for a fresh plan).

    A candidate within 1e-9 (relative) of an earlier one is dropped.
    """
    if len(candidates) <= 1:
        return list(candidates)
    order = choice_order(np.array([c.objective for c in candidates]), np.array([c.distance for c in candidates]),
                         np.array([c.start_index for c in candidates]), np.array([c.x for c in candidates]),
                         np.array([c.success for c in candidates]), MATCH_TOL, F_RTOL, band, DISTANCE_TOL, 1e-18)
    return [candidates[i] for i in order.tolist()]


def exact(cands: list[Candidate]) -> list[Candidate]:
    """The converged candidates whose f is at most :data:`MATCH_TOL` (P matches v), in their order."""
    return [c for c in cands if c.success and c.objective <= MATCH_TOL]


@dataclass
class Search:
    """One plan of a method that fits P to v ('lm', the scipy methods): its starts, candidates and answer.

    Attributes
    ----------
    model : GraspModel
    v : ndarray, shape (K,)
        The checked target.
    x_ref : ndarray, shape (d,)
        The reference (in X) distances are measured to.
    feas : Feasible
    band : float
        Rule 6's residual band: :data:`WARM_BAND` with a warm start, else 0.
    accept : callable x -> bool or None
        The robot constraint, asked about each candidate once, in the choice order.
    demo : ndarray, shape (<= n_starts, d), or None
        The demonstration starts when selected before the reference (no warm start), else None.
    n_starts, top_zones : int
        As for :func:`select_starts`.
    method : str
    t0 : float
        ``time.perf_counter()`` when the plan began.
    found : list of Candidate
        Every scored candidate so far, in start order.
    turned_down : list of Candidate
        The candidates ``accept`` refused, in the order asked.
    """

    model: GraspModel
    v: NDArray[np.float64]
    x_ref: NDArray[np.float64]
    feas: Feasible
    band: float
    accept: Callable[[NDArray[np.float64]], bool] | None
    demo: NDArray[np.float64] | None
    n_starts: int
    top_zones: int
    method: str
    t0: float
    found: list[Candidate] = field(default_factory=list)
    turned_down: list[Candidate] = field(default_factory=list)

    def all_starts(self) -> NDArray[np.float64]:
        """x_ref, then the demonstration starts (with a warm start, selected only when the search goes beyond x_ref)."""
        model, feas, x_ref = self.model, self.feas, self.x_ref
        if self.demo is None:
            return np.concatenate([x_ref[None, :], feas.project(select_starts(model, self.v, self.n_starts,
                                                                              self.top_zones))])
        return np.concatenate([x_ref[None, :], feas.project(self.demo[1:])])

    def candidates_from(self, xs: NDArray[np.float64], origin: NDArray[np.float64], ok: NDArray[np.bool_],
                        its: NDArray[np.int64], first_index: int, message: Callable[[int, bool], str],
                        ) -> list[Candidate]:
        """Scored candidates of the end points xs (N, d); ``message(i, converged)`` says how row i ended."""
        model = self.model
        n = xs.shape[0]
        post, f, dist = score(np.concatenate([xs, origin]), self.v, model.means, model.precisions, model.log_norm,
                              self.x_ref, self.feas.scale)
        f_all = f.tolist()
        return [Candidate(x, p, fi, di, x0, f0, first_index + i, converged, message(i, converged), it)
                for i, (x, p, fi, di, x0, f0, converged, it) in enumerate(zip(
                    xs, post[:n], f_all[:n], dist[:n].tolist(), origin, f_all[n:], ok.tolist(), its.tolist()))]

    def choose(self, ranked: list[Candidate]) -> Candidate | None:
        """The first of ``ranked`` (in choice order) that ``accept`` takes, asking each candidate once."""
        turned_down = self.turned_down
        for cand in ranked:
            if any(cand is c for c in turned_down):
                continue
            if self.accept is None or self.accept(cand.x):
                return cand
            turned_down.append(cand)
        return None

    def result(self, chosen: Candidate | None) -> PlanResult:
        """The plan's result: ``chosen``, else the first of :attr:`found` in choice order ``accept`` takes.

        Status 'ok', 'solver_failed' (the chosen candidate did not converge) or 'rejected' (``accept`` took
        none; the first ranked is returned). The candidates are those asked and turned down, then the chosen
        one, then the rest in choice order.
        """
        model, turned_down, found = self.model, self.turned_down, self.found
        ranked = in_choice_order(found, self.band)
        if chosen is None:
            chosen = self.choose(ranked)
        if chosen is None:
            chosen, status = ranked[0], 'rejected'
            ranked = turned_down + [c for c in ranked if not any(c is t for t in turned_down)]
        else:
            status = 'ok'
            rest = [c for c in ranked if c is not chosen and not any(c is t for t in turned_down)]
            ranked = turned_down + [chosen] + rest
        rejected = len(turned_down)
        if status == 'ok' and not chosen.success:
            status = 'solver_failed'
        message = {'ok': f'planned ({chosen.message})', 'solver_failed': f'not converged: {chosen.message}',
                   'rejected': f'all {len(ranked)} candidates rejected by the robot constraint'}[status]
        return PlanResult(chosen=chosen, w=reconstruct_w(chosen.posterior, model.zones, len(model.task_names)),
                          exact=chosen.objective <= MATCH_TOL, reference=self.x_ref, status=status, message=message,
                          iterations=sum(c.iterations for c in found), wall_time_s=time.perf_counter() - self.t0,
                          method=self.method, candidates=tuple(ranked), rejected=rejected)
