"""The benchmarks can run: every script imports, and the simulated closed loop judges one episode.

No benchmark runs in CI, so a change that moves a name a benchmark uses (or the shape of a table it reads) would
otherwise be found only by the next person who measures. Importing a script runs nothing but its imports and
definitions (each runs its work under ``if __name__ == '__main__'``); ``benchmarks/`` is on the tests' path
(setup.cfg).
"""

from __future__ import annotations

import argparse
import importlib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / 'benchmarks'
SCRIPTS = sorted(p.stem for p in BENCHMARKS.glob('*.py'))


@pytest.mark.parametrize('script', SCRIPTS)
def test_every_benchmark_script_imports(script: str) -> None:
    module = importlib.import_module(script)
    assert module.__doc__, f'benchmarks/{script}.py states what it measures in its docstring'


def test_the_simulated_closed_loop_judges_one_episode_under_each_condition() -> None:
    sim = importlib.import_module('bench_shared_control_sim')
    task = sim.Task('cup', 'spacemouse', 0, seed=0, repeats=1, intent='persistent', timeout=15.0, tracker_mm=5.0,
                    tracker_deg=3.0, conditions=('direct', 'suite'))
    records = sim.run_task(task)
    assert [r['condition'] for r in records] == ['direct', 'suite']
    for record in records:
        assert record['object'] == 'cup' and record['operator'] == 'spacemouse' and record['episode'] == 0
        assert 1 <= record['task_set'] <= 7 and isinstance(record['success'], bool)
        assert 0.0 < record['time'] <= 15.0
        assert record['success'] <= record['closed']  # judged only where the hand closed
    assert records[0]['alpha_mean'] == 0.0 and records[1]['alpha_mean'] > 0.0  # direct: no help; the suite helps


def test_each_live_condition_sets_values_the_assistance_and_the_planner_accept() -> None:
    from grasp_intent_ros.mico.parameters import PLAN_FOR
    from grasp_intent_ros.shared_control.arbitration import ARBITRATIONS

    live = importlib.import_module('bench_shared_control')
    assert set(live.ARBITRATION) == set(live.PLAN_FOR) == set(live.CONDITIONS)
    assert set(live.ARBITRATION.values()) <= set(ARBITRATIONS) and set(live.PLAN_FOR.values()) <= set(PLAN_FOR)
    assert set(live.EXECUTES) <= set(live.CONDITIONS)
    # the paper's foil as the simulated loop's `independent`: the suite's assistance on the single task's grasp
    assert (live.ARBITRATION['independent'], live.PLAN_FOR['independent']) == ('confidence', 'most_likely_task')
    assert ('confidence', 'independent') in live.PAIRS


def test_the_figures_per_ambiguous_case_pool_each_objects_operators_by_the_case_of_the_episode() -> None:
    sim = importlib.import_module('bench_shared_control_sim')
    n_cases = len(sim.AMBIGUOUS_CASES)
    # the suite succeeds exactly on case 1's episodes, direct never; two operator models, two repeats
    records = [{'object': 'cup', 'operator': op, 'episode': e, 'repeat': rep, 'condition': c,
                'success': c == 'suite' and e % n_cases == 1, 'time': 5.0 if c == 'suite' else 10.0,
                'effort_linear': 1.0, 'wrong_pull': 0.0}
               for op in ('joystick', 'spacemouse') for e in range(2 * n_cases) for rep in range(2)
               for c in ('direct', 'suite')]
    args = argparse.Namespace(timeout=25.0)
    report = sim.report_cases(records, args, ['cup'])
    assert list(report['cases']) == [f'cup/{case}' for case in sim.AMBIGUOUS_CASES]
    for k, case in enumerate(sim.AMBIGUOUS_CASES):
        table = report['cases'][f'cup/{case}']
        assert table['suite']['episodes'] == 4  # 2 episodes of the case x 2 operator models, not 2 (merged)
        assert table['suite']['success'] == (1.0 if k == 1 else 0.0) and table['direct']['success'] == 0.0
        assert table['suite-direct']['time_ratio'] == pytest.approx(0.5)


def test_the_two_object_loop_judges_one_episode_under_each_condition() -> None:
    scene = importlib.import_module('bench_shared_control_scene')
    records = scene.run_scene_task(scene.SceneTask('spacemouse', 0, seed=0, repeats=1, timeout=15.0))
    assert [r['condition'] for r in records] == list(scene.SCENE_CONDITIONS)
    for record in records:
        assert record['true_object'] in scene.SCENE_OBJECTS and 1 <= record['task_set'] <= 7
        assert record['success'] <= record['serves'] <= record['closed']  # success: served, and no object swept
        assert not (record['serves'] and record['wrong_object'])
        assert record['success'] == (record['serves'] and not any(record['swept_objects'].values()))
        (x0, y0), (x1, y1) = record['positions']
        assert np.hypot(x0 - x1, y0 - y1) >= scene.GAP
    by = {r['condition']: r for r in records}
    assert by['direct']['alpha_mean'] == 0.0 and by['direct']['followed'] is None
    assert by['ada']['followed'] is None and by['suite']['followed'] in scene.SCENE_OBJECTS
    assert 0.0 < by['estimated']['estimated_p_true'] <= 1.0 and by['estimated']['followed'] in scene.SCENE_OBJECTS
    assert all(r['estimated_p_true'] is None for r in records if r['condition'] != 'estimated')
    table = scene.summarise(records)
    assert {f'{a}-{b}' for a, b in scene.PAIRS if {a, b} <= set(scene.SCENE_CONDITIONS)} <= set(table)


def test_the_operator_that_changes_its_mind_runs_its_devices_episode_and_the_split_conditions_their_estimator() -> None:
    scene = importlib.import_module('bench_shared_control_scene')
    conditions = ('direct', 'estimated_objects', 'estimated_tasks')
    straight, changing = (scene.run_scene_task(scene.SceneTask(op, 0, seed=0, repeats=1, timeout=6.0,
                                                               conditions=conditions))
                          for op in ('spacemouse', 'spacemouse-changing'))
    assert [r['condition'] for r in changing] == list(conditions)
    for one, other in zip(straight, changing):
        assert other['positions'] == one['positions']  # the device's episode: the same draws
        assert other['first_object'] == one['true_object'] != other['true_object']  # its true object first
        assert 1.5 <= other['switch_at'] <= 3.0 and 'switch_at' not in one
    by = {r['condition']: r for r in changing}
    assert by['direct']['follow_delay'] is None and by['direct']['estimate_delay'] is None
    assert all(0.0 < by[c]['estimated_p_true'] <= 1.0 for c in conditions[1:])
    table = scene.summarise(changing)
    assert {'follow_delay_median', 'estimate_delay_p90', 'wrong_object_alpha_after'} <= set(table['estimated_tasks'])
    assert 'follow_delay_median' not in scene.summarise(straight)['estimated_tasks']


def test_the_two_objects_are_drawn_apart_in_the_stated_region() -> None:
    scene = importlib.import_module('bench_shared_control_scene')
    rng = np.random.default_rng(0)
    for _ in range(200):
        poses = scene.draw_positions([0.11, 0.12], rng)
        assert np.linalg.norm(poses[0][:3, 3] - poses[1][:3, 3]) >= 0.11 + 0.12 + scene.GAP
        for pose in poses:
            (x0, x1), (y0, y1) = scene.REGION
            assert x0 <= pose[0, 3] <= x1 and y0 <= pose[1, 3] <= y1 and pose[2, 3] == 0.0
            assert np.array_equal(pose[:3, :3], scene.BASE_T_OBJ[:3, :3])


def test_the_estimated_conditions_estimator_is_the_nodes_defaults_for_its_model_with_the_fields_set(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from _bench.closed_loop import BASE_T_OBJ, load_model

    from grasp_intent_ros.mico.kinematics import MicoKinematics
    from grasp_intent_ros.shared_control import parameters
    from grasp_intent_ros.shared_control.estimator import EstimatorConfig

    sim = importlib.import_module('bench_shared_control_sim')
    listed = {'calibration_models': ['cup_7zone'], 'calibration_slopes': [1.4], 'calibration_offsets': [-0.1]}
    monkeypatch.setattr(parameters, 'ESTIMATOR', tuple(replace(spec, default=listed.get(spec.name, spec.default))
                                                       for spec in parameters.ESTIMATOR))
    estimator = sim.tracked_estimator(load_model('cup'), BASE_T_OBJ, MicoKinematics(), (('memory', 0.2),))
    assert estimator.config == replace(EstimatorConfig(), memory=0.2, calibration_slope=1.4, calibration_offset=-0.1)
