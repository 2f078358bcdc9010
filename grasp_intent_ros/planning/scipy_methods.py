"""The paper's solvers, ``method='slsqp'`` (SQP) and ``'trust-constr'`` (interior point), and the oracle.

Both minimise the paper's objective f(x) = 1/2 sum_k (v_k - P_k(x))^2 over the feasible set X
(:mod:`.common`) from the demonstration starts (:meth:`~.common.Search.all_starts`), with scipy, in scaled
coordinates y = x / s (s the model's ``feature_scale``, each feature's spread over the demonstrations, as
method 'lm''s metric): the features' units differ by orders of magnitude (a palm coordinate spreads over
centimetres, a finger closure over tenths of a radian), and unscaled the problem is ill-conditioned enough
that SLSQP crawls to its iteration limit near a match. trust-constr's first trust region is one unit of the
scaled coordinates (one spread). Each end point is projected onto X and never worse than its start. The answer
follows rule 6 of :mod:`.lm` (the nearest match to the reference, ties by start order). :func:`reference_search`
is a slow multi-start SLSQP search, an oracle for checking :func:`~.planner.plan`.

Machine independence: unlike the other methods, these take the posterior's Jacobian from
``GraspModel.posterior_jacobian`` (numpy) and run scipy's solvers, so their last bits may differ between
machines.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..method.features import PALM
from ..method.model import GraspModel
from .common import Feasible, Search, check_v, objective
from .options import Gradient, Method, ScipyOptions

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult  # type: ignore[import-untyped]

__all__ = ['objective_and_gradient', 'plan_scipy', 'reference_search']

_FTOL = 1e-10
_MAXITER = 200
_TC_MAXITER = 1500


def objective_and_gradient(model: GraspModel, v: NDArray[np.float64],
                           x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """f(x) and its analytic gradient -J^T (v - P), for x of shape (d,)."""
    p, jac = model.posterior_jacobian(x, check=False)
    r = v - p
    return 0.5 * float(r @ r), -(jac.T @ r)


def _refine(model: GraspModel, v: NDArray[np.float64], x0: NDArray[np.float64], method: Method,
            gradient: Gradient, extra_constraints: Sequence[Any],
            feas: Feasible) -> tuple[NDArray[np.float64], bool, str, int]:
    """Refine the start x0 with ``method`` in scaled coordinates y = x / s (s: ``feas.scale``; module docstring).

    Returns the end point projected onto X (x0 when that is worse), whether scipy reports success, its
    message and its iterations.
    """
    s = feas.scale
    lower, upper = model.lower, model.upper
    a = model.features.approach

    def to_x(y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.clip(y * s, lower, upper)

    def fun_grad(y: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        f, g = objective_and_gradient(model, v, to_x(y))
        return f, g * s

    def fun_only(y: NDArray[np.float64]) -> float:
        return float(objective(model, v, to_x(y)))

    fun: Any = fun_grad if gradient == 'analytic' else fun_only
    jac: Any = True if gradient == 'analytic' else '2-point'

    def gauss_newton(y: NDArray[np.float64]) -> NDArray[np.float64]:
        jac = model.posterior_jacobian(to_x(y), check=False)[1] * s
        return jac.T @ jac  # least-squares Hessian approximation J^T J (positive semi-definite)

    def unit(y: NDArray[np.float64]) -> NDArray[np.float64]:
        x = y * s
        return np.array([x[a] @ x[a] - 1.0])

    def unit_jac(y: NDArray[np.float64]) -> NDArray[np.float64]:
        j = np.zeros((1, y.size))
        j[0, a] = 2.0 * y[a] * s[a] ** 2
        return j

    body = model.body

    def clear(y: NDArray[np.float64]) -> NDArray[np.float64]:
        assert body is not None
        return body.distance((y * s)[None, PALM])[0] - body.margin

    def clear_jac(y: NDArray[np.float64]) -> NDArray[np.float64]:
        assert body is not None
        j = np.zeros((1, y.size))
        j[0, PALM] = body.distance((y * s)[None, PALM])[1][0] * s[PALM]
        return j

    # imported here: scipy.optimize is 0.4-0.6 s of a planner node's start-up, and only these methods use it
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    res: OptimizeResult
    y0 = x0 / s
    if method == 'slsqp':
        cons: list[Any] = [{'type': 'eq', 'fun': unit, 'jac': unit_jac}, *extra_constraints]
        if body is not None:
            cons.append({'type': 'ineq', 'fun': clear, 'jac': clear_jac})
        res = minimize(fun, y0, jac=jac, method='SLSQP', bounds=Bounds(lower / s, upper / s),
                       constraints=cons, options={'ftol': _FTOL, 'maxiter': _MAXITER})
    else:
        def unit_hess(y: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.float64]:
            h = np.zeros((y.size, y.size))
            h[a, a] = 2.0 * lam[0] * np.diag(s[a] ** 2)
            return h

        cons2: list[Any] = [NonlinearConstraint(unit, 0.0, 0.0, jac=unit_jac, hess=unit_hess),
                            *extra_constraints]
        if body is not None:
            cons2.append(NonlinearConstraint(clear, 0.0, np.inf, jac=clear_jac))
        res = minimize(fun, y0, jac=jac, method='trust-constr', bounds=Bounds(lower / s, upper / s),
                       constraints=cons2, hess=gauss_newton,
                       options={'gtol': 1e-12, 'xtol': 1e-12, 'maxiter': _TC_MAXITER, 'initial_tr_radius': 1.0})
    x = feas.project(np.clip(np.asarray(res.x, dtype=np.float64) * s, lower, upper)[None, :])[0]
    if not float(objective(model, v, x)) <= float(objective(model, v, x0)):  # never worse than the start
        x = x0
    return x, bool(res.success), str(res.message), int(getattr(res, 'nit', 0) or 0)


def reference_search(model: GraspModel, v: ArrayLike, *, n_starts: int = 60, seed: int = 0) -> float:
    """The lowest f a slow multi-start SLSQP search reaches: an oracle for checking :func:`plan`.

    Starts: every zone mean, then seeded uniform random points in the bounds, ``n_starts`` in all,
    each projected onto X; each is refined with SLSQP (analytic gradient, bounds, unit approach,
    body clearance) and the result projected onto X again.

    Returns
    -------
    float
        The lowest objective over all starts.
    """
    v_arr = check_v(model, v)
    rng = np.random.default_rng(seed)
    starts = list(model.means[:n_starts])
    while len(starts) < n_starts:
        starts.append(rng.uniform(model.lower, model.upper))
    feas = Feasible(model)
    best = np.inf
    for start in feas.project(np.asarray(starts)):
        x = _refine(model, v_arr, start, 'slsqp', 'analytic', (), feas)[0]
        best = min(best, float(objective(model, v_arr, x)))
    return best


def plan_scipy(search: Search, method: Method, opts: ScipyOptions) -> None:
    """Refine every start of ``search`` with ``method``, adding each end point to ``search.found`` in start order."""
    for i, s0 in enumerate(search.all_starts()):
        x1, ok1, text, it = _refine(search.model, search.v, s0, method, opts.gradient, opts.extra_constraints,
                                    search.feas)
        search.found += search.candidates_from(x1[None, :], s0[None, :], np.array([ok1]), np.array([it]), i,
                                               lambda _, __: text)  # called at once, in this iteration
