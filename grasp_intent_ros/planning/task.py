"""The default method, ``method='task'``: serve the likely tasks with a demonstration.

The answer is the labelled demonstration, in X, that serves v's top zone, does (by its label) and is read by
the model (argmax_k P(k|x)) as doing only likely tasks (the top zone's, and tasks whose probability, read
from v, is at least ``tau``), and has the highest expected task success under v as executed: v's mass on the
zones its task set contains, each weighted by the estimated probability that the grasp, landing off by the
execution noise :attr:`~.options.TaskOptions.noise`, still does that zone's tasks
(:mod:`grasp_intent_ros.planning.robustness`: estimated from the labelled demonstrations only, once per
model and noise; None, the default, plans for an exact landing, where that probability is 1); ties go to the
paper's fit 1/2 |v - P|^2, then to the reference, then to demonstration order. A warm start keeps its
demonstration while it stays within stated bands of the best expected success and fit, and tasks it is read
as doing stay likely down to ``tau - hysteresis``. The rules and reasons are
:mod:`grasp_intent_ros.planning.ranking`'s. P(x) does not match v in general: the price in fit is the
benchmarks' to report.

Every quantity sums in a fixed order (:mod:`.ranking`, compiled kernels), so a plan has the same bits under
any BLAS.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanningError
from ..method.intent import reconstruct_w, zone_label
from ..method.model import GraspModel
from .common import MATCH_TOL, Candidate, PlanResult, zone_order
from .options import TaskOptions
from .ranking import rank, task_candidates
from .robustness import ExecutionNoise, retention

__all__ = ['FIRST_CANDIDATES', 'serve', 'precompute']

FIRST_CANDIDATES = 32
"""How many candidates ``accept`` is asked before the rest of the best tier (:func:`serve`)."""


def serve(model: GraspModel, v: NDArray[np.float64], x_ref: NDArray[np.float64], warm: bool,
          accept: Callable[[NDArray[np.float64]], bool] | None, opts: TaskOptions, t0: float) -> PlanResult:
    """Method 'task': the first demonstration of :func:`~.ranking.rank` that ``accept`` takes.

    ``accept`` is asked in the choice order: the first 32 candidates, then, only when it refuses them all, the
    rest of the best tier (the first candidate's, :class:`~.ranking.Ranking`), so that no demonstration that
    serves the likely tasks is left unasked when the arm reaches few of them (an object turned away); further
    candidates of lower tiers are not asked, and the plan is 'rejected'. Asked at most: the larger of 32 and the
    best tier's size, which for a model of one Gaussian per zone is the demonstrations of the zones containing
    v's top zone. The result's ``candidates`` are those asked, in order.
    """
    kept = None if opts.noise is None or opts.noise.is_zero else retention(model, opts.noise)
    ranking = rank(model, v, int(zone_order(v)[0]), x_ref, tau=opts.tau, hysteresis=opts.hysteresis, warm=warm,
                   faithful=opts.faithful, retention=kept)
    names = model.task_names
    likely = zone_label(ranking.likely, names)
    top = zone_label(ranking.top, names)
    tiers = (f'serves the likely tasks {likely}', f'serves the top zone {top}, reads as a task outside {likely}',
             f'misses the top zone {top}')
    labels = task_candidates(model).labels

    if not ranking.order.size:
        raise PlanningError(f'model {model.name!r} has no demonstration outside its body to plan from')
    first = min(FIRST_CANDIDATES, ranking.order.size)

    def build(lo: int, hi: int) -> list[Candidate]:
        """Candidates lo..hi-1 of the ranking (Python scalars converted in bulk: a plan builds dozens)."""
        return [Candidate(x, p, f, d, x, f, k, True, f'demonstration {i} ({labels[i]}): {tiers[t]}', 0, i)
                for k, (x, p, f, d, i, t) in enumerate(zip(
                    ranking.x[lo:hi], ranking.posterior[lo:hi], ranking.objective[lo:hi].tolist(),
                    ranking.distance[lo:hi].tolist(), ranking.order[lo:hi].tolist(), ranking.tier[lo:hi].tolist()),
                    start=lo)]

    candidates = build(0, first)
    index = next((k for k, cand in enumerate(candidates) if accept is None or accept(cand.x)), None)
    if index is None and accept is not None:  # the rest of the best tier (the tier sorts first)
        rest = build(first, int(np.count_nonzero(ranking.tier == ranking.tier[0])))
        index = next((k for k, cand in enumerate(rest, start=first) if accept(cand.x)), None)
        candidates += rest if index is None else rest[:index + 1 - first]
    status = 'ok' if index is not None else 'rejected'
    rejected = index if index is not None else len(candidates)
    chosen = candidates[index if index is not None else 0]
    message = f'planned ({chosen.message})' if status == 'ok' else \
        f'all {len(candidates)} candidates rejected by the robot constraint'
    return PlanResult(chosen=chosen, w=reconstruct_w(chosen.posterior, model.zones, len(names)),
                      exact=chosen.objective <= MATCH_TOL, reference=x_ref, status=status, message=message,
                      iterations=0, wall_time_s=time.perf_counter() - t0, method='task', candidates=tuple(candidates),
                      rejected=rejected)


def precompute(model: GraspModel, noise: ExecutionNoise | None) -> None:
    """Compute what method 'task' keeps of ``model`` for every plan, so that no plan waits on it.

    The ranking's candidates (:func:`~.ranking.task_candidates`) and, for a ``noise`` that is not zero, the
    robustness estimate (:func:`~.robustness.retention`); both are kept per model (and noise), so a caller that
    does not prepare pays them at the model's first plan instead. A planner node calls it when a model arrives.
    """
    task_candidates(model)
    if noise is not None and not noise.is_zero:
        retention(model, noise)
