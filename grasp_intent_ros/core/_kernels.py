"""Compiled inner loops (numba): the planner's log-odds projection, least squares and feasible set; the IK.

The IK is :meth:`grasp_intent_ros.core.kinematics.MicoKinematics.ik`'s descent (:func:`ik_descent`).

The solvers run one start at a time. The algorithms are stated in
:class:`grasp_intent_ros.core.planner._LogOddsProjection` and :func:`grasp_intent_ros.core.planner._refine_lm`;
this module only runs them without numpy's per-call overhead (an iteration is ~10^3 flops, so that
overhead, not the arithmetic, was the cost). Compiled code is cached next to this file
(``cache=True``); the first call in a fresh installation compiles it (about 30 s; ``scripts/venv.sh``
does it at set-up time).

Body primitives are passed as arrays: ``kinds`` (0 cylinder, 1 box), ``centres``, ``axes`` and
``perps`` (cylinders: unit axis and a fixed unit perpendicular), ``radii``, ``lengths`` (cylinders),
``halfs`` (boxes: half extents); no primitive at all means no body.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

_ON_SURFACE = 1e-12  # a palm within this (m) of the body's surface is on it

__all__ = ['project', 'least_squares', 'newton_least_squares', 'feasible', 'score', 'ik_descent', 'warm_up']


@njit(cache=True, nogil=True)
def _distance(p, kinds, centres, axes, perps, radii, lengths, halfs):  # type: ignore[no-untyped-def]
    """Signed distance of p (3,) to the union of primitives (first on ties) and its unit gradient."""
    best = np.inf
    grad = np.zeros(3)
    for m in range(kinds.shape[0]):
        g = np.zeros(3)
        rel = p - centres[m]
        if kinds[m] == 0:
            axis = axes[m]
            t = rel[0] * axis[0] + rel[1] * axis[1] + rel[2] * axis[2]
            radial = rel - t * axis
            rho = math.sqrt(radial[0] ** 2 + radial[1] ** 2 + radial[2] ** 2)
            e_r = radial / max(rho, 1e-12) if rho > 1e-12 else perps[m].copy()
            e_t = -axis if t < 0.0 else axis.copy()
            dr = rho - radii[m]
            dt = abs(t) - 0.5 * lengths[m]
            out_r, out_t = max(dr, 0.0), max(dt, 0.0)
            outside = math.hypot(out_r, out_t)
            if outside > 0.0:
                sd = outside
                g = (out_r / outside) * e_r + (out_t / outside) * e_t
            else:
                sd = max(dr, dt)
                g = e_r if dr >= dt else e_t
        else:
            q = np.abs(rel) - halfs[m]
            sign = np.where(rel < 0.0, -1.0, 1.0)
            out = np.maximum(q, 0.0)
            outside = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2)
            if q[0] > 0.0 or q[1] > 0.0 or q[2] > 0.0:
                sd = outside
                g = sign * out / max(outside, 1e-300)
            else:
                face = int(np.argmax(q))
                sd = q[face]
                g[face] = sign[face]
        if sd < best:
            best = sd
            grad = g
    return best, grad


@njit(cache=True, nogil=True)
def _project(x, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs,  # type: ignore[no-untyped-def]
             margin):
    """Clip to the bounds, normalise the approach, push the palm out of the body (in place)."""
    for i in range(x.size):
        x[i] = min(max(x[i], lower[i]), upper[i])
    norm = math.sqrt(np.sum(x[a0:a1] ** 2))
    if norm > 1e-12:
        x[a0:a1] /= max(norm, 1e-12)
    else:
        x[a0:a1] = 0.0
        x[a0 + 2] = 1.0
    if kinds.shape[0] > 0:
        p = x[0:3].copy()
        for _ in range(4):
            sd, grad = _distance(p, kinds, centres, axes, perps, radii, lengths, halfs)
            if sd >= margin:
                break
            p += (margin - sd) * grad
        for i in range(3):
            x[i] = min(max(p[i], lower[i]), upper[i])
    return x


@njit(cache=True, nogil=True)
def _project_rows(xs, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs,  # type: ignore[no-untyped-def]
                  margin):
    """Every row of xs (N, d) projected onto the feasible set (a new array)."""
    out = xs.copy()
    for s in range(out.shape[0]):
        _project(out[s], lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
    return out


def feasible(xs: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64], a0: int, a1: int,
             body: tuple[Any, ...]) -> NDArray[np.float64]:
    """Rows of xs (N, d) clipped to the bounds, approach normalised, palm pushed out of the body."""
    out: NDArray[np.float64] = _project_rows(np.ascontiguousarray(xs, dtype=np.float64), lower, upper, a0, a1,
                                             *body)
    return out


@njit(cache=True, nogil=True)
def _distance_hessian(p, kinds, centres, axes, perps, radii, lengths, halfs):  # type: ignore[no-untyped-def]
    """Hessian (3, 3) of the signed distance at p, the nearest primitive's curvature.

    A cylinder's side is curved; flat faces, and the edges' small share of the surface, count as flat.
    """
    best = np.inf
    hess = np.zeros((3, 3))
    for m in range(kinds.shape[0]):
        sd = _distance(p, kinds[m:m + 1], centres[m:m + 1], axes[m:m + 1], perps[m:m + 1], radii[m:m + 1],
                       lengths[m:m + 1], halfs[m:m + 1])[0]
        if sd < best:
            best = sd
            hess = np.zeros((3, 3))
            if kinds[m] == 0:
                axis = axes[m]
                rel = p - centres[m]
                t = rel[0] * axis[0] + rel[1] * axis[1] + rel[2] * axis[2]
                radial = rel - t * axis
                rho = math.sqrt(radial[0] ** 2 + radial[1] ** 2 + radial[2] ** 2)
                if rho > 1e-12 and abs(t) <= 0.5 * lengths[m] and rho - radii[m] >= abs(t) - 0.5 * lengths[m]:
                    e_r = radial / rho
                    hess = (np.eye(3) - np.outer(axis, axis) - np.outer(e_r, e_r)) / rho
    return hess


@njit(cache=True, nogil=True)
def _body_hold(x, grad, kinds, centres, axes, perps, radii, lengths, halfs, margin):  # type: ignore[no-untyped-def]
    """Whether the body holds the palm, and the surface's unit normal there (3,).

    It does when the palm is on the surface (margin included) and grad (of f, shape (d,)) points out of
    it, i.e. f would fall inside the body.
    """
    if kinds.shape[0] == 0:
        return False, np.zeros(3)
    sd, normal = _distance(x[0:3].copy(), kinds, centres, axes, perps, radii, lengths, halfs)
    held = sd - margin <= _ON_SURFACE and grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2] > 0.0
    return held, normal


@njit(cache=True, nogil=True)
def _onto_surface(x, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin):  # type: ignore[no-untyped-def]
    """Move the palm of x (in place) onto the body's surface (margin included), within the bounds."""
    p = x[0:3].copy()
    for _ in range(4):
        sd, grad = _distance(p, kinds, centres, axes, perps, radii, lengths, halfs)
        if abs(sd - margin) <= 1e-15:
            break
        p += (margin - sd) * grad
    for i in range(3):
        x[i] = min(max(p[i], lower[i]), upper[i])
    return x


@njit(cache=True, nogil=True)
def _log_joint_score(x, means, prec, log_norm):  # type: ignore[no-untyped-def]
    """log(pi_k N_k(x)) (K,) and its gradient -Sigma_k^-1 (x - mu_k) (K, d)."""
    K, d = means.shape
    lj = np.empty(K)
    g = np.empty((K, d))
    for k in range(K):
        diff = x - means[k]
        gk = -(prec[k] @ diff)
        g[k] = gk
        lj[k] = log_norm[k] + 0.5 * np.sum(diff * gk)
    return lj, g


@njit(cache=True, nogil=True)
def _evaluate(x, means, prec, log_norm, others, r, b, scale, a0, a1,  # type: ignore[no-untyped-def]
              kinds, centres, axes, perps, radii, lengths, halfs, margin):
    """Residuals e (rows,) and their Jacobian in scaled coordinates A (rows, d)."""
    K, d = means.shape
    n_eq = K - 1
    has_body = kinds.shape[0] > 0
    rows = n_eq + 1 + (1 if has_body else 0)
    lj, g = _log_joint_score(x, means, prec, log_norm)
    e = np.zeros(rows)
    A = np.zeros((rows, d))
    for i in range(n_eq):
        k = others[i]
        e[i] = lj[k] - lj[r] - b[i]
        A[i] = (g[k] - g[r]) * scale
    e[n_eq] = np.sum(x[a0:a1] ** 2) - 1.0
    for j in range(a0, a1):
        A[n_eq, j] = 2.0 * x[j] * scale[j]
    if has_body:
        sd, normal = _distance(x[0:3].copy(), kinds, centres, axes, perps, radii, lengths, halfs)
        e[n_eq + 1] = sd - margin
        for j in range(3):
            A[n_eq + 1, j] = normal[j] * scale[j]
    return e, A


@njit(cache=True, nogil=True)
def _min_norm(A, e, fixed, dfix, active, damping):  # type: ignore[no-untyped-def]
    """The shortest dy with e + A dy = 0 on the active rows and dy = dfix where fixed."""
    rows, d = A.shape
    An = A.copy()
    en = e.copy()
    for i in range(rows):
        if not active[i]:
            An[i] = 0.0
            en[i] = 0.0
        norm = math.sqrt(np.sum(An[i] ** 2))
        if not norm > 1e-300:
            norm = 1.0
        An[i] /= norm
        en[i] /= norm
    en = en + An @ dfix
    for j in range(d):
        if fixed[j]:
            An[:, j] = 0.0
    gram = An @ An.T
    ridge = 1e-14 + damping * math.sqrt(np.sum(en ** 2))
    for i in range(rows):
        gram[i, i] += ridge + (0.0 if active[i] else 1.0)
    z = np.linalg.solve(gram, -en)
    return An.T @ z + dfix


@njit(cache=True, nogil=True)
def _step(x, e, A, scale, lower, upper, bounded, has_body, damping):  # type: ignore[no-untyped-def]
    """The shortest scaled step solving the linearised equations, bounds and body held."""
    rows, d = A.shape
    n_eq = rows - 1 - (1 if has_body else 0)
    active = np.ones(rows, dtype=np.bool_)
    if has_body:
        active[n_eq + 1] = False
    fixed = np.zeros(d, dtype=np.bool_)
    zero = np.zeros(d)
    dy = _min_norm(A, e, fixed, zero, active, damping)
    resolve = False
    dfix = np.zeros(d)
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
    if has_body and e[n_eq + 1] + np.sum(A[n_eq + 1] * dy) < 0.0:
        active[n_eq + 1] = True
        resolve = True
    if resolve:
        dy = _min_norm(A, e, fixed, dfix, active, damping)
    return dy


@njit(cache=True, nogil=True)
def _results(n, d):  # type: ignore[no-untyped-def]
    """End points (n, d), converged (n,) and iterations (n,) of n starts, to be filled in."""
    return np.empty((n, d)), np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.int64)


@njit(cache=True, nogil=True)
def _project_starts(starts: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],  # type: ignore[no-untyped-def]
                   log_norm: NDArray[np.float64], others: NDArray[np.int64], r: int, b: NDArray[np.float64],
                   scale: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64],
                   a0: int, a1: int, kinds: NDArray[np.int64], centres: NDArray[np.float64],
                   axes: NDArray[np.float64], perps: NDArray[np.float64], radii: NDArray[np.float64],
                   lengths: NDArray[np.float64], halfs: NDArray[np.float64], margin: float,
                   maxiter: int, stall: int, damping: float, htol: float, steptol: float,
                   b_final: NDArray[np.float64]):
    """Project every start (N, d) onto b, then onto b_final; end points (N, d), converged (N,), iterations (N,)."""
    n, d = starts.shape
    K = means.shape[0]
    n_eq = K - 1
    has_body = kinds.shape[0] > 0
    bounded = np.ones(d, dtype=np.bool_)
    bounded[a0:a1] = False  # a unit vector never leaves [-1, 1]
    out, converged, iterations = _results(n, d)
    for s in range(n):
        x = _project(starts[s].copy(), lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths,
                     halfs, margin)
        e, A = _evaluate(x, means, prec, log_norm, others, r, b, scale, a0, a1, kinds, centres, axes, perps,
                         radii, lengths, halfs, margin)
        l1 = np.sum(np.abs(e[:n_eq]))
        checkpoint = l1
        radius = 1.0
        target = b
        final = True  # no second phase when b_final is b
        for i in range(n_eq):
            final = final and b[i] == b_final[i]
        it = 0
        while it < maxiter:
            it += 1
            if it % stall == 0:  # a start that has not halved its residual in `stall` iterations stalls
                if l1 > 0.5 * checkpoint:
                    break
                checkpoint = l1
            dy = _step(x, e, A, scale, lower, upper, bounded, has_body, damping)
            size = math.sqrt(np.sum(dy ** 2))
            t = min(1.0, radius / max(size, 1e-300))
            x_try = _project(x + (t * dy) * scale, lower, upper, a0, a1, kinds, centres, axes, perps, radii,
                             lengths, halfs, margin)
            e_try, A_try = _evaluate(x_try, means, prec, log_norm, others, r, target, scale, a0, a1, kinds,
                                     centres, axes, perps, radii, lengths, halfs, margin)
            l1_try = np.sum(np.abs(e_try[:n_eq]))
            iterations[s] += 1
            fin = np.max(np.abs(e_try[:n_eq])) <= htol and t * size <= steptol
            ok = l1_try < l1 or fin
            if ok:
                x, e, A, l1 = x_try, e_try, A_try, l1_try
            if fin and final:
                converged[s] = True
                break
            if fin:  # on the path's targets: the same steps onto b_final, with an iteration budget of their own
                final = True
                target = b_final
                e[:n_eq] += b - b_final
                l1 = np.sum(np.abs(e[:n_eq]))
                checkpoint = l1
                it = 0
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

    ``body`` is ``(kinds, centres, axes, perps, radii, lengths, halfs, margin)`` (module docstring). With
    ``b_final``, a start that converges onto the right-hand sides ``b`` goes on to ``b_final`` (with a budget
    of ``maxiter`` iterations of its own) and has converged when it meets them.
    """
    out: tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]] = _project_starts(
        np.ascontiguousarray(starts, dtype=np.float64), means, prec, log_norm, others, r, b, scale, lower,
        upper, a0, a1, *body, maxiter, stall, damping, htol, steptol,
        b if b_final is None else b_final)  # type: ignore[call-arg]
    return out


@njit(cache=True, nogil=True)
def _score(xs, v, means, prec, log_norm, x_ref, scale):  # type: ignore[no-untyped-def]
    """Posterior (N, K), objective 1/2 |v - P|^2 (N,) and scaled distance to x_ref (N,) of every row."""
    n = xs.shape[0]
    K = means.shape[0]
    post = np.empty((n, K))
    f = np.empty(n)
    dist = np.empty(n)
    for s in range(n):
        lj = _log_joint_score(xs[s], means, prec, log_norm)[0]
        p = np.exp(lj - np.max(lj))
        p /= np.sum(p)
        post[s] = p
        f[s] = 0.5 * np.sum((v - p) ** 2)
        dist[s] = math.sqrt(np.sum(((xs[s] - x_ref) / scale) ** 2))
    return post, f, dist


def score(xs: NDArray[np.float64], v: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
          log_norm: NDArray[np.float64], x_ref: NDArray[np.float64], scale: NDArray[np.float64],
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Posterior (N, K), objective (N,) and scaled distance |(x - x_ref) / s| (N,) of every row of xs."""
    out: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] = _score(
        np.ascontiguousarray(xs, dtype=np.float64), v, means, prec, log_norm, x_ref, scale)
    return out


@njit(cache=True, nogil=True)
def _posterior_scores(x, means, prec, log_norm):  # type: ignore[no-untyped-def]
    """P(k|x) (K,) and the gradients of log P(k|x), u_k = g_k - sum_j P_j g_j (K, d)."""
    lj, g = _log_joint_score(x, means, prec, log_norm)
    p = np.exp(lj - np.max(lj))
    p /= np.sum(p)
    u = g - p @ g
    return p, u


@njit(cache=True, nogil=True)
def _posterior_jacobian(x, means, prec, log_norm):  # type: ignore[no-untyped-def]
    """P(k|x) (K,) and dP/dx (K, d)."""
    p, u = _posterior_scores(x, means, prec, log_norm)
    return p, p[:, None] * u


@njit(cache=True, nogil=True)
def _least_squares(starts, v, means, prec, log_norm, lower, upper, a0, a1,  # type: ignore[no-untyped-def]
                   kinds, centres, axes, perps, radii, lengths, halfs, margin, maxiter, ftol, ridge_rel):
    """Projected Levenberg-Marquardt on v - P(x) from every start (see planner._refine_lm)."""
    n, d = starts.shape
    out, converged, iterations = _results(n, d)
    for s in range(n):
        x = _project(starts[s].copy(), lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths,
                     halfs, margin)
        p, jac = _posterior_jacobian(x, means, prec, log_norm)
        r = v - p
        f = 0.5 * np.sum(r * r)
        lam = 1e-3
        done = False
        for _ in range(maxiter):
            ax = x[a0:a1].copy()
            jt = jac.copy()
            proj = np.ascontiguousarray(jac[:, a0:a1]) @ ax
            for k in range(jt.shape[0]):
                jt[k, a0:a1] -= proj[k] * ax
            grad = -(r @ jt)
            on_body, normal = _body_hold(x, grad, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            if on_body:  # on the body's surface, f falling inside: steps on the surface's tangent plane
                proj = np.ascontiguousarray(jt[:, 0:3]) @ normal
                for k in range(jt.shape[0]):
                    jt[k, 0:3] -= proj[k] * normal
                grad = -(r @ jt)
            held = np.zeros(d, dtype=np.bool_)
            for j in range(d):
                held[j] = (x[j] <= lower[j] and grad[j] > 0.0) or (x[j] >= upper[j] and grad[j] < 0.0)
                if held[j]:
                    jt[:, j] = 0.0
                    grad[j] = 0.0
            h = jt.T @ jt
            diag = np.diag(h).copy()
            ridge = ridge_rel * np.max(diag) + 1e-12
            system = h + np.diag(lam * diag + ridge)
            step = np.linalg.solve(system, -grad)
            x_new = _project(x + step, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs,
                             margin)
            if on_body:
                _onto_surface(x_new, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            p_new, jac_new = _posterior_jacobian(x_new, means, prec, log_norm)
            r_new = v - p_new
            f_new = 0.5 * np.sum(r_new * r_new)
            better = f_new < f
            small = better and (f - f_new < ftol * f + 1e-15)
            if better:
                x, p, jac, r, f = x_new, p_new, jac_new, r_new, f_new
                lam = lam / 3.0
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
def _posterior_hessian(x, means, prec, log_norm, v):  # type: ignore[no-untyped-def]
    """P(k|x) (K,), dP/dx (K, d) and the Hessian of f = 1/2 |v - P|^2 (d, d)."""
    K, d = means.shape
    p, u = _posterior_scores(x, means, prec, log_norm)
    jac = p[:, None] * u
    c = p - v
    h = jac.T @ jac
    s = np.sum(c * p)
    for k in range(K):
        # sum_k c_k d2P_k = sum_k c_k p_k (u_k u_k^T - Lambda_k) + s (Lambda_bar - C),
        # Lambda_bar = sum_j p_j Lambda_j, C = sum_j p_j u_j u_j^T
        a = c[k] * p[k] - s * p[k]
        uk = u[k]
        for i in range(d):
            for j in range(d):
                h[i, j] += a * uk[i] * uk[j] + (s * p[k] - c[k] * p[k]) * prec[k, i, j]
    return p, jac, h


@njit(cache=True, nogil=True)
def _cholesky_solve(m, b):  # type: ignore[no-untyped-def]
    """Solve m z = b for a symmetric m by Cholesky; (z, True), or (b, False) when m is not positive definite."""
    n = b.size
    low = np.zeros((n, n))
    for j in range(n):
        acc = m[j, j]
        for q in range(j):
            acc -= low[j, q] * low[j, q]
        if not acc > 0.0:
            return b.copy(), False
        low[j, j] = math.sqrt(acc)
        for i in range(j + 1, n):
            acc = m[i, j]
            for q in range(j):
                acc -= low[i, q] * low[j, q]
            low[i, j] = acc / low[j, j]
    z = b.copy()
    for i in range(n):
        for q in range(i):
            z[i] -= low[i, q] * z[q]
        z[i] /= low[i, i]
    for i in range(n - 1, -1, -1):
        for q in range(i + 1, n):
            z[i] -= low[q, i] * z[q]
        z[i] /= low[i, i]
    return z, True


@njit(cache=True, nogil=True)
def _newton_least_squares(starts, v, means, prec, log_norm, lower, upper, scale, a0, a1,  # type: ignore[no-untyped-def]
                          kinds, centres, axes, perps, radii, lengths, halfs, margin, maxiter, steptol, ridge_rel):
    """Projected trust-region Newton on f = 1/2 |v - P(x)|^2 from every start (see planner._refine_lm)."""
    n, d = starts.shape
    out, converged, iterations = _results(n, d)
    sc = scale.copy()
    sc[a0:a1] = math.sqrt(np.mean(scale[a0:a1] ** 2))
    for s in range(n):
        x = _project(starts[s].copy(), lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths,
                     halfs, margin)
        p, jac, hess = _posterior_hessian(x, means, prec, log_norm, v)
        r = v - p
        f = 0.5 * np.sum(r * r)
        lam = -1.0
        done = False
        fresh = True
        for _ in range(maxiter):
            iterations[s] += 1
            if fresh:
                # on the sphere's tangent plane (Lagrangian Hessian: H - (a . grad_a f) I there), then in
                # scaled coordinates y = x / sc (sc uniform over the approach, so the tangent plane is the same)
                gx = -(r @ jac)
                on_body, normal = _body_hold(x, gx, kinds, centres, axes, perps, radii, lengths, halfs, margin)
                hess_l = hess
                if on_body:  # the Lagrangian's Hessian on the body's surface: minus mu times the surface's curvature
                    hess_l = hess.copy()
                    mu = np.sum(gx[0:3] * normal)
                    hess_l[0:3, 0:3] -= mu * _distance_hessian(x[0:3].copy(), kinds, centres, axes, perps, radii,
                                                               lengths, halfs)
                ax = x[a0:a1].copy()
                tang = np.eye(d)
                for i in range(a0, a1):
                    for j in range(a0, a1):
                        tang[i, j] -= ax[i - a0] * ax[j - a0]
                radial = np.sum(gx[a0:a1] * ax)
                h = tang @ hess_l @ tang
                for i in range(a0, a1):
                    for j in range(a0, a1):
                        h[i, j] -= radial * tang[i, j]
                grad = (tang @ gx) * sc
                h = h * np.outer(sc, sc)
                if on_body:  # and on the surface's tangent plane, in scaled coordinates
                    ns = normal * sc[0:3]
                    ns /= math.sqrt(np.sum(ns * ns))
                    tb = np.eye(d)
                    tb[0:3, 0:3] -= np.outer(ns, ns)
                    h = tb @ h @ tb
                    grad = tb @ grad
                held = np.zeros(d, dtype=np.bool_)
                for j in range(d):
                    if a0 <= j < a1:
                        continue  # a unit vector never leaves [-1, 1]
                    held[j] = (x[j] <= lower[j] and grad[j] > 0.0) or (x[j] >= upper[j] and grad[j] < 0.0)
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
            system = h.copy()
            for j in range(d):
                system[j, j] += lam + ridge + (1.0 if held[j] else 0.0)
            step, pd = _cholesky_solve(system, -grad)
            if not pd:
                lam = max(4.0 * lam, 1e-12 * top + 1e-300)
                continue
            step[held] = 0.0
            predicted = -(np.sum(grad * step) + 0.5 * np.sum(step * (h @ step)))
            x_new = _project(x + step * sc, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths,
                             halfs, margin)
            if on_body:
                _onto_surface(x_new, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            size = math.sqrt(np.sum(step * step))
            p_new, jac_new, hess_new = _posterior_hessian(x_new, means, prec, log_norm, v)
            r_new = v - p_new
            f_new = 0.5 * np.sum(r_new * r_new)
            if f_new < f:
                x, p, jac, hess, r, f = x_new, p_new, jac_new, hess_new, r_new, f_new
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


def newton_least_squares(starts: NDArray[np.float64], v: NDArray[np.float64], means: NDArray[np.float64],
                         prec: NDArray[np.float64], log_norm: NDArray[np.float64], lower: NDArray[np.float64],
                         upper: NDArray[np.float64], scale: NDArray[np.float64], a0: int, a1: int,
                         body: tuple[Any, ...], *, maxiter: int, steptol: float,
                         ridge: float) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
    """Projected trust-region Newton on v - P(x) from every start (N, d): end points, converged, iterations."""
    out: tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]] = _newton_least_squares(
        np.ascontiguousarray(starts, dtype=np.float64), v, means, prec, log_norm, lower, upper, scale, a0, a1,
        *body, maxiter, steptol, ridge)  # type: ignore[call-arg]
    return out


def least_squares(starts: NDArray[np.float64], v: NDArray[np.float64], means: NDArray[np.float64],
                  prec: NDArray[np.float64], log_norm: NDArray[np.float64], lower: NDArray[np.float64],
                  upper: NDArray[np.float64], a0: int, a1: int, body: tuple[Any, ...], *, maxiter: int,
                  ftol: float, ridge: float) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
    """Projected Levenberg-Marquardt on v - P(x) from every start (N, d): end points, converged, iterations."""
    out: tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]] = _least_squares(
        np.ascontiguousarray(starts, dtype=np.float64), v, means, prec, log_norm, lower, upper, a0, a1, *body,
        maxiter, ftol, ridge)  # type: ignore[call-arg]
    return out


# -- inverse kinematics of a serial chain of revolute joints (MicoKinematics.ik) ---------------------------


@njit(cache=True, nogil=True)
def _rotate(R, v):  # type: ignore[no-untyped-def]
    """R v for a 3x3 R (written out: a BLAS call costs more than the arithmetic at this size)."""
    out = np.empty(3)
    for i in range(3):
        out[i] = R[i, 0] * v[0] + R[i, 1] * v[1] + R[i, 2] * v[2]
    return out


@njit(cache=True, nogil=True)
def _rotate_back(R, v):  # type: ignore[no-untyped-def]
    """R^T v for a 3x3 R."""
    out = np.empty(3)
    for i in range(3):
        out[i] = R[0, i] * v[0] + R[1, i] * v[1] + R[2, i] * v[2]
    return out


@njit(cache=True, nogil=True)
def _compose(A, B):  # type: ignore[no-untyped-def]
    """A B for 3x3 matrices."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True, nogil=True)
def _cross(a, b):  # type: ignore[no-untyped-def]
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True, nogil=True)
def _axis_rotation(axis, angle):  # type: ignore[no-untyped-def]
    """Rodrigues: the rotation by ``angle`` about the unit ``axis``."""
    s, c = math.sin(angle), math.cos(angle)
    x, y, z = axis[0], axis[1], axis[2]
    t = 1.0 - c
    return np.array([[c + t * x * x, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, c + t * y * y, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, c + t * z * z]])


@njit(cache=True, nogil=True)
def _chain_fk(q, rots, trans, axes, tip_rot, tip_trans, origins, zs):  # type: ignore[no-untyped-def]
    """World pose (R, p) of the tip; fills each joint's world origin and axis into ``origins``, ``zs``.

    Joint i sits at placement (rots[i], trans[i]) in joint i - 1's frame (the world for i = 0) and turns
    by q[i] about ``axes[i]`` (its own frame); the tip sits at (tip_rot, tip_trans) in the last joint's frame.
    """
    R = np.eye(3)
    p = np.zeros(3)
    for i in range(q.size):
        p = p + _rotate(R, trans[i])
        R = _compose(R, rots[i])
        origins[i] = p
        zs[i] = _rotate(R, axes[i])
        R = _compose(R, _axis_rotation(axes[i], q[i]))
    return _compose(R, tip_rot), p + _rotate(R, tip_trans)


@njit(cache=True, nogil=True)
def _log3(E):  # type: ignore[no-untyped-def]
    """Rotation vector phi of a rotation matrix E (exp([phi]x) = E, |phi| <= pi), accurate near 0 and pi."""
    w = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])  # sin(theta) n
    s = math.sqrt(np.sum(w * w))
    c = 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0)
    theta = math.atan2(s, c)
    if theta < 1e-8:
        return w
    if math.pi - theta > 1e-3:
        return w * (theta / s)
    # near pi: the axis from the symmetric part, n n^T = (sym(E) - c I) / (1 - c); its sign from w
    k = 0
    for i in range(1, 3):
        if E[i, i] > E[k, k]:
            k = i
    n = np.empty(3)
    for i in range(3):
        n[i] = 0.5 * (E[i, k] + E[k, i]) - (c if i == k else 0.0)
    n /= math.sqrt(np.sum(n * n))
    if np.sum(n * w) < 0.0:
        n = -n
    return theta * n


@njit(cache=True, nogil=True)
def _ik_residual(q, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs):  # type: ignore[no-untyped-def]
    """Error e = (R^T (p_t - p), log3(R^T R_t)) of the tip pose (R, p) against the target, in the tip frame."""
    R, p = _chain_fk(q, rots, trans, axes, tip_rot, tip_trans, origins, zs)
    e = np.empty(6)
    e[:3] = _rotate_back(R, p_t - p)
    Rt = R.T.copy()
    e[3:] = _log3(_compose(Rt, R_t))
    return e, R, p


@njit(cache=True, nogil=True)
def _ik_jacobian(e, R, p, origins, zs):  # type: ignore[no-untyped-def]
    """de/dq, with joint i's twist in the tip frame (v_i, w_i): -(w_i x e_p) - v_i and -Jl^-1(phi) w_i.

    A turn dq of joint i moves the tip by R (v_i, w_i) dq, so R^T changes by -[w_i]x R^T dq: e_p by
    -(w_i x e_p + v_i) dq and R^T R_t by exp(-[w_i]x dq) from the left, i.e. phi by -Jl^-1(phi) w_i dq with
    Jl^-1(phi) = I - [phi]x / 2 + (1 / theta^2 - cot(theta / 2) / (2 theta)) [phi]x^2, the inverse left
    Jacobian of SO(3).
    """
    n = zs.shape[0]
    phi = e[3:]
    theta = math.sqrt(np.sum(phi * phi))
    if theta < 1e-4:
        c2 = 1.0 / 12.0 + theta * theta / 720.0
    else:
        c2 = 1.0 / (theta * theta) - math.cos(0.5 * theta) / (2.0 * theta * math.sin(0.5 * theta))
    J = np.empty((6, n))
    for i in range(n):
        w = _rotate_back(R, zs[i])
        v = _rotate_back(R, _cross(zs[i], p - origins[i]))
        J[:3, i] = -_cross(w, e[:3]) - v
        pw = _cross(phi, w)
        J[3:, i] = -(w - 0.5 * pw + c2 * _cross(phi, pw))
    return J


_IK_SOLVED = 1e-10
"""Position (m) and rotation (rad) errors below which an IK descent has reached its solution."""


@njit(cache=True, nogil=True)
def _ik_descent(q, lower, upper, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, max_iter):  # type: ignore[no-untyped-def]
    """One Levenberg-Marquardt descent of the tip onto the target pose (R_t, p_t) from q, within the limits.

    Minimises |e(q)|^2 (:func:`_ik_residual`): each iteration solves (J^T J + lam I) s = -J^T e, shortens s
    to a largest joint step of 0.5 rad, clips q + s to the limits and takes it when |e|^2 falls (lam / 5,
    at least 1e-9), else lam * 10. It stops at the solution (both errors below 1e-10 m and 1e-10 rad, so
    that the answer is the solution this path reaches, not wherever the errors first fell within the
    caller's tolerances: about one more iteration, the convergence being quadratic there), after
    ``max_iter`` iterations, or when lam passes 1e6 (no descent left: a local minimum, a joint limit, or
    errors at rounding level). Returns (q, position error |e_p| (m), rotation error |phi| (rad), iterations).
    """
    n = q.size
    origins = np.empty((n, 3))
    zs = np.empty((n, 3))
    e, R, p = _ik_residual(q, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs)
    cost = np.sum(e * e)
    J = _ik_jacobian(e, R, p, origins, zs)
    damping = 1e-3
    iterations = 0
    while True:
        pos_err = math.sqrt(np.sum(e[:3] * e[:3]))
        rot_err = math.sqrt(np.sum(e[3:] * e[3:]))
        if (pos_err <= _IK_SOLVED and rot_err <= _IK_SOLVED) or iterations >= max_iter:
            return q, pos_err, rot_err, iterations
        iterations += 1
        system = np.empty((n, n))
        grad = np.zeros(n)
        for i in range(n):
            for j in range(n):
                system[i, j] = np.sum(J[:, i] * J[:, j])
            system[i, i] += damping
            grad[i] = np.sum(J[:, i] * e)
        step, _ = _cholesky_solve(system, -grad)
        longest = np.max(np.abs(step))
        if longest > 0.5:
            step *= 0.5 / longest
        q_try = np.minimum(np.maximum(q + step, lower), upper)
        o_try = np.empty((n, 3))
        z_try = np.empty((n, 3))
        e_try, R_try, p_try = _ik_residual(q_try, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, o_try, z_try)
        cost_try = np.sum(e_try * e_try)
        if cost_try < cost:
            q, e, cost = q_try, e_try, cost_try
            J = _ik_jacobian(e, R_try, p_try, o_try, z_try)
            damping = max(damping * 0.2, 1e-9)
        else:
            damping *= 10.0
            if damping > 1e6:
                return q, pos_err, rot_err, iterations


def ik_descent(q: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64],
               chain: tuple[NDArray[np.float64], ...], R_t: NDArray[np.float64], p_t: NDArray[np.float64],
               max_iter: int) -> tuple[NDArray[np.float64], float, float, int]:
    """:func:`_ik_descent` on ``chain`` = (rots, trans, axes, tip_rot, tip_trans) (:func:`_chain_fk`)."""
    out: tuple[NDArray[np.float64], float, float, int] = _ik_descent(
        np.ascontiguousarray(q, dtype=np.float64), lower, upper, *chain, R_t, p_t, max_iter)  # type: ignore[call-arg]
    return out


def warm_up() -> None:
    """Compile (or load from the cache) every kernel on a tiny problem with the planner's argument types.

    ``scripts/venv.sh`` calls it at set-up time, so that no node pays for compilation on its first plan.
    """
    d = 10
    cylinder = (np.zeros(1, dtype=np.int64), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]),
                np.array([[1.0, 0.0, 0.0]]), np.ones(1), np.ones(1), np.zeros((1, 3)), 0.001)
    for body in (cylinder, (np.ones(1, dtype=np.int64), *cylinder[1:6], np.ones((1, 3)), 0.001)):
        project(np.full((1, d), 0.5), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
                np.ones(1, dtype=np.int64), 0, np.zeros(1), np.ones(d), -np.ones(d), np.ones(d), 3, 6, body,
                maxiter=2, stall=12, damping=1e-3, htol=1e-11, steptol=1e-9)
        least_squares(np.full((1, d), 0.5), np.array([0.5, 0.5]), np.zeros((2, d)), np.stack([np.eye(d)] * 2),
                      np.zeros(2), -np.ones(d), np.ones(d), 3, 6, body, maxiter=2, ftol=1e-7, ridge=1e-7)
        newton_least_squares(np.full((1, d), 0.5), np.array([0.5, 0.5]), np.zeros((2, d)),
                             np.stack([np.eye(d)] * 2), np.zeros(2), -np.ones(d), np.ones(d), np.ones(d), 3, 6, body,
                             maxiter=2, steptol=1e-10, ridge=1e-7)
        feasible(np.full((1, d), 0.5), -np.ones(d), np.ones(d), 3, 6, body)
    score(np.full((1, d), 0.5), np.array([0.5, 0.5]), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
          np.zeros(d), np.ones(d))
    eye = np.eye(3)
    limits = -np.ones(2), np.ones(2)
    for limit in limits:  # MicoKinematics's joint limits are read-only arrays, a type of their own to numba
        limit.setflags(write=False)
    ik_descent(np.zeros(2), *limits, (np.stack([eye, eye]), np.zeros((2, 3)),
               np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), eye, np.array([1.0, 0.0, 0.0])), eye,
               np.array([0.0, 1.0, 0.0]), 2)


if __name__ == '__main__':
    warm_up()
