"""Grasp planning under intent uncertainty: a grasp for a target vector v over a model's zones.

Two methods answer two stated problems (docs/planner.md puts them side by side with the figures that
decided the default). Both take a model and v (K entries, a probability vector over the model's zones,
e.g. :func:`grasp_intent_ros.method.intent.interpret`), optionally a warm start (the previous plan of a
stream) and an ``accept`` hook (e.g. IK reachability, asked about candidates in the choice order; the
first it takes is returned, status 'rejected' when it takes none). The feasible set X is

    lower <= x <= upper,   |approach(x)| = 1,   distance(palm(x), body) >= margin

(the last only when the model carries the object's body, see :mod:`grasp_intent_ros.method.body`).

**method='task' (the default): serve the likely tasks.** The answer is the labelled demonstration, in X,
that serves v's top zone, does (by its label) and is read by the model (argmax_k P(k|x)) as doing only
likely tasks (the top zone's, and tasks whose probability, read from v, is at least ``tau``), and has the
highest expected task success under v (v's mass on the zones its task set contains); ties go to the paper's
fit 1/2 |v - P|^2, then to the reference, then to demonstration order. A warm start keeps its demonstration
while it stays within stated bands of the best expected success and fit, and tasks it is read as doing stay
likely down to ``tau - hysteresis``. The rules and reasons are :mod:`grasp_intent_ros.planning.ranking`'s.
P(x) does not match v in general: the price in fit is the benchmarks' to report.

**method='lm' (the paper's planner): match P to v.** The paper's objective is
f(x) = 1/2 sum_k (v_k - P_k(x))^2. With K zones and d = 10 features, P(x) = v is K - 1 equations in 9 free
unknowns, so exact matches form a manifold and "the minimiser of f" does not name one grasp. The planner
answers this problem:

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

The paper's solvers stay available too: ``method='slsqp'`` (SQP) and ``'trust-constr'`` (interior point)
minimise f from the demonstration starts (scipy), with rule 6's choice.

Machine independence (every method): nothing goes through BLAS or LAPACK (their kernels sum in an order
chosen for the CPU). The model's precisions, the screens' log joints and posteriors
(``GraspModel.start_pool``), the demonstrations' scores and every iteration sum in a fixed order and take
``exp`` and ``log`` from the C library, so a plan has the same bits under any BLAS.

One module: :func:`plan` and the rules above are one contract over its methods; the compiled inner loops
are :mod:`grasp_intent_ros.kernels`', the task method's ranking :mod:`grasp_intent_ros.planning.ranking`'s.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PlanningError
from ..kernels import (
    choice_order,
    distinct,
    feasible,
    least_squares_rounds,
    project,
    score,
    screen,
    select_demonstrations,
)
from ..method.features import FINGERS, MICO_3F, PALM
from ..method.intent import reconstruct_w, zone_label
from ..method.model import GraspModel
from .ranking import HYSTERESIS, TAU, Faithful, rank

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult  # type: ignore[import-untyped]

__all__ = [
    'Candidate',
    'PlanResult',
    'Method',
    'METHODS',
    'DEFAULT_METHOD',
    'Gradient',
    'MATCH_TOL',
    'DISTANCE_TOL',
    'WARM_BAND',
    'objective',
    'objective_and_gradient',
    'zone_order',
    'select_starts',
    'search_starts',
    'plan',
    'reference_search',
]

Method = Literal['task', 'lm', 'slsqp', 'trust-constr']
METHODS: tuple[Method, ...] = get_args(Method)
"""Every :data:`Method`, in order."""
DEFAULT_METHOD: Method = 'task'
"""The method :func:`plan` uses unless told otherwise (the planner node's default too)."""
Gradient = Literal['analytic', '2-point']

MATCH_TOL = 1e-12
"""f within this of the best found (or 1e-6 relative, whichever is larger) counts as a match."""
F_RTOL = 1e-6
DISTANCE_TOL = 1e-6
"""Scaled distances to the reference within this of the nearest are a tie, broken by start order."""
WARM_BAND = 3e-3
"""With a warm start and no exact match, converged candidates whose residual |v - P| is within this of the
best one's tie with it (rule 6): a fifth of what v moves in a typical step of the benchmark's walk."""

_FTOL = 1e-10
_MAXITER = 200
_TC_MAXITER = 1500
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
_TASK_CANDIDATES = 32  # method 'task': the best demonstrations offered to ``accept``, in the choice order
_NO_LOGS = np.zeros(0)  # search_starts' screen by f
_NO_EQUATIONS = (np.zeros(0, dtype=np.int64), 0, np.zeros(0), np.zeros(0))  # P = v impossible: nothing to project onto


class Candidate(NamedTuple):
    """One refined start (immutable; a named tuple, as a plan makes some 30 of them: 0.4 us each, 1.5 as a dataclass).

    Attributes
    ----------
    x : ndarray, shape (d,)
    posterior : ndarray, shape (K,)
    objective : float
        f(x) = 1/2 |v - P(x)|^2.
    distance : float
        Scaled distance |(x - x_ref) / s| to the plan's reference.
    start : ndarray, shape (d,)
        Where the refinement began.
    start_objective : float
    start_index : int
        Position of the start in the plan's start order (ties are broken by it).
    success : bool
        The refinement converged (a KKT point or a stationary point of f), not stopped by its
        iteration limit.
    message : str
    iterations : int
    """

    x: NDArray[np.float64]
    posterior: NDArray[np.float64]
    objective: float
    distance: float
    start: NDArray[np.float64]
    start_objective: float
    start_index: int
    success: bool
    message: str
    iterations: int


@dataclass(frozen=True)
class PlanResult:
    """Outcome of :func:`plan`: the chosen candidate and what led to it.

    Attributes
    ----------
    chosen : Candidate
        The answer (see the module docstring); ``x``, ``posterior`` and ``objective`` are its.
    w : ndarray, shape (m,)
        Principal-task probabilities reconstructed from the posterior.
    exact : bool
        The objective is at most :data:`MATCH_TOL`: P matches v.
    reference : ndarray, shape (d,)
        x_ref, the grasp the answer is nearest to.
    status : str
        'ok' (the chosen candidate's refinement converged), 'solver_failed' (it stopped before
        converging) or 'rejected' (no candidate passed ``accept``; x is then the first ranked).
    message : str
    iterations : int
        Solver iterations summed over all starts.
    wall_time_s : float
    method : str
    candidates : tuple of Candidate
        Every distinct refined start, in the choice order.
    rejected : int
        How many candidates ``accept`` turned down before the chosen one.
    """

    chosen: Candidate
    w: NDArray[np.float64]
    exact: bool
    reference: NDArray[np.float64]
    status: str
    message: str
    iterations: int
    wall_time_s: float
    method: str
    candidates: tuple[Candidate, ...]
    rejected: int

    @property
    def x(self) -> NDArray[np.float64]:
        """Planned grasp features, shape (d,)."""
        return self.chosen.x

    @property
    def posterior(self) -> NDArray[np.float64]:
        """P(k|x) over the model's zones, shape (K,)."""
        return self.chosen.posterior

    @property
    def objective(self) -> float:
        """1/2 |v - P(x)|^2."""
        return self.chosen.objective

    @property
    def success(self) -> bool:
        """True when the status is 'ok'."""
        return self.status == 'ok'


def _check_v(model: GraspModel, v: ArrayLike) -> NDArray[np.float64]:
    try:  # a copy: a read-only v (e.g. read in place from a message) would be another type to the compiled kernels
        arr = np.array(v, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PlanningError(f'v must be numeric: {exc}') from None
    K = len(model.zones)
    if arr.shape != (K,):
        raise PlanningError(f'v must have one entry per model zone ({K}: {",".join(model.zone_labels)}), '
                            f'got shape {arr.shape}')
    total = float(arr.sum())  # not finite when an entry is not (or the entries overflow: then no probabilities either)
    if not math.isfinite(total) or float(arr.min()) < 0.0 or abs(total - 1.0) > 1e-6:
        raise PlanningError(f'v must be a probability vector (finite, >= 0, sum 1), got {arr.tolist()}')
    return arr


def objective(model: GraspModel, v: NDArray[np.float64], x: ArrayLike) -> NDArray[np.float64] | float:
    """f(x) = 1/2 |v - P(x)|^2 for x of shape (d,) (float) or (N, d) (array of N)."""
    r = v - model.posterior(x)
    out = 0.5 * np.einsum('...k,...k->...', r, r)
    return float(out) if np.ndim(out) == 0 else out


def objective_and_gradient(model: GraspModel, v: NDArray[np.float64],
                           x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """f(x) and its analytic gradient -J^T (v - P), for x of shape (d,)."""
    p, jac = model.posterior_jacobian(x, check=False)
    r = v - p
    return 0.5 * float(r @ r), -(jac.T @ r)


def _log(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Natural logs by the C library's log, as the compiled kernels take them (numpy has vectorised logs of its own)."""
    return np.array([math.log(t) for t in values.tolist()])


def zone_order(v: NDArray[np.float64]) -> NDArray[np.intp]:
    """Zones from the most to the least likely; v compared at 1e-9, ties in zone order (never noise)."""
    return np.lexsort((np.arange(v.size), -np.rint(v * 1e9)))


def select_starts(model: GraspModel, v: NDArray[np.float64], n_starts: int = 3,
                  top_zones: int = 2) -> NDArray[np.float64]:
    """Algorithm 1's starts, shape (<= n_starts, d).

    The demonstration of the top-v zone with the lowest objective first, then the next best
    demonstrations of the ``top_zones`` most likely zones. A demonstration belongs to zone k when its
    task set contains k (inclusive labeling); when the top zone has none, the best demonstration overall
    comes first. Objectives are compared at 1e-12 relative, then by demonstration order (compiled:
    ``kernels.select_demonstrations``).
    """
    index = select_demonstrations(model.demo_posterior, v, model.zone_members, zone_order(v)[:max(1, top_zones)],
                                  n_starts - 1, MATCH_TOL)
    out: NDArray[np.float64] = model.demo_x[index]
    return out


def search_starts(model: GraspModel, v: NDArray[np.float64], count: int = _SCREEN) -> NDArray[np.float64]:
    """The wider search's extra starts among the zone means and demonstrations, shape (count, d).

    One compiled pass screens them (``kernels.screen``): with every v_k > 0, by the spread of the log-odds
    residuals, max_k q_k - min_k q_k with q_k = log(pi_k N_k(x)) - log v_k (zero exactly where P = v);
    otherwise by f. The first ``count`` by the screen at 1e-12 relative, then in pool order.
    """
    pool, log_joint_t, posterior = model.start_pool
    log_v = _log(v) if float(v.min()) > 0.0 else _NO_LOGS
    out: NDArray[np.float64] = pool[screen(log_joint_t, log_v, posterior, v, count, MATCH_TOL)]
    return out


class _Feasible:
    """Projection onto the feasible set X (compiled: :mod:`.kernels`) and the scale of the distance between grasps."""

    def __init__(self, model: GraspModel) -> None:
        self.model = model
        self.lower, self.upper = model.lower, model.upper
        self.a = model.features.approach
        self.scale = model.feature_scale
        self.body = model.body.kernel_arrays if model.body is not None else (
            np.zeros(0, dtype=np.int64), *np.zeros((3, 0, 3)), *np.zeros((2, 0)), np.zeros((0, 3)), 0.0)
        """The body as the compiled kernels take it (no primitive at all: no body)."""

    def project(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Clip to the bounds, normalise the approach, push the palm out of the body (N, d)."""
        return feasible(x, self.lower, self.upper, self.a.start, self.a.stop, self.body)


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

    Why a start stalls (flashlight, measured): where the projection of x_ref stops short of an existing
    match, the normalised Jacobian's smallest singular value is about 3e-3 (the homotopy path nears a
    fold), and the ridge, larger than its square, turns the step into one that no longer lowers the
    residual's 1-norm, so the trust radius collapses (no bound is active in 16 of the 20 that stall
    even without the stall rule, and the body is 1-3 cm away in all). Without the
    stall rule (400 iterations) 27 instead of 10 of 48 such starts converge, without the ridge too 30,
    but the long paths are not stable: their end points move under a 1e-12 change of v (6-13 in 100).
    A path-following continuation in the right-hand side (Gauss-Newton corrector, adaptive step)
    reached 25 of the 48, stopping where the path meets such a fold. The short, damped paths are
    kept; the wider search finds the other matches.

    Why the path is taken to rounded targets (flashlight, measured): a path that reaches its match only
    after many rejected steps near such a fold amplifies a difference in its input by about 1.8 per
    iteration; for one w (the benchmark's #192) a 1e-12 change of v was 1e-13 after 2 iterations, 1e-7
    after 40 and 1e-4 at the match after 60 (both runs converged, at different points of the match
    manifold). No iteration count was involved, so no convergence rule could fix it. With the targets
    rounded to 1e-9 nats the path sees the same input for both runs (unless a target lies within the
    change of a rounding boundary: odds of about 1e-3 per target, which matter only for such a path),
    and the few local steps onto the exact targets that follow are contractions, not amplifiers.
    """

    def __init__(self, model: GraspModel, v: NDArray[np.float64], feas: _Feasible) -> None:
        self.model, self.feas = model, feas
        self.r = int(zone_order(v)[0])
        self.others = np.delete(np.arange(len(model.zones), dtype=np.int64), self.r)
        self.b = _log(v[self.others]) - math.log(v[self.r])
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
        return project(starts, model.means, model._precisions, model._log_norm, self.others, self.r, self.b_path,
                       feas.scale, feas.lower, feas.upper, feas.a.start, feas.a.stop, feas.body,
                       maxiter=_GN_MAXITER, stall=_GN_STALL, damping=_GN_DAMPING, htol=_GN_HTOL,
                       steptol=_GN_STEPTOL, b_final=self.b)


def _least_squares(model: GraspModel, v: NDArray[np.float64], origins: NDArray[np.float64], feas: _Feasible,
                   projection: _LogOddsProjection | None, screened: NDArray[np.float64],
                   ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], list[str],
                              NDArray[np.float64]]:
    """Rule 5 of the module docstring: end points (N, d), converged, iterations, a label and the origin of each.

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
        origins, v, v_path, model.means, model._precisions, model._log_norm, feas.lower, feas.upper, feas.scale,
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


def _refine_scipy(model: GraspModel, v: NDArray[np.float64], x0: NDArray[np.float64], method: Method,
                  gradient: Gradient, extra_constraints: Sequence[Any],
                  feas: _Feasible) -> tuple[NDArray[np.float64], bool, str, int]:
    lower, upper = model.lower, model.upper
    a = model.features.approach
    x_start = x0

    def fun_grad(x: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        return objective_and_gradient(model, v, np.clip(x, lower, upper))

    def fun_only(x: NDArray[np.float64]) -> float:
        return float(objective(model, v, np.clip(x, lower, upper)))

    fun: Any = fun_grad if gradient == 'analytic' else fun_only
    jac: Any = True if gradient == 'analytic' else '2-point'

    def gauss_newton(x: NDArray[np.float64]) -> NDArray[np.float64]:
        jac = model.posterior_jacobian(np.clip(x, lower, upper), check=False)[1]
        return jac.T @ jac  # least-squares Hessian approximation J^T J (positive semi-definite)

    def unit(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([x[a] @ x[a] - 1.0])

    def unit_jac(x: NDArray[np.float64]) -> NDArray[np.float64]:
        j = np.zeros((1, x.size))
        j[0, a] = 2.0 * x[a]
        return j

    body = model.body

    def clear(x: NDArray[np.float64]) -> NDArray[np.float64]:
        assert body is not None
        return body.distance(x[None, PALM])[0] - body.margin

    def clear_jac(x: NDArray[np.float64]) -> NDArray[np.float64]:
        assert body is not None
        j = np.zeros((1, x.size))
        j[0, PALM] = body.distance(x[None, PALM])[1][0]
        return j

    # imported here: scipy.optimize is 0.4-0.6 s of a planner node's start-up, and only these methods use it
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    res: OptimizeResult
    if method == 'slsqp':
        cons: list[Any] = [{'type': 'eq', 'fun': unit, 'jac': unit_jac}, *extra_constraints]
        if body is not None:
            cons.append({'type': 'ineq', 'fun': clear, 'jac': clear_jac})
        res = minimize(fun, x_start, jac=jac, method='SLSQP', bounds=Bounds(lower, upper),
                       constraints=cons, options={'ftol': _FTOL, 'maxiter': _MAXITER})
    else:
        def unit_hess(x: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.float64]:
            h = np.zeros((x.size, x.size))
            h[a, a] = 2.0 * lam[0] * np.eye(a.stop - a.start)
            return h

        cons2: list[Any] = [NonlinearConstraint(unit, 0.0, 0.0, jac=unit_jac, hess=unit_hess),
                            *extra_constraints]
        if body is not None:
            cons2.append(NonlinearConstraint(clear, 0.0, np.inf, jac=clear_jac))
        res = minimize(fun, x_start, jac=jac, method='trust-constr', bounds=Bounds(lower, upper),
                       constraints=cons2, hess=gauss_newton,
                       options={'gtol': 1e-12, 'xtol': 1e-12, 'maxiter': _TC_MAXITER, 'initial_tr_radius': 0.1})
    x = feas.project(np.asarray(res.x, dtype=np.float64)[None, :])[0]
    if not float(objective(model, v, x)) <= float(objective(model, v, x_start)):  # never worse than the start
        x = x_start
    return x, bool(res.success), str(res.message), int(getattr(res, 'nit', 0) or 0)


def _unique_rows(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rows of x without exact repeats, in their first order (-0.0 and 0.0 are the same; compiled)."""
    out: NDArray[np.float64] = x[distinct(x, 0.0)]
    return out


def _match_message(converged: bool) -> str:
    return 'exact match' if converged else 'projection stopped before matching v (stalled or iteration limit)'


def _choose(candidates: list[Candidate], band: float) -> list[Candidate]:
    """The module docstring's choice order (rule 6, ``band`` its residual band: 0 for a fresh plan).

    A candidate within 1e-9 (relative) of an earlier one is dropped.
    """
    if len(candidates) <= 1:
        return list(candidates)
    order = choice_order(np.array([c.objective for c in candidates]), np.array([c.distance for c in candidates]),
                         np.array([c.start_index for c in candidates]), np.array([c.x for c in candidates]),
                         np.array([c.success for c in candidates]), MATCH_TOL, F_RTOL, band, DISTANCE_TOL, 1e-18)
    return [candidates[i] for i in order.tolist()]


def plan(model: GraspModel, v: ArrayLike, *, method: Method = DEFAULT_METHOD, gradient: Gradient = 'analytic',
         n_starts: int = 3, top_zones: int = 2, warm_start: ArrayLike | None = None,
         accept: Callable[[NDArray[np.float64]], bool] | None = None,
         extra_constraints: Sequence[Any] = (), tau: float = TAU, hysteresis: float = HYSTERESIS,
         faithful: Faithful = 'label') -> PlanResult:
    """Plan a grasp for target v (module docstring): by default the demonstration that serves the likely tasks.

    Parameters
    ----------
    model : GraspModel
    v : array_like, shape (K,)
        Target vector over the model's zones (see :func:`grasp_intent_ros.method.intent.interpret`).
    method : {'task', 'lm', 'slsqp', 'trust-constr'}
        ``'task'`` (default, :data:`DEFAULT_METHOD`): serve the likely tasks (:mod:`.serving`). The paper's
        planner: ``'lm'``, the exact match by log-odds projection, then projected Levenberg-Marquardt least
        squares when no exact match is found; ``'slsqp'`` and ``'trust-constr'``, the paper's solvers on f
        from the demonstration starts.
    gradient : {'analytic', '2-point'}
        Analytic gradient (default) or scipy's finite differences (the paper's baseline; scipy methods only).
    n_starts : int >= 1
        Demonstrations to start from (see :func:`select_starts`; not used by ``'task'``).
    top_zones : int >= 1
        How many of the most likely zones supply starts (not used by ``'task'``).
    warm_start : array_like, shape (d,), optional
        The reference and first start (e.g. the previous plan).
    accept : callable x -> bool, optional
        Robot constraint that cannot be written as a smooth function (e.g. IK reachability): the first
        candidate in the choice order it accepts is returned.
    extra_constraints : sequence
        More smooth constraints in the form the chosen scipy method takes (not with ``'task'`` or ``'lm'``).
    tau : float in [0, 1]
        ``'task'``: the probability at which a task beyond the top zone is likely (:data:`.serving.TAU`).
    hysteresis : float in [0, 1]
        ``'task'``, warm start: tasks the previous grasp is read as doing stay likely down to tau - hysteresis.
    faithful : {'label', 'reading'}
        ``'task'``: what must hold no task outside the likely ones: the demonstration's label (the tasks it
        does) and the model's reading of it (default), or only the reading.

    Raises
    ------
    PlanningError
        For a v that is not a probability vector over the model's zones, or bad options.
    """
    t0 = time.perf_counter()
    v_arr = _check_v(model, v)
    if n_starts < 1 or top_zones < 1:
        raise PlanningError('n_starts and top_zones must be at least 1')
    if method not in METHODS:
        raise PlanningError(f"method must be 'task', 'lm', 'slsqp' or 'trust-constr', got {method!r}")
    if not (0.0 <= tau <= 1.0 and 0.0 <= hysteresis <= 1.0):
        raise PlanningError(f'tau and hysteresis must lie in [0, 1], got {tau!r} and {hysteresis!r}')
    if gradient not in ('analytic', '2-point'):
        raise PlanningError(f"gradient must be 'analytic' or '2-point', got {gradient!r}")
    if method in ('task', 'lm') and (gradient != 'analytic' or extra_constraints):
        raise PlanningError(f"method {method!r} takes the analytic gradient and no extra_constraints")
    demo: NDArray[np.float64] | None = None  # the demonstration starts, Algorithm 1's first
    if warm_start is not None:
        ws = np.asarray(warm_start, dtype=np.float64)
        if ws.shape != (model.features.dim,) or not np.all(np.isfinite(ws)):
            raise PlanningError(f'warm_start must be a finite vector of shape ({model.features.dim},)')
        first = ws[None, :]
    else:
        demo = select_starts(model, v_arr, n_starts, top_zones)
        first = demo[:1]  # Algorithm 1's start
    feas = _Feasible(model)
    x_ref = feas.project(first)[0]
    if method == 'task':
        return _serve(model, v_arr, x_ref, feas, warm_start is not None, accept, tau, hysteresis, faithful, t0)
    band = WARM_BAND if warm_start is not None else 0.0  # rule 6: a stream keeps its branch within the band

    def all_starts() -> NDArray[np.float64]:
        """x_ref, then the demonstration starts (with a warm start, selected only when the search goes beyond x_ref)."""
        if demo is None:
            return np.concatenate([x_ref[None, :], feas.project(select_starts(model, v_arr, n_starts, top_zones))])
        return np.concatenate([x_ref[None, :], feas.project(demo[1:])])

    def candidates_from(xs: NDArray[np.float64], origin: NDArray[np.float64], ok: NDArray[np.bool_],
                        its: NDArray[np.int64], first_index: int, message: Callable[[int, bool], str],
                        ) -> list[Candidate]:
        """Scored candidates of the end points xs (N, d); ``message(i, converged)`` says how row i ended."""
        n = xs.shape[0]
        post, f, dist = score(np.concatenate([xs, origin]), v_arr, model.means, model._precisions, model._log_norm,
                              x_ref, feas.scale)
        f_all = f.tolist()
        return [Candidate(x, p, fi, di, x0, f0, first_index + i, converged, message(i, converged), it)
                for i, (x, p, fi, di, x0, f0, converged, it) in enumerate(zip(
                    xs, post[:n], f_all[:n], dist[:n].tolist(), origin, f_all[n:], ok.tolist(), its.tolist()))]

    found: list[Candidate] = []
    turned_down: list[Candidate] = []

    def choose(ranked: list[Candidate]) -> Candidate | None:
        """The first of ``ranked`` (in choice order) that ``accept`` takes, asking each candidate once."""
        for cand in ranked:
            if any(cand is c for c in turned_down):
                continue
            if accept is None or accept(cand.x):
                return cand
            turned_down.append(cand)
        return None

    def exact(cands: list[Candidate]) -> list[Candidate]:
        return [c for c in cands if c.success and c.objective <= MATCH_TOL]

    chosen: Candidate | None = None
    if method == 'lm':
        # P = v is impossible when some v_k = 0 (P_k > 0 everywhere): then there is nothing to project onto
        projection = _LogOddsProjection(model, v_arr, feas) if float(v_arr.min()) > 0.0 else None
        if projection is not None:
            xs, ok, its = projection.run(x_ref[None, :])  # the reference's own projection first
            found = candidates_from(xs, x_ref[None, :], ok, its, 0, lambda _, c: _match_message(c))
            chosen = choose(_choose(exact(found), band))
        if chosen is None:  # the wider search (its first row is the reference again)
            screened = feas.project(search_starts(model, v_arr))
            wide = _unique_rows(np.concatenate([all_starts(), screened]))
            if projection is not None and wide.shape[0] > 1:
                xs, ok, its = projection.run(wide[1:])
                found += candidates_from(xs, wide[1:], ok, its, 1, lambda _, c: _match_message(c))
                chosen = choose(_choose(exact(found), band))
        if chosen is None:  # least squares from every start and every zone mean
            origins = _unique_rows(np.concatenate([wide, feas.project(model.means)]))
            xs, ok, its, labels, origins = _least_squares(model, v_arr, origins, feas, projection, screened[0])
            found += candidates_from(xs, origins, ok, its, len(found), lambda i, _: labels[i])
    else:
        for i, s0 in enumerate(all_starts()):
            x1, ok1, text, it = _refine_scipy(model, v_arr, s0, method, gradient, extra_constraints, feas)
            found += candidates_from(x1[None, :], s0[None, :], np.array([ok1]), np.array([it]), i,
                                     lambda _, __: text)  # called at once, in this iteration
    ranked = _choose(found, band)
    if chosen is None:
        chosen = choose(ranked)
    if chosen is None:
        chosen, status = ranked[0], 'rejected'
        ranked = turned_down + [c for c in ranked if not any(c is t for t in turned_down)]
    else:
        status = 'ok'
        rest = [c for c in ranked if c is not chosen and not any(c is t for t in turned_down)]
        ranked = turned_down + [chosen] + rest
    rejected = len(turned_down)
    if status == 'ok' and not chosen.success:
        status = 'solver_failed'
    message = {'ok': f'planned ({chosen.message})', 'solver_failed': f'not converged: {chosen.message}',
               'rejected': f'all {len(ranked)} candidates rejected by the robot constraint'}[status]
    return PlanResult(chosen=chosen, w=reconstruct_w(chosen.posterior, model.zones, len(model.task_names)),
                      exact=chosen.objective <= MATCH_TOL, reference=x_ref, status=status, message=message,
                      iterations=sum(c.iterations for c in found), wall_time_s=time.perf_counter() - t0,
                      method=method, candidates=tuple(ranked), rejected=rejected)

def _serve(model: GraspModel, v: NDArray[np.float64], x_ref: NDArray[np.float64], feas: _Feasible, warm: bool,
           accept: Callable[[NDArray[np.float64]], bool] | None, tau: float, hysteresis: float, faithful: Faithful,
           t0: float) -> PlanResult:
    """Method 'task': the first demonstration of :func:`~.ranking.rank` that ``accept`` takes."""
    ranking = rank(model, v, int(zone_order(v)[0]), x_ref, feas.lower, feas.upper, feas.a, feas.body, tau=tau,
                   hysteresis=hysteresis, warm=warm, faithful=faithful)
    names = model.task_names
    likely = zone_label(ranking.likely, names)
    top = zone_label(ranking.top, names)
    tiers = (f'serves the likely tasks {likely}', f'serves the top zone {top}, reads as a task outside {likely}',
             f'misses the top zone {top}')
    sets = model.demo_sets
    n = min(_TASK_CANDIDATES, ranking.order.size)
    candidates = tuple(
        Candidate(x, p, f, d, x, f, i, True, f'demonstration {i} ({zone_label(int(sets[i]), names)}): {tiers[t]}', 0)
        for x, p, f, d, i, t in zip(ranking.x[:n], ranking.posterior[:n], ranking.objective[:n].tolist(),
                                    ranking.distance[:n].tolist(), ranking.order[:n].tolist(),
                                    ranking.tier[:n].tolist()))
    if not candidates:
        raise PlanningError(f'model {model.name!r} has no demonstration outside its body to plan from')
    rejected = 0
    chosen = None
    for cand in candidates:
        if accept is None or accept(cand.x):
            chosen = cand
            break
        rejected += 1
    status = 'ok' if chosen is not None else 'rejected'
    chosen = chosen if chosen is not None else candidates[0]
    message = f'planned ({chosen.message})' if status == 'ok' else \
        f'all {len(candidates)} candidates rejected by the robot constraint'
    return PlanResult(chosen=chosen, w=reconstruct_w(chosen.posterior, model.zones, len(names)),
                      exact=chosen.objective <= MATCH_TOL, reference=x_ref, status=status, message=message,
                      iterations=0, wall_time_s=time.perf_counter() - t0, method='task', candidates=candidates,
                      rejected=rejected)


def reference_search(model: GraspModel, v: ArrayLike, *, n_starts: int = 60, seed: int = 0) -> float:
    """The lowest f a slow multi-start SLSQP search reaches: an oracle for checking :func:`plan`.

    Starts: every zone mean, then seeded uniform random points in the bounds, ``n_starts`` in all,
    each projected onto X; each is refined with SLSQP (analytic gradient, bounds, unit approach,
    body clearance) and the result projected onto X again.

    Returns
    -------
    float
        The lowest objective over all starts.
    """
    v_arr = _check_v(model, v)
    rng = np.random.default_rng(seed)
    starts = list(model.means[:n_starts])
    while len(starts) < n_starts:
        starts.append(rng.uniform(model.lower, model.upper))
    feas = _Feasible(model)
    best = np.inf
    for start in feas.project(np.asarray(starts)):
        x = _refine_scipy(model, v_arr, start, 'slsqp', 'analytic', (), feas)[0]
        best = min(best, float(objective(model, v_arr, x)))
    return best

