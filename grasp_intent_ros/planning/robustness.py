"""Execution noise: where the hand lands when the arm is told to grasp at x.

A real arm never lands exactly on the plan: the object tracker, the IK and the servo each add error, and
finger closure varies with contact. :class:`ExecutionNoise` is the model of that error, one definition for
the planner (which plans for it) and the benchmarks (which judge grasps as executed). For a MICO grasp
(:data:`~grasp_intent_ros.method.features.MICO_3F` layout), one landing of x is

- palm centre + N(0, ``palm``^2) per axis (m);
- the approach direction tilted by N(0, ``tilt``^2) about each of two axes orthogonal to it (rad): the
  rotation by the vector t1 e1 + t2 e2, (a, e1, e2) orthonormal, so the tilt is isotropic about a;
- wrist roll + N(0, ``roll``^2) (rad);
- each finger closure + N(0, ``closure``^2) (rad), clipped to the feature bounds.

A landing is written as nine standard normal numbers z (:data:`DRAW_DIM`: three palm, two tilt, one roll,
three fingers), so that the same draws can be applied to any grasp and any noise level.

**The robustness estimate** (:func:`retention`): for each labelled demonstration n and each zone k within its
task set S_n, the probability R_nk that the grasp, executed under the noise, still does every task of zone k
(the event the operator model's success counts: an intended task set T is served when T is within the label).
It is estimated from the model document only (the labelled demonstrations and the object's body; never the
rules that labelled them), as the geometric mean of two estimates that err in different places,
R_nk = sqrt(V_nk B_nk):

1. Classifier features: the grasp's features, plus the palm's clearance from the body when the model has one
   (:meth:`~grasp_intent_ros.method.body.ObjectBody.distance`).
2. The task sets voted on (:func:`votes`): the zones, then each task that is not a zone of its own. For each,
   the demonstrations whose task set contains it are its positives, the others its negatives.
3. **The vote V** (:func:`bandwidths`): per voted set, a kernel vote q(y) over the demonstrations
   (:mod:`grasp_intent_ros.kernels.voting`), with a diagonal bandwidth per feature. The bandwidths minimise
   the vote's leave-one-out log loss over the demonstrations, by a coordinate search
   (:func:`~grasp_intent_ros.kernels.voting.search_bandwidths`) over 2^p times the noise's own scale of
   each feature (palm and clearance: ``palm``; approach: ``tilt``; roll: ``roll``; fingers: ``closure``; a
   zero scale counts as 1e-3 of the feature's range), p an integer in [-2, 8]: from p = 2 (4x the noise),
   for each feature in index order p goes up by one while the loss drops by more than 1e-9 (relative), else
   down by one while it does; :data:`SWEEPS` sweeps. Losses are compared only beyond that tolerance, so float
   noise never decides a step. At the landings each vote takes its bandwidths times :data:`NARROWING`
   (2^-1/2, half a step of the search's grid). Q is the mean of a vote over :data:`DRAWS` fixed landings of
   demonstration n (:func:`stratified_draws` of seed 0, a Latin hypercube), n itself left out of the vote.
   The vote places a task's edge where positives and negatives meet near the demonstration; where only one
   task set's demonstrations are near (a band a few millimetres wide that no other demonstration borders),
   it smooths across the edge.
4. **The thresholds B** (:func:`thresholds`): per voted set, a conjunction of one-feature thresholds learnt
   from all the demonstrations, so that an edge found where the data meet holds where they are thin. They
   are learnt on the threshold features (:func:`threshold_columns`), so that edges no single classifier
   feature follows are in reach: the classifier features; then, for each pair f < g of the palm's
   coordinates and each pair of the approach's components, the oblique combinations a y_f / s_f + b y_g / s_g
   for (a, b) in :data:`OBLIQUE` (s_f the noise's own scale of step 3; directions at 45, about 63 and about
   27 degrees to the features' axes in units of the noise, either sign: a bound on the palm's bearing about
   the object's axis, on a tilt in two components); then the three finger closures sorted, the least closed
   first (a bound on how many fingers close is a threshold on one of them). Greedy: among the negatives not
   yet excluded, for each threshold feature in index order and each side (above the positives' largest
   value, then below their smallest), count those strictly beyond the positives' extreme; the side that
   excludes the most (ties to the first in that order) becomes a condition, its inner edge the positives'
   extreme, its outer edge the nearest excluded negative; repeat until no side excludes a negative.
   (Negatives no such side excludes stay unexplained; a set without positives or negatives has no
   condition.) A landing y meets a condition to the degree clip((outer - y_f) / (outer - inner), 0, 1): the
   threshold taken as uniform between the edges. Q' is the mean over :data:`THRESHOLD_DRAWS` landings
   (:func:`stratified_draws` of seed 0) of the product of the set's conditions
   (:func:`~grasp_intent_ros.kernels.voting.landed_thresholds`), the threshold features computed at the
   landings for the conditions' features only. Integer counts choose the conditions and the edges are data
   values; each threshold feature is a data value, a sort, or two quotients each times 1 or 2 and their sum
   (each rounded once by IEEE arithmetic), so no float noise decides a condition and the same bits come on
   any machine.
5. For each estimate, its value for zone k is min(Q_k, prod_{i in k} Q_i) (V from the votes, B from the
   thresholds): a landing must keep every task of the zone, and the two miss different ways to lose one (a
   multi-task zone has fewer demonstrations to vote; a product of the tasks' takes their losses as
   independent). A landing that gains a task is not credited: R_nk = 0 for a zone outside S_n.

Without noise (:attr:`ExecutionNoise.is_zero`) R_nk is 1 for every zone within S_n. The estimate does not
depend on v: it is computed once per model and noise and kept with the model. Its cost is O(N^2) per
bandwidth trial (a few hundred trials), O(N^2 DRAWS K) for the votes and O(N THRESHOLD_DRAWS C) for the
thresholds, N demonstrations, K zones, C conditions: about a second and a half of CPU for the shipped
560-demonstration models (docs/planner.md states the measured bound).
"""

from __future__ import annotations

import hashlib
import math
import os
import weakref
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanningError
from ..method.features import APPROACH, FINGERS, PALM, ROLL, FeatureSpace
from ..method.model import GraspModel

__all__ = ['ExecutionNoise', 'DRAW_DIM', 'DRAWS', 'THRESHOLD_DRAWS', 'SWEEPS', 'NARROWING', 'OBLIQUE', 'Column',
           'Condition', 'standard_draws', 'stratified_draws', 'perturb', 'votes', 'bandwidths', 'threshold_columns',
           'thresholds', 'retention']

DRAW_DIM = 9
"""Standard normal numbers per landing: palm (3), tilt (2), roll (1), fingers (3)."""
DRAWS = 16
"""Landings per demonstration in the robustness estimate's vote (stratified: :func:`stratified_draws`)."""
THRESHOLD_DRAWS = 1024
"""Landings per demonstration in the robustness estimate's thresholds (stratified: :func:`stratified_draws`)."""
_CHUNK = 32  # demonstrations whose threshold landings are held at once
OBLIQUE = ((1, 1), (1, -1), (1, 2), (1, -2), (2, 1), (2, -1))
"""The weights (a, b) of the thresholds' oblique combinations of two features (module docstring, step 4)."""
SWEEPS = 2
"""Sweeps of the bandwidth search over the features."""
NARROWING = 2.0 ** -0.5
"""The factor on the searched bandwidths of the votes at the landings (module docstring, step 4)."""
_START_POWER = 2  # bandwidths are the noise's scale times 2^power, power in [_LOWEST_POWER, _HIGHEST_POWER]
_LOWEST_POWER = -2
_HIGHEST_POWER = 8
_LOSS_RTOL = 1e-9


@dataclass(frozen=True)
class ExecutionNoise:
    """Standard deviations of one landing (module docstring); the defaults are the documented 1x level.

    Attributes
    ----------
    palm : float >= 0
        Palm centre, per axis (m); default 5 mm.
    tilt : float >= 0
        Approach direction, about each of two axes orthogonal to it (rad); default 3 degrees.
    roll : float >= 0
        Wrist roll (rad); default 3 degrees.
    closure : float >= 0
        Each finger closure (rad), clipped to its range; default 0.10 rad.

    Raises
    ------
    PlanningError
        A standard deviation that is negative or not finite.
    """

    palm: float = 0.005
    tilt: float = math.radians(3.0)
    roll: float = math.radians(3.0)
    closure: float = 0.10

    def __post_init__(self) -> None:
        for name in ('palm', 'tilt', 'roll', 'closure'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise PlanningError(f'execution noise {name} must be a finite number >= 0, got {value!r}')
            object.__setattr__(self, name, float(value))

    def scaled(self, factor: float) -> ExecutionNoise:
        """Every standard deviation times ``factor`` (>= 0): the benchmarks' levels 0, 1x, 2x."""
        return ExecutionNoise(self.palm * factor, self.tilt * factor, self.roll * factor, self.closure * factor)

    @property
    def is_zero(self) -> bool:
        """No noise: a grasp lands where it is planned."""
        return self.palm == 0.0 and self.tilt == 0.0 and self.roll == 0.0 and self.closure == 0.0


def standard_draws(count: int, seed: int) -> NDArray[np.float64]:
    """``count`` landings as standard normal numbers, shape (count, :data:`DRAW_DIM`), from ``seed``.

    Rounded to 1e-6, so that they are the same numbers on any machine.
    """
    z = np.random.default_rng(seed).standard_normal((count, DRAW_DIM))
    out: NDArray[np.float64] = np.round(z, 6)
    return out


def stratified_draws(count: int, seed: int) -> NDArray[np.float64]:
    """``count`` landings as a Latin hypercube of standard normal numbers, shape (count, :data:`DRAW_DIM`).

    Each of the nine numbers takes the ``count`` stratum medians Phi^-1((j + 1/2) / count), j < count, once
    each, in an order shuffled per number from ``seed``. Rounded to 1e-6, so that they are the same numbers on
    any machine.
    """
    from statistics import NormalDist  # late: a node process imports this module before its signal handlers

    medians = np.array([NormalDist().inv_cdf((j + 0.5) / count) for j in range(count)])
    rng = np.random.default_rng(seed)
    out: NDArray[np.float64] = np.round(np.stack([medians[rng.permutation(count)] for _ in range(DRAW_DIM)],
                                                 axis=1), 6)
    return out


def perturb(x: NDArray[np.float64], z: NDArray[np.float64], noise: ExecutionNoise,
            features: FeatureSpace) -> NDArray[np.float64]:
    """Where grasps x land under the landings z (module docstring): shape (N, D, d) for x (N, d), z (D, 9).

    ``features`` gives the fingers' bounds. The approach of x must be a unit vector; elementwise
    arithmetic only (no sums whose order a library chooses), so the same bits on any machine.
    """
    x = np.asarray(x, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    out = np.repeat(x[:, None, :], z.shape[0], axis=1)
    out[:, :, PALM] += noise.palm * z[None, :, 0:3]
    a = x[:, APPROACH]  # (N, 3)
    # e1: orthogonal to a and to the axis a is least aligned with (z, else x); e2 = a x e1
    helper = np.where((np.abs(a[:, 2]) < 0.9)[:, None], np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    e1 = np.cross(a, helper)
    e1 /= np.sqrt(e1[:, 0] * e1[:, 0] + e1[:, 1] * e1[:, 1] + e1[:, 2] * e1[:, 2])[:, None]
    e2 = np.cross(a, e1)
    t1, t2 = noise.tilt * z[None, :, 3, None], noise.tilt * z[None, :, 4, None]  # (1, D, 1)
    angle = np.sqrt(t1 * t1 + t2 * t2)
    sinc = np.where(angle > 0.0, np.sin(angle) / np.where(angle > 0.0, angle, 1.0), 1.0)
    # rotating a by the vector t1 e1 + t2 e2: a cos|t| + sinc|t| (t2 e1 - t1 e2)
    out[:, :, APPROACH] = a[:, None, :] * np.cos(angle) + sinc * (t2 * e1[:, None, :] - t1 * e2[:, None, :])
    out[:, :, ROLL] += noise.roll * z[None, :, 5]
    fingers = out[:, :, FINGERS] + noise.closure * z[None, :, 6:9]
    out[:, :, FINGERS] = np.clip(fingers, features.lower[FINGERS], features.upper[FINGERS])
    return out


def _scales(noise: ExecutionNoise, features: FeatureSpace, clearance: bool) -> NDArray[np.float64]:
    """The noise's own scale of each classifier feature (module docstring, step 3)."""
    span = features.upper - features.lower
    scale = np.empty(features.dim + (1 if clearance else 0))
    scale[PALM] = noise.palm
    scale[APPROACH] = noise.tilt
    scale[ROLL] = noise.roll
    scale[FINGERS] = noise.closure
    floor = 1e-3 * span
    scale[:features.dim] = np.maximum(scale[:features.dim], floor)
    if clearance:
        scale[-1] = max(noise.palm, float(floor[PALM].min()))
    return scale


def _classifier_features(model: GraspModel, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rows x (M, d), with the palm's clearance from the body appended when the model has one: (M, d or d + 1)."""
    if model.body is None:
        return np.ascontiguousarray(x)
    from ..kernels import clearance  # numba: the planner's import, not every model reader's
    palm_clearance = clearance(x[:, PALM], model.body.kernel_arrays).reshape(-1, 1)
    return np.ascontiguousarray(np.concatenate([x, palm_clearance], axis=1))


def _does(model: GraspModel, tasks: int) -> NDArray[np.float64]:
    """1 for each demonstration whose task set contains ``tasks`` (bitmask), else 0: shape (N,)."""
    out: NDArray[np.float64] = ((model.demo_sets & tasks) == tasks).astype(np.float64)
    return out


def votes(model: GraspModel) -> tuple[int, ...]:
    """The task sets (bitmasks) voted on (module docstring, step 2): the zones, then each task not a zone."""
    tasks = tuple(1 << i for i in range(len(model.task_names)) if (1 << i) not in model.zones)
    return tuple(model.zones) + tasks


def bandwidths(model: GraspModel, noise: ExecutionNoise) -> NDArray[np.float64]:
    """Each vote's bandwidths (module docstring, step 3): shape (V, F), the votes of :func:`votes`, F the features.

    The searches are independent and run on up to one thread per CPU (the compiled search releases the GIL);
    each one's result does not depend on the threads.
    """
    from concurrent.futures import ThreadPoolExecutor  # late: as NormalDist

    from ..kernels import search_bandwidths  # numba: the planner's import, not every model reader's
    data = _classifier_features(model, model.demo_x)
    base = _scales(noise, model.features, model.body is not None)

    def search(voted: int) -> NDArray[np.float64]:
        power = search_bandwidths(data, _does(model, voted), base, _START_POWER, _LOWEST_POWER, _HIGHEST_POWER,
                                  SWEEPS, _LOSS_RTOL)
        out: NDArray[np.float64] = base * 2.0 ** power
        return out

    voted = votes(model)
    with ThreadPoolExecutor(max_workers=min(len(voted), os.cpu_count() or 1)) as pool:
        return np.stack(list(pool.map(search, voted)))


@dataclass(frozen=True)
class Condition:
    """One learnt threshold (module docstring, step 4): threshold feature ``feature`` (:func:`threshold_columns`).

    A landing y meets it fully on the inner side of ``inner`` (the positives' extreme), not at all beyond
    ``outer`` (the nearest excluded negative), linearly between.
    """

    feature: int
    inner: float
    outer: float


Column = tuple[int, ...]
"""One threshold feature (module docstring, step 4): (f,) classifier feature f; (f, g, a, b) the oblique
combination a y_f / s_f + b y_g / s_g; (-1, r) the r-th least closed finger."""


def threshold_columns(width: int) -> tuple[Column, ...]:
    """The threshold features of ``width`` classifier features, in their index order (module docstring, step 4)."""
    out: list[Column] = [(f,) for f in range(width)]
    for block in (PALM, APPROACH):
        members = range(block.start, block.stop)
        out.extend((f, g, a, b) for f in members for g in members if g > f for a, b in OBLIQUE)
    out.extend((-1, r) for r in range(FINGERS.stop - FINGERS.start))
    return tuple(out)


def _threshold_features(data: NDArray[np.float64], scale: NDArray[np.float64],
                        columns: tuple[Column, ...]) -> NDArray[np.float64]:
    """The threshold features ``columns`` of classifier features ``data`` (M, F): shape (M, len(columns)).

    Elementwise operations that IEEE arithmetic rounds once each (a quotient, a product by 1 or 2, a sum of
    two terms) and a sort, so the same bits on any machine.
    """
    out = np.empty((data.shape[0], len(columns)))
    fingers = None  # sorted once, when a column asks for it
    for j, column in enumerate(columns):
        if len(column) == 1:
            out[:, j] = data[:, column[0]]
        elif column[0] < 0:
            fingers = np.sort(data[:, FINGERS], axis=1) if fingers is None else fingers
            out[:, j] = fingers[:, column[1]]
        else:
            f, g, a, b = column
            out[:, j] = a * (data[:, f] / scale[f]) + b * (data[:, g] / scale[g])
    return out


def _conditions(data: NDArray[np.float64], labels: NDArray[np.float64]) -> tuple[Condition, ...]:
    """The greedy conjunction of module docstring step 4 for 0/1 ``labels`` (N,) of ``data`` (N, F)."""
    positive = labels > 0.5
    if not positive.any() or positive.all():
        return ()
    low, high = data[positive].min(axis=0), data[positive].max(axis=0)
    negatives = data[~positive]
    alive = np.ones(negatives.shape[0], dtype=bool)
    out: list[Condition] = []
    while True:
        best: tuple[int, int, float, NDArray[np.bool_]] | None = None
        for f in range(data.shape[1]):
            for inner, beyond in ((high[f], negatives[:, f] > high[f]), (low[f], negatives[:, f] < low[f])):
                excluded = alive & beyond
                count = int(excluded.sum())
                if count and (best is None or count > best[0]):
                    best = (count, f, float(inner), excluded)
        if best is None:
            return tuple(out)
        _, f, inner, excluded = best
        values = negatives[excluded, f]
        outer = float(values.min() if values.min() > inner else values.max())
        out.append(Condition(f, inner, outer))
        alive &= ~excluded


def thresholds(model: GraspModel, noise: ExecutionNoise) -> tuple[tuple[Condition, ...], ...]:
    """Each vote's conditions (module docstring, step 4), for the votes of :func:`votes`, on the threshold features.

    ``noise`` scales the oblique combinations (its own scale of each feature, step 3).
    """
    data = _classifier_features(model, model.demo_x)
    scale = _scales(noise, model.features, model.body is not None)
    features = _threshold_features(data, scale, threshold_columns(data.shape[1]))
    return tuple(_conditions(features, _does(model, voted)) for voted in votes(model))


def _landed_thresholds(model: GraspModel, noise: ExecutionNoise) -> NDArray[np.float64]:
    """Q' of module docstring step 4: shape (N, V), the votes of :func:`votes`."""
    from ..kernels import landed_thresholds
    conditions = thresholds(model, noise)
    scale = _scales(noise, model.features, model.body is not None)  # one entry per classifier feature
    columns = threshold_columns(scale.size)
    used = sorted({c.feature for group in conditions for c in group})  # only these are computed at the landings
    feature = np.array([used.index(c.feature) for group in conditions for c in group], dtype=np.int64)
    inner = np.array([c.inner for group in conditions for c in group])
    outer = np.array([c.outer for group in conditions for c in group])
    starts = np.cumsum([0] + [len(group) for group in conditions]).astype(np.int64)
    z = stratified_draws(THRESHOLD_DRAWS, 0)
    n, d = model.demo_x.shape
    out = np.empty((n, len(conditions)))
    for first in range(0, n, _CHUNK):
        rows = model.demo_x[first:first + _CHUNK]
        landed = perturb(rows, z, noise, model.features).reshape(rows.shape[0] * THRESHOLD_DRAWS, d)
        landed_features = _threshold_features(_classifier_features(model, landed), scale,
                                              tuple(columns[j] for j in used))
        out[first:first + rows.shape[0]] = landed_thresholds(landed_features, feature, inner, outer, starts,
                                                             THRESHOLD_DRAWS)
    return out


def _per_zone(model: GraspModel, q: NDArray[np.float64], within: NDArray[np.bool_]) -> NDArray[np.float64]:
    """min(Q_k, prod_{i in k} Q_i) within S_n, else 0 (module docstring, step 5): shape (N, K)."""
    voted = votes(model)
    n = q.shape[0]
    out = np.zeros((n, len(model.zones)))
    for k, zone in enumerate(model.zones):
        tasks = np.ones(n)
        for i in range(len(model.task_names)):  # the product in task order
            if zone >> i & 1:
                tasks *= q[:, voted.index(1 << i)]
        out[:, k] = np.where(within[:, k], np.minimum(q[:, k], tasks), 0.0)
    return out


_TABLES: weakref.WeakKeyDictionary[GraspModel, dict[ExecutionNoise, NDArray[np.float64]]] = \
    weakref.WeakKeyDictionary()
_BY_CONTENT: OrderedDict[tuple[str, ExecutionNoise], NDArray[np.float64]] = OrderedDict()
"""Estimates kept by the content of what they read, at most :data:`_KEPT` (the oldest goes first)."""
_KEPT = 16


def _content(model: GraspModel) -> str:
    """SHA-256 of everything the estimate reads: the demonstrations, task sets, feature bounds and the body."""
    digest = hashlib.sha256()
    arrays: list[Any] = [model.demo_x, model.demo_sets, model.features.lower, model.features.upper]
    if model.body is not None:
        arrays.extend(model.body.kernel_arrays)
    for array in arrays:
        a = np.ascontiguousarray(array)
        digest.update(f'{a.dtype.str}{a.shape}'.encode())
        digest.update(a.tobytes())
    return digest.hexdigest()


def retention(model: GraspModel, noise: ExecutionNoise) -> NDArray[np.float64]:
    """R (module docstring): shape (N, K), demonstration n, zone k; kept per model and noise after the first call.

    Read-only; the same bits on any machine. A model read again (another object with the same demonstrations,
    feature bounds and body, as a node gets when a model is sent again) reuses the estimate of the first.
    """
    tables = _TABLES.setdefault(model, {})
    table = tables.get(noise)
    if table is None:
        key = (_content(model), noise)
        table = _BY_CONTENT.get(key)
        if table is None:
            table = _retention(model, noise)
            table.setflags(write=False)
            _BY_CONTENT[key] = table
            while len(_BY_CONTENT) > _KEPT:
                _BY_CONTENT.popitem(last=False)
        tables[noise] = table
    return table


def _retention(model: GraspModel, noise: ExecutionNoise) -> NDArray[np.float64]:
    zones = np.asarray(model.zones, dtype=np.int64)
    within = (model.demo_sets[:, None] & zones[None, :]) == zones[None, :]  # (N, K)
    if noise.is_zero:
        out: NDArray[np.float64] = within.astype(np.float64)
        return out
    from ..kernels import landed_votes
    n, d = model.demo_x.shape
    voted = votes(model)
    landed = perturb(model.demo_x, stratified_draws(DRAWS, 0), noise, model.features).reshape(n * DRAWS, d)
    labels = np.stack([_does(model, mask) for mask in voted], axis=1)
    q = landed_votes(_classifier_features(model, model.demo_x), labels, bandwidths(model, noise) * NARROWING,
                     _classifier_features(model, landed), DRAWS)  # (N, V)
    vote, threshold = _per_zone(model, q, within), _per_zone(model, _landed_thresholds(model, noise), within)
    out = np.sqrt(vote * threshold)
    return out
