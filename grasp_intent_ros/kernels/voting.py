"""A kernel vote over labelled points: the share of nearby points that carry a label, and its bandwidth search.

The vote at a query y over data points x_m (features scaled by 1 / h, diagonal) with 0/1 labels l_m is

    q(y) = (sum_m w_m l_m + 1/2) / (sum_m w_m + 1),   w_m = exp(-r_m / 2),   r_m = sum_f (y_f - x_mf)^2 s_f,

s_f = 1 / h_f^2: a Gaussian-kernel average shrunk toward 1/2 by one pseudo-point (so an empty neighbourhood
votes 1/2). Points with r_m > :data:`CUTOFF` (weight below exp(-25)) are left out. Every sum runs in a fixed
order (features, then points, in index order) and ``exp`` and ``log`` come from the C library, so the results
have the same bits on any machine.

- :func:`search_bandwidths`: the powers p (h_f = base_f 2^p_f) that minimise the leave-one-out log loss
  sum_m -log q_-m(x_m) (log(1 - q) for label 0), by the coordinate search its docstring states. The pairwise
  scaled distances are kept (N x N) and a trial moves only one feature's term, so a trial costs N^2 / 2
  weights (they are symmetric), not N^2 F; a trial stops summing once its loss can no longer beat the best
  (every term is positive).
- :func:`landed_votes`: per data point n, the mean over its landings of the votes of several label columns,
  each with its own bandwidths, n left out of its own vote.
- :func:`landed_thresholds`: per data point n, the mean over its landings of a product of soft one-feature
  thresholds per column (the conjunction the robustness estimate learns, :mod:`grasp_intent_ros.planning.robustness`).
  Condition c (feature f_c, inner edge a_c, outer edge b_c != a_c) holds at y with degree
  clip((b_c - y_f) / (b_c - a_c), 0, 1): 1 on the inner side of a_c, 0 beyond b_c, linear between (the
  threshold taken uniform between the two edges).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ['CUTOFF', 'search_bandwidths', 'landed_votes', 'landed_thresholds']

CUTOFF = 50.0
"""Scaled squared distance beyond which a point does not vote."""


@njit(cache=True, nogil=True)
def _pairwise(data, s):
    n, f = data.shape
    r = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            acc = 0.0
            for k in range(f):
                t = data[i, k] - data[j, k]
                acc += (t * t) * s[k]
            r[i, j] = acc
            r[j, i] = acc
    return r


@njit(cache=True, nogil=True)
def _loss(r, column, delta, labels, limit, cutoff, num, den):
    """Leave-one-out loss (a sum) with r + delta (x_f - x_f')^2 for the feature column; inf once >= limit.

    ``num`` and ``den`` (N,) are scratch. A pair's weight is computed once, by row min(m, j), and added to
    both rows, so that row m holds its sums over j < m before its own turn, each in increasing j.
    """
    n = r.shape[0]
    for m in range(n):
        num[m] = 0.5
        den[m] = 1.0
    total = 0.0
    for m in range(n):
        a = num[m]
        b = den[m]
        for j in range(m + 1, n):
            t = column[m] - column[j]
            rr = r[m, j] + (t * t) * delta
            if rr <= cutoff:
                w = math.exp(-0.5 * rr)
                a += w * labels[j]
                b += w
                num[j] += w * labels[m]
                den[j] += w
        q = a / b
        total -= math.log(q) if labels[m] > 0.5 else math.log(1.0 - q)
        if total >= limit:
            return math.inf
    return total


@njit(cache=True, nogil=True)
def _move(r, column, delta):
    n = r.shape[0]
    for m in range(n):
        for j in range(n):
            t = column[m] - column[j]
            r[m, j] += (t * t) * delta


@njit(cache=True, nogil=True)
def _search(data, labels, base, start, lowest, highest, sweeps, rtol, cutoff):
    f = base.size
    power = np.full(f, start)
    s = np.empty(f)
    for k in range(f):
        h = base[k] * 2.0 ** power[k]
        s[k] = 1.0 / (h * h)
    r = _pairwise(data, s)
    num = np.empty(data.shape[0])
    den = np.empty(data.shape[0])
    best = _loss(r, data[:, 0].copy(), 0.0, labels, math.inf, cutoff, num, den)
    for _ in range(sweeps):
        for k in range(f):
            column = data[:, k].copy()
            for step in (1, -1):  # widen while it helps, else narrow while it helps
                moved = False
                while lowest <= power[k] + step <= highest:
                    h = base[k] * 2.0 ** (power[k] + step)
                    delta = 1.0 / (h * h) - s[k]
                    limit = best * (1.0 - rtol)
                    loss = _loss(r, column, delta, labels, limit, cutoff, num, den)
                    if not loss < limit:
                        break
                    _move(r, column, delta)
                    s[k] += delta
                    power[k] += step
                    best = loss
                    moved = True
                if moved:
                    break
    return power


@njit(cache=True, nogil=True)
def _landed(data, labels, s, landed, draws, cutoff):
    n, f = data.shape
    c = labels.shape[1]
    s_min = np.empty(f)
    for k in range(f):
        s_min[k] = s[0, k]
        for j in range(1, c):
            s_min[k] = min(s_min[k], s[j, k])
    out = np.zeros((n, c))
    d2 = np.empty(f)
    num = np.empty(c)
    den = np.empty(c)
    for i in range(n):
        for d in range(draws):
            y = landed[i * draws + d]
            for j in range(c):
                num[j] = 0.5
                den[j] = 1.0
            for m in range(n):
                if m == i:
                    continue
                low = 0.0  # the smallest r of any column: a point beyond the cutoff for it votes in none
                for k in range(f):
                    t = y[k] - data[m, k]
                    d2[k] = t * t
                    low += d2[k] * s_min[k]
                if low > cutoff:
                    continue
                for j in range(c):
                    rr = 0.0
                    for k in range(f):
                        rr += d2[k] * s[j, k]
                    if rr <= cutoff:
                        w = math.exp(-0.5 * rr)
                        num[j] += w * labels[m, j]
                        den[j] += w
            for j in range(c):
                out[i, j] += num[j] / den[j]
    for i in range(n):
        for j in range(c):
            out[i, j] /= draws
    return out


@njit(cache=True, nogil=True)
def _thresholds(landed, feature, inner, outer, starts, draws):
    rows = landed.shape[0] // draws
    c = starts.size - 1
    out = np.zeros((rows, c))
    for i in range(rows):
        for d in range(draws):
            y = landed[i * draws + d]
            for j in range(c):
                degree = 1.0
                for k in range(starts[j], starts[j + 1]):
                    t = (outer[k] - y[feature[k]]) / (outer[k] - inner[k])
                    degree *= min(max(t, 0.0), 1.0)
                out[i, j] += degree
    for i in range(rows):
        for j in range(c):
            out[i, j] /= draws
    return out


def search_bandwidths(data: NDArray[np.float64], labels: NDArray[np.float64], base: NDArray[np.float64],
                      start: int, lowest: int, highest: int, sweeps: int, rtol: float) -> NDArray[np.int64]:
    """Powers p (F,) of h_f = base_f 2^p_f minimising the leave-one-out log loss of the vote of ``labels``.

    ``data`` (N, F), 0/1 ``labels`` (N,), ``base`` (F,) > 0. From p = ``start`` for every feature, ``sweeps``
    sweeps over the features in index order: p_f goes up by one while the loss drops below (1 - ``rtol``) times
    the best so far, else down by one while it does, within [``lowest``, ``highest``]. Losses are compared only
    beyond that tolerance, so float noise never decides a step. Memory: N^2 floats.
    """
    out: NDArray[np.int64] = _search(np.ascontiguousarray(data, dtype=np.float64),
                                     np.ascontiguousarray(labels, dtype=np.float64),
                                     np.ascontiguousarray(base, dtype=np.float64), start, lowest, highest, sweeps,
                                     rtol, CUTOFF)
    return out


def landed_votes(data: NDArray[np.float64], labels: NDArray[np.float64], h: NDArray[np.float64],
                 landed: NDArray[np.float64], draws: int) -> NDArray[np.float64]:
    """Mean vote of each label column at the landings of each data point, the point left out: shape (N, C).

    ``data`` (N, F); 0/1 ``labels`` (N, C); ``h`` (C, F) > 0, column j's bandwidths; ``landed`` (N * draws, F),
    rows n * draws to (n + 1) * draws - 1 the landings of point n. The mean sums landing by landing.
    """
    h = np.asarray(h, dtype=np.float64)
    out: NDArray[np.float64] = _landed(np.ascontiguousarray(data, dtype=np.float64),
                                       np.ascontiguousarray(labels, dtype=np.float64),
                                       np.ascontiguousarray(1.0 / (h * h)), np.ascontiguousarray(landed,
                                                                                                 dtype=np.float64),
                                       draws, CUTOFF)
    return out


def landed_thresholds(landed: NDArray[np.float64], feature: NDArray[np.int64], inner: NDArray[np.float64],
                      outer: NDArray[np.float64], starts: NDArray[np.int64], draws: int) -> NDArray[np.float64]:
    """Mean over each point's landings of the product of its columns' soft thresholds: shape (M, C).

    ``landed`` (M * draws, F), rows m * draws to (m + 1) * draws - 1 the landings of point m; the conditions
    of column j are ``starts[j]`` to ``starts[j + 1] - 1`` of ``feature``, ``inner``, ``outer`` (module
    docstring; ``inner != outer``), ``starts`` (C + 1,) non-decreasing from 0. A column without conditions
    is 1. The product runs in condition order and the mean sums landing by landing.
    """
    out: NDArray[np.float64] = _thresholds(np.ascontiguousarray(landed, dtype=np.float64),
                                           np.ascontiguousarray(feature, dtype=np.int64),
                                           np.ascontiguousarray(inner, dtype=np.float64),
                                           np.ascontiguousarray(outer, dtype=np.float64),
                                           np.ascontiguousarray(starts, dtype=np.int64), draws)
    return out
