"""benchmarks/compare_records.py: two record files of a simulated closed loop paired run by run.

Hand-built records (no loop runs) of both benchmarks, one object's and two objects': identical runs, a cell whose
figures drop, files that cannot be paired (one object's against two objects' among them), a gzip-compressed file;
and the shipped reference files. ROS-free, beside the other benchmarks' tests.
"""

from __future__ import annotations

import gzip
import itertools
import json
from pathlib import Path
from typing import Any

import bench_shared_control_scene as scene
import pytest
from bench_shared_control_sim import EPISODE_SETTINGS, read_records
from compare_records import SCENE, SIM, compare, main, write_reference

REFERENCE = Path(__file__).resolve().parents[2] / 'benchmarks' / 'reference'
SETTINGS = {'seed': 0, 'intent': 'persistent', 'timeout': 25.0, 'tracker_mm': 5.0, 'tracker_deg': 3.0,
            'operator_mm': 5.0, 'operator_deg': 3.0, 'execute': True, 'execution_noise': True, 'margin_sigmas': 0.0,
            'estimator': {}}
OBJECT_OPERATORS = [(o, op) for o in ('cup', 'flashlight') for op in ('joystick', 'spacemouse')]
CONDITIONS = ('direct', 'suite')
CELLS = [(o, op, c) for o, op in OBJECT_OPERATORS for c in CONDITIONS]
EPISODES, REPEATS = 12, 2
DROPPED = ('cup', 'spacemouse', 'suite')


def records(**run: Any) -> list[dict[str, Any]]:
    """Every cell of :data:`CELLS`, 12 episodes x 2 repeats, in a --records file's order.

    ``run`` overrides :data:`SETTINGS`. A success in every run of :data:`DROPPED`, in 2 of 3 episodes elsewhere;
    closed at 5-8 s or never (the timeout); every fourth episode swept.
    """
    out = []
    for (o, op), e, rep, c in itertools.product(OBJECT_OPERATORS, range(EPISODES), range(REPEATS), CONDITIONS):
        success = (o, op, c) == DROPPED or e % 3 != 0
        closed = success or rep == 0
        out.append({'object': o, 'operator': op, 'episode': e, 'repeat': rep, 'condition': c,
                    'task_set': 1 + e % 7, 'success': success, 'closed': closed,
                    'time': 5.0 + 0.25 * e + 0.5 * rep if closed else 25.0, 'swept': e % 4 == 0,
                    'in_at_closing': False, 'effort_linear': 0.5, 'wrong_pull': 0.0,
                    'wall_s': 0.1, 'run': {**SETTINGS, **run}})
    return out


def write(path: Path, runs: list[dict[str, Any]]) -> str:
    """``runs`` as a --records file writes them (a line per episode), gzip-compressed if the name ends in .gz."""
    lines = {}
    for r in runs:
        lines.setdefault((r.get('object'), r['operator'], r['episode']), []).append(r)
    text = ''.join(json.dumps(line) + '\n' for line in lines.values())
    path.write_bytes(gzip.compress(text.encode()) if path.name.endswith('.gz') else text.encode())
    return str(path)


def changed(runs: list[dict[str, Any]], cell: tuple[str, str, str], **fields: Any) -> list[dict[str, Any]]:
    """``runs`` with ``fields`` set in every run of ``cell``."""
    return [{**r, **fields} if (r['object'], r['operator'], r['condition']) == cell else r for r in runs]


def test_identical_runs_pair_identically_and_regress_nowhere(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    base = write(tmp_path / 'base.jsonl', records())
    new = write(tmp_path / 'new.jsonl', records())
    assert main([base, new]) == 0
    kind, cells, notes, pairs = compare(read_records(base), read_records(new))
    assert kind is SIM
    assert pairs == len(CELLS) * EPISODES * REPEATS and len(cells) == len(CELLS)
    for cell in cells:
        assert cell.pairs == cell.identical == EPISODES * REPEATS, cell
        assert (cell.episodes, cell.repeats) == (EPISODES, REPEATS)
        assert cell.diff['success_diff'] == cell.diff['clear_diff'] == 0.0 and cell.diff['ci'] == [0.0, 0.0]
        assert cell.diff['time_ratio'] == 1.0 and cell.diff['time_ratio_ci'] == [1.0, 1.0]
        assert cell.success[0] == cell.success[1] and cell.never_closed[0] == cell.never_closed[1]
        assert not cell.regression
    assert notes[-1].endswith("the loop's: the same")
    out = capsys.readouterr().out
    assert '0 of 8 cells regress' in out and '**regression**' not in out


@pytest.mark.parametrize('change', ['success', 'clear', 'time'])
def test_a_cell_that_drops_on_every_episode_is_flagged_alone(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                            change: str) -> None:
    base = records()
    if change == 'success':  # every run of the cell fails, at the same closing time
        worse = changed(base, DROPPED, success=False)
    elif change == 'clear':  # every run of the cell sweeps: success, not with a clear path
        worse = changed(base, DROPPED, swept=True)
    else:  # every run of the cell closes 20 % later
        worse = [{**r, 'time': 1.2 * r['time']} if (r['object'], r['operator'], r['condition']) == DROPPED else r
                 for r in base]
    assert main([write(tmp_path / 'base.jsonl', base), write(tmp_path / 'new.jsonl', worse)]) == 1
    _, cells, _, _ = compare(base, worse)
    assert [(*c.group, c.condition) for c in cells if c.regression] == [DROPPED]
    flagged = next(c for c in cells if (*c.group, c.condition) == DROPPED)
    assert flagged.identical == (EPISODES // 4 * REPEATS if change == 'clear' else 0)  # those swept already
    out = capsys.readouterr().out
    assert out.count('**regression**') == 1 and '1 of 8 cells regress' in out
    assert out.rstrip().endswith('wholly above 1.0): cup / spacemouse / suite')


def test_a_drop_whose_ci_reaches_above_minus_two_points_is_not_flagged(tmp_path: Path) -> None:
    base = records()
    worse = [{**r, 'success': False} if (r['object'], r['operator'], r['condition'], r['episode']) == (*DROPPED, 0)
             else r for r in base]  # one episode of 12 fails: -8.3 points, the CI reaching 0
    _, cells, _, _ = compare(base, worse)
    flagged = next(c for c in cells if (*c.group, c.condition) == DROPPED)
    assert flagged.diff['success_diff'] == pytest.approx(-1 / EPISODES) and flagged.diff['ci'][1] == 0.0
    assert not flagged.regression and flagged.identical == EPISODES * REPEATS - REPEATS
    assert main([write(tmp_path / 'base.jsonl', base), write(tmp_path / 'new.jsonl', worse)]) == 0


@pytest.mark.parametrize('setting', EPISODE_SETTINGS)
def test_runs_of_other_episode_settings_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                    setting: str) -> None:
    other = {setting: 'sharpening' if setting == 'intent' else SETTINGS[setting] + 1}
    base = write(tmp_path / 'base.jsonl', records())
    assert main([base, write(tmp_path / 'new.jsonl', records(**other))]) == 2
    assert f'refused: the runs make other episodes: {setting} ' in capsys.readouterr().err


def test_the_loops_settings_may_differ_and_are_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = write(tmp_path / 'base.jsonl', records())
    assert main([base, write(tmp_path / 'new.jsonl', records(margin_sigmas=1.0, estimator={'memory': 0.2}))]) == 0
    assert "the loop's: estimator {} -> {'memory': 0.2}; margin_sigmas 0.0 -> 1.0" in capsys.readouterr().out


def test_files_without_settings_are_paired_on_their_task_sets(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    old = [{k: v for k, v in r.items() if k != 'run'} for r in records()]
    assert main([write(tmp_path / 'old.jsonl', old), write(tmp_path / 'new.jsonl', records())]) == 0
    assert 'warning: the settings of base are unknown' in capsys.readouterr().out
    other = [{**r, 'task_set': 7} if r['episode'] == 3 else r for r in old]  # other draws: other episodes
    assert main([write(tmp_path / 'other.jsonl', other), write(tmp_path / 'new.jsonl', records())]) == 2
    assert 'pairs have another true task set' in capsys.readouterr().err


@pytest.mark.parametrize(('fault', 'message'), [
    ('two runs in one file', 'the run cup/joystick/0/0/direct appears twice'),
    ('no common run', 'no run is in both files'),
    ('two settings', "its records carry more than one run's settings"),
    ('not records', 'a line is not a JSON list of records'),
    ('a field missing', 'a record lacks time'),
    ('no such file', 'No such file'),
])
def test_files_that_cannot_be_paired_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], fault: str,
                                                 message: str) -> None:
    base = write(tmp_path / 'base.jsonl', records())
    new = tmp_path / 'new.jsonl'
    if fault == 'two runs in one file':
        write(new, records() + records())
    elif fault == 'no common run':
        write(new, [{**r, 'episode': r['episode'] + EPISODES} for r in records()])
    elif fault == 'two settings':
        write(new, records()[:10] + records(seed=1)[10:])
    elif fault == 'not records':
        new.write_text('{"cells": {}}\n')
    elif fault == 'a field missing':
        write(new, [{k: v for k, v in r.items() if k != 'time'} for r in records()])
    assert main([base, str(new)]) == 2
    err = capsys.readouterr().err
    assert err.startswith('compare_records: refused: ') and message in err


def test_gzip_compressed_records_read_as_plain_ones(tmp_path: Path) -> None:
    runs = records()
    assert read_records(write(tmp_path / 'r.jsonl.gz', runs)) == read_records(write(tmp_path / 'r.jsonl', runs)) == runs
    assert main([str(tmp_path / 'r.jsonl.gz'), str(tmp_path / 'r.jsonl')]) == 0


def test_a_reference_keeps_the_fields_read_and_the_same_bytes_for_the_same_records(tmp_path: Path) -> None:
    runs = records()
    write_reference(runs, str(tmp_path / 'a.jsonl.gz'))
    write_reference(runs, str(tmp_path / 'b.jsonl.gz'))
    assert (tmp_path / 'a.jsonl.gz').read_bytes() == (tmp_path / 'b.jsonl.gz').read_bytes()
    assert (tmp_path / 'a.jsonl.gz').read_bytes()[4:8] == bytes(4)  # gzip's time stamp: none
    kept = read_records(str(tmp_path / 'a.jsonl.gz'))
    assert kept == [{k: v for k, v in r.items() if k in SIM.reference_fields} for r in runs]
    assert all('wall_s' not in r for r in kept)
    old = [{k: v for k, v in r.items() if k != 'run'} for r in runs]
    assert main([write(tmp_path / 'old.jsonl', old), '--write-reference', str(tmp_path / 'c.jsonl.gz')]) == 2


@pytest.mark.parametrize('intent', ['persistent', 'sharpening'])
def test_the_shipped_reference_parses_and_carries_what_is_read(intent: str) -> None:
    runs = read_records(str(REFERENCE / f'{intent}.jsonl.gz'))
    assert len(runs) == 2 * 3 * 50 * 3 * 6  # objects x operators x episodes x repeats x conditions
    assert all(set(SIM.needed) <= set(r) <= set(SIM.reference_fields) for r in runs)
    assert all(r['run'] == {**SETTINGS, 'intent': intent} for r in runs)
    assert len({tuple(r[f] for f in SIM.key) for r in runs}) == len(runs)
    swept = {r['condition'] for r in runs if 'swept' in r}
    assert swept == ({'direct', 'ada', 'independent', 'suite', 'estimated', 'fused'} if intent == 'persistent'
                     else {'independent', 'suite', 'estimated', 'fused'})  # its direct and ADA runs predate `swept`


SCENE_SETTINGS = {'seed': 0, 'timeout': 25.0, 'tracker_mm': 5.0, 'tracker_deg': 3.0, 'operator_mm': 5.0,
                  'operator_deg': 3.0, 'favoured': 0.6, 'execute': True}
SCENE_DROPPED = ('spacemouse', 'suite')


def scene_records(**run: Any) -> list[dict[str, Any]]:
    """bench_shared_control_scene's records: both devices x :data:`CONDITIONS`, 12 episodes x 2 repeats.

    ``run`` overrides :data:`SCENE_SETTINGS`. A success in every run of :data:`SCENE_DROPPED`, in 2 of 3 episodes
    elsewhere; every fourth episode's failures swept (the benchmark's success needs no object swept); closed at
    5-8 s or never (the timeout).
    """
    out = []
    for op, e, rep, c in itertools.product(('joystick', 'spacemouse'), range(EPISODES), range(REPEATS), CONDITIONS):
        success = (op, c) == SCENE_DROPPED or e % 3 != 0
        closed = success or rep == 0
        out.append({'operator': op, 'episode': e, 'repeat': rep, 'condition': c,
                    'true_object': ('cup', 'flashlight')[e % 2], 'favoured': e % 5 < 3, 'task_set': 1 + e % 7,
                    'success': success, 'serves': success or e % 4 == 0, 'wrong_object': False, 'closed': closed,
                    'time': 5.0 + 0.25 * e + 0.5 * rep if closed else 25.0, 'wrong_object_alpha': 0.1,
                    'swept': not success and e % 4 == 0, 'estimated_p_true': None, 'effort_linear': 0.5,
                    'wall_s': 0.1, 'run': {**SCENE_SETTINGS, **run}})
    return out


def test_scene_files_pair_by_device_with_the_scenes_figures(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    base = write(tmp_path / 'base.jsonl', scene_records())
    new = write(tmp_path / 'new.jsonl', scene_records())
    assert main([base, new]) == 0
    kind, cells, notes, pairs = compare(read_records(base), read_records(new))
    assert kind is SCENE and pairs == 2 * len(CONDITIONS) * EPISODES * REPEATS
    assert [c.name for c in cells] == [f'{op} / {c}' for op in ('joystick', 'spacemouse') for c in CONDITIONS]
    for cell in cells:
        assert cell.pairs == cell.identical == EPISODES * REPEATS and (cell.episodes, cell.repeats) == (12, 2)
        assert cell.clear is None and 'clear_diff' not in cell.diff  # its success is already clear-path
        assert cell.diff['ci'] == [0.0, 0.0] and cell.diff['time_ratio_ci'] == [1.0, 1.0] and not cell.regression
    assert notes == ["settings: seed 0, timeout 25.0, tracker_mm 5.0, tracker_deg 3.0, operator_mm 5.0, "
                     "operator_deg 3.0, favoured 0.6; the loop's: the same"]
    assert '0 of 4 cells regress (success CI wholly below' in capsys.readouterr().out


def test_the_scenes_split_conditions_and_changing_operators_pair_as_cells_of_their_own() -> None:
    splits = ('estimated_objects', 'estimated_tasks')
    runs = [{**r, 'operator': f"{r['operator']}-changing", 'condition': split}
            for r in scene_records() if r['condition'] == 'direct' for split in splits]
    kind, cells, _, pairs = compare(runs, runs)
    assert kind is SCENE and pairs == len(runs)
    assert sorted(c.name for c in cells) == sorted(f'{op}-changing / {c}' for op in ('joystick', 'spacemouse')
                                                   for c in splits)


@pytest.mark.parametrize('change', ['success', 'time'])
def test_a_scene_cell_that_drops_on_every_episode_is_flagged_alone(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str],
                                                                  change: str) -> None:
    base = scene_records()
    doctored = {'success': False, 'swept': True} if change == 'success' else {}  # every run of the cell sweeps
    worse = [{**r, **doctored, **({'time': 1.2 * r['time']} if change == 'time' else {})}
             if (r['operator'], r['condition']) == SCENE_DROPPED else r for r in base]
    assert main([write(tmp_path / 'base.jsonl', base), write(tmp_path / 'new.jsonl', worse)]) == 1
    _, cells, _, _ = compare(base, worse)
    assert [c.name for c in cells if c.regression] == ['spacemouse / suite']
    assert next(c for c in cells if c.regression).identical == 0
    out = capsys.readouterr().out
    assert out.count('**regression**') == 1 and out.rstrip().endswith('wholly above 1.0): spacemouse / suite')


def test_one_object_and_scene_files_are_never_paired(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    one = write(tmp_path / 'one.jsonl', records())
    two = write(tmp_path / 'two.jsonl', scene_records())
    assert main([one, two]) == 2
    assert ('refused: base holds bench_shared_control_sim records, new bench_shared_control_scene records'
            in capsys.readouterr().err)
    assert main([two, one]) == 2
    assert 'base holds bench_shared_control_scene records, new bench_shared_control_sim' in capsys.readouterr().err
    assert main([write(tmp_path / 'both.jsonl', records() + scene_records()), two]) == 2
    assert 'base: it holds records of both' in capsys.readouterr().err
    neither = [{k: v for k, v in r.items() if k != 'true_object'} for r in scene_records()]
    assert main([write(tmp_path / 'neither.jsonl', neither), two]) == 2
    assert 'base: a record has neither object nor true_object' in capsys.readouterr().err


@pytest.mark.parametrize('setting', scene.EPISODE_SETTINGS)
def test_scene_runs_of_other_episodes_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  setting: str) -> None:
    base = write(tmp_path / 'base.jsonl', scene_records())
    new = write(tmp_path / 'new.jsonl', scene_records(**{setting: SCENE_SETTINGS[setting] + 0.1}))
    assert main([base, new]) == 2
    assert f'refused: the runs make other episodes: {setting} ' in capsys.readouterr().err


def test_scene_runs_of_another_loop_pair_and_of_another_true_object_do_not(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = write(tmp_path / 'base.jsonl', scene_records())
    assert main([base, write(tmp_path / 'stop.jsonl', scene_records(execute=False, twist_joint_limit='stop'))]) == 0
    assert "the loop's: execute True -> False; twist_joint_limit None -> stop" in capsys.readouterr().out
    other = [{**r, 'true_object': 'cup'} if r['episode'] == 3 else r for r in scene_records()]
    assert main([base, write(tmp_path / 'other.jsonl', other)]) == 2
    assert '8 of 96 pairs have another true object or task set (first: joystick/3/0/direct)' in capsys.readouterr().err


def test_a_scene_reference_keeps_what_summarise_reads(tmp_path: Path) -> None:
    runs = scene_records()
    out = tmp_path / 'scene.jsonl.gz'
    assert main([write(tmp_path / 'runs.jsonl', runs), '--write-reference', str(out)]) == 0
    kept = read_records(str(out))
    assert kept == [{k: v for k, v in r.items() if k in SCENE.reference_fields} for r in runs]
    assert all('wall_s' not in r and 'effort_linear' not in r for r in kept)
    assert scene.summarise(kept) == scene.summarise(runs)
    assert len(gzip.decompress(out.read_bytes()).splitlines()) == 2 * EPISODES  # a line per device and episode


def test_the_shipped_scene_reference_gives_the_readme_rows_figures() -> None:
    runs = read_records(str(REFERENCE / 'scene.jsonl.gz'))
    assert len(runs) == 2 * 50 * 3 * 5  # devices x episodes x repeats x conditions
    assert all(set(SCENE.needed) <= set(r) <= set(SCENE.reference_fields) for r in runs)
    assert all(r['run'] == SCENE_SETTINGS for r in runs)
    assert len({tuple(r[f] for f in SCENE.key) for r in runs}) == len(runs)
    success = {op: {c: round(row['success'], 3) for c, row in scene.summarise(
        [r for r in runs if r['operator'] == op]).items() if c in scene.SCENE_CONDITIONS}
        for op in ('joystick', 'spacemouse')}  # the reference's devices (the changing operators: not in it)
    assert success == {'joystick': {'direct': 0.367, 'ada': 0.16, 'suite': 0.587, 'top_object': 0.38,
                                    'estimated': 0.567},
                       'spacemouse': {'direct': 0.64, 'ada': 0.62, 'suite': 0.753, 'top_object': 0.567,
                                      'estimated': 0.76}}
