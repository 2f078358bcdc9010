"""grasp_intent_ros.kernels.voting: the landed votes and the bandwidth search against their formulas in numpy."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from grasp_intent_ros.kernels.voting import CUTOFF, landed_votes, search_bandwidths

RTOL = 1e-12
"""Another summation order changes a vote's sums by a few ulps of terms in (0, 1]: far below this."""


def _votes(query: NDArray[np.float64], data: NDArray[np.float64], labels: NDArray[np.float64],
           h: NDArray[np.float64], skip: int) -> NDArray[np.float64]:
    """The module docstring's q at one query, point ``skip`` left out, for each label column: shape (C,)."""
    r = (((query[None, None, :] - data[None, :, :]) / h[:, None, :]) ** 2).sum(axis=2)  # (C, N)
    w = np.where(r <= CUTOFF, np.exp(-0.5 * r), 0.0)
    w[:, skip] = 0.0
    out: NDArray[np.float64] = ((w * labels.T).sum(axis=1) + 0.5) / (w.sum(axis=1) + 1.0)
    return out


def _loo(data: NDArray[np.float64], labels: NDArray[np.float64], h: NDArray[np.float64]) -> float:
    q = np.array([_votes(data[m], data, labels[:, None], h[None, :], m)[0] for m in range(len(data))])
    return float(-np.where(labels > 0.5, np.log(q), np.log(1.0 - q)).sum())


def _data(seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points in the unit square plus a noise feature; label 1 left of x = 0.5, a few flipped."""
    rng = np.random.default_rng(seed)
    data = rng.uniform(size=(60, 3))
    labels = (data[:, 0] < 0.5).astype(np.float64)
    labels[rng.choice(60, 5, replace=False)] = 1.0 - labels[:5]
    return data, labels


def test_landed_votes_are_the_mean_vote_over_each_points_landings() -> None:
    data, labels = _data(0)
    columns = np.stack([labels, 1.0 - labels], axis=1)
    h = np.array([[0.1, 0.2, 0.05], [0.3, 0.1, 1.0]])
    draws = 4
    landed = np.repeat(data, draws, axis=0) + np.random.default_rng(1).normal(0.0, 0.05, (60 * draws, 3))
    got = landed_votes(data, columns, h, landed, draws)
    expected = np.array([np.mean([_votes(landed[n * draws + d], data, columns, h, n) for d in range(draws)], axis=0)
                         for n in range(60)])
    np.testing.assert_allclose(got, expected, rtol=RTOL)


def test_the_search_takes_the_steps_a_direct_search_takes() -> None:
    data, labels = _data(2)
    base = np.array([0.05, 0.05, 0.05])
    start, lowest, highest, sweeps, rtol = 1, -1, 5, 2, 1e-9
    power = np.full(3, start)
    best = _loo(data, labels, base * 2.0 ** power)
    for _ in range(sweeps):  # the coordinate search as search_bandwidths states it, every loss from scratch
        for f in range(3):
            for step in (1, -1):
                moved = False
                while lowest <= power[f] + step <= highest:
                    trial = power.copy()
                    trial[f] += step
                    loss = _loo(data, labels, base * 2.0 ** trial)
                    if not loss < best * (1.0 - rtol):
                        break
                    power, best, moved = trial, loss, True
                if moved:
                    break
    got = search_bandwidths(data, labels, base, start, lowest, highest, sweeps, rtol)
    np.testing.assert_array_equal(got, power)
    assert power[2] > power[0]  # the feature that says nothing of the label is voted over widely
