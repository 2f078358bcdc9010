"""Small dense linear algebra written as loops: Gram matrices, Cholesky solves, the minimum-norm step.

At the planner's sizes (d = 10 unknowns, a handful of equations) a BLAS or LAPACK call, or a temporary
array, costs more than the arithmetic; these loops sum in a fixed order, so their results do not depend
on the machine's BLAS (only :func:`_spd_solve`'s fallback, for a matrix that Cholesky rejects, is
LAPACK's). Also the solvers' shared result arrays and residual norms.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _cholesky_solve(m, b, z, low):
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
def _spd_solve(m, b, z, low):
    """Solve m z = b into z (which may be b) for a symmetric m that a ridge makes positive definite.

    By Cholesky (:func:`_cholesky_solve`, low its work); where rounding defeats it (the ridge below the
    rounding of m), or m holds NaN, by LU (``np.linalg.solve``, which raises on NaN and on a singular m).
    """
    if not _cholesky_solve(m, b, z, low):
        z[:] = np.linalg.solve(m, b)


@njit(cache=True, nogil=True)
def _gram(J, out):
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
def _min_norm(A, e, fixed, dfix, active, damping, dy, work):
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
def _results(n, d):
    """End points (n, d), converged (n,) and iterations (n,) of n starts, to be filled in."""
    return np.empty((n, d)), np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.int64)


@njit(cache=True, nogil=True)
def _l1_max(e, n):
    """The 1-norm and the largest magnitude of e[:n]."""
    l1 = 0.0
    top = 0.0
    for i in range(n):
        a = abs(e[i])
        l1 += a
        if a > top or a != a:  # NaN propagates, as in np.max
            top = a
    return l1, top
