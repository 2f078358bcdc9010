"""The task-serving choice: the demonstration whose task set the operator most likely wants, read faithfully.

The problem (:func:`grasp_intent_ros.planning.planner.plan`'s default, ``method='task'``): given a model and a
target vector v over its zones, return a grasp that serves the operator's likely tasks. The operator's true
task set T holds each task i with probability w_i (the paper's joint events, eq. 3); a grasp whose task set is
S serves T when T is a subset of S. The model knows which tasks a grasp serves only at its labelled
demonstrations (inclusive labeling: demonstration n serves the zones contained in its set S_n), so the
answer is chosen among them; between demonstrations no label says what a grasp does.

Definitions, all from v and the model document (zone Gaussians, labelled demonstrations, body, bounds):

- z*: v's top zone (v compared at 1e-9, ties to the first zone).
- The likely set A: z*, plus every task i outside it whose zone z* + i is a zone of the model and is at
  least tau / (1 - tau) times as likely as z* under v, v(z* + i) (1 - tau) >= tau v(z*) (1 - 1e-9). Under
  eq. 4, v(z* + i) / v(z*) = w_i / (1 - w_i), so for a model with every zone this is w_i >= tau.
- The model's expected success of demonstration n: E_n = sum of v_k over the zones k contained in S_n; when
  the plan accounts for execution noise (``retention`` R, :func:`grasp_intent_ros.planning.robustness.retention`),
  E_n = sum_k v_k R_nk, R_nk the estimated probability that the grasp, landing off by the noise, still does
  every task of zone k (the expected success of the grasp as executed; R_nk = 1 within S_n without noise).
- Its reading: the zone argmax_k P(k | x_n) (the model's posterior of the demonstration).

Candidates are the demonstrations whose palm is outside the body (with its margin), projected onto the
feasible set (unit approach). They are ranked by, in order:

1. serves z* (S_n contains z*);
2. faithful: its reading within A and (``faithful='label'``, the default) S_n within A: the grasp does, and
   reads as doing, only likely tasks (with ``faithful='reading'`` only the reading counts, and a
   demonstration that does unlikely tasks but that the model reads as the top zone may be chosen: the
   highest expected success, at the price of grasps that serve every task whatever the intent);
3. E_n, highest first (quantised to 1e-9): with noise, the demonstration whose landings the labelled
   demonstrations around it say keep its tasks;
4. fresh plan: the paper's fit f_n = 1/2 |v - P(x_n)|^2, lowest first (quantised to 1e-9), then the scaled
   distance to the reference (quantised to 1e-6); warm plan: see below;
5. demonstration order.

The first candidate is the answer; the ``accept`` hook (IK reachability) is asked in this order.

**A stream keeps its branch** (warm start, the previous plan). Three bands, each against the grasp going
back and forth between two answers of nearly the same merit while the intent moves a little:

- *likely set*: when the warm start is a demonstration, the tasks the model reads it as doing (and, with
  ``faithful='label'``, the tasks it does) stay in A down to w_i >= tau - ``hysteresis`` (tasks join A at
  tau, in fresh and warm plans alike);
- *expected success*: in the best tier, the candidates whose E is within ``band`` of the best tie with it;
- *fit*: among those, the candidates whose residual |v - P| = sqrt(2 f) is within ``fit_band`` of the
  group's best (the previous grasp's demonstration: within ``keep_band``) come first, then by the scaled
  distance to the warm start, then by f.

So the previous grasp is kept exactly while it stays within the bands, and otherwise the nearest
demonstration within them is taken. Against a fresh plan for the same v with the same likely set and tier,
a stream's answer has E at most ``band`` lower and a residual at most ``keep_band`` higher; the likely sets
differ only by tasks with w_i within ``hysteresis`` below tau.

Every quantity is computed by the planner's compiled kernels in a fixed order (``kernels.log_joints``,
``kernels.fit_and_distance``) or elementwise, and sorted by ``kernels.lex_order``, so the choice has the same
bits on any machine.

What does not depend on v, the reference or the options (the candidates projected onto X, which of them
have the palm inside the body, their posteriors and readings: :class:`TaskCandidates`) is computed once per
model (:func:`task_candidates`) and kept with it; a plan computes only its f, distances, likely set, E and
order from them.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..kernels import fit_and_distance, lex_order, log_joints
from ..method.intent import zone_label
from ..method.model import GraspModel
from .common import feasible_demonstrations

__all__ = ['TAU', 'HYSTERESIS', 'BAND', 'FIT_BAND', 'KEEP_BAND', 'Faithful', 'TaskCandidates', 'task_candidates',
           'Ranking', 'likely_tasks', 'expected_success', 'rank']

Faithful = Literal['label', 'reading']
"""What must hold no unlikely task: the demonstration's label and the model's reading of it, or the reading only."""
TAU = 0.3
"""A task outside the top zone is served when its probability is at least this (see the module docstring)."""
HYSTERESIS = 0.05
"""With a warm start, a task the previous grasp serves stays in the likely set down to TAU - HYSTERESIS."""
BAND = 0.05
"""With a warm start, candidates whose expected success E is within this of the best one's tie with it."""
FIT_BAND = 0.1
"""With a warm start, candidates of the top group whose residual |v - P| is within this of its best one's tie."""
KEEP_BAND = 0.3
"""With a warm start, the previous grasp's demonstration ties while its residual is within this of the best."""
_E_QUANTUM = 1e-9
_F_QUANTUM = 1e-9
_D_QUANTUM = 1e-6
_RATIO_RTOL = 1e-9
_ON_DEMO = 1e-9  # scaled distance within which a warm start is the demonstration it came from


@dataclass(frozen=True)
class TaskCandidates:
    """The model's demonstrations as the ranking's candidates: what of them no v, reference or option changes.

    Every array is read-only.

    Attributes
    ----------
    x : ndarray, shape (N, d)
        The demonstrations projected onto the feasible set (:func:`~.common.feasible_demonstrations`, bit for bit).
    inside : ndarray of bool, shape (N,)
        The projection moved the palm (it lay inside the body with its margin): never a candidate. All False
        for a model without a body.
    posterior : ndarray, shape (N, K)
        P(k | x_n) of each projected demonstration, by the planner's kernels (``kernels.log_joints``: the
        arithmetic of ``kernels.score``, so the same bits).
    reading : ndarray of int, shape (N,)
        The zone (bitmask) the model reads each as doing, argmax_k P(k | x_n) (ties to the first zone).
    labels : tuple of str, length N
        Each demonstration's task set as a zone label (:func:`~grasp_intent_ros.method.intent.zone_label`).
    """

    x: NDArray[np.float64]
    inside: NDArray[np.bool_]
    posterior: NDArray[np.float64]
    reading: NDArray[np.int64]
    labels: tuple[str, ...]


_CANDIDATES: weakref.WeakKeyDictionary[GraspModel, TaskCandidates] = weakref.WeakKeyDictionary()
_CANDIDATES_LOCK = threading.Lock()


def task_candidates(model: GraspModel) -> TaskCandidates:
    """The ranking's candidates of ``model`` (:class:`TaskCandidates`): computed at the first call, then kept.

    Kept by the model object (a :class:`~grasp_intent_ros.method.model.GraspModel` is immutable; another
    model, e.g. one read again or switched to, has its own), for as long as the model lives. Everything in
    it is a function of the model alone (demonstrations, bounds, body, Gaussians), never of a plan's input.
    Safe to call from several threads (the first calls may each compute it; they get the same bits).
    """
    with _CANDIDATES_LOCK:
        kept = _CANDIDATES.get(model)
    if kept is not None:
        return kept
    demo_x = model.demo_x
    xs = feasible_demonstrations(model)
    inside = np.abs(xs[:, :3] - demo_x[:, :3]).max(axis=1) > 0.0 if model.body is not None else \
        np.zeros(demo_x.shape[0], dtype=np.bool_)
    posterior = log_joints(xs, model.means, model.precisions, model.log_norm)[1]
    reading = np.asarray(model.zones, dtype=np.int64)[np.argmax(posterior, axis=1)]
    for array in (xs, inside, posterior, reading):
        array.setflags(write=False)
    made = TaskCandidates(xs, inside, posterior, reading,
                          tuple(zone_label(int(s), model.task_names) for s in model.demo_sets.tolist()))
    with _CANDIDATES_LOCK:
        return _CANDIDATES.setdefault(model, made)


@dataclass(frozen=True)
class Ranking:
    """The demonstrations in the choice order, with what decided it.

    Attributes
    ----------
    order : ndarray of int, shape (M,)
        Candidate demonstrations (indices into ``model.demo_x``), best first.
    x : ndarray, shape (M, d)
        Their features, projected onto the feasible set.
    posterior : ndarray, shape (M, K)
    objective : ndarray, shape (M,)
        f = 1/2 |v - P|^2 of each.
    distance : ndarray, shape (M,)
        Scaled distance to the reference.
    expected : ndarray, shape (M,)
        The model's expected success E_n (under execution noise when the ranking was given ``retention``).
    tier : ndarray of int, shape (M,)
        0: serves z* and faithful; 1: serves z*, not faithful; 2: does not serve z*.
    top : int
        z* (bitmask).
    likely : int
        A (bitmask).
    """

    order: NDArray[np.int64]
    x: NDArray[np.float64]
    posterior: NDArray[np.float64]
    objective: NDArray[np.float64]
    distance: NDArray[np.float64]
    expected: NDArray[np.float64]
    tier: NDArray[np.int64]
    top: int
    likely: int


def likely_tasks(model: GraspModel, v: NDArray[np.float64], top: int, tau: float, keep: int = 0,
                 hysteresis: float = HYSTERESIS) -> int:
    """A, the likely set (bitmask): zone ``top`` (index) plus the tasks likely enough (module docstring).

    Tasks in ``keep`` (bitmask) need only tau - hysteresis.
    """
    zones = model.zones
    z_top = zones[top]
    index = {z: k for k, z in enumerate(zones)}
    likely = z_top
    for i in range(len(model.task_names)):
        bit = 1 << i
        k = index.get(z_top | bit)
        if z_top & bit or k is None:
            continue
        t = tau - hysteresis if keep & bit else tau
        if t <= 0.0 or float(v[k]) * (1.0 - t) >= t * float(v[top]) * (1.0 - _RATIO_RTOL):
            likely |= bit
    return likely


def expected_success(sets: NDArray[np.int64], zones: Sequence[int], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """E of each task set in ``sets`` (bitmasks): the sum of ``v[k]`` over the zones ``zones[k]`` it contains.

    Summed zone by zone in the given order, so the same on any machine.
    """
    expected = np.zeros(np.shape(sets))
    for k, z in enumerate(zones):
        expected += np.where((sets & z) == z, v[k], 0.0)
    return expected


def _expected_as_executed(retention: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """sum_k v_k R_nk for every demonstration n, summed zone by zone in order (the same on any machine)."""
    expected = np.zeros(retention.shape[0])
    for k in range(retention.shape[1]):
        expected += v[k] * retention[:, k]
    return expected


def _quantised(values: NDArray[np.float64], quantum: float) -> NDArray[np.float64]:
    out: NDArray[np.float64] = np.rint(values / quantum)
    return out


def rank(model: GraspModel, v: NDArray[np.float64], top: int, reference: NDArray[np.float64],
         *, tau: float = TAU, hysteresis: float = HYSTERESIS, warm: bool = False, faithful: Faithful = 'label',
         band: float = BAND, fit_band: float = FIT_BAND, keep_band: float = KEEP_BAND,
         retention: NDArray[np.float64] | None = None) -> Ranking:
    """Rank the demonstrations (module docstring) for target v with top zone index ``top``.

    ``reference`` (d,) is Algorithm 1's start (fresh) or the warm start (``warm``); ``retention`` (N, K), when
    given, turns E into the expected success under execution noise. The candidates are
    :func:`task_candidates`'s (computed at the model's first ranking).
    """
    cands = task_candidates(model)
    xs, inside, posterior, reading = cands.x, cands.inside, cands.posterior, cands.reading
    f, dist = fit_and_distance(posterior, v, xs, reference, model.feature_scale)
    zones = np.asarray(model.zones, dtype=np.int64)
    sets = model.demo_sets
    keep = 0
    if warm and dist.size and float(dist.min()) <= _ON_DEMO:
        n = int(np.argmin(dist))
        keep = int(reading[n]) | (int(sets[n]) if faithful == 'label' else 0)
    likely = likely_tasks(model, v, top, tau, keep, hysteresis)
    z_top = int(zones[top])
    serves = (sets & z_top) == z_top
    read_faithfully = (reading & ~likely) == 0  # the model reads it as doing only likely tasks
    if faithful == 'label':
        read_faithfully &= (sets & ~likely) == 0  # and it does only likely tasks
    expected = expected_success(sets, model.zones, v) if retention is None else _expected_as_executed(retention, v)
    tier = np.where(serves, np.where(read_faithfully, 0, 1), 2).astype(np.int64)
    expected_key = _quantised(expected, _E_QUANTUM)
    if warm and band > 0.0:  # the best tier's candidates within the band of its best E tie with it
        best_tier = int(tier[~inside].min())
        tied = (tier == best_tier) & ~inside
        best = float(expected[tied].max())
        expected_key[tied & (expected >= best - band)] = _quantised(np.array([best]), _E_QUANTUM)[0]
    fit_key, dist_key = _quantised(f, _F_QUANTUM), _quantised(dist, _D_QUANTUM)
    outside_band = np.zeros(sets.size, dtype=np.int64)
    if warm:  # within the top group, residuals within fit_band of the best tie, then go by distance
        top_group = (tier == tier[~inside].min()) & ~inside
        top_group &= expected_key == expected_key[top_group].max()
        residual = np.sqrt(2.0 * f)
        limit = np.full(sets.size, float(residual[top_group].min()) + fit_band)
        limit[dist <= _ON_DEMO] += keep_band - fit_band  # the previous grasp itself keeps a wider band
        outside_band[top_group & (residual > limit)] = 1
    secondary = (fit_key, dist_key, outside_band) if warm else (dist_key, fit_key)
    # the last key is the primary one; ties stay in demonstration order
    order = lex_order(np.stack((*secondary, -expected_key, tier)))
    order = order[~inside[order]]
    return Ranking(order=order.astype(np.int64), x=xs[order], posterior=posterior[order], objective=f[order],
                   distance=dist[order], expected=expected[order], tier=tier[order], top=z_top, likely=likely)
