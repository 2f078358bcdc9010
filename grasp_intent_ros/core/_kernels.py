"""Compiled inner loops (numba): the planner's log-odds projection, least squares and feasible set; the IK.

The IK is :meth:`grasp_intent_ros.core.kinematics.MicoKinematics.ik`'s descent (:func:`ik_descent`).

The solvers run one start at a time. The algorithms are stated in
:class:`grasp_intent_ros.core.planner._LogOddsProjection` and in :func:`_least_squares` and
:func:`_newton_least_squares` below; the planner's least squares (its rule 5) runs in one call,
:func:`least_squares_rounds`. This module only runs them without numpy's per-call overhead (an
iteration is ~10^3 flops, so that overhead, not the arithmetic, was the cost): the iterations work in
arrays allocated once per call and write their small products and solves as loops (a BLAS or LAPACK
call, or a temporary array, costs more than the arithmetic at these sizes). Compiled code is cached
next to this file (``cache=True``); the first call in a fresh installation compiles it (about 30 s;
``scripts/venv.sh`` does it at set-up time).

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

__all__ = ['project', 'least_squares_rounds', 'feasible', 'score', 'screen', 'choice_order',
           'select_demonstrations', 'distinct', 'ik_descent', 'warm_up']


@njit(cache=True, nogil=True)
def _primitive_distance(p, m, kinds, centres, axes, perps, radii, lengths, halfs, normal):  # type: ignore[no-untyped-def]
    """Signed distance of p (its first three entries) to primitive m and its unit gradient: (sd, g0, g1, g2).

    Without ``normal`` only the distance is asked for: the same value, with g = 0 where g would cost divisions.
    """
    r0, r1, r2 = p[0] - centres[m, 0], p[1] - centres[m, 1], p[2] - centres[m, 2]
    if kinds[m] == 0:
        ax, ay, az = axes[m, 0], axes[m, 1], axes[m, 2]
        t = r0 * ax + r1 * ay + r2 * az
        q0, q1, q2 = r0 - t * ax, r1 - t * ay, r2 - t * az
        rho = math.sqrt(q0 ** 2 + q1 ** 2 + q2 ** 2)
        if not normal:
            dr = rho - radii[m]
            dt = abs(t) - 0.5 * lengths[m]
            outside = math.hypot(max(dr, 0.0), max(dt, 0.0))
            return (outside if outside > 0.0 else max(dr, dt)), 0.0, 0.0, 0.0
        if rho > 1e-12:
            er0, er1, er2 = q0 / rho, q1 / rho, q2 / rho
        else:
            er0, er1, er2 = perps[m, 0], perps[m, 1], perps[m, 2]
        et0, et1, et2 = (-ax, -ay, -az) if t < 0.0 else (ax, ay, az)
        dr = rho - radii[m]
        dt = abs(t) - 0.5 * lengths[m]
        out_r, out_t = max(dr, 0.0), max(dt, 0.0)
        outside = math.hypot(out_r, out_t)
        if outside > 0.0:
            wr, wt = out_r / outside, out_t / outside
            return outside, wr * er0 + wt * et0, wr * er1 + wt * et1, wr * er2 + wt * et2
        if dr >= dt:
            return max(dr, dt), er0, er1, er2
        return max(dr, dt), et0, et1, et2
    q0, q1, q2 = abs(r0) - halfs[m, 0], abs(r1) - halfs[m, 1], abs(r2) - halfs[m, 2]
    s0, s1, s2 = (-1.0 if r0 < 0.0 else 1.0), (-1.0 if r1 < 0.0 else 1.0), (-1.0 if r2 < 0.0 else 1.0)
    if q0 > 0.0 or q1 > 0.0 or q2 > 0.0:
        o0, o1, o2 = max(q0, 0.0), max(q1, 0.0), max(q2, 0.0)
        outside = math.sqrt(o0 ** 2 + o1 ** 2 + o2 ** 2)
        if not normal:
            return outside, 0.0, 0.0, 0.0
        den = max(outside, 1e-300)
        return outside, s0 * o0 / den, s1 * o1 / den, s2 * o2 / den
    if q0 >= q1 and q0 >= q2:  # the nearest face (the first on ties)
        return q0, s0, 0.0, 0.0
    if q1 >= q2:
        return q1, 0.0, s1, 0.0
    return q2, 0.0, 0.0, s2


@njit(cache=True, nogil=True)
def _distance(p, kinds, centres, axes, perps, radii, lengths, halfs, normal):  # type: ignore[no-untyped-def]
    """Signed distance of p (its first three entries) to the union of primitives and its unit gradient.

    Returns (sd, g0, g1, g2), of the first primitive on ties; without ``normal`` only sd is meaningful.
    """
    best, b0, b1, b2 = np.inf, 0.0, 0.0, 0.0
    for m in range(kinds.shape[0]):
        sd, g0, g1, g2 = _primitive_distance(p, m, kinds, centres, axes, perps, radii, lengths, halfs, normal)
        if sd < best:
            best, b0, b1, b2 = sd, g0, g1, g2
    return best, b0, b1, b2


@njit(cache=True, nogil=True)
def _push_out(x, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin, tol):  # type: ignore[no-untyped-def]
    """Move the palm x[0:3] (in place) along the distance's gradient, then clip it to the bounds.

    Up to 4 moves, until its distance is within tol of the margin (tol < 0: until it is at least the margin).
    """
    for _ in range(4):
        sd = _distance(x, kinds, centres, axes, perps, radii, lengths, halfs, False)[0]
        if (sd >= margin) if tol < 0.0 else (abs(sd - margin) <= tol):
            break
        sd, g0, g1, g2 = _distance(x, kinds, centres, axes, perps, radii, lengths, halfs, True)
        c = margin - sd
        x[0] += c * g0
        x[1] += c * g1
        x[2] += c * g2
    for i in range(3):
        x[i] = min(max(x[i], lower[i]), upper[i])


@njit(cache=True, nogil=True)
def _project(x, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs,  # type: ignore[no-untyped-def]
             margin):
    """Clip to the bounds, normalise the approach, push the palm out of the body (in place)."""
    for i in range(x.size):
        x[i] = min(max(x[i], lower[i]), upper[i])
    acc = 0.0
    for i in range(a0, a1):
        acc += x[i] ** 2
    norm = math.sqrt(acc)
    if norm > 1e-12:
        for i in range(a0, a1):
            x[i] /= norm
    else:
        x[a0:a1] = 0.0
        x[a0 + 2] = 1.0
    if kinds.shape[0] > 0:
        _push_out(x, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin, -1.0)
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
def _distance_hessian(p, kinds, centres, axes, perps, radii, lengths, halfs, hess):  # type: ignore[no-untyped-def]
    """Fills hess (3, 3) with the signed distance's Hessian at p[:3], the nearest primitive's curvature.

    A cylinder's side is curved, (I - a a^T - e e^T) / rho with a its axis, e the radial unit vector and rho
    the radius at p; flat faces, and the edges' small share of the surface, count as flat. (Written out:
    building it from small arrays cost ten times the arithmetic.)
    """
    best = np.inf
    for m in range(kinds.shape[0]):
        sd = _primitive_distance(p, m, kinds, centres, axes, perps, radii, lengths, halfs, False)[0]
        if sd < best:
            best = sd
            hess[:] = 0.0
            if kinds[m] == 0:
                a0, a1, a2 = axes[m, 0], axes[m, 1], axes[m, 2]
                r0, r1, r2 = p[0] - centres[m, 0], p[1] - centres[m, 1], p[2] - centres[m, 2]
                t = r0 * a0 + r1 * a1 + r2 * a2
                q0, q1, q2 = r0 - t * a0, r1 - t * a1, r2 - t * a2
                rho = math.sqrt(q0 ** 2 + q1 ** 2 + q2 ** 2)
                if rho > 1e-12 and abs(t) <= 0.5 * lengths[m] and rho - radii[m] >= abs(t) - 0.5 * lengths[m]:
                    a = (a0, a1, a2)
                    e = (q0 / rho, q1 / rho, q2 / rho)
                    for i in range(3):
                        for j in range(3):
                            hess[i, j] = (((1.0 if i == j else 0.0) - a[i] * a[j]) - e[i] * e[j]) / rho


@njit(cache=True, nogil=True)
def _body_hold(x, grad, kinds, centres, axes, perps, radii, lengths, halfs, margin, normal):  # type: ignore[no-untyped-def]
    """Whether the body holds the palm; fills ``normal`` (3,) with the surface's unit normal there when it may.

    It does when the palm is on the surface (margin included) and grad (of f, shape (d,)) points out of
    it, i.e. f would fall inside the body.
    """
    if kinds.shape[0] == 0:
        return False
    if not _distance(x, kinds, centres, axes, perps, radii, lengths, halfs, False)[0] - margin <= _ON_SURFACE:
        return False  # off the surface: no normal needed
    sd, normal[0], normal[1], normal[2] = _distance(x, kinds, centres, axes, perps, radii, lengths, halfs, True)
    return sd - margin <= _ON_SURFACE and grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2] > 0.0


@njit(cache=True, nogil=True)
def _onto_surface(x, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin):  # type: ignore[no-untyped-def]
    """Move the palm of x (in place) onto the body's surface (margin included), within the bounds."""
    _push_out(x, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin, 1e-15)
    return x


@njit(cache=True, nogil=True)
def _on_plane(g, lo, a):  # type: ignore[no-untyped-def]
    """Set g <- (I - a a^T) g on the entries lo, ..., lo + len(a) - 1 of g (in place; a a unit vector)."""
    c = 0.0
    for i in range(a.size):
        c += g[lo + i] * a[i]
    for i in range(a.size):
        g[lo + i] -= c * a[i]


@njit(cache=True, nogil=True)
def _on_plane_both(h, lo, a):  # type: ignore[no-untyped-def]
    """Set h <- T h T (in place) for a square h, T = I - a a^T on the block lo, ..., lo + len(a) - 1, I elsewhere."""
    d = h.shape[0]
    for i in range(d):
        _on_plane(h[i], lo, a)
    for j in range(d):
        c = 0.0
        for i in range(a.size):
            c += h[lo + i, j] * a[i]
        for i in range(a.size):
            h[lo + i, j] -= c * a[i]


@njit(cache=True, nogil=True)
def _log_joint_score(x, means, prec, log_norm, lj, g, diff):  # type: ignore[no-untyped-def]
    """Fills lj (K,) with log(pi_k N_k(x)) and g (K, d) with its gradient -Sigma_k^-1 (x - mu_k); diff (d,) is work."""
    K, d = means.shape
    for k in range(K):
        for j in range(d):
            diff[j] = x[j] - means[k, j]
        q = 0.0
        i = 0
        while i + 4 < d:  # five rows of the product at a time: five independent sums (a third less time)
            a0 = a1 = a2 = a3 = a4 = 0.0
            for j in range(d):
                dj = diff[j]
                a0 += prec[k, i, j] * dj
                a1 += prec[k, i + 1, j] * dj
                a2 += prec[k, i + 2, j] * dj
                a3 += prec[k, i + 3, j] * dj
                a4 += prec[k, i + 4, j] * dj
            g[k, i], g[k, i + 1], g[k, i + 2], g[k, i + 3], g[k, i + 4] = -a0, -a1, -a2, -a3, -a4
            for m in range(i, i + 5):
                q += diff[m] * g[k, m]
            i += 5
        while i < d:
            acc = 0.0
            for j in range(d):
                acc += prec[k, i, j] * diff[j]
            g[k, i] = -acc
            q += diff[i] * g[k, i]
            i += 1
        lj[k] = log_norm[k] + 0.5 * q


@njit(cache=True, nogil=True)
def _evaluate(x, means, prec, log_norm, others, r, b, scale, a0, a1,  # type: ignore[no-untyped-def]
              kinds, centres, axes, perps, radii, lengths, halfs, margin, e, A, lj, g, diff):
    """Fills the residuals e (rows,) and their Jacobian in scaled coordinates A (rows, d); lj (K,), g (K, d) work."""
    K, d = means.shape
    n_eq = K - 1
    _log_joint_score(x, means, prec, log_norm, lj, g, diff)
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
        sd, n0, n1, n2 = _distance(x, kinds, centres, axes, perps, radii, lengths, halfs, True)
        e[n_eq + 1] = sd - margin
        A[n_eq + 1] = 0.0
        A[n_eq + 1, 0] = n0 * scale[0]
        A[n_eq + 1, 1] = n1 * scale[1]
        A[n_eq + 1, 2] = n2 * scale[2]


@njit(cache=True, nogil=True)
def _cholesky_solve(m, b, z, low):  # type: ignore[no-untyped-def]
    """Solve m z = b for a symmetric m (its lower triangle) by Cholesky into z (which may be b); low (n, n) is work.

    Returns whether m is positive definite; when it is not, z is b. (Rows are taken once as views and each
    sum kept in a local: 24% less time than indexing the arrays in the inner loops, the same arithmetic.)
    """
    n = b.size
    for j in range(n):
        acc = m[j, j]
        lj = low[j]
        for q in range(j):
            acc -= lj[q] * lj[q]
        if not acc > 0.0:
            for i in range(n):
                z[i] = b[i]
            return False
        pivot = math.sqrt(acc)
        lj[j] = pivot
        for i in range(j + 1, n):
            acc = m[i, j]
            li = low[i]
            for q in range(j):
                acc -= li[q] * lj[q]
            li[j] = acc / pivot
    for i in range(n):
        acc = b[i]
        li = low[i]
        for q in range(i):
            acc -= li[q] * z[q]
        z[i] = acc / li[i]
    for i in range(n - 1, -1, -1):
        acc = z[i]
        for q in range(i + 1, n):
            acc -= low[q, i] * z[q]
        z[i] = acc / low[i, i]
    return True


@njit(cache=True, nogil=True)
def _spd_solve(m, b, z, low):  # type: ignore[no-untyped-def]
    """Solve m z = b into z (which may be b) for a symmetric m that a ridge makes positive definite.

    By Cholesky (:func:`_cholesky_solve`, low its work); where rounding defeats it (the ridge below the
    rounding of m), or m holds NaN, by LU (``np.linalg.solve``, which raises on NaN and on a singular m).
    """
    if not _cholesky_solve(m, b, z, low):
        z[:] = np.linalg.solve(m, b)


@njit(cache=True, nogil=True)
def _gram(J, out):  # type: ignore[no-untyped-def]
    """Fills out (n, n) with J^T J for J (m, n)."""
    m, n = J.shape
    for i in range(n):
        j = 0
        while j < i:  # two entries of row i at a time: two independent sums (a sixth less time)
            a0 = a1 = 0.0
            for k in range(m):
                c = J[k, i]
                a0 += c * J[k, j]
                a1 += c * J[k, j + 1]
            out[i, j] = out[j, i] = a0
            out[i, j + 1] = out[j + 1, i] = a1
            j += 2
        if j == i:
            acc = 0.0
            for k in range(m):
                acc += J[k, i] * J[k, j]
            out[i, j] = acc


@njit(cache=True, nogil=True)
def _min_norm(A, e, fixed, dfix, active, damping, dy, work):  # type: ignore[no-untyped-def]
    """Fills dy with the shortest dy with e + A dy = 0 on the active rows and dy = dfix where fixed.

    ``work`` is (Ant (d, rows): the rows of unit length, transposed; en (rows,), gram (rows, rows), z (rows,),
    low (rows, rows)).
    """
    Ant, en, gram, z, low = work
    rows, d = A.shape
    for i in range(rows):
        acc = 0.0
        for j in range(d):
            Ant[j, i] = A[i, j] if active[i] else 0.0
            acc += Ant[j, i] ** 2
        en[i] = e[i] if active[i] else 0.0
        norm = math.sqrt(acc)
        if not norm > 1e-300:
            norm = 1.0
        for j in range(d):
            Ant[j, i] /= norm
        en[i] /= norm
    acc = 0.0
    for i in range(rows):
        shift = 0.0
        for j in range(d):
            shift += Ant[j, i] * dfix[j]
        en[i] = en[i] + shift
        acc += en[i] ** 2
    for j in range(d):
        if fixed[j]:
            Ant[j] = 0.0
    ridge = 1e-14 + damping * math.sqrt(acc)
    _gram(Ant, gram)
    for i in range(rows):
        gram[i, i] += ridge + (0.0 if active[i] else 1.0)
        en[i] = -en[i]
    _spd_solve(gram, en, z, low)
    for j in range(d):
        acc = 0.0
        for i in range(rows):
            acc += Ant[j, i] * z[i]
        dy[j] = acc + dfix[j]


@njit(cache=True, nogil=True)
def _step(x, e, A, scale, lower, upper, bounded, has_body, damping, dy, fixed, dfix, active, work):  # type: ignore[no-untyped-def]
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
def _results(n, d):  # type: ignore[no-untyped-def]
    """End points (n, d), converged (n,) and iterations (n,) of n starts, to be filled in."""
    return np.empty((n, d)), np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.int64)


@njit(cache=True, nogil=True)
def _l1_max(e, n):  # type: ignore[no-untyped-def]
    """The 1-norm and the largest magnitude of e[:n]."""
    l1 = 0.0
    top = 0.0
    for i in range(n):
        a = abs(e[i])
        l1 += a
        if a > top or a != a:  # NaN propagates, as in np.max
            top = a
    return l1, top


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
        _project(x, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
        _evaluate(x, means, prec, log_norm, others, r, b, scale, a0, a1, kinds, centres, axes, perps,
                  radii, lengths, halfs, margin, e, A, lj, g, diff)
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
            _project(x_try, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            _evaluate(x_try, means, prec, log_norm, others, r, target, scale, a0, a1, kinds, centres, axes, perps,
                      radii, lengths, halfs, margin, e_try, A_try, lj, g, diff)
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
def _half_square(v, p):  # type: ignore[no-untyped-def]
    """1/2 |v - p|^2, summed in zone order (every objective of the planner is summed so)."""
    acc = 0.0
    for k in range(v.size):
        acc += (v[k] - p[k]) ** 2
    return 0.5 * acc


@njit(cache=True, nogil=True)
def _objective(x, v, means, prec, log_norm, p, u, diff):  # type: ignore[no-untyped-def]
    """The objective 1/2 |v - P(x)|^2 (:func:`_half_square`); fills p (K,) with P(x) (u, diff: work)."""
    _posterior_and_scores(x, means, prec, log_norm, p, u, diff)
    return _half_square(v, p)


@njit(cache=True, nogil=True)
def _score(xs, v, means, prec, log_norm, x_ref, scale):  # type: ignore[no-untyped-def]
    """Posterior (N, K), objective 1/2 |v - P|^2 (N,) and scaled distance to x_ref (N,) of every row."""
    n, d = xs.shape
    K = means.shape[0]
    post = np.empty((n, K))
    f = np.empty(n)
    dist = np.empty(n)
    u, diff = np.empty((K, d)), np.empty(d)
    for s in range(n):
        f[s] = _objective(xs[s], v, means, prec, log_norm, post[s], u, diff)
        acc = 0.0
        for j in range(d):
            acc += ((xs[s, j] - x_ref[j]) / scale[j]) ** 2
        dist[s] = math.sqrt(acc)
    return post, f, dist


def score(xs: NDArray[np.float64], v: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
          log_norm: NDArray[np.float64], x_ref: NDArray[np.float64], scale: NDArray[np.float64],
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Posterior (N, K), objective (N,) and scaled distance |(x - x_ref) / s| (N,) of every row of xs."""
    out: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] = _score(
        np.ascontiguousarray(xs, dtype=np.float64), v, means, prec, log_norm, x_ref, scale)
    return out


@njit(cache=True, nogil=True)
def _rank_key(f, index, n, tol):  # type: ignore[no-untyped-def]
    """The rank key of entry ``index`` of n (see :func:`_rank_keys`)."""
    q = 1.0 / tol if f != f else np.rint(f / (tol * (1.0 + abs(f))))
    return np.int64(q) * n + index


@njit(cache=True, nogil=True)
def _rank_keys(f, tol):  # type: ignore[no-untyped-def]
    """One integer per entry of f (N,) whose order is f quantised to ``tol`` relative, then the index.

    The quantised value is rint(f / (tol (1 + |f|))), with a NaN f after every number (as 1 / tol); for f >= 0
    it is below 1 / tol, so the key, value * N + index, fits an int64 for N < 9e6 entries at tol = 1e-12: keys
    are distinct, and float noise below the quantum cannot reorder them.
    """
    n = f.size
    keys = np.empty(n, dtype=np.int64)
    for i in range(n):
        keys[i] = _rank_key(f[i], i, n, tol)
    return keys


@njit(cache=True, nogil=True)
def _keep_best(best, m, keys, i):  # type: ignore[no-untyped-def]
    """Offer index i to best[:m], the best m indices so far in key order (at most best.size): returns the new m.

    i is inserted at its rank; when best is full, the worst is dropped (or i, when it is no better).
    """
    if m == best.size and (m == 0 or keys[i] >= keys[best[m - 1]]):
        return m
    if m < best.size:
        m += 1
    j = m - 1
    while j > 0 and keys[best[j - 1]] > keys[i]:
        best[j] = best[j - 1]
        j -= 1
    best[j] = i
    return m


@njit(cache=True, nogil=True)
def _first_ranked(f, tol, count):  # type: ignore[no-untyped-def]
    """The indices of the ``count`` entries of f (N,) first by :func:`_rank_keys` (``tol``), in that order.

    All N of them, sorted, when count >= N; none when count <= 0.
    """
    keys = _rank_keys(f, tol)
    out = np.empty(max(0, min(count, f.size)), dtype=np.int64)
    m = 0
    for i in range(f.size):
        m = _keep_best(out, m, keys, i)
    return out


@njit(cache=True, nogil=True)
def _screen(log_joint_t, log_v, posterior, v, count, tol):  # type: ignore[no-untyped-def]
    K, n = log_joint_t.shape
    score = np.empty(n)
    for i in range(n):
        if log_v.size:
            top = low = log_joint_t[0, i] - log_v[0]
            for k in range(1, K):
                q = log_joint_t[k, i] - log_v[k]
                if q > top or q != q:  # NaN propagates, as in np.max
                    top = q
                if q < low or q != q:
                    low = q
            score[i] = top - low
        else:
            score[i] = _half_square(v, posterior[i])
    return _first_ranked(score, tol, count)


def screen(log_joint_t: NDArray[np.float64], log_v: NDArray[np.float64], posterior: NDArray[np.float64],
           v: NDArray[np.float64], count: int, tol: float) -> NDArray[np.int64]:
    """The ``count`` best of N candidate starts by the planner's screen (``planner.search_starts``): indices.

    With log v given (K,), the score of start i is max_k q_k - min_k q_k, q_k = log_joint_t[k, i] - log v_k
    (log joints (K, N)); with an empty ``log_v``, 1/2 |v - posterior[i]|^2 (posteriors (N, K)), summed in zone
    order. Ranked by :func:`_rank_keys` at ``tol``.
    """
    out: NDArray[np.int64] = _screen(log_joint_t, log_v, posterior, v, count, tol)
    return out


@njit(cache=True, nogil=True)
def _select_demonstrations(posterior, v, members, zones, rest_count, tol):  # type: ignore[no-untyped-def]
    n = posterior.shape[0]
    keys = np.empty(n, dtype=np.int64)
    for i in range(n):
        keys[i] = _rank_key(_half_square(v, posterior[i]), i, n, tol)
    first = -1
    for i in range(n):  # the best of the first zone's demonstrations
        if members[zones[0], i] and (first < 0 or keys[i] < keys[first]):
            first = i
    if first < 0:  # none: the best overall
        first = 0
        for i in range(1, n):
            if keys[i] < keys[first]:
                first = i
    out = np.empty(1 + rest_count, dtype=np.int64)
    out[0] = first
    rest = out[1:]
    m = 0  # rest[:m] holds the best m so far, in key order
    for i in range(n):
        if i == first:
            continue
        member = False
        for z in range(zones.size):
            member = member or members[zones[z], i]
        if member:
            m = _keep_best(rest, m, keys, i)
    return out[:1 + m]


def select_demonstrations(posterior: NDArray[np.float64], v: NDArray[np.float64], members: NDArray[np.bool_],
                          zones: NDArray[np.int64], rest_count: int, tol: float) -> NDArray[np.int64]:
    """Algorithm 1's demonstrations: indices, the first zone's best first, then up to ``rest_count`` more.

    f = 1/2 |v - P|^2 of every demonstration (posteriors (N, K)) is ranked by :func:`_rank_keys` (``tol``).
    The first index is the best demonstration of zone ``zones[0]`` (``members`` (K, N): demonstration n
    belongs to zone k), or the best overall when that zone has none; then the best ``rest_count`` of
    the others that belong to any of ``zones``, in rank order.
    """
    out: NDArray[np.int64] = _select_demonstrations(
        np.ascontiguousarray(posterior, dtype=np.float64), np.ascontiguousarray(v, dtype=np.float64),
        np.ascontiguousarray(members, dtype=np.bool_), np.ascontiguousarray(zones, dtype=np.int64), rest_count, tol)
    return out


@njit(cache=True, nogil=True)
def _distinct(x, tol):  # type: ignore[no-untyped-def]
    n, d = x.shape
    keep = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        repeat = False
        for j in range(i):
            if keep[j]:
                acc = 0.0
                for k in range(d):
                    r = (x[i, k] - x[j, k]) / max(abs(x[j, k]), 1.0)
                    acc += r * r
                if acc < tol or acc == 0.0:
                    repeat = True
                    break
        keep[i] = not repeat
    return keep


def distinct(x: NDArray[np.float64], tol: float) -> NDArray[np.bool_]:
    """Whether each row of x (N, d) is kept: not within ``tol`` (squared, relative) of an earlier kept row.

    Row i repeats row j when sum_k ((x_ik - x_jk) / max(|x_jk|, 1))^2 < tol, or is 0 (an exact repeat: with
    tol = 0 only those; -0.0 equals 0.0, and a row holding NaN or an infinity repeats no row).
    """
    out: NDArray[np.bool_] = _distinct(np.ascontiguousarray(x, dtype=np.float64), tol)
    return out


@njit(cache=True, nogil=True)
def _choice_order(f, dist, start, xs, converged, match_tol, f_rtol, band, dist_tol, same_tol):  # type: ignore[no-untyped-def]
    n = f.size
    best = f[0]
    for i in range(1, n):  # the first lowest (as Python's min)
        if f[i] < best:
            best = f[i]
    slack = f_rtol * best
    if not slack > match_tol:
        slack = match_tol
    wide = slack  # no exact match: converged candidates whose residual |v - P| is within ``band`` of the best's
    if band > 0.0 and best > match_tol:
        wide = max(slack, 0.5 * (math.sqrt(2.0 * best) + band) ** 2 - best)
    pool = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        if f[i] <= best + slack or (converged[i] and f[i] <= best + wide):
            pool[m] = i
            m += 1
    matched = np.zeros(n, dtype=np.bool_)
    for i in range(m):
        matched[pool[i]] = True
    order = np.empty(n, dtype=np.int64)
    count = 0
    while m:  # nearest first; distances within dist_tol of it tie, broken by start order
        nearest = dist[pool[0]]
        for i in range(1, m):
            if dist[pool[i]] < nearest:
                nearest = dist[pool[i]]
        pick = -1  # the nearest itself is never farther, so one is picked
        for i in range(m):
            far = dist[pool[i]] > nearest + dist_tol
            if not far and (pick < 0 or start[pool[i]] < start[pool[pick]]):
                pick = i
        order[count] = pool[pick]
        count += 1
        for i in range(pick, m - 1):
            pool[i] = pool[i + 1]
        m -= 1
    for i in np.argsort(_rank_keys(f, match_tol)):
        if not matched[i]:
            order[count] = i
            count += 1
    keep = _distinct(xs[order], same_tol)
    return order[keep]


def choice_order(f: NDArray[np.float64], dist: NDArray[np.float64], start: NDArray[np.int64],
                 xs: NDArray[np.float64], converged: NDArray[np.bool_], match_tol: float, f_rtol: float, band: float,
                 dist_tol: float, same_tol: float) -> NDArray[np.int64]:
    """The planner's choice order (its rule 6): indices into the candidates.

    The candidates have objectives f (N,), distances dist (N,), start indices start (N,), end points xs (N, d)
    and whether each converged (N,). The matches are those with f <= f* + max(match_tol, f_rtol f*), f* the
    lowest f, and, when f* > match_tol (no exact match) and ``band`` > 0, the converged ones whose residual
    sqrt(2 f) is within ``band`` of sqrt(2 f*). The matches come nearest first, distances within ``dist_tol``
    of the nearest tying, broken by the lower start index; then the others by :func:`_rank_keys` of f
    (``match_tol``). A row within ``same_tol`` of an earlier one (:func:`distinct`) is dropped.
    """
    out: NDArray[np.int64] = _choice_order(f, dist, start, np.ascontiguousarray(xs, dtype=np.float64), converged,
                                           match_tol, f_rtol, band, dist_tol, same_tol)
    return out


@njit(cache=True, nogil=True)
def _posterior_and_scores(x, means, prec, log_norm, p, g, diff):  # type: ignore[no-untyped-def]
    """Fills p (K,) with P(k|x) and g (K, d) with the gradients of log(pi_k N_k(x)); diff (d,) is work.

    :func:`_centre_scores` turns g into the gradients of log P(k|x), :func:`_scores_to_jacobian` into dP/dx.
    """
    _log_joint_score(x, means, prec, log_norm, p, g, diff)
    _normalise(p)


@njit(cache=True, nogil=True)
def _normalise(p):  # type: ignore[no-untyped-def]
    """Turns log joints p (K,) into the posterior in place: exp(p_k - max p) / sum_j exp(p_j - max p)."""
    K = p.size
    top = p[0]
    for k in range(1, K):
        if p[k] > top or p[k] != p[k]:  # NaN propagates, as in np.max
            top = p[k]
    total = 0.0
    for k in range(K):
        p[k] = math.exp(p[k] - top)
        total += p[k]
    for k in range(K):
        p[k] /= total


@njit(cache=True, nogil=True)
def _log_joints(xs, means, prec, log_norm):  # type: ignore[no-untyped-def]
    n = xs.shape[0]
    K, d = means.shape
    lj, post = np.empty((n, K)), np.empty((n, K))
    g, diff = np.empty((K, d)), np.empty(d)
    for s in range(n):
        _log_joint_score(xs[s], means, prec, log_norm, lj[s], g, diff)
        post[s] = lj[s]
        _normalise(post[s])
    return lj, post


def log_joints(xs: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
               log_norm: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """log(pi_k N_k(x)) and P(k|x) of every row of xs (N, d), each (N, K), with the iterations' own arithmetic."""
    lj: NDArray[np.float64]
    post: NDArray[np.float64]
    lj, post = _log_joints(np.ascontiguousarray(xs, dtype=np.float64), means, prec, log_norm)
    return lj, post


@njit(cache=True, nogil=True)
def _centre_scores(p, u):  # type: ignore[no-untyped-def]
    """u_k <- u_k - sum_j P_j u_j (in place): the gradients of log(pi_k N_k) to those of log P(k|x)."""
    K, d = u.shape
    for i in range(d):
        mean = 0.0
        for k in range(K):
            mean += p[k] * u[k, i]
        for k in range(K):
            u[k, i] -= mean


@njit(cache=True, nogil=True)
def _posterior_jacobian(x, means, prec, log_norm, p, jac, diff):  # type: ignore[no-untyped-def]
    """Fills p (K,) with P(k|x) and jac (K, d) with dP/dx."""
    _posterior_and_scores(x, means, prec, log_norm, p, jac, diff)
    _scores_to_jacobian(p, jac)


@njit(cache=True, nogil=True)
def _scores_to_jacobian(p, jac):  # type: ignore[no-untyped-def]
    """Turns jac (K, d), the gradients of log(pi_k N_k(x)), into dP/dx in place (p = P(k|x))."""
    _centre_scores(p, jac)
    for k in range(p.size):
        for i in range(jac.shape[1]):
            jac[k, i] *= p[k]


@njit(cache=True, nogil=True)
def _residual(v, p, r):  # type: ignore[no-untyped-def]
    """Fills r with v - p; returns f = 1/2 |r|^2."""
    acc = 0.0
    for k in range(v.size):
        r[k] = v[k] - p[k]
        acc += r[k] * r[k]
    return 0.5 * acc


@njit(cache=True, nogil=True)
def _gradient(r, jac, grad):  # type: ignore[no-untyped-def]
    """Fills grad (d,) with the gradient -r^T jac of f = 1/2 |r|^2 (r (K,), jac = dP/dx (K, d))."""
    for j in range(grad.size):
        acc = 0.0
        for k in range(r.size):
            acc += r[k] * jac[k, j]
        grad[j] = -acc


@njit(cache=True, nogil=True)
def _hold_leaving(x, step, held, lower, upper, a0, a1):  # type: ignore[no-untyped-def]
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
def _least_squares(starts, v, means, prec, log_norm, lower, upper, a0, a1,  # type: ignore[no-untyped-def]
                   kinds, centres, axes, perps, radii, lengths, halfs, margin, maxiter, ftol, ridge_rel):
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
        _project(x, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
        _posterior_jacobian(x, means, prec, log_norm, p, jac, diff)
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
                on_body = _body_hold(x, grad, kinds, centres, axes, perps, radii, lengths, halfs, margin, normal)
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
            _project(x_new, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            if on_body:
                _onto_surface(x_new, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            _posterior_and_scores(x_new, means, prec, log_norm, p_new, jac_new, diff)  # dP/dx only if taken
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
def _posterior_hessian(x, means, prec, log_norm, v, p, u, jac, h, diff):  # type: ignore[no-untyped-def]
    """Fills p (K,) with P(k|x), jac (K, d) with dP/dx and h (d, d) with the Hessian of f = 1/2 |v - P|^2.

    u (K, d) and diff (d,) are work (u ends holding the gradients of log P(k|x)).
    """
    _posterior_and_scores(x, means, prec, log_norm, p, u, diff)
    _scores_to_hessian(prec, v, p, u, jac, h)


@njit(cache=True, nogil=True)
def _scores_to_hessian(prec, v, p, u, jac, h):  # type: ignore[no-untyped-def]
    """Fills jac (K, d) with dP/dx and h (d, d) with the Hessian of f = 1/2 |v - P|^2.

    From p = P(k|x) and u (K, d) holding the gradients of log(pi_k N_k(x)) (:func:`_posterior_and_scores`);
    u ends holding those of log P(k|x).
    """
    K, d = u.shape
    _centre_scores(p, u)
    s = 0.0
    for k in range(K):
        s += (p[k] - v[k]) * p[k]
        for i in range(d):
            jac[k, i] = p[k] * u[k, i]
    _gram(jac, h)
    for k in range(K):
        # sum_k c_k d2P_k = sum_k c_k p_k (u_k u_k^T - Lambda_k) + s (Lambda_bar - C), c = p - v,
        # Lambda_bar = sum_j p_j Lambda_j, C = sum_j p_j u_j u_j^T
        c = p[k] - v[k]
        a = c * p[k] - s * p[k]
        b = s * p[k] - c * p[k]
        for i in range(d):
            for j in range(d):
                h[i, j] += a * u[k, i] * u[k, j] + b * prec[k, i, j]


@njit(cache=True, nogil=True)
def _newton_least_squares(starts, v, means, prec, log_norm, lower, upper, scale, a0, a1,  # type: ignore[no-untyped-def]
                          kinds, centres, axes, perps, radii, lengths, halfs, margin, maxiter, steptol, ridge_rel):
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
        _project(x, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
        _posterior_hessian(x, means, prec, log_norm, v, p, u, jac, hess, diff)
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
                on_body = _body_hold(x, grad, kinds, centres, axes, perps, radii, lengths, halfs, margin, normal)
                h[:] = hess
                if on_body:  # the Lagrangian's Hessian on the body's surface: minus mu times the surface's curvature
                    mu = grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2]
                    _distance_hessian(x, kinds, centres, axes, perps, radii, lengths, halfs, curvature)
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
            _project(x_new, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            if on_body:
                _onto_surface(x_new, lower, upper, kinds, centres, axes, perps, radii, lengths, halfs, margin)
            _posterior_and_scores(x_new, means, prec, log_norm, p_new, u, diff)  # the Hessian only if taken
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


@njit(cache=True, nogil=True)
def _objectives(xs, v, means, prec, log_norm):  # type: ignore[no-untyped-def]
    """The objective 1/2 |v - P|^2 of every row of xs (N, d), as :func:`_score` computes it."""
    n, d = xs.shape
    K = means.shape[0]
    f = np.empty(n)
    p, u, diff = np.empty(K), np.empty((K, d)), np.empty(d)
    for s in range(n):
        f[s] = _objective(xs[s], v, means, prec, log_norm, p, u, diff)
    return f


@njit(cache=True, nogil=True)
def _unconverged_first(xs, ok, v, means, prec, log_norm, count, tol):  # type: ignore[no-untyped-def]
    """The ``count`` rows of xs that have not converged (``ok`` False) with the lowest f, in rank-key order."""
    going = np.empty(ok.size, dtype=np.int64)
    m = 0
    for i in range(ok.size):
        if not ok[i]:
            going[m] = i
            m += 1
    going = going[:m]
    return going[_first_ranked(_objectives(xs[going], v, means, prec, log_norm), tol, count)]


@njit(cache=True, nogil=True)
def _newton_polish(xs, ok, its, left, v, means, prec, log_norm, lower, upper, scale, a0, a1,  # type: ignore[no-untyped-def]
                   kinds, centres, axes, perps, radii, lengths, halfs, margin, polish, race, keep, maxiter,
                   steptol, ridge_rel, tol):
    """Newton from the ``polish`` rows of xs with the lowest f, in place where it converges.

    ``race`` iterations each, then the ``keep`` best unconverged on to ``maxiter``; ``ok``, ``its`` and
    ``left`` (cleared where it converges) are updated too.
    """
    best = _first_ranked(_objectives(xs, v, means, prec, log_norm), tol, polish)
    xs_n, ok_n, its_n = _newton_least_squares(xs[best], v, means, prec, log_norm, lower, upper, scale, a0,
                                              a1, kinds, centres, axes, perps, radii, lengths, halfs, margin, race,
                                              steptol, ridge_rel)
    ahead = _unconverged_first(xs_n, ok_n, v, means, prec, log_norm, keep, tol)
    if ahead.size:
        xs_a, ok_a, more = _newton_least_squares(xs_n[ahead], v, means, prec, log_norm, lower, upper, scale,
                                                 a0, a1, kinds, centres, axes, perps, radii, lengths, halfs, margin,
                                                 maxiter - race, steptol, ridge_rel)
        for i in range(ahead.size):
            xs_n[ahead[i]] = xs_a[i]
            ok_n[ahead[i]] = ok_a[i]
            its_n[ahead[i]] += more[i]
    for i in range(best.size):
        if ok_n[i]:
            xs[best[i]] = xs_n[i]
            ok[best[i]] = True
            left[best[i]] = 0
        its[best[i]] += its_n[i]


@njit(cache=True, nogil=True)
def _least_squares_rounds(origins, v, v_path, means, prec, log_norm, lower, upper, scale, a0, a1,  # type: ignore[no-untyped-def]
                          kinds, centres, axes, perps, radii, lengths, halfs, margin,
                          lm_race, lm_keep, lm_maxiter, lm_ftol, ridge_rel,
                          polish, newton_race, newton_keep, newton_maxiter, newton_steptol,
                          screened, f0, f1, open_f, open_lm,
                          others, r, b_path, b, near_f, gn_maxiter, gn_stall, gn_damping, gn_htol, gn_steptol, tol):
    """The planner's least squares (:func:`least_squares_rounds`)."""
    d = origins.shape[1]
    xs, ok, its = _least_squares(origins, v_path, means, prec, log_norm, lower, upper, a0, a1, kinds, centres,
                                 axes, perps, radii, lengths, halfs, margin, lm_race, lm_ftol, ridge_rel)
    left = _unless(ok, 1)  # 1: left behind the race's leaders
    ahead = _unconverged_first(xs, ok, v_path, means, prec, log_norm, lm_keep, tol)
    if ahead.size:
        xs_a, ok_a, more = _least_squares(xs[ahead], v_path, means, prec, log_norm, lower, upper, a0, a1,
                                          kinds, centres, axes, perps, radii, lengths, halfs, margin,
                                          lm_maxiter - lm_race, lm_ftol, ridge_rel)
        for i in range(ahead.size):
            xs[ahead[i]] = xs_a[i]
            ok[ahead[i]] = ok_a[i]
            its[ahead[i]] += more[i]
            left[ahead[i]] = 0
    _newton_polish(xs, ok, its, left, v_path, means, prec, log_norm, lower, upper, scale, a0, a1, kinds, centres,
                   axes, perps, radii, lengths, halfs, margin, polish, newton_race, newton_keep, newton_maxiter,
                   newton_steptol, ridge_rel, tol)
    f = _objectives(xs, v_path, means, prec, log_norm)
    lowest = f[0]
    for i in range(1, f.size):
        if f[i] < lowest or f[i] != f[i]:  # NaN propagates, as in np.min
            lowest = f[i]
    fingers = np.empty(max(0, f1 - f0), dtype=np.int64)
    m = 0
    for j in range(f0, f1):
        if screened[j] != lower[j]:
            fingers[m] = j
            m += 1
    if lowest > open_f and m > 0:  # clearly no match: the fingers' other minima
        opened = np.empty((m, d))
        for i in range(m):
            opened[i] = screened
            opened[i, fingers[i]] = lower[fingers[i]]  # one finger open in each
        starts = _project_rows(opened, lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths, halfs,
                               margin)
        xs_o, ok_o, its_o = _least_squares(starts, v_path, means, prec, log_norm, lower, upper, a0, a1, kinds,
                                           centres, axes, perps, radii, lengths, halfs, margin, open_lm, lm_ftol,
                                           ridge_rel)
        left_o = _unless(ok_o, 2)  # 2: an opened start left behind the polished ones
        _newton_polish(xs_o, ok_o, its_o, left_o, v_path, means, prec, log_norm, lower, upper, scale, a0, a1, kinds,
                       centres, axes, perps, radii, lengths, halfs, margin, polish, newton_race, newton_keep,
                       newton_maxiter, newton_steptol, ridge_rel, tol)
        xs, ok, its = np.concatenate((xs, xs_o)), np.concatenate((ok, ok_o)), np.concatenate((its, its_o))
        left, origins = np.concatenate((left, left_o)), np.concatenate((origins, starts))
    if others.size:  # P = v is possible: end points within near_f of a match are projected onto the matches
        f = _objectives(xs, v, means, prec, log_norm)
        near = np.empty(f.size, dtype=np.int64)
        m = 0
        for i in range(f.size):
            if f[i] <= near_f:
                near[m] = i
                m += 1
        near = near[:m]
        if m:
            xs_p, ok_p, its_p = _project_starts(xs[near], means, prec, log_norm, others, r, b_path, scale,
                                                lower, upper, a0, a1, kinds, centres, axes, perps, radii, lengths,
                                                halfs, margin, gn_maxiter, gn_stall, gn_damping, gn_htol, gn_steptol,
                                                b)
            for i in range(m):
                if ok_p[i]:  # a converged projection is a converged answer
                    xs[near[i]] = xs_p[i]
                    ok[near[i]] = True
                    left[near[i]] = 3  # 3: projected onto the matches
                its[near[i]] += its_p[i]
    return xs, ok, its, left, origins


@njit(cache=True, nogil=True)
def _unless(ok, code):  # type: ignore[no-untyped-def]
    """int8 codes: 0 where ok, else ``code``."""
    out = np.zeros(ok.size, dtype=np.int8)
    for i in range(ok.size):
        if not ok[i]:
            out[i] = code
    return out


def least_squares_rounds(origins: NDArray[np.float64], v: NDArray[np.float64], v_path: NDArray[np.float64],
                         means: NDArray[np.float64], prec: NDArray[np.float64], log_norm: NDArray[np.float64],
                         lower: NDArray[np.float64], upper: NDArray[np.float64], scale: NDArray[np.float64],
                         a0: int, a1: int, body: tuple[Any, ...], *, lm: tuple[int, int, int, float, float],
                         newton: tuple[int, int, int, int, float], screened: NDArray[np.float64],
                         fingers: tuple[int, int], open_f: float, open_lm: int,
                         equations: tuple[NDArray[np.int64], int, NDArray[np.float64], NDArray[np.float64]],
                         near_f: float, gn: tuple[int, int, float, float, float], tol: float,
                         ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], NDArray[np.int8],
                                    NDArray[np.float64]]:
    """The planner's least squares (rule 5 of :mod:`grasp_intent_ros.core.planner`) in one compiled call.

    Levenberg-Marquardt (``lm`` = race iterations, leaders kept, their iteration limit, ftol, ridge) from every
    origin (N, d) on ``v_path``, then Newton (``newton`` = end points polished, race iterations, leaders kept,
    their iteration limit, step tolerance) from the best end points; when the lowest f is above ``open_f``,
    the open-finger round from ``screened`` (features ``fingers`` = (start, stop); an empty range: no round);
    then, with log-odds ``equations`` (others, r, path targets, exact targets; no others: no projection),
    the end points with f (on v) within ``near_f`` are projected onto the matches (``gn`` = iteration limit,
    stall, damping, residual and step tolerances). Rows are ranked by :func:`_rank_keys` at ``tol``.

    Returns end points, converged, iterations, how each row ended (0: as ``converged`` says; 1: left
    behind the race's leaders; 2: an opened start left behind the polished ones; 3: projected onto the
    matches) and the origin of each row.
    """
    out: tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], NDArray[np.int8],
               NDArray[np.float64]] = _least_squares_rounds(
        np.ascontiguousarray(origins, dtype=np.float64), v, v_path, means, prec, log_norm, lower, upper, scale, a0,
        a1, *body, *lm, *newton, screened, *fingers, open_f, open_lm, *equations, near_f, *gn, tol)  # type: ignore[call-arg]
    return out


# -- inverse kinematics of a serial chain of revolute joints (MicoKinematics.ik) ---------------------------
# 3-vectors and 3x3 products are written out (a BLAS call, or a temporary array, costs more than the
# arithmetic at this size).


@njit(cache=True, nogil=True)
def _compose(A, B, out):  # type: ignore[no-untyped-def]
    """Fills out with A B for 3x3 matrices (out is neither)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True, nogil=True)
def _axis_rotation(axis, angle, out):  # type: ignore[no-untyped-def]
    """Fills out with the rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    s, c = math.sin(angle), math.cos(angle)
    x, y, z = axis[0], axis[1], axis[2]
    t = 1.0 - c
    out[0, 0], out[0, 1], out[0, 2] = c + t * x * x, t * x * y - s * z, t * x * z + s * y
    out[1, 0], out[1, 1], out[1, 2] = t * x * y + s * z, c + t * y * y, t * y * z - s * x
    out[2, 0], out[2, 1], out[2, 2] = t * x * z - s * y, t * y * z + s * x, c + t * z * z


@njit(cache=True, nogil=True)
def _chain_fk(q, rots, trans, axes, tip_rot, tip_trans, origins, zs):  # type: ignore[no-untyped-def]
    """World pose (R, p) of the tip; fills each joint's world origin and axis into ``origins``, ``zs``.

    Joint i sits at placement (rots[i], trans[i]) in joint i - 1's frame (the world for i = 0) and turns
    by q[i] about ``axes[i]`` (its own frame); the tip sits at (tip_rot, tip_trans) in the last joint's frame.
    """
    R = np.eye(3)
    p = np.zeros(3)
    M, T = np.empty((3, 3)), np.empty((3, 3))
    for i in range(q.size):
        for r in range(3):
            p[r] += R[r, 0] * trans[i, 0] + R[r, 1] * trans[i, 1] + R[r, 2] * trans[i, 2]
        _compose(R, rots[i], M)
        origins[i] = p
        for r in range(3):
            zs[i, r] = M[r, 0] * axes[i, 0] + M[r, 1] * axes[i, 1] + M[r, 2] * axes[i, 2]
        _axis_rotation(axes[i], q[i], T)
        _compose(M, T, R)
    for r in range(3):
        p[r] += R[r, 0] * tip_trans[0] + R[r, 1] * tip_trans[1] + R[r, 2] * tip_trans[2]
    _compose(R, tip_rot, M)
    return M, p


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
    d0, d1, d2 = p_t[0] - p[0], p_t[1] - p[1], p_t[2] - p[2]
    E = np.empty((3, 3))
    for i in range(3):
        e[i] = R[0, i] * d0 + R[1, i] * d1 + R[2, i] * d2
        for j in range(3):
            E[i, j] = R[0, i] * R_t[0, j] + R[1, i] * R_t[1, j] + R[2, i] * R_t[2, j]
    e[3:] = _log3(E)
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
    e0, e1, e2, f0, f1, f2 = e[0], e[1], e[2], e[3], e[4], e[5]  # f = phi
    theta = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if theta < 1e-4:
        c2 = 1.0 / 12.0 + theta * theta / 720.0
    else:
        c2 = 1.0 / (theta * theta) - math.cos(0.5 * theta) / (2.0 * theta * math.sin(0.5 * theta))
    J = np.empty((6, n))
    for i in range(n):
        z0, z1, z2 = zs[i, 0], zs[i, 1], zs[i, 2]
        w0 = R[0, 0] * z0 + R[1, 0] * z1 + R[2, 0] * z2  # w = R^T z
        w1 = R[0, 1] * z0 + R[1, 1] * z1 + R[2, 1] * z2
        w2 = R[0, 2] * z0 + R[1, 2] * z1 + R[2, 2] * z2
        r0, r1, r2 = p[0] - origins[i, 0], p[1] - origins[i, 1], p[2] - origins[i, 2]
        c0, c1, c2_ = z1 * r2 - z2 * r1, z2 * r0 - z0 * r2, z0 * r1 - z1 * r0  # z x (p - o)
        J[0, i] = -(w1 * e2 - w2 * e1) - (R[0, 0] * c0 + R[1, 0] * c1 + R[2, 0] * c2_)
        J[1, i] = -(w2 * e0 - w0 * e2) - (R[0, 1] * c0 + R[1, 1] * c1 + R[2, 1] * c2_)
        J[2, i] = -(w0 * e1 - w1 * e0) - (R[0, 2] * c0 + R[1, 2] * c1 + R[2, 2] * c2_)
        pw0, pw1, pw2 = f1 * w2 - f2 * w1, f2 * w0 - f0 * w2, f0 * w1 - f1 * w0  # phi x w
        J[3, i] = -(w0 - 0.5 * pw0 + c2 * (f1 * pw2 - f2 * pw1))
        J[4, i] = -(w1 - 0.5 * pw1 + c2 * (f2 * pw0 - f0 * pw2))
        J[5, i] = -(w2 - 0.5 * pw2 + c2 * (f0 * pw1 - f1 * pw0))
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
    q = q.copy()  # the iterate (its buffer swaps with q_try's): the caller's q is left as it is
    origins, zs = np.empty((n, 3)), np.empty((n, 3))
    q_try, step = np.empty(n), np.empty(n)
    system, low = np.empty((n, n)), np.empty((n, n))
    e, R, p = _ik_residual(q, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs)
    cost = np.sum(e * e)
    J = _ik_jacobian(e, R, p, origins, zs)
    damping = 1e-3
    iterations = 0
    while True:
        pos_err = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        rot_err = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        if (pos_err <= _IK_SOLVED and rot_err <= _IK_SOLVED) or iterations >= max_iter:
            return q, pos_err, rot_err, iterations
        iterations += 1
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(6):
                    acc += J[k, i] * J[k, j]
                system[i, j] = acc
            system[i, i] += damping
            acc = 0.0
            for k in range(6):
                acc += J[k, i] * e[k]
            step[i] = -acc  # -J^T e
        _cholesky_solve(system, step, step, low)  # (should rounding make it indefinite, the step stays -J^T e)
        longest = 0.0
        for i in range(n):
            if abs(step[i]) > longest or step[i] != step[i]:  # NaN propagates, as in np.max
                longest = abs(step[i])
        if longest > 0.5:
            shorten = 0.5 / longest
            for i in range(n):
                step[i] *= shorten
        for i in range(n):
            q_try[i] = min(max(q[i] + step[i], lower[i]), upper[i])
        e_try, R_try, p_try = _ik_residual(q_try, rots, trans, axes, tip_rot, tip_trans, R_t, p_t, origins, zs)
        cost_try = np.sum(e_try * e_try)
        if cost_try < cost:
            q, q_try = q_try, q
            e, cost = e_try, cost_try
            J = _ik_jacobian(e, R_try, p_try, origins, zs)
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
        v = np.array([0.5, 0.5])
        least_squares_rounds(np.full((1, d), 0.5), v, v, np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
                             -np.ones(d), np.ones(d), np.ones(d), 3, 6, body, lm=(2, 1, 3, 1e-7, 1e-7),
                             newton=(1, 2, 1, 3, 1e-10), screened=np.full(d, 0.5), fingers=(7, 10), open_f=-1.0,
                             open_lm=2, equations=(np.ones(1, dtype=np.int64), 0, np.zeros(1), np.zeros(1)),
                             near_f=1.0, gn=(2, 12, 1e-3, 1e-11, 1e-9), tol=1e-12)
        feasible(np.full((1, d), 0.5), -np.ones(d), np.ones(d), 3, 6, body)
    score(np.full((1, d), 0.5), np.array([0.5, 0.5]), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
          np.zeros(d), np.ones(d))
    log_joints(np.full((1, d), 0.5), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2))
    for log_v in (np.zeros(2), np.zeros(0)):
        screen(np.zeros((2, 3)), log_v, np.full((3, 2), 0.5), np.array([0.5, 0.5]), 1, 1e-12)
    distinct(np.ones((2, d)), 1e-18)
    choice_order(np.ones(2), np.ones(2), np.arange(2), np.ones((2, d)), np.ones(2, dtype=np.bool_), 1e-12, 1e-6, 3e-3,
                 1e-6, 1e-18)
    select_demonstrations(np.full((2, 2), 0.5), np.array([0.5, 0.5]), np.ones((2, 2), dtype=np.bool_),
                          np.zeros(1, dtype=np.int64), 1, 1e-12)
    eye = np.eye(3)
    limits = -np.ones(2), np.ones(2)
    for limit in limits:  # MicoKinematics's joint limits are read-only arrays, a type of their own to numba
        limit.setflags(write=False)
    ik_descent(np.zeros(2), *limits, (np.stack([eye, eye]), np.zeros((2, 3)),
               np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), eye, np.array([1.0, 0.0, 0.0])), eye,
               np.array([0.0, 1.0, 0.0]), 2)


if __name__ == '__main__':
    warm_up()
