"""The planner's least squares (its rule 5, :mod:`grasp_intent_ros.planning.lm`) in one compiled call.

Levenberg-Marquardt races from every origin, Newton polishes the best end points, an open-finger round
runs when nothing matches, and end points near an exact match are projected onto it
(:func:`least_squares_rounds` states the schedule).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .geometry import _project_rows
from .least_squares import _least_squares, _newton_least_squares
from .posterior import _objectives
from .projection import _project_starts
from .selection import _first_ranked
from .types import Body, Mixture

__all__ = ['least_squares_rounds']


@njit(cache=True, nogil=True)
def _unconverged_first(xs, ok, v, mixture, count, tol):
    """The ``count`` rows of xs that have not converged (``ok`` False) with the lowest f, in rank-key order."""
    going = np.empty(ok.size, dtype=np.int64)
    m = 0
    for i in range(ok.size):
        if not ok[i]:
            going[m] = i
            m += 1
    going = going[:m]
    return going[_first_ranked(_objectives(xs[going], v, mixture), tol, count)]


@njit(cache=True, nogil=True)
def _newton_polish(xs, ok, its, left, v, mixture, lower, upper, scale, a0, a1, body, polish, race, keep, maxiter,
                   steptol, ridge_rel, tol):
    """Newton from the ``polish`` rows of xs with the lowest f, in place where it converges.

    ``race`` iterations each, then the ``keep`` best unconverged on to ``maxiter``; ``ok``, ``its`` and
    ``left`` (cleared where it converges) are updated too.
    """
    best = _first_ranked(_objectives(xs, v, mixture), tol, polish)
    xs_n, ok_n, its_n = _newton_least_squares(xs[best], v, mixture, lower, upper, scale, a0, a1, body, race,
                                              steptol, ridge_rel)
    ahead = _unconverged_first(xs_n, ok_n, v, mixture, keep, tol)
    if ahead.size:
        xs_a, ok_a, more = _newton_least_squares(xs_n[ahead], v, mixture, lower, upper, scale, a0, a1, body,
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
def _least_squares_rounds(origins, v, v_path, mixture, lower, upper, scale, a0, a1, body, lm, newton, screened,
                          finger_range, open_f, open_lm, equations, near_f, gn, tol):
    """The planner's least squares (:func:`least_squares_rounds`)."""
    lm_race, lm_keep, lm_maxiter, lm_ftol, ridge_rel = lm
    polish, newton_race, newton_keep, newton_maxiter, newton_steptol = newton
    f0, f1 = finger_range
    others, r, b_path, b = equations
    gn_maxiter, gn_stall, gn_damping, gn_htol, gn_steptol = gn
    d = origins.shape[1]
    xs, ok, its = _least_squares(origins, v_path, mixture, lower, upper, a0, a1, body, lm_race, lm_ftol, ridge_rel)
    left = _unless(ok, 1)  # 1: left behind the race's leaders
    ahead = _unconverged_first(xs, ok, v_path, mixture, lm_keep, tol)
    if ahead.size:
        xs_a, ok_a, more = _least_squares(xs[ahead], v_path, mixture, lower, upper, a0, a1, body,
                                          lm_maxiter - lm_race, lm_ftol, ridge_rel)
        for i in range(ahead.size):
            xs[ahead[i]] = xs_a[i]
            ok[ahead[i]] = ok_a[i]
            its[ahead[i]] += more[i]
            left[ahead[i]] = 0
    _newton_polish(xs, ok, its, left, v_path, mixture, lower, upper, scale, a0, a1, body, polish, newton_race,
                   newton_keep, newton_maxiter, newton_steptol, ridge_rel, tol)
    f = _objectives(xs, v_path, mixture)
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
        starts = _project_rows(opened, lower, upper, a0, a1, body)
        xs_o, ok_o, its_o = _least_squares(starts, v_path, mixture, lower, upper, a0, a1, body, open_lm, lm_ftol,
                                           ridge_rel)
        left_o = _unless(ok_o, 2)  # 2: an opened start left behind the polished ones
        _newton_polish(xs_o, ok_o, its_o, left_o, v_path, mixture, lower, upper, scale, a0, a1, body, polish,
                       newton_race, newton_keep, newton_maxiter, newton_steptol, ridge_rel, tol)
        xs, ok, its = np.concatenate((xs, xs_o)), np.concatenate((ok, ok_o)), np.concatenate((its, its_o))
        left, origins = np.concatenate((left, left_o)), np.concatenate((origins, starts))
    if others.size:  # P = v is possible: end points within near_f of a match are projected onto the matches
        f = _objectives(xs, v, mixture)
        near = np.empty(f.size, dtype=np.int64)
        m = 0
        for i in range(f.size):
            if f[i] <= near_f:
                near[m] = i
                m += 1
        near = near[:m]
        if m:
            xs_p, ok_p, its_p = _project_starts(xs[near], mixture, others, r, b_path, scale, lower, upper, a0, a1,
                                                body, gn_maxiter, gn_stall, gn_damping, gn_htol, gn_steptol, b)
            for i in range(m):
                if ok_p[i]:  # a converged projection is a converged answer
                    xs[near[i]] = xs_p[i]
                    ok[near[i]] = True
                    left[near[i]] = 3  # 3: projected onto the matches
                its[near[i]] += its_p[i]
    return xs, ok, its, left, origins


@njit(cache=True, nogil=True)
def _unless(ok, code):
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
    """The planner's least squares (rule 5 of :mod:`grasp_intent_ros.planning.lm`) in one compiled call.

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
        np.ascontiguousarray(origins, dtype=np.float64), v, v_path, Mixture(means, prec, log_norm), lower, upper,
        scale, a0, a1, Body(*body), lm, newton, screened, fingers, open_f, open_lm, equations, near_f, gn, tol)
    return out
