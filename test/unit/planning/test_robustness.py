"""The execution noise model and the robustness estimate (planning.robustness), on hand-built demonstrations."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from grasp_intent_ros.errors import PlanningError
from grasp_intent_ros.kernels import landed_thresholds
from grasp_intent_ros.method.data import Demonstrations
from grasp_intent_ros.method.features import APPROACH, FINGERS, MICO_3F, PALM, ROLL
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import planner, robustness
from grasp_intent_ros.planning.options import LmOptions, TaskOptions, node_options, noise_from, options_for
from grasp_intent_ros.planning.robustness import (
    DRAW_DIM,
    Condition,
    ExecutionNoise,
    perturb,
    retention,
    standard_draws,
    stratified_draws,
)

A, B, AB = 1, 2, 3
BAND = (0.0, 0.03)  # palm_x (m) where the demonstrations do both tasks


def _grasp(px: float, py: float, fingers: float) -> list[float]:
    return [px, py, 0.05, 0.0, 0.0, -1.0, 0.0, fingers, fingers, fingers]


def _slab_model() -> GraspModel:
    """Two tasks along palm_x: A below the band, both tasks within it, B above it (2.5 mm grid, 3 rows in y)."""
    xs, sets = [], []
    for i, px in enumerate(round(-0.04 + 0.0025 * i, 6) for i in range(45)):
        for j, py in enumerate((-0.004, 0.0, 0.004)):
            xs.append(_grasp(px, py, 0.9 + 0.05 * ((i + j) % 3)))
            sets.append(AB if BAND[0] <= px <= BAND[1] else A if px < BAND[0] else B)
    demos = Demonstrations(np.array(xs), np.array(sets, dtype=np.int64), ('a', 'b'))
    return GraspModel.fit(demos, name='slab')


@pytest.fixture(scope='module')
def slab() -> GraspModel:
    return _slab_model()


def test_noise_defaults_are_the_documented_1x_level() -> None:
    noise = ExecutionNoise()
    assert (noise.palm, noise.closure) == (0.005, 0.10)
    assert noise.tilt == noise.roll == pytest.approx(math.radians(3.0), abs=1e-15)
    assert noise.scaled(2.0).palm == 0.010 and noise.scaled(0.0).is_zero and not noise.is_zero


@pytest.mark.parametrize('bad', [-1e-3, math.nan, math.inf])
def test_noise_rejects_a_negative_or_non_finite_deviation(bad: float) -> None:
    with pytest.raises(PlanningError, match='closure'):
        ExecutionNoise(closure=bad)


def test_a_landing_moves_each_part_by_its_deviation() -> None:
    x = np.array([_grasp(0.01, 0.02, 1.45)])
    x[0, APPROACH] = [0.6, 0.0, -0.8]
    z = standard_draws(200, 3)
    assert z.shape == (200, DRAW_DIM)
    noise = ExecutionNoise(palm=0.004, tilt=0.05, roll=0.02, closure=0.2)
    landed = perturb(x, z, noise, MICO_3F)[0]
    np.testing.assert_allclose(landed[:, PALM] - x[0, PALM], 0.004 * z[:, 0:3], atol=1e-15)
    np.testing.assert_allclose(landed[:, ROLL] - x[0, ROLL], 0.02 * z[:, 5], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(landed[:, APPROACH], axis=1), 1.0, atol=1e-12)
    tilt = np.arccos(np.clip(landed[:, APPROACH] @ x[0, APPROACH], -1.0, 1.0))
    np.testing.assert_allclose(tilt, 0.05 * np.hypot(z[:, 3], z[:, 4]), atol=1e-7)
    fingers = landed[:, FINGERS]
    assert fingers.max() <= MICO_3F.upper[7] and (fingers == MICO_3F.upper[7]).any()  # clipped at closed
    np.testing.assert_array_equal(perturb(x, z, ExecutionNoise().scaled(0.0), MICO_3F)[0], np.repeat(x, 200, 0))


def test_retention_is_higher_inside_a_task_sets_region_than_at_its_edge(slab: GraspModel) -> None:
    table = retention(slab, ExecutionNoise())
    k_ab = slab.zones.index(AB)
    px = slab.demo_x[:, 0]
    middle = table[(np.abs(px - 0.015) < 1e-9), k_ab]
    edges = table[(np.abs(px - BAND[0]) < 1e-9) | (np.abs(px - BAND[1]) < 1e-9), k_ab]
    # 5 mm of palm noise across a 30 mm band: the middle keeps both tasks nearly always, an edge about half the time
    assert middle.min() > 0.8 and edges.max() < 0.7
    assert middle.min() - edges.max() > 0.2


def test_retention_credits_only_the_tasks_a_demonstration_does(slab: GraspModel) -> None:
    table = retention(slab, ExecutionNoise())
    within = (slab.demo_sets[:, None] & np.array(slab.zones)) == np.array(slab.zones)
    assert np.all(table[~within] == 0.0) and np.all((table[within] > 0.0) & (table[within] < 1.0))
    np.testing.assert_array_equal(retention(slab, ExecutionNoise().scaled(0.0)), within.astype(float))
    assert retention(slab, ExecutionNoise()) is table  # kept per model and noise


def test_a_zones_retention_is_at_most_the_product_of_its_tasks(slab: GraspModel) -> None:
    table = retention(slab, ExecutionNoise())
    k_a, k_b, k_ab = (slab.zones.index(z) for z in (A, B, AB))
    both = slab.demo_sets == AB
    # the tasks' product bounds the zone's, in each of the two estimates and so in their geometric mean (which
    # takes its square roots in another order: up to rounding)
    assert np.all(table[both, k_ab] <= table[both, k_a] * table[both, k_b] + 1e-12)


def test_a_task_that_is_no_zone_gets_a_vote_of_its_own() -> None:
    xs = [_grasp(round(-0.04 + 0.0025 * i, 6), 0.0, 1.0) for i in range(30)]
    sets = np.array([A if i < 15 else AB for i in range(30)], dtype=np.int64)
    demos = Demonstrations(np.array(xs), sets, ('a', 'b'))
    model = GraspModel.fit(demos, zones=(A, AB), name='no b alone')
    assert robustness.votes(model) == (A, AB, B)
    assert robustness.bandwidths(model, ExecutionNoise()).shape[0] == len(model.zones) + 1


def test_soft_thresholds_hold_fully_inside_not_beyond_and_linearly_between() -> None:
    landed = np.array([[-1.0, 0.0], [0.25, 0.0], [0.5, 5.0], [2.0, 5.0]])  # two points, two landings each
    # column 0: feature 0 below 0 fully, beyond 1 not at all; column 1: no condition; column 2: column 0's and
    # feature 1 above 4 fully, below 2 not at all (a lower side)
    feature = np.array([0, 0, 1], dtype=np.int64)
    inner, outer = np.array([0.0, 0.0, 4.0]), np.array([1.0, 1.0, 2.0])
    out = landed_thresholds(landed, feature, inner, outer, np.array([0, 1, 1, 3], dtype=np.int64), 2)
    np.testing.assert_allclose(out, [[(1.0 + 0.75) / 2, 1.0, (1.0 * 0.0 + 0.75 * 0.0) / 2],
                                     [(0.5 + 0.0) / 2, 1.0, (0.5 * 1.0 + 0.0) / 2]], atol=1e-15)


def test_thresholds_take_the_edges_where_positives_and_negatives_meet(slab: GraspModel) -> None:
    conditions = dict(zip(robustness.votes(slab), robustness.thresholds(slab, ExecutionNoise())))
    # a: A and AB below palm_x 0.03, B from 0.0325; b: the mirror image; both: the band's two edges
    assert conditions[A] == (Condition(0, 0.03, 0.0325),)
    assert conditions[B] == (Condition(0, 0.0, -0.0025),)
    assert set(conditions[AB]) == {Condition(0, 0.03, 0.0325), Condition(0, 0.0, -0.0025)}


def _edge_model() -> GraspModel:
    """Task b ends at palm_z 0.06 m: seen at palm_x -0.05 (AB below, A above), unseen at +0.05 (AB only).

    Grid of 5 mm in palm_y; the fingers vary a little so that no two rows are equal.
    """
    xs, sets = [], []
    for j, py in enumerate((-0.01, -0.005, 0.0, 0.005, 0.01)):
        for i in range(25):  # where the data meet: 0.03 .. 0.09
            pz = round(0.03 + 0.0025 * i, 6)
            xs.append([-0.05, py, pz, 0.0, 0.0, -1.0, 0.0, 0.9 + 0.01 * j, 0.9, 0.9])
            sets.append(AB if pz <= 0.06 else A)
        for i in range(13):  # a band against the edge that no A demonstration borders: 0.03 .. 0.06
            pz = round(0.03 + 0.0025 * i, 6)
            if pz <= 0.06:
                xs.append([0.05, py, pz, 0.0, 0.0, -1.0, 0.0, 0.9 + 0.01 * j, 0.9, 0.9])
                sets.append(AB)
    return GraspModel.fit(Demonstrations(np.array(xs), np.array(sets, dtype=np.int64), ('a', 'b')), name='edge')


def test_an_edge_learnt_where_the_data_meet_holds_where_they_are_thin() -> None:
    model = _edge_model()
    conditions = dict(zip(robustness.votes(model), robustness.thresholds(model, ExecutionNoise())))
    assert Condition(2, 0.06, 0.0625) in conditions[B]  # palm_z: the last AB, the first A
    table = retention(model, ExecutionNoise())
    k_ab = model.zones.index(AB)
    px, pz = model.demo_x[:, 0], model.demo_x[:, 2]
    thin_top = table[(px > 0.0) & (np.abs(pz - 0.06) < 1e-9), k_ab]
    thin_low = table[(px > 0.0) & (np.abs(pz - 0.05) < 1e-9), k_ab]
    # 5 mm of palm noise: at the edge about half the landings keep b, two deviations below nearly all of them
    assert thin_top.max() < 0.75 and thin_low.min() > 0.9


def test_an_oblique_edge_is_learnt_on_a_combination_of_two_palm_coordinates() -> None:
    """Task b holds where palm_x + palm_y >= 0: no bound on either coordinate alone separates it."""
    xs, sets = [], []
    for i in range(13):
        for j in range(13):
            px, py = round(-0.03 + 0.005 * i, 6), round(-0.03 + 0.005 * j, 6)
            xs.append([px, py, 0.05, 0.0, 0.0, -1.0, 0.0, 0.9 + 0.01 * (i % 3), 0.9, 0.9 + 0.01 * (j % 3)])
            sets.append(AB if i + j >= 12 else A)
    model = GraspModel.fit(Demonstrations(np.array(xs), np.array(sets, dtype=np.int64), ('a', 'b')), name='wedge')
    noise = ExecutionNoise()
    column = robustness.threshold_columns(model.features.dim).index((0, 1, 1, 1))  # x / 5 mm + y / 5 mm
    b = robustness.votes(model).index(B)
    (condition,) = [c for c in robustness.thresholds(model, noise)[b] if c.feature == column]
    # the positives' lowest x + y is 0, the nearest negative's -5 mm: -1 in units of the noise's 5 mm
    assert condition.inner == pytest.approx(0.0, abs=1e-9) and condition.outer == pytest.approx(-1.0, abs=1e-9)
    kept = robustness._landed_thresholds(model, noise)[:, b]
    s = model.demo_x[:, 0] + model.demo_x[:, 1]
    # each landing moves x + y by N(0, 7.1 mm): on the edge about half the landings meet it, 30 mm inside all
    on_edge, inside = kept[np.abs(s) < 1e-9], kept[np.abs(s - 0.03) < 1e-9]
    assert 0.3 < on_edge.min() and on_edge.max() < 0.75 and inside.min() > 0.99


def test_a_bound_on_the_closed_fingers_is_learnt_on_the_least_closed_one() -> None:
    """Task b holds while some finger stays open (any one of the three): no bound on one finger separates it."""
    xs, sets = [], []
    for i in range(30):
        palm = [round(-0.03 + 0.002 * i, 6), 0.002 * (i % 2), 0.05]  # the same palms for both sets
        fingers = [round(1.0 + 0.01 * ((i + k) % 3), 6) for k in range(3)]
        xs.append([*palm, 0.0, 0.0, -1.0, 0.0, *fingers])
        sets.append(A)
        fingers[i % 3] = 0.3 if i % 2 else 0.9  # one finger open: fully, or just short of the others
        xs.append([*palm, 0.0, 0.0, -1.0, 0.0, *fingers])
        sets.append(AB)
    model = GraspModel.fit(Demonstrations(np.array(xs), np.array(sets, dtype=np.int64), ('a', 'b')), name='fingers')
    noise = ExecutionNoise()
    least = robustness.threshold_columns(model.features.dim).index((-1, 0))
    b = robustness.votes(model).index(B)
    assert Condition(least, 0.9, 1.0) in robustness.thresholds(model, noise)[b]
    kept = robustness._landed_thresholds(model, noise)[:, b]
    open_finger = model.demo_x[:, FINGERS].min(axis=1)
    # 0.1 rad of closure noise: a finger at 0.3 stays below 0.9 always; one at 0.9 sits on the bound's inner
    # edge, and the least closed of its three noisy fingers goes past it in about half the landings, past the
    # outer edge (1.0) in some (the mean degree is about 0.83)
    assert kept[np.abs(open_finger - 0.3) < 1e-9].min() > 0.99
    assert kept[np.abs(open_finger - 0.9) < 1e-9].max() < 0.9


def test_a_set_without_negatives_has_no_condition_and_its_thresholds_hold_everywhere() -> None:
    xs = [[0.01 * i, 0.0, 0.05, 0.0, 0.0, -1.0, 0.0, 0.9 + 0.01 * (i % 3), 0.9, 0.9 + 0.01 * (i % 5)]
          for i in range(30)]
    model = GraspModel.fit(Demonstrations(np.array(xs), np.full(30, AB, dtype=np.int64), ('a', 'b')), zones=(AB,),
                           name='every demonstration does both')
    assert robustness.thresholds(model, ExecutionNoise()) == ((), (), ())
    np.testing.assert_array_equal(robustness._landed_thresholds(model, ExecutionNoise()), np.ones((30, 3)))


def test_retention_is_a_function_of_the_document(slab: GraspModel) -> None:
    again = _slab_model()  # another model object from the same demonstrations, as a node reads a model sent again
    np.testing.assert_array_equal(robustness._retention(again, ExecutionNoise()), retention(slab, ExecutionNoise()))
    assert retention(again, ExecutionNoise()) is retention(slab, ExecutionNoise())  # computed once


def test_each_noise_has_its_own_estimate(slab: GraspModel) -> None:
    """A new execution noise on a model that has an estimate: the new noise's, as computed from scratch."""
    one, two = ExecutionNoise(), ExecutionNoise().scaled(2.0)
    first = retention(slab, one)
    np.testing.assert_array_equal(retention(slab, two), robustness._retention(slab, two))
    assert not np.array_equal(retention(slab, two), first)
    assert retention(slab, one) is first


def test_stratified_landings_take_each_strata_median_once_per_number() -> None:
    z = stratified_draws(16, 0)
    assert z.shape == (16, DRAW_DIM)
    medians = np.sort(z[:, 0])
    for column in z.T:
        np.testing.assert_array_equal(np.sort(column), medians)
    assert medians[7] < 0.0 < medians[8] and abs(medians[0] + medians[15]) <= 1e-6  # symmetric about 0
    assert not np.array_equal(z[:, 0], z[:, 1])  # shuffled per number


def test_the_planner_takes_the_demonstration_inside_the_region(slab: GraspModel) -> None:
    v = np.zeros(len(slab.zones))
    v[slab.zones.index(AB)], v[slab.zones.index(A)], v[slab.zones.index(B)] = 0.8, 0.1, 0.1
    robust = planner.plan(slab, v, options=TaskOptions(noise=ExecutionNoise())).x
    assert abs(robust[0] - 0.015) <= 0.006  # within the middle fifth of the band
    exact = planner.plan(slab, v).x  # the default: an exact landing
    assert BAND[0] <= exact[0] <= BAND[1]  # without noise any demonstration of the band serves as well
    with pytest.raises(PlanningError, match='ExecutionNoise'):
        planner.plan(slab, v, options=TaskOptions(noise=(0.005, 0.05, 0.05, 0.1)))  # type: ignore[arg-type]


def test_the_noise_is_an_option_of_the_task_method_only(slab: GraspModel) -> None:
    v = np.full(len(slab.zones), 1.0 / len(slab.zones))
    assert TaskOptions().noise is None  # the default: an exact landing, no estimate to compute
    with pytest.raises(PlanningError, match='noise'):
        options_for('lm', noise=ExecutionNoise())
    with pytest.raises(PlanningError, match='TaskOptions'):
        planner.plan(slab, v, method='lm', options=TaskOptions(noise=ExecutionNoise()))
    assert node_options('task', 3, (0.0, 0.0, 0.0, 0.0)) == TaskOptions()
    assert node_options('task', 3, (0.005, 0.1, 0.1, 0.2)) == TaskOptions(noise=ExecutionNoise(0.005, 0.1, 0.1, 0.2))
    assert node_options('lm', 3, (0.005, 0.1, 0.1, 0.2)) == LmOptions(n_starts=3)  # the node's noise is for 'task'
    with pytest.raises(PlanningError, match='4 numbers'):
        noise_from((0.005, 0.1, 0.1))


def test_the_planner_never_imports_the_rules() -> None:
    """The objects' rules (grasp_intent_ros.objects) judge plans; the planner and its node must not read them."""
    code = ('import sys, grasp_intent_ros.planning.planner, grasp_intent_ros.planning.robustness, '
            'grasp_intent_ros.nodes.grasp_planner; '
            "print(sorted(m for m in sys.modules if m.startswith('grasp_intent_ros.objects')))")
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == '[]'
