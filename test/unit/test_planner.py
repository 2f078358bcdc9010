"""Planner (Algorithm 1): never worse than its start, solvers agree, hooks and warm starts work."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.core import intent, planner
from grasp_intent_ros.core.errors import PlanningError
from grasp_intent_ros.core.model import GraspModel

CASES = [(0.9, 0.1, 0.1), (0.9, 0.9, 0.1), (0.9, 0.9, 0.9), (0.9, 0.1, 0.9), (0.2, 0.7, 0.6)]


def _v(w: tuple[float, ...]) -> np.ndarray:
    r = intent.interpret(w)
    assert r.v is not None
    return r.v


@pytest.mark.parametrize('method', ['lm', 'slsqp', 'trust-constr'])
@pytest.mark.parametrize('w', CASES)
def test_never_ends_worse_than_its_start(toy_model: GraspModel, w: tuple[float, ...], method: str) -> None:
    v = _v(w)
    res = planner.plan(toy_model, v, method=method)  # type: ignore[arg-type]
    # trust-constr may stop at its iteration limit while still improving: reported, not hidden
    assert res.success or (method == 'trust-constr' and res.status == 'solver_failed'), res.message
    for cand in res.candidates:
        assert cand.objective <= cand.start_objective + 1e-15
    first = planner.select_starts(toy_model, v, n_starts=1)[0]
    assert res.objective <= planner.objective(toy_model, v, first) + 1e-15
    # result is consistent: posterior and w belong to x, x is feasible
    assert_allclose(res.posterior, toy_model.posterior(res.x), atol=1e-12)
    assert_allclose(res.w, intent.reconstruct_w(res.posterior, toy_model.zones, 3), atol=1e-12)
    assert np.all(res.x >= toy_model.lower) and np.all(res.x <= toy_model.upper)
    assert np.linalg.norm(res.x[3:6]) == pytest.approx(1.0, abs=1e-9)
    assert res.objective == pytest.approx(0.5 * np.sum((v - res.posterior) ** 2), abs=1e-15)


def test_first_start_is_the_best_demonstration_of_the_top_zone(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.1))  # top zone UT
    start = planner.select_starts(toy_model, v, n_starts=1)[0]
    ut = toy_model.zones.index(0b011)
    members = (toy_model.demo_sets & 0b011) == 0b011
    f = [planner.objective(toy_model, v, x) for x in toy_model.demo_x[members]]
    assert_allclose(start, toy_model.demo_x[members][int(np.argmin(f))])
    assert np.argmax(v) == ut


def test_analytic_gradient_of_the_objective(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.9))
    rng = np.random.default_rng(3)
    for x in toy_model.demo_x[rng.integers(0, len(toy_model.demo_x), 30)]:
        _, g = planner.objective_and_gradient(toy_model, v, x)
        h = 1e-6
        fd = np.array([(planner.objective(toy_model, v, x + h * e) - planner.objective(toy_model, v, x - h * e))
                       / (2 * h) for e in np.eye(x.size)])
        assert np.abs(g - fd).max() <= 1e-5 * max(np.abs(fd).max(), 1e-4)


def test_warm_start_and_accept_hook(toy_model: GraspModel) -> None:
    v = _v((0.9, 0.9, 0.1))
    first = planner.plan(toy_model, v)
    again = planner.plan(toy_model, v, warm_start=first.x, n_starts=1)
    assert again.objective <= first.objective + 1e-12
    assert_allclose(again.candidates[0].start if again.candidates[0].start_objective <= first.objective
                    else first.x, first.x, atol=1e-9)
    best = first.candidates[0].x
    res = planner.plan(toy_model, v, accept=lambda x: not np.allclose(x, best))
    assert res.rejected >= 1 and not np.allclose(res.x, best)
    none = planner.plan(toy_model, v, accept=lambda x: False)
    assert none.status == 'rejected' and not none.success
    assert none.rejected == len(none.candidates)


def test_bad_inputs_raise(toy_model: GraspModel) -> None:
    with pytest.raises(PlanningError, match='one entry per model zone'):
        planner.plan(toy_model, np.ones(3) / 3)
    with pytest.raises(PlanningError, match='probability vector'):
        planner.plan(toy_model, np.full(7, 0.5))
    with pytest.raises(PlanningError, match='method'):
        planner.plan(toy_model, _v((0.9, 0.1, 0.1)), method='newton')  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match="'lm' takes the analytic gradient"):
        planner.plan(toy_model, _v((0.9, 0.1, 0.1)), gradient='2-point')
    with pytest.raises(PlanningError, match='warm_start'):
        planner.plan(toy_model, _v((0.9, 0.1, 0.1)), warm_start=np.zeros(3))
