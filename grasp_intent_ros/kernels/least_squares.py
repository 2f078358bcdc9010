"""The planner's two local solvers of min f(x) = 1/2 |v - P(x)|^2 over X, run from many starts at once.

:func:`_least_squares` is a projected Levenberg-Marquardt on the residual v - P(x);
:func:`_newton_least_squares` a projected trust-region Newton with the exact Hessian. Their docstrings
state the steps, what is held on a bound or on the body's surface, and when a start has converged.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry import _body_hold, _distance_hessian, _on_plane, _on_plane_both, _onto_surface, _project
from .linalg import _cholesky_solve, _gram, _results, _spd_solve
from .posterior import (
    _posterior_and_scores,
    _posterior_hessian,
    _posterior_jacobian,
    _scores_to_hessian,
    _scores_to_jacobian,
)


@njit(cache=True, nogil=True)
def _residual(v, p, r):
    """Fills r with v - p; returns f = 1/2 |r|^2."""
    acc = 0.0
    for k in range(v.size):
        r[k] = v[k] - p[k]
        acc += r[k] * r[k]
    return 0.5 * acc


@njit(cache=True, nogil=True)
def _gradient(r, jac, grad):
    """Fills grad (d,) with the gradient -r^T jac of f = 1/2 |r|^2 (r (K,), jac = dP/dx (K, d))."""
    for j in range(grad.size):
        acc = 0.0
        for k in range(r.size):
            acc += r[k] * jac[k, j]
        grad[j] = -acc


@njit(cache=True, nogil=True)
def _hold_leaving(x, step, held, lower, upper, a0, a1):
    """Holds (in ``held``) every free variable on a bound whose step would leave it; whether there was one.

    The approach's entries are left alone: a unit vector never leaves [-1, 1].
    """
    more = False
    for j in range(x.size):
        if (not held[j] and not a0 <= j < a1
                and ((x[j] <= lower[j] and step[j] < 0.0) or (x[j] >= upper[j] and step[j] > 0.0))):
            held[j] = True
            more = True
    return more


@njit(cache=True, nogil=True)
def _least_squares(starts, v, mixture, lower, upper, a0, a1, body, maxiter, ftol, ridge_rel):
    """Projected Levenberg-Marquardt on r(x) = v - P(x) from every start (N, d): end points, converged, iterations.

    Each iteration solves (J^T J + lam diag(J^T J) + eps I) dx = J^T r per start (eps = 1e-7 times the
    largest curvature, so that nearly flat directions cannot amplify last-bit differences), with J restricted to
    the free variables (a variable on a bound is held when its gradient points outwards, or when the
    solved step would take it out: the step is then solved again without it, so that a step along a
    bound is not clipped into one the system did not solve for) and, for the approach, to the sphere's
    tangent plane; with the palm on the body's surface and the gradient
    pointing out of it (f falls inside), the palm's columns are restricted to the surface's tangent
    plane too. The step is then projected onto X (and such a palm back onto the surface). A step is taken only
    when it lowers f (lam shrinks), else lam grows. A start has converged when an accepted step gains
    less than 1e-7 f + 1e-15 or no step lowers f any more (stationary to machine precision); one that
    reaches ``maxiter`` has not. The path does not depend on ``maxiter``: stopping at 100 and going on
    from there for 200 more (with the damping started afresh) is a path of its own, taken the same way
    on every run.
    """
    means, prec, log_norm = mixture
    n, d = starts.shape
    K = means.shape[0]
    out, converged, iterations = _results(n, d)
    # every iteration works in these (an iteration is ~10^3 flops: allocating them each time cost more)
    x, x_new, grad, step = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    p, p_new, r, r_new = np.empty(K), np.empty(K), np.empty(K), np.empty(K)
    jac, jac_new, jt, diff = np.empty((K, d)), np.empty((K, d)), np.empty((K, d)), np.empty(d)
    gram, system, low = np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    held, normal = np.empty(d, dtype=np.bool_), np.empty(3)
    for s in range(n):
        x[:] = starts[s]
        _project(x, lower, upper, a0, a1, body)
        _posterior_jacobian(x, mixture, p, jac, diff)
        f = _residual(v, p, r)
        lam = 1e-3
        done = False
        fresh = True
        on_body = False
        ridge = 0.0
        for _ in range(maxiter):
            if fresh:  # a new x: its restricted Jacobian, gradient and Gram matrix (kept while steps are rejected)
                jt[:] = jac
                for k in range(K):
                    _on_plane(jt[k], a0, x[a0:a1])
                _gradient(r, jt, grad)
                on_body = _body_hold(x, grad, body, normal)
                if on_body:  # on the body's surface, f falling inside: steps on the surface's tangent plane
                    for k in range(K):
                        _on_plane(jt[k], 0, normal)
                    _gradient(r, jt, grad)
                for j in range(d):
                    held[j] = (x[j] <= lower[j] and grad[j] > 0.0) or (x[j] >= upper[j] and grad[j] < 0.0)
                    if held[j]:
                        jt[:, j] = 0.0
                        grad[j] = 0.0
                _gram(jt, gram)
                top = 0.0
                for j in range(d):
                    top = max(top, gram[j, j])
                ridge = ridge_rel * top + 1e-12
                fresh = False
            system[:] = gram  # system = jt^T jt + diag(lam diag(jt^T jt) + ridge)
            for j in range(d):
                system[j, j] += lam * system[j, j] + ridge
                step[j] = -grad[j]
            _spd_solve(system, step, step, low)
            if _hold_leaving(x, step, held, lower, upper, a0, a1):  # solved again, counted as an iteration
                for j in range(d):
                    if held[j]:
                        jt[:, j] = 0.0
                        grad[j] = 0.0
                _gram(jt, gram)
                iterations[s] += 1
                continue
            for j in range(d):
                x_new[j] = x[j] + step[j]
            _project(x_new, lower, upper, a0, a1, body)
            if on_body:
                _onto_surface(x_new, lower, upper, body)
            _posterior_and_scores(x_new, mixture, p_new, jac_new, diff)  # dP/dx only if taken
            f_new = _residual(v, p_new, r_new)
            better = f_new < f
            small = better and (f - f_new < ftol * f + 1e-15)
            if better:
                _scores_to_jacobian(p_new, jac_new)
                x, x_new = x_new, x
                p, p_new = p_new, p
                jac, jac_new = jac_new, jac
                r, r_new = r_new, r
                f = f_new
                lam = lam / 3.0
                fresh = True
            else:
                lam = lam * 4.0
            iterations[s] += 1
            if small or lam > 1e10:
                done = True
                break
        out[s] = x
        converged[s] = done
    return out, converged, iterations


@njit(cache=True, nogil=True)
def _newton_least_squares(starts, v, mixture, lower, upper, scale, a0, a1, body, maxiter, steptol, ridge_rel):
    """Projected trust-region Newton on f = 1/2 |v - P(x)|^2 with its exact Hessian from every start (N, d).

    The Hessian J^T J + sum_k (P_k - v_k) d2P_k keeps the curvature that the least-squares steps leave
    out, which is what a nearly flat valley has. Each iteration solves (H + lam I + eps I) dy = -g in
    scaled coordinates (the approach's three scales replaced by their root mean square, so that the
    sphere's tangent plane is the same in both), with H the Lagrangian Hessian on the sphere's tangent
    plane and variables on a bound held as in :func:`_least_squares`; a palm held on the body's surface
    (as there) moves on its tangent plane (in scaled coordinates) with the Lagrangian's curvature
    -mu d2(distance), mu = n . grad_palm f, added to H; a step is taken only when it lowers
    f (lam shrinks), else lam grows (also while H + lam I is not positive definite). A start has
    converged after a step of less than 1e-10 (scaled), or when the predicted gain is below 1e-15 f
    with lam negligible, or when no step lowers f any more; one that reaches ``maxiter`` has not.
    Returns end points, converged and iterations, as :func:`_least_squares` does.
    """
    means, prec, log_norm = mixture
    n, d = starts.shape
    K = means.shape[0]
    out, converged, iterations = _results(n, d)
    sc = scale.copy()
    sc[a0:a1] = math.sqrt(np.mean(scale[a0:a1] ** 2))
    # every iteration works in these (an iteration is ~10^3 flops: allocating them each time cost more)
    x, x_new, grad, step = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    p, p_new, r, r_new = np.empty(K), np.empty(K), np.empty(K), np.empty(K)
    jac, jac_new, u, diff = np.empty((K, d)), np.empty((K, d)), np.empty((K, d)), np.empty(d)
    hess, hess_new, h = np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    system, low, curvature = np.empty((d, d)), np.empty((d, d)), np.empty((3, 3))
    held, normal, ns = np.empty(d, dtype=np.bool_), np.empty(3), np.empty(3)
    for s in range(n):
        x[:] = starts[s]
        _project(x, lower, upper, a0, a1, body)
        _posterior_hessian(x, mixture, v, p, u, jac, hess, diff)
        f = _residual(v, p, r)
        lam = -1.0
        done = False
        fresh = True
        on_body = False
        top = ridge = 0.0
        for _ in range(maxiter):
            iterations[s] += 1
            if fresh:
                # on the sphere's tangent plane (Lagrangian Hessian: H - (a . grad_a f) I there), then in
                # scaled coordinates y = x / sc (sc uniform over the approach, so the tangent plane is the same)
                _gradient(r, jac, grad)  # the gradient in x, until it is taken to the tangent plane
                on_body = _body_hold(x, grad, body, normal)
                h[:] = hess
                if on_body:  # the Lagrangian's Hessian on the body's surface: minus mu times the surface's curvature
                    mu = grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2]
                    _distance_hessian(x, body, curvature)
                    for i in range(3):
                        for j in range(3):
                            h[i, j] -= mu * curvature[i, j]
                ax = x[a0:a1]
                radial = 0.0
                for i in range(a1 - a0):
                    radial += grad[a0 + i] * ax[i]
                _on_plane_both(h, a0, ax)
                for i in range(a0, a1):
                    for j in range(a0, a1):
                        h[i, j] -= radial * ((1.0 if i == j else 0.0) - ax[i - a0] * ax[j - a0])
                _on_plane(grad, a0, ax)
                for i in range(d):
                    grad[i] *= sc[i]
                    for j in range(d):
                        h[i, j] = h[i, j] * (sc[i] * sc[j])
                if on_body:  # and on the surface's tangent plane, in scaled coordinates
                    acc = 0.0
                    for i in range(3):
                        ns[i] = normal[i] * sc[i]
                        acc += ns[i] * ns[i]
                    norm = math.sqrt(acc)
                    for i in range(3):
                        ns[i] /= norm
                    _on_plane_both(h, 0, ns)
                    _on_plane(grad, 0, ns)
                for j in range(d):
                    held[j] = (not a0 <= j < a1  # a unit vector never leaves [-1, 1]
                               and ((x[j] <= lower[j] and grad[j] > 0.0) or (x[j] >= upper[j] and grad[j] < 0.0)))
                    if held[j]:
                        grad[j] = 0.0
                        h[j, :] = 0.0
                        h[:, j] = 0.0
                top = 0.0
                for j in range(d):
                    top = max(top, abs(h[j, j]))
                ridge = ridge_rel * top + 1e-300
                if lam < 0.0:
                    lam = 1e-3 * top
                fresh = False
            system[:] = h
            for j in range(d):
                system[j, j] += lam + ridge + (1.0 if held[j] else 0.0)
                step[j] = -grad[j]
            if not _cholesky_solve(system, step, step, low):
                lam = max(4.0 * lam, 1e-12 * top + 1e-300)
                continue
            if _hold_leaving(x, step, held, lower, upper, a0, a1):  # solved again
                for i in range(d):
                    if held[i]:
                        grad[i] = 0.0
                        h[i, :] = 0.0
                        h[:, i] = 0.0
                continue
            gain = 0.0
            curve = 0.0
            size = 0.0
            for i in range(d):
                if held[i]:
                    step[i] = 0.0
            for i in range(d):
                hs = 0.0
                for j in range(d):
                    hs += h[i, j] * step[j]
                gain += grad[i] * step[i]
                curve += step[i] * hs
                size += step[i] * step[i]
                x_new[i] = x[i] + step[i] * sc[i]
            predicted = -(gain + 0.5 * curve)
            size = math.sqrt(size)
            _project(x_new, lower, upper, a0, a1, body)
            if on_body:
                _onto_surface(x_new, lower, upper, body)
            _posterior_and_scores(x_new, mixture, p_new, u, diff)  # the Hessian only if taken
            f_new = _residual(v, p_new, r_new)
            if f_new < f:
                _scores_to_hessian(prec, v, p_new, u, jac_new, hess_new)
                x, x_new = x_new, x
                p, p_new = p_new, p
                jac, jac_new = jac_new, jac
                hess, hess_new = hess_new, hess
                r, r_new = r_new, r
                f = f_new
                lam = lam / 3.0
                fresh = True
                if size <= steptol or (predicted <= 1e-15 * f and lam <= 1e-4 * top):
                    done = True
                    break
            else:
                if size <= steptol or not predicted > 1e-16 * f:  # no step lowers f: stationary to machine precision
                    done = True
                    break
                lam = max(4.0 * lam, 1e-12 * top + 1e-300)
        out[s] = x
        converged[s] = done
    return out, converged, iterations
