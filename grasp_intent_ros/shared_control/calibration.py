r"""Calibration of task marginals: a monotone logistic map of w, and its fit to labelled estimates.

The map (Platt scaling, applied to each task's marginal alike) is

.. math::

    w_i' = \sigma(a \operatorname{logit}(w_i) + b), \qquad \sigma(z) = 1 / (1 + e^{-z}),

with ``w_i`` first clipped to ``[floor, 1 - floor]`` (so the logit is finite) and ``w_i'`` clipped to it
again. ``a > 0`` keeps the order of the estimates (``a > 1`` spreads them away from 1/2, ``a < 1`` draws them
in), ``b`` shifts them; ``a = 1, b = 0`` is no map (w clipped, exactly).

The fit (:func:`fit_calibration`) takes estimates w of many (episode, task) pairs with the truth y (1 when the
task is in the episode's true set, else 0) and returns the ``(a, b)`` that minimises the mean binary
cross-entropy (log loss) of the map's output before the second clip,

.. math::

    J(a, b) = -\frac{1}{n} \sum_k y_k \log w_k' + (1 - y_k) \log (1 - w_k')
              + \lambda ((a - 1)^2 + b^2), \qquad \lambda = 10^{-6},

a logistic regression of y on ``logit(w)``. The small ridge toward the identity makes ``J`` strictly convex, so
the minimiser is unique (no tie to break) and exists even for separable data. Solved by Newton's method with
step halving from the identity, to a step below 1e-10 (at most 100 iterations).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError

__all__ = ['calibrate', 'fit_calibration', 'model_calibration', 'RIDGE']

RIDGE = 1e-6
"""lambda: the ridge of the fit toward the identity map."""


def _logit(w: NDArray[np.float64], floor: float) -> NDArray[np.float64]:
    p = np.clip(w, floor, 1.0 - floor)
    out: NDArray[np.float64] = np.log(p) - np.log1p(-p)
    return out


def _sigmoid(z: NDArray[np.float64]) -> NDArray[np.float64]:
    out: NDArray[np.float64] = 0.5 * (1.0 + np.tanh(0.5 * z))  # no overflow for any finite z
    return out


def calibrate(w: ArrayLike, slope: float, offset: float, floor: float) -> NDArray[np.float64]:
    """The map ``clip(sigmoid(slope * logit(clip(w)) + offset))`` of each element (module docstring).

    Parameters
    ----------
    w : array_like of float, any shape
        Probabilities; values outside ``[floor, 1 - floor]`` (and infinities) are clipped first.
    slope : float
        a, finite and > 0.
    offset : float
        b, finite.
    floor : float
        In (0, 0.5): the output lies in ``[floor, 1 - floor]``.

    Returns
    -------
    ndarray, the shape of ``w``: finite, in ``[floor, 1 - floor]``, non-decreasing in ``w``.

    Raises
    ------
    InvalidIntentError
        For a NaN in ``w`` or parameters out of their ranges.
    """
    if not (np.isfinite(slope) and slope > 0.0 and np.isfinite(offset) and 0.0 < floor < 0.5):
        raise InvalidIntentError(f'calibration needs a finite slope > 0, a finite offset and a floor in (0, 0.5), '
                                 f'got {slope!r}, {offset!r}, {floor!r}')
    p = np.asarray(w, dtype=np.float64)
    if np.isnan(p).any():
        raise InvalidIntentError('calibration of a NaN probability')
    mapped = p if slope == 1.0 and offset == 0.0 else _sigmoid(slope * _logit(p, floor) + offset)  # (1, 0): no map
    out: NDArray[np.float64] = np.clip(mapped, floor, 1.0 - floor)
    return out


def fit_calibration(w: ArrayLike, truth: ArrayLike, floor: float) -> tuple[float, float]:
    """The ``(slope, offset)`` minimising the ridged mean log loss of :func:`calibrate` on ``(w, truth)``.

    Parameters
    ----------
    w : array_like of float, shape (n,) or any shape
        Estimated probabilities (clipped to ``[floor, 1 - floor]`` as :func:`calibrate` does), finite.
    truth : array_like, the shape of ``w``
        1 where the event happened, 0 where not.
    floor : float
        As :func:`calibrate`'s.

    Returns
    -------
    (slope, offset) : the unique minimiser of J (module docstring); slope > 0 unless the estimates order the
    truth backwards (then the fit's slope is negative and this raises, as such a map would reverse w).

    Raises
    ------
    InvalidIntentError
        For empty or mismatched inputs, non-finite w, truth other than 0 / 1, a floor outside (0, 0.5), a fit
        that does not converge, or a slope <= 0.
    """
    p = np.asarray(w, dtype=np.float64).ravel()
    y = np.asarray(truth, dtype=np.float64).ravel()
    if p.size == 0 or p.shape != y.shape or not np.isfinite(p).all() or not np.isin(y, (0.0, 1.0)).all():
        raise InvalidIntentError(f'calibration fit needs finite w and 0/1 truth of one non-empty shape, got '
                                 f'{np.shape(w)} and {np.shape(truth)}')
    if not 0.0 < floor < 0.5:
        raise InvalidIntentError(f'floor must lie in (0, 0.5), got {floor!r}')
    x = np.stack([_logit(p, floor), np.ones_like(p)], axis=1)
    identity = np.array([1.0, 0.0])

    def loss(theta: NDArray[np.float64]) -> float:
        z = x @ theta
        # log(1 + e^z) - y z, stably
        return float(np.mean(np.logaddexp(0.0, z) - y * z) + RIDGE * np.sum((theta - identity) ** 2))

    theta = identity.copy()
    current = loss(theta)
    for _ in range(100):
        q = _sigmoid(x @ theta)
        grad = x.T @ (q - y) / p.size + 2.0 * RIDGE * (theta - identity)
        hess = (x.T * (q * (1.0 - q))) @ x / p.size + 2.0 * RIDGE * np.eye(2)
        step = np.linalg.solve(hess, grad)
        scale = 1.0
        while scale > 1e-12 and loss(theta - scale * step) > current:
            scale *= 0.5
        theta = theta - scale * step
        current = loss(theta)
        if float(np.max(np.abs(scale * step))) < 1e-10:
            break
    else:
        raise InvalidIntentError('calibration fit did not converge in 100 Newton steps')
    if not theta[0] > 0.0:
        raise InvalidIntentError(f'calibration fit reverses the estimates (slope {theta[0]:.3g})')
    return float(theta[0]), float(theta[1])


def model_calibration(model_name: str | None, models: Sequence[str], slopes: Sequence[float],
                      offsets: Sequence[float]) -> tuple[float, float]:
    """The (slope, offset) listed for ``model_name`` (``models[k]`` -> ``slopes[k]``, ``offsets[k]``); (1, 0) if not.

    Raises InvalidIntentError when the three lists differ in length, a model is listed twice, or a listed map is
    invalid (a slope <= 0, a non-finite value).
    """
    if not len(models) == len(slopes) == len(offsets):
        raise InvalidIntentError(f'calibration: {len(models)} models, {len(slopes)} slopes and {len(offsets)} '
                                 'offsets (one of each per model)')
    if len(set(models)) != len(models):
        raise InvalidIntentError(f'calibration: a model is listed twice in {list(models)}')
    for name, slope, offset in zip(models, slopes, offsets):
        if not (np.isfinite(slope) and slope > 0.0 and np.isfinite(offset)):
            raise InvalidIntentError(f'calibration of {name!r}: slope {slope!r} must be finite and > 0, offset '
                                     f'{offset!r} finite')
    for name, slope, offset in zip(models, slopes, offsets):
        if name == model_name:
            return float(slope), float(offset)
    return 1.0, 0.0

