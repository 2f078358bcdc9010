"""The model's posterior P(k|x) over its K zones and the planner's objective, with their derivatives.

The model is K Gaussians over grasps x (d,), a :class:`~.types.Mixture`: ``means`` (K, d), precision
matrices ``prec`` (K, d, d) and ``log_norm`` (K,) = log(pi_k) + the Gaussian's log normaliser, so that
log(pi_k N_k(x)) = log_norm[k] - 1/2 (x - mu_k)^T Lambda_k (x - mu_k). P(k|x) is the softmax of those
log joints. The objective is f(x) = 1/2 |v - P(x)|^2 for a target vector v (K,), summed in zone order;
its gradient is -(v - P)^T dP/dx and its Hessian J^T J + sum_k (P_k - v_k) d2P_k.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .linalg import _gram
from .types import Mixture

__all__ = ['log_joints', 'score', 'fit_and_distance']


@njit(cache=True, nogil=True)
def _log_joint_score(x, mixture, lj, g, diff):
    """Fills lj (K,) with log(pi_k N_k(x)) and g (K, d) with its gradient -Sigma_k^-1 (x - mu_k); diff (d,) is work."""
    means, prec, log_norm = mixture
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
def _posterior_and_scores(x, mixture, p, g, diff):
    """Fills p (K,) with P(k|x) and g (K, d) with the gradients of log(pi_k N_k(x)); diff (d,) is work.

    :func:`_centre_scores` turns g into the gradients of log P(k|x), :func:`_scores_to_jacobian` into dP/dx.
    """
    _log_joint_score(x, mixture, p, g, diff)
    _normalise(p)


@njit(cache=True, nogil=True)
def _normalise(p):
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
def _log_joints(xs, mixture):
    means, prec, log_norm = mixture
    n = xs.shape[0]
    K, d = means.shape
    lj, post = np.empty((n, K)), np.empty((n, K))
    g, diff = np.empty((K, d)), np.empty(d)
    for s in range(n):
        _log_joint_score(xs[s], mixture, lj[s], g, diff)
        post[s] = lj[s]
        _normalise(post[s])
    return lj, post


def log_joints(xs: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
               log_norm: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """log(pi_k N_k(x)) and P(k|x) of every row of xs (N, d), each (N, K), with the iterations' own arithmetic.

    The fixed-order reference of :meth:`grasp_intent_ros.method.model.GraspModel.log_joint` and
    :meth:`~grasp_intent_ros.method.model.GraspModel.posterior` (numpy, BLAS): the same quantities, every
    sum in a stated order, so the planner's answers do not depend on the CPU's BLAS kernels. The two agree
    to rounding (test/unit/kernels/test_posterior.py).
    """
    lj: NDArray[np.float64]
    post: NDArray[np.float64]
    lj, post = _log_joints(np.ascontiguousarray(xs, dtype=np.float64), Mixture(means, prec, log_norm))
    return lj, post


@njit(cache=True, nogil=True)
def _centre_scores(p, u):
    """u_k <- u_k - sum_j P_j u_j (in place): the gradients of log(pi_k N_k) to those of log P(k|x)."""
    K, d = u.shape
    for i in range(d):
        mean = 0.0
        for k in range(K):
            mean += p[k] * u[k, i]
        for k in range(K):
            u[k, i] -= mean


@njit(cache=True, nogil=True)
def _posterior_jacobian(x, mixture, p, jac, diff):
    """Fills p (K,) with P(k|x) and jac (K, d) with dP/dx."""
    _posterior_and_scores(x, mixture, p, jac, diff)
    _scores_to_jacobian(p, jac)


@njit(cache=True, nogil=True)
def _scores_to_jacobian(p, jac):
    """Turns jac (K, d), the gradients of log(pi_k N_k(x)), into dP/dx in place (p = P(k|x))."""
    _centre_scores(p, jac)
    for k in range(p.size):
        for i in range(jac.shape[1]):
            jac[k, i] *= p[k]


@njit(cache=True, nogil=True)
def _posterior_hessian(x, mixture, v, p, u, jac, h, diff):
    """Fills p (K,) with P(k|x), jac (K, d) with dP/dx and h (d, d) with the Hessian of f = 1/2 |v - P|^2.

    u (K, d) and diff (d,) are work (u ends holding the gradients of log P(k|x)).
    """
    means, prec, log_norm = mixture
    _posterior_and_scores(x, mixture, p, u, diff)
    _scores_to_hessian(prec, v, p, u, jac, h)


@njit(cache=True, nogil=True)
def _scores_to_hessian(prec, v, p, u, jac, h):
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
def _half_square(v, p):
    """1/2 |v - p|^2, summed in zone order (every objective of the planner is summed so)."""
    acc = 0.0
    for k in range(v.size):
        acc += (v[k] - p[k]) ** 2
    return 0.5 * acc


@njit(cache=True, nogil=True)
def _objective(x, v, mixture, p, u, diff):
    """The objective 1/2 |v - P(x)|^2 (:func:`_half_square`); fills p (K,) with P(x) (u, diff: work)."""
    _posterior_and_scores(x, mixture, p, u, diff)
    return _half_square(v, p)


@njit(cache=True, nogil=True)
def _scaled_distance(x, x_ref, scale):
    """|(x - x_ref) / scale|, summed in feature order."""
    acc = 0.0
    for j in range(x.size):
        acc += ((x[j] - x_ref[j]) / scale[j]) ** 2
    return math.sqrt(acc)


@njit(cache=True, nogil=True)
def _score(xs, v, mixture, x_ref, scale):
    """Posterior (N, K), objective 1/2 |v - P|^2 (N,) and scaled distance to x_ref (N,) of every row."""
    means, prec, log_norm = mixture
    n, d = xs.shape
    K = means.shape[0]
    post = np.empty((n, K))
    f = np.empty(n)
    dist = np.empty(n)
    u, diff = np.empty((K, d)), np.empty(d)
    for s in range(n):
        f[s] = _objective(xs[s], v, mixture, post[s], u, diff)
        dist[s] = _scaled_distance(xs[s], x_ref, scale)
    return post, f, dist


def score(xs: NDArray[np.float64], v: NDArray[np.float64], means: NDArray[np.float64], prec: NDArray[np.float64],
          log_norm: NDArray[np.float64], x_ref: NDArray[np.float64], scale: NDArray[np.float64],
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Posterior (N, K), objective (N,) and scaled distance |(x - x_ref) / s| (N,) of every row of xs."""
    out: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] = _score(
        np.ascontiguousarray(xs, dtype=np.float64), v, Mixture(means, prec, log_norm), x_ref, scale)
    return out


@njit(cache=True, nogil=True)
def _fit_and_distance(post, v, xs, x_ref, scale):
    n = xs.shape[0]
    f = np.empty(n)
    dist = np.empty(n)
    for s in range(n):
        f[s] = _half_square(v, post[s])
        dist[s] = _scaled_distance(xs[s], x_ref, scale)
    return f, dist


def fit_and_distance(post: NDArray[np.float64], v: NDArray[np.float64], xs: NDArray[np.float64],
                     x_ref: NDArray[np.float64], scale: NDArray[np.float64],
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`score`'s objective (N,) and scaled distance (N,) of rows xs (N, d) whose posteriors post (N, K) are known.

    ``post`` must be the rows' posteriors as :func:`score` or :func:`log_joints` computes them (the same
    arithmetic); then both outputs have :func:`score`'s bits, without evaluating the N K Gaussians again.
    """
    out: tuple[NDArray[np.float64], NDArray[np.float64]] = _fit_and_distance(
        np.ascontiguousarray(post, dtype=np.float64), v, np.ascontiguousarray(xs, dtype=np.float64), x_ref, scale)
    return out


@njit(cache=True, nogil=True)
def _objectives(xs, v, mixture):
    """The objective 1/2 |v - P|^2 of every row of xs (N, d), as :func:`_score` computes it."""
    means, prec, log_norm = mixture
    n, d = xs.shape
    K = means.shape[0]
    f = np.empty(n)
    p, u, diff = np.empty(K), np.empty((K, d)), np.empty(d)
    for s in range(n):
        f[s] = _objective(xs[s], v, mixture, p, u, diff)
    return f
