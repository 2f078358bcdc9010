"""A kernel vote over labelled points: the share of nearby points that carry a label, and its leave-one-out loss.

The vote at a query y over data points x_m (features scaled by 1 / h, diagonal) with 0/1 labels y_m is

    q(y) = (sum_m w_m y_m + 1/2) / (sum_m w_m + 1),   w_m = exp(-r_m / 2),   r_m = sum_f ((y_f - x_mf) / h_f)^2,

a Gaussian-kernel average shrunk toward 1/2 by one pseudo-point (so an empty neighbourhood votes 1/2). Points
with r_m > :data:`CUTOFF` (weight below exp(-25)) are left out; r_m is summed feature by feature, the
narrowest bandwidth first (ties in index order), and a point is dropped as soon as the partial sum passes the
cutoff. Every sum runs in a fixed order and ``exp`` and ``log`` come from the C library, so the result has
the same bits on any machine.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ['CUTOFF', 'vote', 'loo_loss']

CUTOFF = 50.0
"""Scaled squared distance beyond which a point does not vote."""


@njit(cache=True, nogil=True)
def _vote_one(y, data, labels, inv_h, skip, cutoff):
    n, f = data.shape
    num = 0.5
    den = 1.0
    for m in range(n):
        if m == skip:
            continue
        r = 0.0
        for k in range(f):
            t = (y[k] - data[m, k]) * inv_h[k]
            r += t * t
            if r > cutoff:
                break
        if r <= cutoff:
            w = math.exp(-0.5 * r)
            num += w * labels[m]
            den += w
    return num / den


@njit(cache=True, nogil=True)
def _vote(queries, skip, data, labels, inv_h, cutoff):
    out = np.empty(queries.shape[0])
    for i in range(queries.shape[0]):
        out[i] = _vote_one(queries[i], data, labels, inv_h, skip[i], cutoff)
    return out


@njit(cache=True, nogil=True)
def _loo_loss(data, labels, inv_h, cutoff):
    n = data.shape[0]
    total = 0.0
    for m in range(n):
        q = _vote_one(data[m], data, labels, inv_h, m, cutoff)
        total -= math.log(q) if labels[m] > 0.5 else math.log(1.0 - q)
    return total / n


def _narrowest_first(inv_h: NDArray[np.float64], *arrays: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """inv_h and the arrays' columns in the order the distance is summed: largest 1/h first, ties by index."""
    inv_h = np.asarray(inv_h, dtype=np.float64)
    order = np.argsort(-inv_h, kind='stable')
    return [np.ascontiguousarray(inv_h[order])] + [np.ascontiguousarray(np.asarray(a, dtype=np.float64)[:, order])
                                                   for a in arrays]


def vote(queries: NDArray[np.float64], skip: NDArray[np.int64], data: NDArray[np.float64],
         labels: NDArray[np.float64], inv_h: NDArray[np.float64]) -> NDArray[np.float64]:
    """Q (module docstring) at each query (Q, F) over ``data`` (N, F) with 0/1 ``labels`` (N,), scales 1/h (F,).

    Query i leaves data point ``skip[i]`` out (-1: none). Returns shape (Q,), values in (0, 1).
    """
    scales, q, x = _narrowest_first(inv_h, queries, data)
    out: NDArray[np.float64] = _vote(q, np.ascontiguousarray(skip, dtype=np.int64), x,
                                     np.ascontiguousarray(labels, dtype=np.float64), scales, CUTOFF)
    return out


def loo_loss(data: NDArray[np.float64], labels: NDArray[np.float64], inv_h: NDArray[np.float64]) -> float:
    """Mean leave-one-out log loss of the vote: -mean_m log q_-m(x_m) (or log(1 - q) for label 0), q without m."""
    scales, x = _narrowest_first(inv_h, data)
    return float(_loo_loss(x, np.ascontiguousarray(labels, dtype=np.float64), scales, CUTOFF))
