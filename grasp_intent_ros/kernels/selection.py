"""Candidate selection and ranking: which starts to try, which end points are distinct, which answer wins.

Every ranking sorts by an integer key: the value quantised to a stated relative tolerance, then the
index (:func:`_rank_keys`), so that float noise below the quantum never reorders candidates.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .posterior import _half_square

__all__ = ['screen', 'select_demonstrations', 'distinct', 'choice_order', 'lex_order']


@njit(cache=True, nogil=True)
def _rank_key(f, index, n, tol):
    """The rank key of entry ``index`` of n (see :func:`_rank_keys`)."""
    q = 1.0 / tol if f != f else np.rint(f / (tol * (1.0 + abs(f))))
    return np.int64(q) * n + index


@njit(cache=True, nogil=True)
def _rank_keys(f, tol):
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
def _keep_best(best, m, keys, i):
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
def _first_ranked(f, tol, count):
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
def _screen(log_joint_t, log_v, posterior, v, count, tol):
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
    """The ``count`` best of N candidate starts by the planner's screen (``planning.lm.search_starts``): indices.

    With log v given (K,), the score of start i is max_k q_k - min_k q_k, q_k = log_joint_t[k, i] - log v_k
    (log joints (K, N)); with an empty ``log_v``, 1/2 |v - posterior[i]|^2 (posteriors (N, K)), summed in zone
    order. Ranked by :func:`_rank_keys` at ``tol``.
    """
    out: NDArray[np.int64] = _screen(log_joint_t, log_v, posterior, v, count, tol)
    return out


@njit(cache=True, nogil=True)
def _select_demonstrations(posterior, v, members, zones, rest_count, tol):
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
def _distinct(x, tol):
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
def _choice_order(f, dist, start, xs, converged, match_tol, f_rtol, band, dist_tol, same_tol):
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
def _before(keys, i, j):
    """Whether column i of keys comes strictly before column j: the last row first, NaN after every number."""
    for r in range(keys.shape[0] - 1, -1, -1):
        a, b = keys[r, i], keys[r, j]
        if a < b or (b != b and a == a):
            return True
        if b < a or (a != a and b == b):
            return False
    return False


@njit(cache=True, nogil=True)
def _lex_order(keys):
    n = keys.shape[1]
    order = np.arange(n)
    work = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:  # bottom-up merge sort: runs of ``width`` merged in pairs, the left run first on ties
        for lo in range(0, n, 2 * width):
            mid, hi = min(lo + width, n), min(lo + 2 * width, n)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if _before(keys, order[j], order[i]):
                    work[k] = order[j]
                    j += 1
                else:
                    work[k] = order[i]
                    i += 1
                k += 1
            while i < mid:
                work[k] = order[i]
                i += 1
                k += 1
            while j < hi:
                work[k] = order[j]
                j += 1
                k += 1
        order, work = work, order
        width *= 2
    return order


def lex_order(keys: NDArray[np.float64]) -> NDArray[np.int64]:
    """The stable lexicographic order of the columns of keys (R, N), the last row the primary key: indices (N,).

    ``np.lexsort(keys)``'s answer for float keys (a NaN after every number, NaNs and -0.0 and 0.0 equal to
    each other; ties in column order), by a merge sort without numpy's one pass per key.
    """
    out: NDArray[np.int64] = _lex_order(np.ascontiguousarray(keys, dtype=np.float64))
    return out
