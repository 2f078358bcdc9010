"""The planner's log-odds projection: the nearest grasp in X whose posterior meets given log-odds.

Solves, from each start, log(pi_k N_k(x)) - log(pi_r N_r(x)) = b_i for every other zone k (the equations
that P(x) = v means for a reference zone r), with x in X (:mod:`.geometry`), by damped Gauss-Newton
steps of minimum scaled length (:func:`~.linalg._min_norm`) in a trust region. The algorithm and its
stopping rules are stated in :class:`grasp_intent_ros.planning.lm._LogOddsProjection`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import _distance, _project
from .linalg import _l1_max, _min_norm, _results
from .posterior import _log_joint_score
from .types import Body, Mixture

__all__ = ['project']


@njit(cache=True, nogil=True)
def _evaluate(x, mixture, others, r, b, scale, a0, a1, body, e, A, lj, g, diff):
    """Fills the residuals e (rows,) and their Jacobian in scaled coordinates A (rows, d); lj (K,), g (K, d) work."""
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    means, prec, log_norm = mixture
    K, d = means.shape
    n_eq = K - 1
    _log_joint_score(x, mixture, lj, g, diff)
    for i in range(n_eq):
        k = others[i]
        e[i] = lj[k] - lj[r] - b[i]
        for j in range(d):
            A[i, j] = (g[k, j] - g[r, j]) * scale[j]
    acc = 0.0
    for j in range(a0, a1):
        acc += x[j] ** 2
    e[n_eq] = acc - 1.0
    A[n_eq] = 0.0
    for j in range(a0, a1):
        A[n_eq, j] = 2.0 * x[j] * scale[j]
    if kinds.shape[0] > 0:
        sd, n0, n1, n2 = _distance(x, body, True)
        e[n_eq + 1] = sd - margin
        A[n_eq + 1] = 0.0
        A[n_eq + 1, 0] = n0 * scale[0]
        A[n_eq + 1, 1] = n1 * scale[1]
        A[n_eq + 1, 2] = n2 * scale[2]


@njit(cache=True, nogil=True)
def _step(x, e, A, scale, lower, upper, bounded, has_body, damping, dy, fixed, dfix, active, work):
    """Fills dy with the shortest scaled step solving the linearised equations, bounds and body held.

    fixed (d,), dfix (d,), active (rows,) and work (:func:`_min_norm`) are work arrays.
    """
    rows, d = A.shape
    n_eq = rows - 1 - (1 if has_body else 0)
    active[:] = True
    if has_body:
        active[n_eq + 1] = False
    fixed[:] = False
    dfix[:] = 0.0
    _min_norm(A, e, fixed, dfix, active, damping, dy, work)
    resolve = False
    for j in range(d):
        pred = x[j] + dy[j] * scale[j]
        if bounded[j] and pred < lower[j]:
            fixed[j] = True
            dfix[j] = (lower[j] - x[j]) / scale[j]
            resolve = True
        elif bounded[j] and pred > upper[j]:
            fixed[j] = True
            dfix[j] = (upper[j] - x[j]) / scale[j]
            resolve = True
    if has_body:
        acc = 0.0
        for j in range(d):
            acc += A[n_eq + 1, j] * dy[j]
        if e[n_eq + 1] + acc < 0.0:
            active[n_eq + 1] = True
            resolve = True
    if resolve:
        _min_norm(A, e, fixed, dfix, active, damping, dy, work)


@njit(cache=True, nogil=True)
def _project_starts(starts, mixture, others, r, b, scale, lower, upper, a0, a1, body, maxiter, stall, damping, htol,
                    steptol, b_final):
    """Project every start (N, d) onto b, then onto b_final; end points (N, d), converged (N,), iterations (N,)."""
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    means, prec, log_norm = mixture
    n, d = starts.shape
    K = means.shape[0]
    n_eq = K - 1
    has_body = kinds.shape[0] > 0
    rows = n_eq + 1 + (1 if has_body else 0)
    bounded = np.ones(d, dtype=np.bool_)
    bounded[a0:a1] = False  # a unit vector never leaves [-1, 1]
    out, converged, iterations = _results(n, d)
    # every iteration works in these (an iteration is ~10^3 flops: allocating them each time cost more)
    x, x_try, dy, dfix = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    e, e_try, A, A_try = np.empty(rows), np.empty(rows), np.empty((rows, d)), np.empty((rows, d))
    lj, g, diff = np.empty(K), np.empty((K, d)), np.empty(d)
    fixed, active = np.empty(d, dtype=np.bool_), np.empty(rows, dtype=np.bool_)
    work = (np.empty((d, rows)), np.empty(rows), np.empty((rows, rows)), np.empty(rows), np.empty((rows, rows)))
    for s in range(n):
        x[:] = starts[s]
        _project(x, lower, upper, a0, a1, body)
        _evaluate(x, mixture, others, r, b, scale, a0, a1, body, e, A, lj, g, diff)
        l1 = _l1_max(e, n_eq)[0]
        checkpoint = l1
        radius = 1.0
        target = b
        final = True  # no second phase when b_final is b
        for i in range(n_eq):
            final = final and b[i] == b_final[i]
        it = 0
        fresh = True
        size = 0.0
        while it < maxiter:
            it += 1
            if it % stall == 0:  # a start that has not halved its residual in `stall` iterations stalls
                if l1 > 0.5 * checkpoint:
                    break
                checkpoint = l1
            if fresh:  # a new x or new targets: a new step (kept while shorter tries of it are rejected)
                _step(x, e, A, scale, lower, upper, bounded, has_body, damping, dy, fixed, dfix, active, work)
                acc = 0.0
                for j in range(d):
                    acc += dy[j] ** 2
                size = math.sqrt(acc)
                fresh = False
            t = min(1.0, radius / max(size, 1e-300))
            for j in range(d):
                x_try[j] = x[j] + (t * dy[j]) * scale[j]
            _project(x_try, lower, upper, a0, a1, body)
            _evaluate(x_try, mixture, others, r, target, scale, a0, a1, body, e_try, A_try, lj, g, diff)
            l1_try, top = _l1_max(e_try, n_eq)
            iterations[s] += 1
            fin = top <= htol and t * size <= steptol
            ok = l1_try < l1 or fin
            if ok:
                x, x_try = x_try, x
                e, e_try = e_try, e
                A, A_try = A_try, A
                l1 = l1_try
                fresh = True
            if fin and final:
                converged[s] = True
                break
            if fin:  # on the path's targets: the same steps onto b_final, with an iteration budget of their own
                final = True
                target = b_final
                for i in range(n_eq):
                    e[i] += b[i] - b_final[i]
                l1 = _l1_max(e, n_eq)[0]
                checkpoint = l1
                it = 0
                fresh = True
                continue
            radius = min(2.0 * max(radius, t * size), 4.0) if ok else 0.25 * min(radius, t * size)
            if radius < 1e-12:
                break
        out[s] = x
    return out, converged, iterations


def project(starts: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
            log_norm: NDArray[np.float64], others: NDArray[np.int64], r: int, b: NDArray[np.float64],
            scale: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64], a0: int, a1: int,
            body: tuple[Any, ...], *, maxiter: int, stall: int, damping: float, htol: float,
            steptol: float, b_final: NDArray[np.float64] | None = None,
            ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
    """Project every start (N, d) onto the log-odds equations: end points, converged (N,), iterations (N,).

    ``body`` is ``(kinds, centres, axes, perps, radii, lengths, halfs, margin)`` (:class:`~.types.Body`). With
    ``b_final``, a start that converges onto the right-hand sides ``b`` goes on to ``b_final`` (with a budget
    of ``maxiter`` iterations of its own) and has converged when it meets them.
    """
    out: tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]] = _project_starts(
        np.ascontiguousarray(starts, dtype=np.float64), Mixture(means, prec, log_norm), others, r, b, scale, lower,
        upper, a0, a1, Body(*body), maxiter, stall, damping, htol, steptol, b if b_final is None else b_final)
    return out
