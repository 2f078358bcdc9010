"""Intent-uncertainty-aware grasp planning (paper Algorithm 1).

Given a model and a target vector v over its zones, find grasp features x that make the model's
posterior P(k|x) match v:

    minimise   f(x) = 1/2 sum_k (v_k - P_k(x))^2
    subject to lower <= x <= upper,   |approach(x)| = 1

with the analytic gradient  grad f = -J(x)^T (v - P(x)),  J = dP/dx.

The search starts from the training demonstration of the top-v zone with the lowest objective
(Algorithm 1) and, for robustness, from a few more of the best demonstrations of the top zones and
from a warm start (e.g. the previous solution during teleoperation). Each start is refined with SQP
(scipy SLSQP) or an interior-point / trust-region method (scipy trust-constr), as in the paper, or
with ``method='lm'`` (the default): a projected Levenberg-Marquardt iteration written here because it
refines every start at once with vectorised numpy (one posterior/Jacobian evaluation per iteration for
all starts) and converges in few iterations on this small least-squares problem, which suits
replanning at teleoperation rates. Candidates are ranked by objective; an optional ``accept`` hook
(e.g. "the arm can reach this grasp") filters them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import (  # type: ignore[import-untyped]
    Bounds, NonlinearConstraint, OptimizeResult, minimize)

from .errors import PlanningError
from .intent import reconstruct_w
from .model import GraspModel

__all__ = [
    'Candidate',
    'PlanResult',
    'Method',
    'Gradient',
    'objective',
    'objective_and_gradient',
    'select_starts',
    'plan',
]

Method = Literal['slsqp', 'trust-constr', 'lm']
Gradient = Literal['analytic', '2-point']

_FTOL = 1e-10
_MAXITER = 200
_TC_MAXITER = 500
_LM_MAXITER = 100
_LM_FTOL = 1e-10   # stop a start when one accepted step improves f by less than this (relative to 1 + f)
_LM_FSTOP = 1e-14  # stop every start once one reaches this objective (a match to ~1e-7 per zone)


@dataclass(frozen=True)
class Candidate:
    """One refined start.

    Attributes
    ----------
    x : ndarray, shape (d,)
    posterior : ndarray, shape (K,)
    objective : float
    start : ndarray, shape (d,)
        Where the refinement began.
    start_objective : float
    success : bool
        The solver's own verdict.
    message : str
    iterations : int
    """

    x: NDArray[np.float64]
    posterior: NDArray[np.float64]
    objective: float
    start: NDArray[np.float64]
    start_objective: float
    success: bool
    message: str
    iterations: int


@dataclass(frozen=True)
class PlanResult:
    """Outcome of :func:`plan`.

    Attributes
    ----------
    x : ndarray, shape (d,)
        Planned grasp features (best accepted candidate).
    posterior : ndarray, shape (K,)
        P(k|x) over the model's zones.
    w : ndarray, shape (m,)
        Principal-task probabilities reconstructed from the posterior.
    objective : float
        1/2 |v - P(x)|^2.
    success : bool
        A candidate was accepted and its solver reported success (or it stayed at its start, which is
        then optimal among the tried starts).
    status : str
        'ok', 'solver_failed' (best candidate not converged) or 'rejected' (no candidate passed ``accept``;
        x is then the best rejected one).
    message : str
    iterations : int
        Solver iterations summed over all starts.
    wall_time_s : float
    method : str
    candidates : tuple of Candidate
        Every refined start, best objective first.
    rejected : int
        How many better candidates ``accept`` turned down before the chosen one.
    """

    x: NDArray[np.float64]
    posterior: NDArray[np.float64]
    w: NDArray[np.float64]
    objective: float
    success: bool
    status: str
    message: str
    iterations: int
    wall_time_s: float
    method: str
    candidates: tuple[Candidate, ...]
    rejected: int


def _check_v(model: GraspModel, v: ArrayLike) -> NDArray[np.float64]:
    try:
        arr = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PlanningError(f'v must be numeric: {exc}') from None
    K = len(model.zones)
    if arr.shape != (K,):
        raise PlanningError(f'v must have one entry per model zone ({K}: {",".join(model.zone_labels)}), '
                            f'got shape {arr.shape}')
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or abs(arr.sum() - 1.0) > 1e-6:
        raise PlanningError(f'v must be a probability vector (finite, >= 0, sum 1), got {arr.tolist()}')
    return arr


def objective(model: GraspModel, v: NDArray[np.float64], x: ArrayLike) -> NDArray[np.float64] | float:
    """f(x) = 1/2 |v - P(x)|^2 for x of shape (d,) (float) or (N, d) (array of N)."""
    r = v - model.posterior(x)
    out = 0.5 * np.einsum('...k,...k->...', r, r)
    return float(out) if np.ndim(out) == 0 else out


def objective_and_gradient(model: GraspModel, v: NDArray[np.float64],
                           x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """f(x) and its analytic gradient -J^T (v - P), for x of shape (d,)."""
    p, jac = model.posterior_jacobian(x, check=False)
    r = v - p
    return 0.5 * float(r @ r), -(jac.T @ r)


def select_starts(model: GraspModel, v: NDArray[np.float64], n_starts: int = 3,
                  top_zones: int = 2) -> NDArray[np.float64]:
    """Starting points: the demonstration of the top-v zone with the lowest objective first, then the
    next best demonstrations of the ``top_zones`` most likely zones, shape (<= n_starts, d).

    A demonstration belongs to zone k when its task set contains k (inclusive labeling).
    """
    order = np.argsort(-v, kind='stable')[:max(1, top_zones)]
    r = v[None, :] - model.demo_posterior
    f = 0.5 * np.einsum('nk,nk->n', r, r)

    def members(zone: int) -> NDArray[np.intp]:
        idx = np.flatnonzero((model.demo_sets & zone) == zone)
        return idx[np.argsort(f[idx], kind='stable')]

    first = members(model.zones[int(order[0])])
    pool = np.unique(np.concatenate([members(model.zones[int(k)]) for k in order]))
    if first.size == 0:  # no demonstration in the top zone: start from the best one overall
        first = np.argsort(f, kind='stable')[:1]
    rest = [int(i) for i in pool[np.argsort(f[pool], kind='stable')] if i != first[0]]
    starts = [int(first[0]), *rest[:n_starts - 1]]
    out: NDArray[np.float64] = model.demo_x[np.asarray(starts)]
    return out


def _refine(model: GraspModel, v: NDArray[np.float64], x0: NDArray[np.float64], method: Method,
            gradient: Gradient, extra_constraints: Sequence[Any]) -> Candidate:
    lower, upper = model.lower, model.upper
    a = model.features.approach
    x_start = np.clip(x0, lower, upper)
    norm = np.linalg.norm(x_start[a])
    if norm > 0:
        x_start[a] = x_start[a] / norm
    f0 = float(objective(model, v, x_start))

    def fun_grad(x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        return objective_and_gradient(model, v, np.clip(x, lower, upper))

    def fun_only(x: NDArray[np.float64]) -> float:
        return float(objective(model, v, np.clip(x, lower, upper)))

    if gradient not in ('analytic', '2-point'):
        raise PlanningError(f"gradient must be 'analytic' or '2-point', got {gradient!r}")
    fun: Any = fun_grad if gradient == 'analytic' else fun_only
    jac: Any = True if gradient == 'analytic' else '2-point'

    def gauss_newton(x: NDArray[np.float64]) -> NDArray[np.float64]:
        jac = model.posterior_jacobian(np.clip(x, lower, upper), check=False)[1]
        return jac.T @ jac  # least-squares Hessian approximation J^T J (positive semi-definite)

    def unit(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([x[a] @ x[a] - 1.0])

    def unit_jac(x: NDArray[np.float64]) -> NDArray[np.float64]:
        j = np.zeros((1, x.size))
        j[0, a] = 2.0 * x[a]
        return j

    res: OptimizeResult
    if method == 'slsqp':
        cons = [{'type': 'eq', 'fun': unit, 'jac': unit_jac}, *extra_constraints]
        res = minimize(fun, x_start, jac=jac, method='SLSQP', bounds=Bounds(lower, upper),
                       constraints=cons, options={'ftol': _FTOL, 'maxiter': _MAXITER})
    elif method == 'trust-constr':
        def unit_hess(x: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.float64]:
            h = np.zeros((x.size, x.size))
            h[a, a] = 2.0 * lam[0] * np.eye(a.stop - a.start)
            return h

        cons2 = [NonlinearConstraint(unit, 0.0, 0.0, jac=unit_jac, hess=unit_hess), *extra_constraints]
        res = minimize(fun, x_start, jac=jac, method='trust-constr', bounds=Bounds(lower, upper),
                       constraints=cons2, hess=gauss_newton,
                       options={'gtol': 1e-12, 'xtol': 1e-12, 'maxiter': _TC_MAXITER, 'initial_tr_radius': 0.1})
    else:
        raise PlanningError(f"method must be 'slsqp', 'trust-constr' or 'lm', got {method!r}")
    x = np.clip(np.asarray(res.x, dtype=np.float64), lower, upper)
    n = np.linalg.norm(x[a])
    if n > 0:
        x[a] = x[a] / n
    f = float(objective(model, v, x))
    if not f <= f0:  # never end worse than the start
        x, f = x_start, f0
    return Candidate(x=x, posterior=model.posterior(x), objective=f, start=x_start, start_objective=f0,
                     success=bool(res.success), message=str(res.message),
                     iterations=int(getattr(res, 'nit', 0) or 0))


def _refine_lm(model: GraspModel, v: NDArray[np.float64], starts: NDArray[np.float64]) -> list[Candidate]:
    """Projected Levenberg-Marquardt on r(x) = v - P(x), all starts at once (shape (N, d)).

    Each iteration solves (J^T J + lam diag(J^T J) + eps I) dx = J^T r per start, with J restricted to
    the free variables (a variable on a bound whose gradient points outwards is held) and, for the
    approach, to the sphere's tangent plane; the step is then projected back onto the box and the unit
    sphere. A step is taken only when it lowers f (lam shrinks), else lam grows.
    """
    lower, upper = model.lower, model.upper
    a = model.features.approach
    n, d = starts.shape
    eye = np.eye(d)

    def project(x: NDArray[np.float64]) -> NDArray[np.float64]:
        x = np.clip(x, lower, upper)
        x[:, a] /= np.linalg.norm(x[:, a], axis=1, keepdims=True)
        return x

    x = project(starts.astype(np.float64, copy=True))
    x0 = x.copy()
    p, jac = model.posterior_jacobian(x, check=False)
    r = v - p
    f = 0.5 * np.sum(r * r, axis=1)
    f0 = f.copy()
    lam = np.full(n, 1e-3)
    done = np.zeros(n, dtype=bool)
    iterations = np.zeros(n, dtype=np.int64)
    for _ in range(_LM_MAXITER):
        # tangent plane of the unit approach: J <- J (I - a a^T) on the approach columns
        ax = x[:, a]
        jt = jac.copy()
        jt[:, :, a] -= np.matmul(np.matmul(jac[:, :, a], ax[:, :, None]), ax[:, None, :])
        grad = -np.matmul(r[:, None, :], jt)[:, 0, :]  # (n, d), gradient of f
        held = ((x <= lower) & (grad > 0.0)) | ((x >= upper) & (grad < 0.0))
        jt = np.where(held[:, None, :], 0.0, jt)
        h = np.matmul(np.swapaxes(jt, 1, 2), jt)
        diag = np.einsum('nii->ni', h)
        system = h + (lam[:, None] * diag + 1e-12)[:, :, None] * eye
        step = np.linalg.solve(system, -np.where(held, 0.0, grad)[:, :, None])[:, :, 0]
        x_new = project(x + step)
        p_new, jac_new = model.posterior_jacobian(x_new, check=False)
        r_new = v - p_new
        f_new = 0.5 * np.sum(r_new * r_new, axis=1)
        better = (f_new < f) & ~done
        converged = better & (f - f_new < _LM_FTOL * (1.0 + f))
        x[better], p[better], jac[better], r[better] = x_new[better], p_new[better], jac_new[better], r_new[better]
        f = np.where(better, f_new, f)
        lam = np.where(better, lam / 3.0, lam * 4.0)
        iterations += ~done
        done |= converged | (lam > 1e10)
        if done.all() or f.min() < _LM_FSTOP:
            break
    return [Candidate(x=x[i], posterior=p[i], objective=float(f[i]), start=x0[i], start_objective=float(f0[i]),
                      success=True, message='converged' if done[i] else 'stopped: another start matched v',
                      iterations=int(iterations[i]))
            for i in range(n)]


def plan(model: GraspModel, v: ArrayLike, *, method: Method = 'lm', gradient: Gradient = 'analytic',
         n_starts: int = 3, top_zones: int = 2, warm_start: ArrayLike | None = None,
         accept: Callable[[NDArray[np.float64]], bool] | None = None,
         extra_constraints: Sequence[Any] = ()) -> PlanResult:
    """Plan grasp features whose zone posterior matches v.

    Parameters
    ----------
    model : GraspModel
    v : array_like, shape (K,)
        Target vector over the model's zones (see :func:`grasp_intent_ros.core.intent.interpret`).
    method : {'lm', 'slsqp', 'trust-constr'}
        The vectorised projected Levenberg-Marquardt refinement (default; fastest; analytic gradient
        only, no ``extra_constraints``), SQP, or interior point / trust region.
    gradient : {'analytic', '2-point'}
        Analytic gradient (default) or scipy's finite differences (the paper's baseline).
    n_starts : int >= 1
        Demonstrations to start from (see :func:`select_starts`).
    top_zones : int >= 1
        How many of the most likely zones supply starts.
    warm_start : array_like, shape (d,), optional
        An extra start tried first (e.g. the previous plan).
    accept : callable x -> bool, optional
        Robot constraint that cannot be written as a smooth function (e.g. IK reachability): the best
        candidate it accepts is returned.
    extra_constraints : sequence
        More smooth constraints in the form the chosen scipy method takes.

    Raises
    ------
    PlanningError
        For a v that is not a probability vector over the model's zones, or bad options.
    """
    t0 = time.perf_counter()
    v_arr = _check_v(model, v)
    if n_starts < 1 or top_zones < 1:
        raise PlanningError('n_starts and top_zones must be at least 1')
    starts = list(select_starts(model, v_arr, n_starts, top_zones))
    if warm_start is not None:
        ws = np.asarray(warm_start, dtype=np.float64)
        if ws.shape != (model.features.dim,) or not np.all(np.isfinite(ws)):
            raise PlanningError(f'warm_start must be a finite vector of shape ({model.features.dim},)')
        starts.insert(0, ws)
    if method == 'lm':
        if gradient != 'analytic' or extra_constraints:
            raise PlanningError("method 'lm' takes the analytic gradient and no extra_constraints")
        refined = _refine_lm(model, v_arr, np.asarray(starts))
    else:
        refined = [_refine(model, v_arr, s, method, gradient, extra_constraints) for s in starts]
    candidates = sorted(refined, key=lambda c: c.objective)
    chosen, rejected = candidates[0], 0
    status = 'ok'
    if accept is not None:
        for rejected, cand in enumerate(candidates):
            if accept(cand.x):
                chosen = cand
                break
        else:
            rejected, status = len(candidates), 'rejected'
    if status == 'ok' and not chosen.success:
        status = 'solver_failed'
    message = {'ok': 'planned', 'solver_failed': f'solver: {chosen.message}',
               'rejected': f'all {len(candidates)} candidates rejected by the robot constraint'}[status]
    return PlanResult(x=chosen.x, posterior=chosen.posterior,
                      w=reconstruct_w(chosen.posterior, model.zones, len(model.task_names)),
                      objective=chosen.objective, success=status == 'ok', status=status,
                      message=message, iterations=sum(c.iterations for c in candidates),
                      wall_time_s=time.perf_counter() - t0, method=method,
                      candidates=tuple(candidates), rejected=rejected)
