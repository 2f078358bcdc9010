"""The paper's planner, ``method='lm'``: match P to v, nearest to a reference.

The paper's objective is f(x) = 1/2 sum_k (v_k - P_k(x))^2. With K zones and d = 10 features, P(x) = v is
K - 1 equations in 9 free unknowns, so exact matches form a manifold and "the minimiser of f" does not name
one grasp. The planner answers this problem:

1. **Reference.** x_ref is the warm start when one is given, else Algorithm 1's start: the demonstration of
   the top-v zone with the lowest f (v compared at 1e-9 and f at 1e-12 relative; ties go to the first zone
   and demonstration).
2. **Distance.** dist(x) = |(x - x_ref) / s|, with s the model's ``feature_scale`` (each feature's standard
   deviation over the demonstrations).
3. **Exact match.** When every v_k > 0, P(x) = v is written as the log-odds equations
   log(pi_k N_k(x)) - log(pi_r N_r(x)) = log(v_k / v_r), k != r (r the top-v zone); they are quadratic in
   x, so their gradients do not vanish in a Gaussian's tail. A start is projected onto them by
   minimum-distance Gauss-Newton steps (each the shortest step, in the scaled metric, that solves the
   linearised equations; damped, with bounds and body as an active set; class ``_LogOddsProjection``).
   From a start near the matches this ends at the nearest match, up to second order in the distance; from
   farther away, at the match this deterministic path reaches. The path is taken to the right-hand sides
   rounded to 1e-9 nats and its end point then projected onto the exact ones, so that the last bits of v
   cannot steer a long damped path (which amplifies any difference in its input).
4. **Search, nearest first.** The reference itself is projected first: when it reaches a match (and
   ``accept`` takes it), that is the answer. Otherwise the other starts are projected, and the matches
   found are chosen from (rule 6).
5. **Least squares.** When no start reaches an acceptable match (some v_k = 0, or v is outside what the
   model can attain in X), f is minimised from every start and every zone mean with a projected
   Levenberg-Marquardt iteration: 100 iterations each, then only the three unconverged with the lowest f go
   on, to 200 (the others stop there, labelled so). The two best end points by f go on with a projected
   trust-region Newton iteration on f's exact Hessian (which keeps the curvature of a nearly flat valley
   that the Levenberg-Marquardt steps leave out): 50 iterations each, then the better unconverged one to
   400; its end point replaces theirs where it converges. **Open fingers**: when the best end point has
   f > 1e-7 (no match) and the model has the MICO's finger features, the best screened start with one
   finger open (at its lower bound; one start per finger not already open) starts a last round: 50
   Levenberg-Marquardt iterations, then the same Newton polish of its two best. A finger's bounds split
   the least squares into separate local minima (finger open or closed) that the other origins, whose
   fingers sit near the demonstrations' closure, rarely reach. All selections rank f at 1e-12 relative,
   then by start order. Both iterations hold the bounds, the unit approach and the body as an active set:
   a palm on the body's surface whose objective would fall inside the body moves on the surface (steps on
   its tangent plane, then back onto it; Newton adds the surface's curvature times its multiplier to the
   Hessian). End points within 1e-8 of a match are projected onto the matches (kept, counted converged
   and labelled 'exact match (least squares, then projected)', where the projection converges). Where
   neither iteration converges in a nearly flat valley, the end point is where the damped iteration
   stopped: a deterministic function of the input whose last bits can move it along the valley in rare
   cases. Both iterations take their paths to v rounded to 1e-9, for rule 3's reason; f, the choice and
   the projection onto the matches use v exactly.
6. **Choice.** Let f* be the lowest f found. The candidates with f <= f* + max(1e-12, 1e-6 f*) are the
   matches; the planner returns the one nearest to x_ref, and among matches whose distances are within
   1e-6 of the nearest, the first in start order. Ties are never left to float noise. ``accept`` is asked
   about candidates in this order (then the others by f).
   **A stream keeps its branch.** With a warm start and no exact match (f* > 1e-12), the converged
   candidates whose residual |v - P| = sqrt(2 f) is within ``WARM_BAND`` = 3e-3 of the best one's are
   matches too, so the nearest of them to the previous plan is returned: where v asks what the model
   cannot quite give, local minima of f within a fraction of a percent of each other change rank from one
   step of the intent to the next, and without the band the grasp would alternate between them. A
   candidate stopped at an iteration limit is no branch to keep, so only converged ones join. A fresh plan
   has no band.

Starts, in order: x_ref; Algorithm 1's start (when x_ref is a warm start); the next best demonstrations of
the ``top_zones`` most likely zones (``n_starts`` demonstrations in all); then the zone means and
demonstrations nearest to P = v (screened by one vectorised evaluation over all of them); the least
squares add every zone mean, then the open-finger starts. With the previous plan as x_ref, a smoothly
moving intent moves the grasp smoothly while the previous match's branch still matches v; otherwise the
wider search runs and the grasp may jump.

Machine independence: nothing goes through BLAS or LAPACK (their kernels sum in an order chosen for the
CPU). The model's precisions, the screens' log joints and posteriors (``GraspModel.start_pool``) and every
iteration sum in a fixed order and take ``exp`` and ``log`` from the C library, so a plan has the same bits
under any BLAS. The compiled inner loops are :mod:`grasp_intent_ros.kernels`'.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..kernels import least_squares_rounds, project, screen
from ..method.features import FINGERS, MICO_3F
from ..method.model import GraspModel
from .common import MATCH_TOL, Candidate, Feasible, Search, c_log, exact, in_choice_order, unique_rows, zone_order

__all__ = ['search_starts', 'plan_lm']

_LM_MAXITER = 200
_LM_RACE = 100       # iterations every least-squares start gets; then only the _LM_KEEP best unconverged go on
_LM_KEEP = 3
_LM_RIDGE = 1e-7     # ridge of the least-squares steps, relative to the largest curvature
_LM_FTOL = 1e-7      # a start has converged when an accepted step improves f by less than this * f + 1e-15
_LS_QUANTUM = 1e-9    # v is rounded to this for the least squares' paths (class _LogOddsProjection's reason)
_NEWTON_POLISH = 2   # least-squares end points (the best by f) refined further with Newton's method
_NEWTON_MAXITER = 400
_NEWTON_RACE = 50    # Newton iterations each of those gets; then only the _NEWTON_KEEP best unconverged go on
_NEWTON_KEEP = 1
_NEWTON_STEPTOL = 1e-10
_GN_MAXITER = 60
_GN_DAMPING = 1e-3   # ridge of the minimum-norm steps, relative to the residual's norm
_GN_STALL = 12       # iterations in which a start must halve its log-odds residual to go on
_GN_HTOL = 1e-11     # log-odds residual (nats) below which the equations hold
_GN_STEPTOL = 1e-9   # scaled step below which a start has converged
_GN_QUANTUM = 1e-9   # log-odds targets (nats) are rounded to this for the path, then met exactly
_POLISH = 1e-8      # a least-squares end point this close to a match is projected onto the matches
_OPEN_F = 1e-7       # f of the least squares' best above which the open-finger round runs (rule 5)
_OPEN_LM = 50        # Levenberg-Marquardt iterations of the open-finger starts (rule 5)
_SCREEN = 6          # extra screened starts (demonstrations and zone means) for a fresh plan
_NO_LOGS = np.zeros(0)  # search_starts' screen by f
_NO_EQUATIONS = (np.zeros(0, dtype=np.int64), 0, np.zeros(0), np.zeros(0))  # P = v impossible: nothing to project onto


def search_starts(model: GraspModel, v: NDArray[np.float64], count: int = _SCREEN) -> NDArray[np.float64]:
    """The wider search's extra starts among the zone means and demonstrations, shape (count, d).

    One compiled pass screens them (``kernels.screen``): with every v_k > 0, by the spread of the log-odds
    residuals, max_k q_k - min_k q_k with q_k = log(pi_k N_k(x)) - log v_k (zero exactly where P = v);
    otherwise by f. The first ``count`` by the screen at 1e-12 relative, then in pool order.
    """
    pool = model.start_pool
    log_v = c_log(v) if float(v.min()) > 0.0 else _NO_LOGS
    out: NDArray[np.float64] = pool.x[screen(pool.log_joint_t, log_v, pool.posterior, v, count, MATCH_TOL)]
    return out


class _LogOddsProjection:
    """Minimum-distance Gauss-Newton projection of starts onto the exact matches (compiled: :mod:`.kernels`).

    The equations, in scaled coordinates y = x / s: the K - 1 log-odds equations, the unit approach,
    and (when the model has a body) the body clearance, active only when a step would cross it.
    Bounds are held by an active set. Each iteration takes the shortest step (in the scaled metric)
    that solves the linearised equations (rows of unit length, a ridge of 1e-14 + 1e-3 |e| so that
    nearly dependent rows cannot amplify last-bit differences), shortened to a trust radius until the
    1-norm of the log-odds residual falls. Near a solution the steps converge quadratically, to the
    match that is nearest to the start up to second order in the distance. A start has converged when
    the residual is below 1e-11 nats after a step of less than 1e-9 (scaled); it stops without a match
    when its residual has not halved in 12 iterations, or after 60.

    Why the paths are short and damped, and taken to targets rounded to 1e-9 nats: near a fold of the
    homotopy path the ridge turns the steps into ones that no longer lower the residual, and a long path
    amplifies a difference in its input at every iteration; with rounded targets both runs of a perturbed
    input see the same path, and the few local steps onto the exact targets that follow are contractions.
    The wider search finds the matches a short path misses. The measurements behind these choices are in
    docs/measurements.md ("The planner's log-odds projection").
    """

    def __init__(self, model: GraspModel, v: NDArray[np.float64], feas: Feasible) -> None:
        self.model, self.feas = model, feas
        self.r = int(zone_order(v)[0])
        self.others = np.delete(np.arange(len(model.zones), dtype=np.int64), self.r)
        self.b = c_log(v[self.others]) - math.log(v[self.r])
        self.b_path = np.rint(self.b / _GN_QUANTUM) * _GN_QUANTUM
        """The targets the long path is taken to: v's last bits cannot steer it (class docstring)."""
        self.equations = self.others, self.r, self.b_path, self.b
        """As ``kernels.least_squares_rounds`` takes them."""

    def run(self, starts: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
        """End points (N, d), whether each converged with the equations met, iterations per start.

        The path goes to the rounded targets; a start that meets them goes on to the exact ones (one or
        two steps from 1e-9 nats away, in the same compiled call).
        """
        model, feas = self.model, self.feas
        return project(starts, model.means, model.precisions, model.log_norm, self.others, self.r, self.b_path,
                       feas.scale, feas.lower, feas.upper, feas.a.start, feas.a.stop, feas.body,
                       maxiter=_GN_MAXITER, stall=_GN_STALL, damping=_GN_DAMPING, htol=_GN_HTOL,
                       steptol=_GN_STEPTOL, b_final=self.b)


def _least_squares(model: GraspModel, v: NDArray[np.float64], origins: NDArray[np.float64], feas: Feasible,
                   projection: _LogOddsProjection | None, screened: NDArray[np.float64],
                   ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], list[str],
                              NDArray[np.float64]]:
    """Rule 5 (module docstring): end points (N, d), converged, iterations, a label and the origin of each.

    Levenberg-Marquardt from every origin for ``_LM_RACE`` iterations, then the ``_LM_KEEP`` best
    unconverged on to ``_LM_MAXITER``; the ``_NEWTON_POLISH`` best end points go on with Newton
    (``_NEWTON_RACE`` iterations each, then the ``_NEWTON_KEEP`` best unconverged to ``_NEWTON_MAXITER``;
    kept where it converges). When the best of them has f above ``_OPEN_F`` (and the model's features
    include the MICO's fingers), ``screened`` (the best screened start) with each finger open starts a
    last round: Levenberg-Marquardt for ``_OPEN_LM`` iterations, then the same Newton polish; its rows and
    origins follow ``origins``'. End points within ``_POLISH`` of a match are projected onto the matches
    (with ``projection``, when P = v is possible; kept where that converges).
    """
    v_path = np.rint(v / _LS_QUANTUM) * _LS_QUANTUM
    mico_fingers = model.features.names[FINGERS] == MICO_3F.names[FINGERS]  # other feature spaces: no round
    equations = projection.equations if projection is not None else _NO_EQUATIONS
    xs, ok, its, ends, origins = least_squares_rounds(
        origins, v, v_path, model.means, model.precisions, model.log_norm, feas.lower, feas.upper, feas.scale,
        feas.a.start, feas.a.stop, feas.body, lm=(_LM_RACE, _LM_KEEP, _LM_MAXITER, _LM_FTOL, _LM_RIDGE),
        newton=(_NEWTON_POLISH, _NEWTON_RACE, _NEWTON_KEEP, _NEWTON_MAXITER, _NEWTON_STEPTOL), screened=screened,
        fingers=(FINGERS.start, FINGERS.stop) if mico_fingers else (0, 0), open_f=_OPEN_F, open_lm=_OPEN_LM,
        equations=equations, near_f=_POLISH, gn=(_GN_MAXITER, _GN_STALL, _GN_DAMPING, _GN_HTOL, _GN_STEPTOL),
        tol=MATCH_TOL)
    return xs, ok, its, _labels(ends, ok), origins


def _labels(ends: NDArray[np.int8], converged: NDArray[np.bool_]) -> list[str]:
    """The least squares' candidate messages from ``kernels.least_squares_rounds``' endings and convergence."""
    ended = ('least squares: iteration limit',
             f'least squares: left at {_LM_RACE} iterations, behind {_LM_KEEP} others',
             f'least squares: a finger opened, left at {_OPEN_LM} iterations, behind {_NEWTON_POLISH} others',
             'exact match (least squares, then projected)')
    return [ended[e] if e or not c else 'least squares: converged' for e, c in zip(ends.tolist(), converged.tolist())]


def _match_message(converged: bool) -> str:
    return 'exact match' if converged else 'projection stopped before matching v (stalled or iteration limit)'


def plan_lm(search: Search) -> Candidate | None:
    """Rules 3-5 (module docstring): the reference's projection, the wider search, then the least squares.

    Adds every candidate to ``search.found``; returns the exact match ``accept`` took, or None when the
    choice is left to :meth:`Search.result` (no exact match accepted: the least squares ran).
    """
    model, v_arr, feas, x_ref, band = search.model, search.v, search.feas, search.x_ref, search.band
    chosen: Candidate | None = None
    # P = v is impossible when some v_k = 0 (P_k > 0 everywhere): then there is nothing to project onto
    projection = _LogOddsProjection(model, v_arr, feas) if float(v_arr.min()) > 0.0 else None
    if projection is not None:
        xs, ok, its = projection.run(x_ref[None, :])  # the reference's own projection first
        search.found = search.candidates_from(xs, x_ref[None, :], ok, its, 0, lambda _, c: _match_message(c))
        chosen = search.choose(in_choice_order(exact(search.found), band))
    if chosen is None:  # the wider search (its first row is the reference again)
        screened = feas.project(search_starts(model, v_arr))
        wide = unique_rows(np.concatenate([search.all_starts(), screened]))
        if projection is not None and wide.shape[0] > 1:
            xs, ok, its = projection.run(wide[1:])
            search.found += search.candidates_from(xs, wide[1:], ok, its, 1, lambda _, c: _match_message(c))
            chosen = search.choose(in_choice_order(exact(search.found), band))
    if chosen is None:  # least squares from every start and every zone mean
        origins = unique_rows(np.concatenate([wide, feas.project(model.means)]))
        xs, ok, its, labels, origins = _least_squares(model, v_arr, origins, feas, projection, screened[0])
        search.found += search.candidates_from(xs, origins, ok, its, len(search.found), lambda i, _: labels[i])
    return chosen
