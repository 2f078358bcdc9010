"""The object's body: signed distance, its gradient and Hessian; the projection onto the feasible set X.

A grasp x (d,) has its palm position in x[0:3] (m, object frame) and a unit approach vector in
x[a0:a1]. X is: every entry within [lower, upper], the approach of unit length, and the palm at least
``margin`` outside the body. The body is the union of primitives in a :class:`~.types.Body`; no
primitive at all means no body. The union's signed distance is the least of the primitives' (each exact); its gradient
is the nearest primitive's, the first one's on ties.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .types import Body

__all__ = ['feasible']

_ON_SURFACE = 1e-12  # a palm within this (m) of the body's surface is on it


@njit(cache=True, nogil=True)
def _primitive_distance(p, m, body, normal):
    """Signed distance of p (its first three entries) to primitive m and its unit gradient: (sd, g0, g1, g2).

    Without ``normal`` only the distance is asked for: the same value, with g = 0 where g would cost divisions.
    """
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
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
def _distance(p, body, normal):
    """Signed distance of p (its first three entries) to the union of primitives and its unit gradient.

    Returns (sd, g0, g1, g2), of the first primitive on ties; without ``normal`` only sd is meaningful.
    """
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    best, b0, b1, b2 = np.inf, 0.0, 0.0, 0.0
    for m in range(kinds.shape[0]):
        sd, g0, g1, g2 = _primitive_distance(p, m, body, normal)
        if sd < best:
            best, b0, b1, b2 = sd, g0, g1, g2
    return best, b0, b1, b2


@njit(cache=True, nogil=True)
def _push_out(x, lower, upper, body, tol):
    """Move the palm x[0:3] (in place) along the distance's gradient, then clip it to the bounds.

    Up to 4 moves, until its distance is within tol of the margin (tol < 0: until it is at least the margin).
    """
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    for _ in range(4):
        sd = _distance(x, body, False)[0]
        if (sd >= margin) if tol < 0.0 else (abs(sd - margin) <= tol):
            break
        sd, g0, g1, g2 = _distance(x, body, True)
        c = margin - sd
        x[0] += c * g0
        x[1] += c * g1
        x[2] += c * g2
    for i in range(3):
        x[i] = min(max(x[i], lower[i]), upper[i])


@njit(cache=True, nogil=True)
def _project(x, lower, upper, a0, a1, body):
    """Clip to the bounds, normalise the approach, push the palm out of the body (in place)."""
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
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
        _push_out(x, lower, upper, body, -1.0)
    return x


@njit(cache=True, nogil=True)
def _project_rows(xs, lower, upper, a0, a1, body):
    """Every row of xs (N, d) projected onto the feasible set (a new array)."""
    out = xs.copy()
    for s in range(out.shape[0]):
        _project(out[s], lower, upper, a0, a1, body)
    return out


def feasible(xs: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64], a0: int, a1: int,
             body: tuple[Any, ...]) -> NDArray[np.float64]:
    """Rows of xs (N, d) clipped to the bounds, approach normalised, palm pushed out of the body."""
    out: NDArray[np.float64] = _project_rows(np.ascontiguousarray(xs, dtype=np.float64), lower, upper, a0, a1,
                                             Body(*body))
    return out


@njit(cache=True, nogil=True)
def _distance_hessian(p, body, hess):
    """Fills hess (3, 3) with the signed distance's Hessian at p[:3], the nearest primitive's curvature.

    A cylinder's side is curved, (I - a a^T - e e^T) / rho with a its axis, e the radial unit vector and rho
    the radius at p; flat faces, and the edges' small share of the surface, count as flat. (Written out:
    building it from small arrays cost ten times the arithmetic.)
    """
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    best = np.inf
    for m in range(kinds.shape[0]):
        sd = _primitive_distance(p, m, body, False)[0]
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
def _body_hold(x, grad, body, normal):
    """Whether the body holds the palm; fills ``normal`` (3,) with the surface's unit normal there when it may.

    It does when the palm is on the surface (margin included) and grad (of f, shape (d,)) points out of
    it, i.e. f would fall inside the body.
    """
    kinds, centres, axes, perps, radii, lengths, halfs, margin = body
    if kinds.shape[0] == 0:
        return False
    if not _distance(x, body, False)[0] - margin <= _ON_SURFACE:
        return False  # off the surface: no normal needed
    sd, normal[0], normal[1], normal[2] = _distance(x, body, True)
    return sd - margin <= _ON_SURFACE and grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2] > 0.0


@njit(cache=True, nogil=True)
def _onto_surface(x, lower, upper, body):
    """Move the palm of x (in place) onto the body's surface (margin included), within the bounds."""
    _push_out(x, lower, upper, body, 1e-15)
    return x


@njit(cache=True, nogil=True)
def _on_plane(g, lo, a):
    """Set g <- (I - a a^T) g on the entries lo, ..., lo + len(a) - 1 of g (in place; a a unit vector)."""
    c = 0.0
    for i in range(a.size):
        c += g[lo + i] * a[i]
    for i in range(a.size):
        g[lo + i] -= c * a[i]


@njit(cache=True, nogil=True)
def _on_plane_both(h, lo, a):
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
