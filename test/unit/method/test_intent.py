"""Intent interpretation (paper eqs. 3-4) against the paper's tables."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import InvalidIntentError
from grasp_intent_ros.method import intent
from grasp_intent_ros.method.model import structure_zones

TASKS = intent.DEFAULT_TASKS

# Target vectors printed in the paper (Table II: cup 7 zones; Table IV: 7, 5 and 4 zones), 4 decimals.
PAPER_TARGETS = [
    ((0.9, 0.1, 0.1), '7zone', [0.7933, 0.0098, 0.0098, 0.0881, 0.0881, 0.0011, 0.0098]),
    ((0.9, 0.9, 0.1), '7zone', [0.0817, 0.0817, 0.0010, 0.7356, 0.0091, 0.0091, 0.0817]),
    ((0.9, 0.9, 0.9), '7zone', [0.0090, 0.0090, 0.0090, 0.0811, 0.0811, 0.0811, 0.7297]),
    ((0.9, 0.1, 0.9), '7zone', [0.0817, 0.0010, 0.0817, 0.0091, 0.7356, 0.0091, 0.0817]),
    ((0.9, 0.1, 0.9), '5zone', [0.4475, 0.0055, 0.0497, 0.0497, 0.4475]),
    ((0.9, 0.1, 0.9), '4zone', [0.0100, 0.0900, 0.0900, 0.8100]),
]


def test_zone_order_is_the_papers_row_order() -> None:
    assert intent.zone_labels(intent.all_zones(3), TASKS) == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
    assert intent.all_zones(1) == (1,)
    assert len(intent.all_zones(10)) == 1023


@pytest.mark.parametrize(('w', 'structure', 'expected'), PAPER_TARGETS)
def test_paper_target_vectors(w: tuple[float, ...], structure: str, expected: list[float]) -> None:
    r = intent.interpret(w, structure_zones(structure, TASKS))
    assert not r.needs_clarification
    assert_allclose(np.round(r.v, 4), expected, atol=1e-12)
    assert math.isclose(r.v.sum(), 1.0, abs_tol=1e-12)


def test_paper_worked_example_of_eq3() -> None:
    # Section III-C: w = (0.88, 0.9, 0.2) -> P(U, not T, not H) = 0.07, P(U, T, not H) = 0.63
    u = intent.event_probabilities([0.88, 0.9, 0.2])
    assert round(u[0b001], 2) == 0.07
    assert round(u[0b011], 2) == 0.63


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=10))
def test_u_is_a_distribution_and_w_is_its_marginal(w: list[float]) -> None:
    u = intent.event_probabilities(w)
    assert u.shape == (1 << len(w),)
    assert_allclose(u.sum(), 1.0, atol=1e-12)
    # the marginal of task i over all 2^m events (including "no task") is w_i
    zones = list(range(1 << len(w)))[1:]
    assert_allclose(intent.reconstruct_w(u[1:], zones, len(w)), w, atol=1e-12)


def test_clarification_when_no_task_is_likely() -> None:
    r = intent.interpret([0.1, 0.1, 0.1])
    assert r.needs_clarification and r.v is None
    assert isinstance(r, intent.NeedsClarification)
    assert r.p_none == pytest.approx(0.729)
    assert 'P(no task)' in r.reason
    r2 = intent.interpret([0.1, 0.1, 0.1], clarification_threshold=0.9)
    assert not r2.needs_clarification


def test_clarification_when_the_model_has_no_supported_zone() -> None:
    r = intent.interpret([1.0, 0.0, 0.0], structure_zones('4zone', TASKS))
    assert isinstance(r, intent.NeedsClarification)
    assert 'no zone' in r.reason


@pytest.mark.parametrize('bad', [[], [0.5, float('nan'), 0.1], [0.5, math.inf, 0.2], [1.2, 0.1, 0.1],
                                 [-0.1, 0.2, 0.3], [[0.1, 0.2]], [0.1] * 11, ['a', 'b']])
def test_bad_w_raises_typed_error(bad: object) -> None:
    with pytest.raises(InvalidIntentError):
        intent.interpret(bad)  # type: ignore[arg-type]


def test_wrong_length_and_bad_options() -> None:
    with pytest.raises(InvalidIntentError, match='3 entries'):
        intent.validate_w([0.1, 0.2], m=3)
    with pytest.raises(InvalidIntentError, match='threshold'):
        intent.interpret([0.5, 0.5, 0.5], clarification_threshold=0.0)
    with pytest.raises(InvalidIntentError, match='not non-empty subsets'):
        intent.interpret([0.5, 0.5, 0.5], zones=[8])
    with pytest.raises(InvalidIntentError, match='unknown zone'):
        intent.parse_zones(['UX'], TASKS)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=6), st.integers(0, 2**31), st.floats(0.05, 1.0))
def test_zone_interpreter_equals_interpret(w: list[float], seed: int, threshold: float) -> None:
    m = len(w)
    rng = np.random.default_rng(seed)
    zones = tuple(int(z) for z in rng.permutation(np.arange(1, 1 << m))[:rng.integers(1, 1 << m)])
    support = zones[:rng.integers(1, len(zones) + 1)]
    expected = intent.interpret(w, zones, clarification_threshold=threshold, support=support)
    got = intent.ZoneInterpreter(m, zones, clarification_threshold=threshold, support=support)(w)
    assert type(got) is type(expected)
    assert (got.zones, got.p_none) == (expected.zones, expected.p_none)
    assert_allclose(got.u, expected.u, rtol=0, atol=0)
    if isinstance(expected, intent.NeedsClarification):
        assert isinstance(got, intent.NeedsClarification) and got.reason == expected.reason
    else:
        assert_allclose(got.v, expected.v, rtol=0, atol=0)


def test_zone_interpreter_checks_its_options_once_and_w_every_time() -> None:
    with pytest.raises(InvalidIntentError, match='threshold'):
        intent.ZoneInterpreter(3, clarification_threshold=1.5)
    with pytest.raises(InvalidIntentError, match='not non-empty subsets'):
        intent.ZoneInterpreter(2, zones=[4])
    with pytest.raises(InvalidIntentError, match='number of tasks'):
        intent.ZoneInterpreter(11, zones=[1])
    interpreter = intent.ZoneInterpreter(3)
    with pytest.raises(InvalidIntentError, match='3 entries'):
        interpreter([0.5, 0.5])
    for bad, reason in (([0.5, np.nan, 0.5], 'finite'), ([0.5, -np.inf, 0.5], 'finite'),
                        ([0.5, 1.01, 0.5], r'\[0, 1\]')):
        with pytest.raises(InvalidIntentError, match=reason):
            interpreter(bad)


def test_reconstruct_w_from_posterior() -> None:
    zones = intent.all_zones(3)
    p = np.zeros(7)
    p[zones.index(0b011)] = 1.0  # all mass on "usage and transfer"
    assert_allclose(intent.reconstruct_w(p, zones, 3), [1.0, 1.0, 0.0])
    batch = np.eye(7)
    assert intent.reconstruct_w(batch, zones, 3).shape == (7, 3)


def test_labels_for_generic_tasks() -> None:
    names = intent.default_task_names(4)
    assert intent.zone_label(0b0101, names) == '1+3'
    assert intent.parse_zones(['1+3'], names) == (0b0101,)


@pytest.mark.parametrize('structure', ['7zone', '5zone', '4zone'])
def test_restrict_equals_interpreting_for_the_model(structure: str) -> None:
    zones = structure_zones(structure, TASKS)
    for w in [(0.9, 0.1, 0.9), (0.3, 0.8, 0.2), (0.9, 0.9, 0.9)]:
        full = intent.interpret(w)
        direct = intent.interpret(w, zones)
        assert full.v is not None and direct.v is not None
        assert_allclose(intent.restrict(full.v, full.zones, zones), direct.v, atol=1e-12)
    v_u_only = np.eye(7)[0]
    assert intent.restrict(v_u_only, intent.all_zones(3), structure_zones('4zone', TASKS)) is None
    with pytest.raises(InvalidIntentError):
        intent.restrict([0.5, 0.5], intent.all_zones(3), zones)


def test_v_zones_match_the_model_tasks_by_label_or_core_order() -> None:
    tasks = ('usage', 'transfer', 'handover')
    assert intent.match_zones(7, None, tasks) == intent.all_zones(3)
    assert intent.match_zones(3, ['UT', 'U', 'T'], ('usage', 'transfer')) == (3, 1, 2)
    with pytest.raises(InvalidIntentError, match=r"v must have 7 entries \(all zones of the model's 3 tasks\)"):
        intent.match_zones(3, None, tasks)
    with pytest.raises(InvalidIntentError, match="v labels do not match the model's 3 tasks"):
        intent.match_zones(3, ['U', 'T', 'X'], tasks)
    with pytest.raises(InvalidIntentError, match='must name each of the 3 zones'):
        intent.match_zones(3, ['U', 'U', 'T'], ('usage', 'transfer'))


def test_v_as_received_is_a_probability_vector() -> None:
    assert intent.validate_v([0.25, 0.75], ('U', 'T')).tolist() == [0.25, 0.75]
    for bad in ([0.5, 0.6], [-0.5, 1.5], [np.nan, 1.0]):
        with pytest.raises(InvalidIntentError, match=r'non-negative and sum to 1 \(within 1e-6\)'):
            intent.validate_v(bad)
    with pytest.raises(InvalidIntentError, match='2 values but its label names 3 zones'):
        intent.validate_v([0.5, 0.5], ('U', 'T', 'UT'))


def test_support_asks_for_clarification_when_no_model_zone_is_possible() -> None:
    from grasp_intent_ros.method.intent import DEFAULT_TASKS, all_zones, interpret, parse_zones, restrict, support_zones
    four = parse_zones(['T', 'UT', 'TH', 'UTH'], DEFAULT_TASKS)
    # usage only: P(no task) = 0.1, yet no zone of the 4-zone model has probability
    r = interpret([0.9, 0.0, 0.0], support=four)
    assert r.needs_clarification and r.v is None and 'no zone of the model' in r.reason
    assert r.p_none == pytest.approx(0.1, abs=1e-15)
    # v stays over all zones when the model can serve the intent, and agrees with restrict()
    w = [0.9, 0.9, 0.1]
    r = interpret(w, support=four)
    assert not r.needs_clarification and r.zones == all_zones(3)
    assert_allclose(r.v, interpret(w).v, rtol=0, atol=0)
    assert_allclose(restrict(r.v, r.zones, four), interpret(w, four).v, rtol=0, atol=1e-15)
    # P(no task) is checked first
    assert 'P(no task)' in interpret([0.1, 0.1, 0.1], support=four).reason
    with pytest.raises(InvalidIntentError, match='support'):
        interpret(w, support=[8])
    assert support_zones(DEFAULT_TASKS, DEFAULT_TASKS, four) == four
    assert support_zones(('a', 'b', 'c'), DEFAULT_TASKS, four) is None


def test_the_most_likely_task_is_argmax_w_and_an_exact_tie_goes_to_the_first_task() -> None:
    rng = np.random.default_rng(0)
    for w in rng.uniform(0.05, 0.95, (200, 3)):
        v = intent.interpret(w, clarification_threshold=1.0).v
        assert v is not None
        assert intent.most_likely_task(v, intent.all_zones(3), 3) == int(np.argmax(w))
    # an exact tie of w whose v sums put the later task one ulp ahead: the rounding must not decide it
    for w, first in (((0.67, 0.4, 0.67), 0), ((0.34, 0.56, 0.56), 1)):
        v = intent.interpret(w).v
        assert v is not None
        p_task = intent.reconstruct_w(v, intent.all_zones(3), 3)
        assert p_task[2] > p_task[first], 'the case the tie rule is for'
        assert intent.most_likely_task(v, intent.all_zones(3), 3) == first


def test_the_single_task_target_is_one_hot_on_that_tasks_zone_over_all_zones() -> None:
    zones = intent.all_zones(3)
    w = (0.2, 0.3, 0.9)
    for v, v_zones, task in ((intent.interpret(w).v, zones, 0b100),
                             # over the 5-zone model's zones alone (U, T, UT, TH, UTH): handover comes with transfer
                             (intent.interpret(w, structure_zones('5zone', TASKS)).v,
                              structure_zones('5zone', TASKS), 0b010)):
        single = intent.single_task_v(v, v_zones, 3)
        assert single is not None
        assert_allclose(single, np.eye(7)[zones.index(task)], rtol=0, atol=0)
    assert intent.single_task_v(np.zeros(7), intent.all_zones(3), 3) is None  # no probability: no target
    for bad in ([0.5, math.nan, 0.5, 0, 0, 0, 0], [-0.1, 1.1, 0, 0, 0, 0, 0], [0.5, 0.5]):
        with pytest.raises(InvalidIntentError):
            intent.single_task_v(bad, intent.all_zones(3), 3)
