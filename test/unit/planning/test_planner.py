"""The paper's planner (method 'lm'): a well-posed answer, feasible and plausible grasps, honest status.

Exact where possible, nearest to the reference, never decided by float noise; tested over every task,
every model, random and perturbed intents.

Stability under last-bit perturbations is asserted for converged plans: for the grasp where P matches
v, and for the objective where only least squares is possible (a nearly flat least-squares valley need
not name one grasp). A plan stopped at its iteration limit says so in its status. The benchmark's
stability section reports how often the grasp itself moves, over all plans (rarely, by about 1e-6: the
projection's end point can depend on its path). The property tests are derandomised, so CI runs the
same examples on every machine.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from grasp_intent_ros import kernels
from grasp_intent_ros.errors import PlanningError
from grasp_intent_ros.kernels import least_squares, selection
from grasp_intent_ros.kernels.types import Body, Mixture
from grasp_intent_ros.method import intent
from grasp_intent_ros.method.data import Demonstrations
from grasp_intent_ros.method.features import FINGERS, MICO_3F, FeatureSpace
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import common, lm, planner, scipy_methods
from grasp_intent_ros.planning.options import ScipyOptions
from grasp_intent_ros.resources import config_dir

from ..fixed_reference import FixedReference

CASES = [(0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9), (0.9, 0.9, 0.1), (0.9, 0.1, 0.9), (0.1, 0.9, 0.9),
         (0.9, 0.9, 0.9)]
"""Every task alone, every pair, all three (the paper's 7 cases per object)."""



def plan_lm(model: GraspModel, v: np.ndarray, **inputs: object) -> common.PlanResult:
    """The paper's planner (method 'lm'), the subject of this module; the default method is test_ranking's."""
    return planner.plan(model, v, method='lm', **inputs)  # type: ignore[arg-type]


SHIPPED = ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')
STABLE_PALM_M = 1e-6
STABLE_APPROACH = 1e-6


def _v(w: tuple[float, ...], model: GraspModel | None = None) -> np.ndarray:
    r = intent.interpret(w, None if model is None else model.zones)
    assert r.v is not None
    return r.v


@pytest.fixture(scope='module')
def shipped() -> dict[str, GraspModel]:
    return {name: GraspModel.load(config_dir() / 'models' / f'{name}.yaml') for name in SHIPPED}


def assert_feasible(model: GraspModel, x: np.ndarray) -> None:
    assert np.all(x >= model.lower) and np.all(x <= model.upper)
    assert np.linalg.norm(x[3:6]) == pytest.approx(1.0, abs=1e-9)
    if model.body is not None:
        assert model.body.distance(x[None, :3])[0][0] >= model.body.margin - 1e-9


@pytest.mark.parametrize('method', ['lm', 'slsqp', 'trust-constr'])
@pytest.mark.parametrize('w', CASES)
def test_result_is_consistent_feasible_and_never_worse_than_algorithm1s_start(
        toy_model: GraspModel, w: tuple[float, ...], method: str) -> None:
    v = _v(w)
    res = planner.plan(toy_model, v, method=method)  # type: ignore[arg-type]
    # scipy's solvers may stop at their iteration limit (sliding along the matches): reported, not hidden
    assert res.success or (method != 'lm' and res.status == 'solver_failed'
                           and ('limit' in res.message or 'maximum number' in res.message)), res.message
    first = common.select_starts(toy_model, v, n_starts=1)[0]
    assert res.objective <= common.objective(toy_model, v, first) + common.MATCH_TOL
    assert_allclose(res.reference, first)
    assert_allclose(res.posterior, toy_model.posterior(res.x), atol=1e-12)
    assert_allclose(res.w, intent.reconstruct_w(res.posterior, toy_model.zones, 3), atol=1e-12)
    assert_feasible(toy_model, res.x)
    assert res.objective == pytest.approx(0.5 * np.sum((v - res.posterior) ** 2), abs=1e-15)
    assert res.exact == (res.objective <= common.MATCH_TOL)
    assert res.candidates[0].distance == pytest.approx(
        float(np.linalg.norm((res.x - res.reference) / toy_model.feature_scale)))


def test_first_start_is_the_best_demonstration_of_the_top_zone(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.1))  # top zone UT
    start = common.select_starts(toy_model, v, n_starts=1)[0]
    ut = toy_model.zones.index(0b011)
    members = (toy_model.demo_sets & 0b011) == 0b011
    f = [common.objective(toy_model, v, x) for x in toy_model.demo_x[members]]
    assert_allclose(start, toy_model.demo_x[members][int(np.argmin(f))])
    assert np.argmax(v) == ut


@settings(max_examples=200, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 40), n_starts=st.integers(1, 6), top_zones=st.integers(1, 4),
       ties=st.booleans())
def test_demonstration_starts_follow_their_stated_rule(seed: int, n: int, n_starts: int, top_zones: int,
                                                       ties: bool) -> None:
    """The compiled selection against the rule written out: the top zone's best, then the best of the top zones."""
    rng = np.random.default_rng(seed)
    K = 4
    posterior = rng.dirichlet(np.ones(K), size=n)
    if ties:  # repeated demonstrations: equal f, decided by demonstration order
        posterior[rng.integers(0, n, size=n)] = posterior[0]
    members = rng.random((K, n)) < 0.4
    v = rng.dirichlet(np.ones(K))
    zones = common.zone_order(v)[:top_zones]
    f = [0.5 * sum((v[k] - posterior[i, k]) ** 2 for k in range(K)) for i in range(n)]  # summed in order
    rank = {i: (round(f[i] / (1e-12 * (1 + f[i]))), i) for i in range(n)}
    top = [i for i in range(n) if members[zones[0], i]]
    first = min(top or range(n), key=rank.__getitem__)
    rest = sorted((i for i in range(n) if i != first and members[zones, i].any()), key=rank.__getitem__)
    got = kernels.select_demonstrations(posterior, v, members, zones, n_starts - 1, common.MATCH_TOL)
    assert got.tolist() == [first] + rest[:n_starts - 1]


def test_analytic_gradient_of_the_objective(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.9))
    rng = np.random.default_rng(3)
    for x in toy_model.demo_x[rng.integers(0, len(toy_model.demo_x), 30)]:
        _, g = scipy_methods.objective_and_gradient(toy_model, v, x)
        h = 1e-6
        fd = np.array([(common.objective(toy_model, v, x + h * e) - common.objective(toy_model, v, x - h * e))
                       / (2 * h) for e in np.eye(x.size)])
        assert np.abs(g - fd).max() <= 1e-5 * max(np.abs(fd).max(), 1e-4)


def _cand(f: float, dist: float, index: int, success: bool = True) -> common.Candidate:
    x = np.full(3, float(index))
    return common.Candidate(x=x, posterior=np.ones(1), objective=f, distance=dist, start=x,
                             start_objective=f, start_index=index, success=success, message='', iterations=1)


def test_the_choice_rule_tolerance_then_distance_then_start_order() -> None:
    cand = _cand

    # a worse objective loses even when nearer; objectives within the match tolerance tie
    order = common.in_choice_order([cand(1e-3, 0.1, 0), cand(1e-20, 2.0, 1), cand(1e-14, 1.0, 2)], 0.0)
    assert [c.start_index for c in order] == [2, 1, 0]
    # distances within DISTANCE_TOL of the nearest tie: the earlier start wins, whatever the last bits
    tie = common.DISTANCE_TOL / 2
    assert common.in_choice_order([cand(1e-20, 1.0 + tie, 0), cand(1e-20, 1.0, 1)], 0.0)[0].start_index == 0
    assert common.in_choice_order([cand(1e-20, 1.0, 0), cand(1e-20, 1.0 + tie, 1)], 0.0)[0].start_index == 0
    # least squares: objectives within 1e-6 relative of the best tie
    order = common.in_choice_order([cand(2e-3 * (1 + 1e-8), 0.5, 0), cand(2e-3, 1.5, 1), cand(3e-3, 0.1, 2)], 0.0)
    assert [c.start_index for c in order] == [0, 1, 2]


def test_a_stream_keeps_its_branch_within_the_residual_band() -> None:
    """Rule 6's band: with no exact match, a converged candidate within WARM_BAND in |v - P| of the best ties."""
    band = common.WARM_BAND
    best = 2e-3  # residual sqrt(2 f) = 0.0632...
    inside = 0.5 * (math.sqrt(2 * best) + 0.99 * band) ** 2
    outside = 0.5 * (math.sqrt(2 * best) + 1.01 * band) ** 2
    # the nearer one within the band is chosen; a fresh plan (band 0) keeps the best
    assert common.in_choice_order([_cand(best, 2.0, 0), _cand(inside, 0.1, 1)], band)[0].start_index == 1
    assert common.in_choice_order([_cand(best, 2.0, 0), _cand(inside, 0.1, 1)], 0.0)[0].start_index == 0
    # beyond the band, or stopped unconverged, the nearer one does not tie
    assert common.in_choice_order([_cand(best, 2.0, 0), _cand(outside, 0.1, 1)], band)[0].start_index == 0
    assert common.in_choice_order([_cand(best, 2.0, 0), _cand(inside, 0.1, 1, success=False)], band)[0].start_index == 0
    # the best itself is a match even when it stopped unconverged
    assert common.in_choice_order([_cand(best, 2.0, 0, success=False), _cand(inside, 0.1, 1)], band)[0].start_index == 1
    # an exact match exists: the band does not apply, a near-match nearer to the reference does not tie
    assert common.in_choice_order([_cand(1e-20, 2.0, 0), _cand(1e-8, 0.1, 1)], band)[0].start_index == 0


def _walk_jumps(model: GraspModel, steps: int, seed: int) -> list[int]:
    """Steps of bench_planner's walk of w (N(0, 0.01) per task) where the warm-started grasp jumps (20 mm, 0.3 rad)."""
    rng = np.random.default_rng(seed)
    w, previous, jumps, step = np.array([0.9, 0.5, 0.2]), None, [], 0
    while step < steps:
        w = np.clip(w + rng.normal(0.0, 0.01, 3), 0.02, 0.98)
        v = intent.interpret(w, model.zones).v
        if v is None:
            continue
        x = plan_lm(model, v, warm_start=previous).x
        if previous is not None and (np.linalg.norm(x[:3] - previous[:3]) > 0.02
                                     or x[3:6] @ previous[3:6] < math.cos(0.3)):
            jumps.append(step)
        previous, step = x, step + 1
    return jumps


@pytest.mark.slow
@pytest.mark.parametrize('name', ['flashlight_7zone', 'cup_7zone'])
def test_the_band_adds_no_jump_to_a_warm_stream(shipped: dict[str, GraspModel], monkeypatch: pytest.MonkeyPatch,
                                                name: str) -> None:
    """The first 140 steps of the benchmark's walks with seeds 0 and 1: every jump with rule 6's band is one without.

    The band keeps a stream on its branch among minima whose residuals lie within it
    (:func:`test_a_stream_keeps_its_branch_within_the_residual_band`, :func:`test_only_a_warm_plan_has_the_band`);
    it must never make the grasp jump where the stream without it stays. A walk where the band removes
    back-and-forth flips is searched for by these walks with seeds 0-9 on both 7-zone models (jumps without
    the band, WARM_BAND 0, that the band removes); on the shipped data, where nearly every w has an exact
    match, the search finds none (docs/planner.md, "The paper's solvers on the feasible data").
    """
    model = shipped[name]
    for seed in (0, 1):
        with_band = _walk_jumps(model, 140, seed)
        with monkeypatch.context() as patch:
            patch.setattr(planner, 'WARM_BAND', 0.0)
            without = _walk_jumps(model, 140, seed)
        assert set(with_band) <= set(without), (seed, with_band, without)


def test_only_a_warm_plan_has_the_band(shipped: dict[str, GraspModel], monkeypatch: pytest.MonkeyPatch) -> None:
    """A fresh plan ignores WARM_BAND bit for bit; a warm one from the same reference takes the nearest in it.

    The witness w: the first of bench_planner's seed-0 draws (``random_targets(model, 500, 0)``) on the cup
    7-zone model whose fresh plan has no exact match and whose warm plan with every converged candidate tied
    (WARM_BAND 1) takes a nearer one (#9; after regenerating the data, repeat that search).
    """
    model = shipped['cup_7zone']
    v = _v((0.9808353387762301, 0.6855419844806947, 0.6504592762678163), model)  # no exact match
    fresh = plan_lm(model, v)
    assert not fresh.exact
    monkeypatch.setattr(planner, 'WARM_BAND', 1.0)  # every converged candidate ties
    assert plan_lm(model, v).x.tobytes() == fresh.x.tobytes()
    wide = plan_lm(model, v, warm_start=fresh.reference)
    nearest = min((c for c in wide.candidates if c.success), key=lambda c: c.distance)
    assert wide.chosen.distance == nearest.distance < fresh.chosen.distance


def _choice_rule(f: list[float], dist: list[float], start: list[int], xs: np.ndarray, converged: list[bool],
                 band: float) -> list[int]:
    """Rule 6 as the module docstring states it, in plain Python: the oracle for the compiled choice order."""
    best = min(f)
    matches = [i for i, fi in enumerate(f) if fi <= best + max(common.MATCH_TOL, common.F_RTOL * best)
               or (best > common.MATCH_TOL and converged[i] and math.sqrt(2 * fi) <= math.sqrt(2 * best) + band)]
    order, pool = [], list(matches)
    while pool:
        nearest = min(dist[i] for i in pool)
        pick = min(pool, key=lambda i: (dist[i] > nearest + common.DISTANCE_TOL, start[i]))
        order.append(pick)
        pool.remove(pick)
    ranked = np.argsort(selection._rank_keys(np.array(f), common.MATCH_TOL)).tolist()
    order += [i for i in ranked if i not in matches]
    kept: list[int] = []
    for i in order:  # a row within 1e-18 (squared, relative) of an earlier kept one is dropped
        if not any(np.sum(((xs[i] - xs[j]) / np.maximum(np.abs(xs[j]), 1.0)) ** 2) < 1e-18 for j in kept):
            kept.append(i)
    return kept


@settings(max_examples=400, deadline=None, derandomize=True)
@given(data=st.data(), n=st.integers(2, 12))
def test_the_compiled_choice_order_is_the_rule(data: st.DataObject, n: int) -> None:
    """Objectives and distances drawn around ties at the tolerances and the band's edge, repeated grasps included."""
    band = data.draw(st.sampled_from([0.0, common.WARM_BAND]))
    base_f = data.draw(st.sampled_from([0.0, 1e-20, 1e-13, 2e-3, 0.5]))
    edge = 0.5 * (math.sqrt(2 * base_f) + band) ** 2 / base_f if base_f > 0.0 else 1.0  # f's factor at the edge
    f = [base_f * data.draw(st.sampled_from([1.0, 1 + 1e-7, 1 + 1e-5, 3.0, edge * (1 - 1e-9), edge * (1 + 1e-9)]))
         + data.draw(st.sampled_from([0.0, 5e-13, 2e-12])) for _ in range(n)]
    dist = [data.draw(st.sampled_from([0.5, 1.0, 1.0 + 4e-7, 1.0 + 2e-6, 3.0])) for _ in range(n)]
    start = data.draw(st.permutations(list(range(n))))
    converged = [data.draw(st.booleans()) for _ in range(n)]
    xs = np.array([[float(data.draw(st.integers(0, 3))), 1.0] for _ in range(n)])
    cands = [common.Candidate(x=xs[i], posterior=np.ones(1), objective=f[i], distance=dist[i], start=xs[i],
                               start_objective=f[i], start_index=start[i], success=converged[i], message='',
                               iterations=1)
             for i in range(n)]
    expected = _choice_rule(f, dist, start, xs, converged, band)
    assert [c.start_index for c in common.in_choice_order(cands, band)] == [start[i] for i in expected]


def _random_vs(model: GraspModel, n: int, seed: int, zero_share: float) -> list[np.ndarray]:
    """Seeded random v over the model's zones (n of them), about ``zero_share`` with one zone at 0."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        v = rng.dirichlet(np.ones(len(model.zones)))
        if rng.random() < zero_share:
            v[rng.integers(len(v))] = 0.0
            v /= v.sum()
        out.append(v)
    return out


@pytest.mark.parametrize('name', ['cup_7zone', 'flashlight_7zone'])
def test_the_compiled_screen_is_the_log_odds_spread_or_f(shipped: dict[str, GraspModel], name: str) -> None:
    model = shipped[name]
    pool, log_joint_t, posterior = model.start_pool
    for v in _random_vs(model, 50, 3, 0.5):
        if v.min() > 0.0:
            q = log_joint_t - common.c_log(v)[:, None]
            score = q.max(axis=0) - q.min(axis=0)
        else:
            score = 0.5 * np.sum((v[None, :] - posterior) ** 2, axis=1)
        expected = np.argsort(selection._rank_keys(score, common.MATCH_TOL))[:lm._SCREEN]
        got = kernels.screen(log_joint_t, common.c_log(v) if v.min() > 0.0 else np.zeros(0), posterior, v,
                              lm._SCREEN, common.MATCH_TOL)
        if v.min() > 0.0:  # the same arithmetic: the same order
            assert got.tolist() == expected.tolist()
        else:  # numpy sums the squares in an order of its own: the same starts up to ties at 1e-12
            assert_allclose(score[got], score[expected], rtol=1e-12, atol=1e-300)
        assert_allclose(lm.search_starts(model, v), pool[got])


def test_ranking_quantises_f_then_takes_the_index_and_puts_nan_last() -> None:
    f = np.array([3e-3, 1e-20, np.nan, 2e-3, 1e-14, 2e-3 * (1 + 1e-13), 5.0, 0.5])
    order = np.argsort(selection._rank_keys(f, common.MATCH_TOL)).tolist()
    # 1e-20 and 1e-14 are both 0 at the quantum (index order); 2e-3 and its 1e-13 relative neighbour tie
    assert order == [1, 4, 3, 5, 0, 7, 6, 2]
    for count in range(-1, len(f) + 2):
        assert selection._first_ranked(f, common.MATCH_TOL, count).tolist() == order[:max(count, 0)]
    rng = np.random.default_rng(7)
    for n in (1, 6, 40, 600):  # ties at the quantum as well as distinct values
        f = np.round(rng.exponential(1e-3, n), 5) * (1.0 + 1e-14 * rng.standard_normal(n))
        ranked = np.argsort(selection._rank_keys(f, common.MATCH_TOL)).tolist()
        for count in (1, 3, 6, n):
            assert selection._first_ranked(f, common.MATCH_TOL, count).tolist() == ranked[:count]


def test_unique_rows_drop_exact_repeats_only() -> None:
    x = np.array([[0.0, 1.0], [-0.0, 1.0], [1.0, 2.0], [0.0, 1.0], [1.0, np.nextafter(2.0, 3.0)], [1.0, 2.0]])
    assert common.unique_rows(x).tolist() == [[0.0, 1.0], [1.0, 2.0], [1.0, np.nextafter(2.0, 3.0)]]


def test_warm_start_on_a_match_is_its_own_answer(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.1))
    first = plan_lm(toy_model, v)
    assert first.exact, first.message
    again = plan_lm(toy_model, v, warm_start=first.x)
    assert_allclose(again.reference, first.x)
    assert_allclose(again.x, first.x, atol=1e-9)
    assert again.candidates[0].distance < 1e-8


def test_accept_hook_takes_the_first_acceptable_candidate_in_choice_order(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.1))
    first = plan_lm(toy_model, v)
    best = first.candidates[0].x
    asked: list[np.ndarray] = []

    def not_best(x: np.ndarray) -> bool:
        asked.append(x)
        return not np.allclose(x, best)

    res = plan_lm(toy_model, v, accept=not_best)
    assert res.rejected == 1 and not np.allclose(res.x, best)
    assert_allclose(res.candidates[0].x, best)
    assert_allclose(res.candidates[res.rejected].x, res.x)
    assert len(asked) == 2  # each candidate asked once, in choice order, until one is taken
    assert res.exact == first.exact
    none = plan_lm(toy_model, v, accept=lambda x: False)
    assert none.status == 'rejected' and not none.success
    assert none.rejected == len(none.candidates)


def test_status_tells_an_iteration_limit_from_convergence(shipped: dict[str, GraspModel],
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    model = shipped['cup_7zone']
    v = _v((0.1, 0.9, 0.1), model)
    assert plan_lm(model, v).status == 'ok'
    monkeypatch.setattr(lm, '_GN_MAXITER', 1)
    for name in ('_LM_RACE', '_LM_MAXITER', '_NEWTON_RACE', '_NEWTON_MAXITER', '_OPEN_LM'):
        monkeypatch.setattr(lm, name, 1)
    res = plan_lm(model, v)
    assert res.status == 'solver_failed' and not res.success
    assert 'iteration limit' in res.message
    # the starts that the best few left behind say so (and are not counted converged either)
    behind = [c for c in res.candidates if 'left at 1 iterations, behind 3 others' in c.message]
    assert behind and not any(c.success for c in behind)


def test_a_match_found_by_the_least_squares_says_so(shipped: dict[str, GraspModel]) -> None:
    """No start's projection matches v; a least-squares end point, projected, does.

    The answer is an exact match, converged, and its message says how it was found (it said
    'least squares: converged'). The witness w: the first of bench_planner's seed-0 draws
    (``random_targets(model, 500, 0)``) on the cup 7-zone model whose plan says so (#5; after regenerating the
    data, repeat that search).
    """
    model = shipped['cup_7zone']
    v = _v((0.17565562060255901, 0.8631789223498866, 0.5414612202490917), model)
    res = plan_lm(model, v)
    assert res.exact and res.status == 'ok'
    assert res.chosen.message == 'exact match (least squares, then projected)'


def test_hessian_of_the_objective_matches_finite_differences(shipped: dict[str, GraspModel]) -> None:
    """The Newton stage's exact Hessian of f against central differences of the analytic gradient (1e-5 relative)."""
    from grasp_intent_ros.kernels.posterior import _posterior_hessian
    from grasp_intent_ros.kernels.types import Mixture
    rng = np.random.default_rng(3)
    for name in ('cup_7zone', 'flashlight_7zone'):
        model = shipped[name]
        for _ in range(5):
            v = rng.dirichlet(np.ones(len(model.zones)))
            i, j = rng.choice(len(model.zones), 2, replace=False)
            x = 0.5 * (model.means[i] + model.means[j])  # between two zones, where P varies
            K, d = model.means.shape
            hess = np.empty((d, d))
            _posterior_hessian(x, Mixture(model.means, model.precisions, model.log_norm), v, np.empty(K),
                               np.empty((K, d)), np.empty((K, d)), hess, np.empty(d))
            step = 1e-6 * model.feature_scale
            numeric = np.stack([(scipy_methods.objective_and_gradient(model, v, x + h)[1]
                                 - scipy_methods.objective_and_gradient(model, v, x - h)[1]) / (2.0 * h[i])
                                for i, h in enumerate(np.diag(step))])
            assert_allclose(hess, numeric, rtol=0.0, atol=1e-5 * np.abs(hess).max())


def test_the_distance_alone_is_the_distance_with_its_gradient(shipped: dict[str, GraspModel]) -> None:
    """The kernels' distance without the gradient (where only the distance decides) is the same number."""
    from grasp_intent_ros.kernels.geometry import _distance
    from grasp_intent_ros.kernels.types import Body
    body = shipped['cup_7zone'].body
    assert body is not None
    cylinder = Body(*body.kernel_arrays)
    box = cylinder._replace(kinds=np.ones(1, dtype=np.int64), centres=np.array([[0.01, 0.0, 0.02]]),
                            halfs=np.array([[0.03, 0.02, 0.05]]))
    rng = np.random.default_rng(8)
    for arrays in (cylinder, box):
        for p in rng.normal(0.0, 0.06, (2000, 3)):
            assert _distance(p, arrays, False)[0] == _distance(p, arrays, True)[0]


def test_kernel_sums_run_in_their_stated_order() -> None:
    """The unrolled kernel loops give, bit for bit, each sum taken term by term in index order.

    The recorded bags' answers rest on the kernels' arithmetic; an unrolled loop must not reorder a sum
    (shapes with and without a remainder of the unrolling).
    """
    from grasp_intent_ros.kernels.linalg import _gram
    from grasp_intent_ros.kernels.posterior import _log_joint_score
    from grasp_intent_ros.kernels.types import Mixture
    rng = np.random.default_rng(6)
    for m, n in ((7, 10), (8, 7), (3, 1), (2, 4)):
        J = rng.standard_normal((m, n))
        out = np.empty((n, n))
        _gram(J, out)
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(m):
                    acc += float(J[k, i]) * float(J[k, j])
                assert out[i, j] == acc
    for K, d in ((7, 10), (4, 7), (2, 3)):
        means = rng.standard_normal((K, d))
        prec = rng.standard_normal((K, d, d))
        log_norm = rng.standard_normal(K)
        x = rng.standard_normal(d)
        lj, g = np.empty(K), np.empty((K, d))
        _log_joint_score(x, Mixture(means, prec, log_norm), lj, g, np.empty(d))
        for k in range(K):
            diff = [float(x[j] - means[k, j]) for j in range(d)]
            q = 0.0
            for i in range(d):
                acc = 0.0
                for j in range(d):
                    acc += float(prec[k, i, j]) * diff[j]
                assert g[k, i] == -acc
                q += diff[i] * -acc
            assert lj[k] == float(log_norm[k]) + 0.5 * q


def test_spd_solve_falls_back_to_lu_where_cholesky_fails() -> None:
    """The kernels' solve of their ridged SPD systems: Cholesky, else LU, else LU's error.

    A symmetric matrix that is not positive definite (as rounding can leave a system whose ridge is below
    the rounding of its entries) is still solved; NaN raises, as np.linalg.solve does.
    """
    from grasp_intent_ros.kernels.linalg import _spd_solve
    rng = np.random.default_rng(5)
    J = rng.standard_normal((7, 10))
    b = rng.standard_normal(10)
    indefinite = np.diag(np.r_[-1.0, np.ones(9)]) + 0.1 * (J.T @ J)
    assert np.linalg.eigvalsh(indefinite).min() < 0.0
    for m in (J.T @ J + 1e-7 * np.eye(10), indefinite):
        z = np.empty(10)
        _spd_solve(m, b, z, np.empty((10, 10)))
        # a backward-stable solve leaves a residual of about d * eps * cond(m) * |b| in any summation order
        # (numpy's m @ z runs the CPU's BLAS kernels): 1e-8 is 1e6 times that
        assert_allclose(m @ z, b, atol=1e-8 * np.abs(b).max() * np.linalg.cond(m))
    with pytest.raises(np.linalg.LinAlgError):
        _spd_solve(np.full((10, 10), np.nan), b, np.empty(10), np.empty((10, 10)))


def test_newton_converges_where_least_squares_steps_run_out(shipped: dict[str, GraspModel],
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Newton converges where the Levenberg-Marquardt steps stop at their limit.

    No exact match; the LM iteration alone stops at its limit in a nearly flat valley, Newton with the exact
    Hessian converges from its best end points, lower or equal. The witness w: the first of bench_planner's
    seed-0 draws (``random_targets(model, 500, 0)``) on the cup 7-zone model without an exact match whose
    plan converges by least squares and stops at the limit without the Newton polish (#30; after regenerating
    the data, repeat that search).
    """
    model = shipped['cup_7zone']
    v = _v((0.9274239286245599, 0.9679261899246464, 0.014706304965369288), model)
    res = plan_lm(model, v)
    assert not res.exact and res.status == 'ok' and res.chosen.message == 'least squares: converged'
    monkeypatch.setattr(lm, '_NEWTON_POLISH', 0)
    steps_only = plan_lm(model, v)
    assert steps_only.status == 'solver_failed'
    assert res.objective <= steps_only.objective * (1.0 + 1e-12)


def test_body_surface_curvature_matches_finite_differences(shipped: dict[str, GraspModel]) -> None:
    """The Hessian of the distance to the body (the least squares' surface curvature) against differences.

    On the cylinder's side and beyond its cap (flat), against central differences of the distance's
    gradient (1e-6 relative).
    """
    from grasp_intent_ros.kernels.geometry import _distance, _distance_hessian
    from grasp_intent_ros.kernels.types import Body
    body = shipped['flashlight_7zone'].body
    assert body is not None
    arrays = Body(*body.kernel_arrays)
    for p in (np.array([0.03, 0.0, 0.041]), np.array([0.03, 0.012, 0.035]), np.array([-0.05, -0.02, 0.0]),
              np.array([0.12, 0.005, 0.03])):
        step = 1e-7
        numeric = np.stack([(np.array(_distance(p + h, arrays, True)[1:])
                             - np.array(_distance(p - h, arrays, True)[1:])) / (2.0 * step)
                            for h in np.eye(3) * step])
        hess = np.full((3, 3), np.nan)
        _distance_hessian(p, arrays, hess)
        assert_allclose(hess, numeric, rtol=0.0, atol=1e-6 * max(np.abs(numeric).max(), 1.0))
        assert_allclose(hess, hess.T, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize('w', [(0.00022169971029817326, 0.48253762200167294, 0.6080006650804403)])
def test_least_squares_with_the_palm_on_the_body_converge_as_well_as_a_60_start_search(
        shipped: dict[str, GraspModel], fixed_reference: FixedReference, w: tuple[float, ...]) -> None:
    """Intents without an exact match whose least-squares best puts the palm on the body.

    The iterations hold the palm on the body's surface (steps on its tangent plane, Newton with its
    curvature); pushing the palm back out after each step crawled to the iteration limits. The witnesses:
    the first three of bench_planner's draws with seeds 0, 1, 2 (``random_targets(model, 500, seed)``) on the
    cup 7-zone model without an exact match whose plan converges with the palm on the body: on the shipped
    data the 1500 draws hold one (seed 0, #301; after regenerating the data, repeat that search).
    """
    model = shipped['cup_7zone']
    assert model.body is not None
    v = _v(w, model)
    res = plan_lm(model, v)
    assert res.status == 'ok' and not res.exact, res.message
    assert abs(model.body.distance(res.x[None, :3])[0][0] - model.body.margin) <= 1e-9
    assert res.objective <= 1.01 * fixed_reference.search('cup_7zone', v)


@pytest.mark.slow
@pytest.mark.parametrize(('name', 'w'), [
    ('flashlight_7zone', (0.991684718333888, 0.9191899892378982, 0.28984114981603737)),
    ('cup_7zone', (0.6153851114812539, 0.38367755426188344, 0.997209935789211)),
])
def test_least_squares_along_a_bound_do_as_well_as_a_60_start_search(shipped: dict[str, GraspModel],
                                                                     fixed_reference: FixedReference, name: str,
                                                                     w: tuple[float, ...]) -> None:
    """Intents whose least-squares best has a finger closed at its bound (the benchmark's seed-0 w #250, #8).

    A variable on a bound whose gradient pointed inwards was free, but the solved step took it out: clipped
    at the bound, the step was not the one the system was solved for, was mostly rejected, and the
    iterations zigzagged to their limits, 1.10 and 1.50 times the search's objective. Now such a variable is
    held and the step solved again: 0.82 and 0.37 times it (the search on fixed kernels).
    """
    model = shipped[name]
    v = _v(w, model)
    res = plan_lm(model, v)
    assert res.objective <= 1.01 * fixed_reference.search(name, v)


@pytest.mark.slow
@pytest.mark.parametrize('w', [(0.8574042765875693, 0.033585575305464355, 0.7296554464299441),
                               (0.1995154439682133, 0.9421131105064978, 0.36511016824482856)])
def test_least_squares_find_the_minima_with_a_finger_open(shipped: dict[str, GraspModel],
                                                          fixed_reference: FixedReference,
                                                          w: tuple[float, ...]) -> None:
    """Intents whose least-squares best comes from a start with one finger open.

    Every origin's fingers sit near the demonstrations' closure, and minima with a finger open are reached
    only from the last round's starts, the best screened start with one finger open. The witnesses: the first
    two of bench_planner's seed-0 draws (``random_targets(model, 500, 0)``) on the cup 7-zone model without
    an exact match whose plan comes from such a start (#4, #22; after regenerating the data, repeat that
    search).

    The search on other OpenBLAS kernels can end in other, lower minima (fixed_reference.py): such a minimum is
    a lead for the planner, not a reference; the comparison is with the search on fixed kernels.
    """
    model = shipped['cup_7zone']
    v = _v(w, model)
    res = plan_lm(model, v)
    assert not res.exact and res.status == 'ok'
    assert res.objective <= 1.01 * fixed_reference.search('cup_7zone', v)
    opened = res.chosen.start[FINGERS] == model.lower[FINGERS]
    assert opened.sum() == 1


def _rule_5(model: GraspModel, v: np.ndarray, origins: np.ndarray, screened: np.ndarray,
            projection: lm._LogOddsProjection | None) -> tuple[np.ndarray, ...]:
    """Rule 5 as the module docstring states it, driven from Python over the compiled iterations: the oracle."""
    feas = common.Feasible(model)
    body = Body(*feas.body)
    v_path = np.rint(v / lm._LS_QUANTUM) * lm._LS_QUANTUM
    consts = (model.means, model.precisions, model.log_norm)
    mixture = Mixture(*consts)

    def f_of(xs: np.ndarray, target: np.ndarray) -> np.ndarray:
        return kernels.score(xs, target, *consts, xs[0], feas.scale)[1] if len(xs) else np.zeros(0)

    def first(f: np.ndarray, count: int) -> np.ndarray:
        return np.argsort(selection._rank_keys(f, common.MATCH_TOL))[:count]

    def levenberg(starts: np.ndarray, maxiter: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return least_squares._least_squares(np.ascontiguousarray(starts), v_path, mixture, feas.lower, feas.upper,
                                            feas.a.start, feas.a.stop, body, maxiter, lm._LM_FTOL,
                                            lm._LM_RIDGE)

    def newton(starts: np.ndarray, maxiter: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return least_squares._newton_least_squares(np.ascontiguousarray(starts), v_path, mixture, feas.lower,
                                                   feas.upper, feas.scale, feas.a.start, feas.a.stop, body, maxiter,
                                                   lm._NEWTON_STEPTOL, lm._LM_RIDGE)

    def polish(xs: np.ndarray, ok: np.ndarray, its: np.ndarray, left: np.ndarray) -> None:
        best = first(f_of(xs, v_path), lm._NEWTON_POLISH)
        xs_n, ok_n, its_n = newton(xs[best], lm._NEWTON_RACE)
        going = np.flatnonzero(~ok_n)
        ahead = going[first(f_of(xs_n[going], v_path), lm._NEWTON_KEEP)]
        if ahead.size:
            xs_n[ahead], ok_n[ahead], more = newton(xs_n[ahead], lm._NEWTON_MAXITER - lm._NEWTON_RACE)
            its_n[ahead] += more
        xs[best[ok_n]] = xs_n[ok_n]
        ok[best] |= ok_n
        its[best] += its_n
        left[best[ok_n]] = 0

    xs, ok, its = levenberg(origins, lm._LM_RACE)
    left = np.where(ok, 0, 1)
    going = np.flatnonzero(~ok)
    ahead = going[first(f_of(xs[going], v_path), lm._LM_KEEP)]
    if ahead.size:
        xs[ahead], ok[ahead], more = levenberg(xs[ahead], lm._LM_MAXITER - lm._LM_RACE)
        its[ahead] += more
        left[ahead] = 0
    polish(xs, ok, its, left)
    fingers = [j for j in range(FINGERS.start, FINGERS.stop) if screened[j] != model.lower[j]]
    if f_of(xs, v_path).min() > lm._OPEN_F and fingers:
        opened = np.repeat(screened[None, :], len(fingers), axis=0)
        opened[np.arange(len(fingers)), fingers] = model.lower[fingers]
        starts = feas.project(opened)
        xs_o, ok_o, its_o = levenberg(starts, lm._OPEN_LM)
        left_o = np.where(ok_o, 0, 2)
        polish(xs_o, ok_o, its_o, left_o)
        xs, ok, its = np.concatenate([xs, xs_o]), np.concatenate([ok, ok_o]), np.concatenate([its, its_o])
        left, origins = np.concatenate([left, left_o]), np.concatenate([origins, starts])
    near = np.flatnonzero(f_of(xs, v) <= lm._POLISH)
    if near.size and projection is not None:
        xs_p, ok_p, its_p = projection.run(xs[near])
        xs[near[ok_p]] = xs_p[ok_p]
        ok[near[ok_p]] = True
        left[near[ok_p]] = 3
        its[near] += its_p
    return xs, ok, its, left, origins


@pytest.mark.parametrize('name', ['cup_7zone', 'flashlight_7zone'])
def test_the_compiled_least_squares_is_rule_5(shipped: dict[str, GraspModel], name: str) -> None:
    """Rule 5 compiled and driven from Python give the same bits.

    End points, convergence, iterations, endings and origins, over random v (a quarter with a zone at 0),
    from the origins a fresh plan would use.
    """
    model = shipped[name]
    feas = common.Feasible(model)
    for v in _random_vs(model, 12, 11, 0.25):
        projection = lm._LogOddsProjection(model, v, feas) if v.min() > 0.0 else None
        screened = feas.project(lm.search_starts(model, v))
        origins = common.unique_rows(np.concatenate([feas.project(common.select_starts(model, v)), screened,
                                                       feas.project(model.means)]))
        got = lm._least_squares(model, v, origins, feas, projection, screened[0])
        expected = _rule_5(model, v, origins, screened[0], projection)
        for a, b in zip(got[:3] + got[4:], expected[:3] + expected[4:]):
            assert np.array_equal(a, b)
        assert got[3] == lm._labels(expected[3], expected[1])


def test_a_model_without_the_mico_fingers_plans_without_the_open_finger_round(demos: Demonstrations) -> None:
    """A model over the first seven MICO features (palm, approach, roll) runs the least squares without fingers.

    The open-finger round opened features 7-9 of every model; with seven features it raised IndexError.
    """
    features = FeatureSpace(names=MICO_3F.names[:7], units=MICO_3F.units[:7], lower=MICO_3F.lower[:7],
                            upper=MICO_3F.upper[:7])
    model = GraspModel.fit(Demonstrations(demos.x[:, :7], demos.task_sets, demos.task_names, features))
    res = plan_lm(model, _v((0.51, 0.95, 0.14), model))  # no match: the least squares, f 2.9e-3
    assert res.status == 'ok' and res.chosen.message.startswith('least squares')
    assert res.x.shape == (7,) and res.objective > lm._OPEN_F
    assert not any('finger opened' in c.message for c in res.candidates)


def test_bad_inputs_raise(toy_model: GraspModel) -> None:
    with pytest.raises(PlanningError, match='one entry per model zone'):
        plan_lm(toy_model, np.ones(3) / 3)
    with pytest.raises(PlanningError, match='probability vector'):
        plan_lm(toy_model, np.full(7, 0.5))
    with pytest.raises(PlanningError, match='method'):
        planner.plan(toy_model, _v((0.9, 0.1, 0.1)), method='newton')  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match="'lm' takes LmOptions, got ScipyOptions"):
        plan_lm(toy_model, _v((0.9, 0.1, 0.1)), options=ScipyOptions(gradient='2-point'))
    with pytest.raises(PlanningError, match='warm_start'):
        plan_lm(toy_model, _v((0.9, 0.1, 0.1)), warm_start=np.zeros(3))


LM_SHORT_OF_THE_SEARCH = {
    ('cup_7zone', (0.9, 0.9, 0.1)): 'no exact match on the data the arm reaches; lm ends at f 6.16e-5 from 3 to '
                                    '40 starts, the search at 3.94e-5 (docs/planner.md, "The paper\'s results on '
                                    'the data the arm reaches")',
    ('cup_7zone', (0.1, 0.9, 0.9)): 'lm\'s best end point, f 2.7e-7, stops at its iteration limit (250) from 3 to '
                                    '40 starts (docs/planner.md, "The paper\'s results on the data the arm reaches")',
}
"""The cases where lm falls short of this test on the shipped data, measured: known failures, strict."""


@pytest.mark.slow
@pytest.mark.parametrize('name', ['cup_7zone', 'flashlight_7zone'])
@pytest.mark.parametrize('w', CASES)
def test_every_task_and_combination_matches_v_as_well_as_a_60_start_search(
        shipped: dict[str, GraspModel], fixed_reference: FixedReference, name: str, w: tuple[float, ...],
        request: pytest.FixtureRequest) -> None:
    """Within max(1e-9, 1%) of a 60-start SLSQP search (zone means, then seeded random points; fixed kernels)."""
    if (name, w) in LM_SHORT_OF_THE_SEARCH:
        request.applymarker(pytest.mark.xfail(strict=True, reason=LM_SHORT_OF_THE_SEARCH[name, w]))
    model = shipped[name]
    v = _v(w, model)
    res = plan_lm(model, v)
    best = fixed_reference.search(name, v)
    assert res.objective <= max(1e-9, 1.01 * best), (res.objective, best, res.message)
    assert res.success, res.message


@pytest.mark.parametrize('name', SHIPPED)
def test_every_shipped_model_plans_feasible_grasps_for_every_case(shipped: dict[str, GraspModel],
                                                                  name: str) -> None:
    model = shipped[name]
    for w in CASES:
        r = intent.interpret(w, model.zones)
        if r.v is None:  # e.g. usage alone on the 4-zone model, which has no zone for it
            continue
        res = plan_lm(model, r.v)
        assert_feasible(model, res.x)
        assert res.objective <= common.objective(model, r.v, res.reference) + common.MATCH_TOL


ws = st.tuples(*[st.floats(0.02, 0.98) for _ in range(3)])


def _perturbed(v: np.ndarray, seed: int) -> np.ndarray:
    noise = np.random.default_rng(seed).standard_normal(v.size)
    out = v * (1.0 + 1e-12 * noise)
    return out / out.sum()


@pytest.mark.parametrize('name', ['cup_7zone', 'flashlight_7zone'])
@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(w=ws, seed=st.integers(0, 2**31))
def test_last_bit_perturbations_of_v_give_the_same_grasp(shipped: dict[str, GraspModel], name: str,
                                                         w: tuple[float, ...], seed: int) -> None:
    model = shipped[name]
    r = intent.interpret(w, model.zones)
    if r.v is None:
        return
    a = plan_lm(model, r.v)
    b = plan_lm(model, _perturbed(r.v, seed))
    if not (a.success and b.success):  # stopped before converging: said in the status, no claim here
        assert 'solver_failed' in (a.status, b.status)
        return
    assert a.exact == b.exact, (a.message, b.message)
    if a.exact:  # a match: the same grasp
        assert np.abs(a.x[:3] - b.x[:3]).max() <= STABLE_PALM_M, (a.message, b.message)
        assert np.abs(a.x[3:6] - b.x[3:6]).max() <= STABLE_APPROACH, (a.message, b.message)
    else:  # least squares: the same objective (a nearly flat valley need not name one grasp)
        assert b.objective == pytest.approx(a.objective, rel=1e-4), (a.message, b.message)


W_LONG_PATH = (0.08374032389677899, 0.3230536931058179, 0.9275588094659627)
"""Flashlight: the chosen match is reached by a ~60-iteration damped projection whose accept/reject decisions
amplified a 1e-12 change of v to a 1e-4 move of the grasp before the targets were rounded for the path."""


def test_a_long_projection_path_is_not_steered_by_the_last_bits_of_v(shipped: dict[str, GraspModel]) -> None:
    model = shipped['flashlight_7zone']
    v = _v(W_LONG_PATH, model)
    a = plan_lm(model, v)
    assert a.exact and a.success, a.message
    log_odds = np.log(a.posterior) - np.log(v)  # the exact targets are met, not only the rounded ones
    assert np.ptp(log_odds) <= 2e-11
    for seed in range(1, 5):
        b = plan_lm(model, _perturbed(v, seed))
        assert b.exact and b.success, b.message
        assert np.abs(a.x[:3] - b.x[:3]).max() <= STABLE_PALM_M, seed
        assert np.abs(a.x[3:6] - b.x[3:6]).max() <= STABLE_APPROACH, seed


@pytest.mark.parametrize('name', ['cup_7zone', 'flashlight_7zone'])
@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(w=ws)
def test_the_palm_never_enters_the_object(shipped: dict[str, GraspModel], name: str,
                                         w: tuple[float, ...]) -> None:
    model = shipped[name]
    assert model.body is not None
    r = intent.interpret(w, model.zones)
    if r.v is None:
        return
    for cand in plan_lm(model, r.v).candidates:
        assert model.body.distance(cand.x[None, :3])[0][0] >= model.body.margin - 1e-9


def test_a_model_without_a_body_is_unconstrained(shipped: dict[str, GraspModel]) -> None:
    """Without its body the palm may go where the body was: a match the body rules out.

    The witness w: the first of bench_planner's seed-0 draws (``random_targets(model, 500, 0)``) on the cup
    7-zone model without an exact match whose plan on the same model without a body matches exactly (#19;
    after regenerating the data, repeat that search).
    """
    model = shipped['cup_7zone']
    v = _v((0.7963242702872942, 0.23064220899374743, 0.05202130106440961), model)
    assert not plan_lm(model, v).exact
    res = plan_lm(dataclasses.replace(model, body=None), v)
    assert res.exact and res.success


def test_zone_order_of_round_numbers_survives_last_bit_perturbations() -> None:
    v = np.array([0.2, 0.1, 0.2, 0.1, 0.2, 0.1, 0.1])  # w = (0.5, 1/3, 0.5): ties at round values
    order = common.zone_order(v)
    assert order.tolist() == [0, 2, 4, 1, 3, 5, 6]
    for seed in range(50):
        assert common.zone_order(_perturbed(v, seed)).tolist() == order.tolist()
