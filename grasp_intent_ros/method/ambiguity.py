"""Model ambiguity (paper eqs. 5-8, Table V): KL divergence between principal-task Gaussians.

Task i's Gaussian is fitted to every training demonstration that satisfies task i (stored in the model
as ``task_means`` / ``task_covariances``). KL(P||Q) is small when Q predicts P well: a small entry means
the two tasks are ambiguous (their grasps overlap), a large one that they are well separated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from .model import GraspModel

__all__ = ['AmbiguityReport', 'kl_gaussian', 'kl_matrix', 'symmetric_kl', 'pinsker_bounds', 'report']


def kl_gaussian(mean_p: ArrayLike, cov_p: ArrayLike, mean_q: ArrayLike, cov_q: ArrayLike) -> float:
    """KL(P||Q) between two multivariate normals (eq. 5), in nats.

    KL = 1/2 [tr(Sq^-1 Sp) + (mq - mp)^T Sq^-1 (mq - mp) - d + ln(|Sq| / |Sp|)]

    Parameters
    ----------
    mean_p, mean_q : array_like, shape (d,)
    cov_p, cov_q : array_like, shape (d, d), symmetric positive definite

    Raises
    ------
    ModelError
        For mismatched shapes or a covariance that is not positive definite.
    """
    mp, mq = np.asarray(mean_p, dtype=np.float64), np.asarray(mean_q, dtype=np.float64)
    sp, sq = np.asarray(cov_p, dtype=np.float64), np.asarray(cov_q, dtype=np.float64)
    d = mp.size
    if mp.shape != (d,) or mq.shape != (d,) or sp.shape != (d, d) or sq.shape != (d, d):
        raise ModelError(f'shape mismatch: means {mp.shape}, {mq.shape}; covariances {sp.shape}, {sq.shape}')
    try:
        lp, lq = np.linalg.cholesky(sp), np.linalg.cholesky(sq)
    except np.linalg.LinAlgError:
        raise ModelError('covariances must be positive definite') from None
    lq_inv_lp = np.linalg.solve(lq, lp)
    trace = float(np.sum(lq_inv_lp ** 2))
    y = np.linalg.solve(lq, mq - mp)
    maha = float(y @ y)
    log_det_ratio = 2.0 * float(np.sum(np.log(np.diag(lq))) - np.sum(np.log(np.diag(lp))))
    return 0.5 * (trace + maha - d + log_det_ratio)


def kl_matrix(model: GraspModel) -> NDArray[np.float64]:
    """Nonsymmetric KL matrix (eq. 6), shape (m, m): entry [i, j] = KL(task_i || task_j), zero diagonal.

    Row i takes task i as the true population, column j task j as the inference.
    """
    m = len(model.task_names)
    out = np.zeros((m, m))
    for i in range(m):
        for j in range(m):
            if i != j:
                out[i, j] = kl_gaussian(model.task_means[i], model.task_covariances[i],
                                        model.task_means[j], model.task_covariances[j])
    return out


def symmetric_kl(kl: ArrayLike) -> NDArray[np.float64]:
    """Symmetric divergence matrix (eq. 8): KL + KL^T."""
    arr = np.asarray(kl, dtype=np.float64)
    return arr + arr.T


def pinsker_bounds(kl: ArrayLike) -> NDArray[np.float64]:
    """Pinsker upper bounds on the total-variation distance (eq. 7): sqrt(KL / 2), capped at 1."""
    return np.minimum(np.sqrt(0.5 * np.asarray(kl, dtype=np.float64)), 1.0)


@dataclass(frozen=True)
class AmbiguityReport:
    """All ambiguity figures of one model. Matrices have shape (m, m); eigenvalues shape (m,)."""

    task_names: tuple[str, ...]
    kl: NDArray[np.float64]
    symmetric: NDArray[np.float64]
    pinsker: NDArray[np.float64]
    eigenvalues: NDArray[np.complex128]
    symmetric_eigenvalues: NDArray[np.float64]


def report(model: GraspModel) -> AmbiguityReport:
    """KL matrix, symmetric matrix, Pinsker bounds and eigenvalues (largest magnitude first)."""
    kl = kl_matrix(model)
    sym = symmetric_kl(kl)
    eig = np.linalg.eigvals(kl)
    eig = eig[np.argsort(-np.abs(eig), kind='stable')]
    sym_eig = np.sort(np.linalg.eigvalsh(sym))[::-1]
    return AmbiguityReport(task_names=model.task_names, kl=kl, symmetric=sym, pinsker=pinsker_bounds(kl),
                           eigenvalues=eig.astype(np.complex128), symmetric_eigenvalues=sym_eig)
