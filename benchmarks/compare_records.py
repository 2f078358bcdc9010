r"""Did a change make a simulated closed loop worse? Two runs of one benchmark paired, run by run.

Reads two ``--records`` files (``.jsonl`` or ``.jsonl.gz``; e.g. the shipped reference, ``benchmarks/reference/``,
and a run of your change) of one of two benchmarks, told by the records' fields (:func:`kind_of`):
``bench_shared_control_sim.py`` (one object: :data:`SIM`) or ``bench_shared_control_scene.py`` (two objects:
:data:`SCENE`). It pairs their runs: a pair is the same object (one-object records), operator, episode, repeat and
condition in both. Per cell (object x operator x condition, or operator x condition for two objects) present in
both it prints the pairs and how many are identical (the same success, closing, time to grasp and, where both
carry it, sweep); success, and success with a clear path where the benchmark reports it (one object; two objects'
success already requires that no object was swept), new minus base in points, paired over episodes (each
episode's mean over the repeats both files hold), with 95% bootstrap CIs; time to grasp as the paired
geometric-mean ratio new / base with its CI, and the medians (a run that never closed counts as the timeout: its
record's ``time``; so a ratio cannot tell a run that closed at the timeout from one that never did, and the
never-closed counts are printed beside it). The figures are the benchmark's own (its ``episode_figures``) and so
are the statistics (:func:`bench_shared_control_sim.paired_difference`: the seeded bootstrap of
``_bench.bootstrap_ci``, success first, then time, on ``default_rng(0)``; clear on ``default_rng(1)``), fresh per
cell.

Verdict per cell: **regression** when the success or the clear-path difference has its CI wholly below -2 points,
or the time ratio its CI wholly above 1.0 (any slowdown the CI is sure of). A flag for a person to look at, not a
gate: a change that alters the runs without making the loop worse can cross it by chance in one of the cells (36
for one object, 10 for two). Fewer episodes widen the CIs, but with very few (under about 10) the percentile
bootstrap's interval is narrower than it should be (one episode gives a point): a small run's flag is a hint to
confirm on the full run.

Pairing. The records carry the run's settings (``run``: each benchmark's ``run_settings``); the files are refused
when they are of different benchmarks (one object's runs against two objects'), when one file holds runs of more
than one setting or a run twice, when the settings that make the episodes differ (the benchmark's
``EPISODE_SETTINGS``: other seeds, intent, tracker or operator errors, timeout, the favoured object's P(o): other
episodes), when any pair's truth differs (its true task set, and for two objects its true object: the episodes are
not the same; this check needs no settings, so files written before records carried ``run`` are still checked by
it, with a warning that their settings are unknown), or when no run pairs. The loop's settings (the grasp
command's execution, the planner's noise and margin, the estimator's fields, the mock arm's rule at a joint limit)
may differ: they are printed as what the comparison measures.

Exit status: 0 no cell regresses, 1 some cell regresses, 2 the input was refused.

A reference file (``--write-reference OUT``, e.g. the shipped ``benchmarks/reference/persistent.jsonl.gz`` and
``scene.jsonl.gz``): a records file with the fields a comparison and the benchmark's ``--summarise`` read alone
(:attr:`Kind.reference_fields`), gzip-compressed; only records that carry their run's settings make one.

    .venv/bin/python benchmarks/compare_records.py benchmarks/reference/persistent.jsonl.gz mine.jsonl
    .venv/bin/python benchmarks/compare_records.py benchmarks/reference/scene.jsonl.gz mine_scene.jsonl
    .venv/bin/python benchmarks/compare_records.py full_run.jsonl --write-reference persistent.jsonl.gz
"""

from __future__ import annotations

import argparse
import gzip
import itertools
import json
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import bench_shared_control_scene as scene
import bench_shared_control_sim as sim
import numpy as np
from _bench.closed_loop import OBJECTS

REGRESSION_POINTS = -0.02
"""A success or clear-path difference whose CI lies wholly below this (a share: -2 points) flags its cell."""
REGRESSION_RATIO = 1.0
"""A time ratio (new / base) whose CI lies wholly above this flags its cell."""
OUTCOME = ('success', 'closed', 'time')
"""The fields two identical runs agree on (and ``swept`` where both carry it)."""

Figures = Callable[[list[dict[str, Any]]], dict[str, dict[str, dict[int, float]]]]
"""A benchmark's figures of its records: figure -> condition -> episode -> the mean over repeats."""


@dataclass(frozen=True)
class Kind:
    """One benchmark's records: what names a run and a cell, what a pair shares, what is compared and kept."""

    benchmark: str
    groups: tuple[tuple[str, tuple[str, ...]], ...]
    """The fields that, with the condition, name a cell, each with its values in the order cells are printed."""
    conditions: tuple[str, ...]
    """The conditions in the order cells are printed."""
    episode: tuple[str, ...]
    """The fields two runs of one episode share (what the benchmark drew as the truth)."""
    episode_name: str
    """What :attr:`episode` is, in a refusal."""
    episode_settings: tuple[str, ...]
    """The fields of the records' ``run`` that make other episodes."""
    figures: Figures
    """The benchmark's own figures (success, time and, where it reports it, clear-path success)."""
    summarised: tuple[str, ...]
    """The further fields the benchmark's ``--summarise`` reads."""

    @property
    def key(self) -> tuple[str, ...]:
        """The fields that name a run: a pair is one key in both files."""
        return (*(field for field, _ in self.groups), 'episode', 'repeat', 'condition')

    @property
    def needed(self) -> tuple[str, ...]:
        """The fields a comparison needs in every record (it reads ``swept`` and ``run`` too, where carried)."""
        return (*self.key, *self.episode, *OUTCOME)

    @property
    def reference_fields(self) -> tuple[str, ...]:
        """What a reference file keeps of each record (those it carries): what compare and ``--summarise`` read."""
        return (*self.needed, 'swept', *self.summarised, 'run')


SIM = Kind('bench_shared_control_sim', (('object', tuple(OBJECTS)), ('operator', sim.OPERATORS)), sim.RUN,
           ('task_set',), 'true task set', sim.EPISODE_SETTINGS, sim.episode_figures,
           ('in_at_closing', 'effort_linear', 'wrong_pull'))
"""One object's closed loop (``bench_shared_control_sim.py``); its records carry ``object``."""
SCENE = Kind('bench_shared_control_scene', (('operator', scene.OPERATORS),), scene.ALL_SCENE_CONDITIONS,
             ('true_object', 'task_set'), 'true object or task set', scene.EPISODE_SETTINGS, scene.episode_figures,
             ('favoured', 'serves', 'wrong_object', 'wrong_object_alpha', 'estimated_p_true'))
"""Two objects' closed loop (``bench_shared_control_scene.py``); its records carry ``true_object``, not ``object``."""


Runs = dict[tuple[Any, ...], dict[str, Any]]
"""A file's runs by their kind's :attr:`Kind.key`."""


class Unpairable(ValueError):
    """The two record files cannot be compared run by run (the message says why)."""


@dataclass(frozen=True)
class Cell:
    """One cell (the kind's groups x condition) of both files: its pairs and the paired figures."""

    group: tuple[str, ...]
    """The values of :attr:`Kind.groups`: object and operator, or the operator."""
    condition: str
    pairs: int
    identical: int
    episodes: int
    repeats: int
    diff: dict[str, Any]
    """:func:`bench_shared_control_sim.paired_difference` of new minus base."""
    success: tuple[float, float]
    clear: tuple[float, float] | None
    median_time: tuple[float, float]
    never_closed: tuple[int, int]
    """Base, new."""

    @property
    def name(self) -> str:
        """The cell as printed: its group's values and the condition."""
        return ' / '.join((*self.group, self.condition))

    @property
    def regression(self) -> bool:
        """Whether the cell regresses (module docstring)."""
        return (self.diff['ci'][1] < REGRESSION_POINTS or self.diff['time_ratio_ci'][0] > REGRESSION_RATIO
                or ('clear_ci' in self.diff and self.diff['clear_ci'][1] < REGRESSION_POINTS))


def kind_of(records: list[dict[str, Any]], name: str) -> Kind:
    """The benchmark whose records these are, told by their fields.

    :data:`SIM` when every record carries ``object``, :data:`SCENE` when every one ``true_object`` and no
    ``object`` (a field the other benchmark's records never carry, so no flag is needed). Raises
    :class:`Unpairable` when there are none, when a record carries neither or when the file holds both.
    """
    kinds = {SIM if 'object' in r else SCENE if 'true_object' in r else None for r in records}
    if not kinds:
        raise Unpairable(f'{name}: no records')
    if None in kinds:
        raise Unpairable(f'{name}: a record has neither object nor true_object (not records of '
                         f'{SIM.benchmark} or {SCENE.benchmark}?)')
    if len(kinds) > 1:
        raise Unpairable(f'{name}: it holds records of both {SIM.benchmark} and {SCENE.benchmark}')
    return kinds.pop()  # type: ignore[return-value]


def index(records: list[dict[str, Any]], name: str) -> tuple[Kind, Runs, Any]:
    """The records' kind (:func:`kind_of`), the records by its key, the settings their ``run`` gives (None: none).

    Raises :class:`Unpairable` when the kind is unknown, when a record lacks a field of :attr:`Kind.needed`, when a
    key appears twice (two runs appended to one file) or when the records carry more than one run's settings.
    """
    kind = kind_of(records, name)
    runs: Runs = {}
    settings = []
    for r in records:
        missing = [f for f in kind.needed if f not in r]
        if missing:
            raise Unpairable(f'{name}: a record lacks {", ".join(missing)} (not {kind.benchmark} records?)')
        key = tuple(r[f] for f in kind.key)
        if key in runs:
            raise Unpairable(f'{name}: the run {"/".join(map(str, key))} appears twice (two runs in one file?)')
        runs[key] = r
        if r.get('run') not in settings:
            settings.append(r.get('run'))
    if len(settings) > 1:
        raise Unpairable(f'{name}: its records carry more than one run\'s settings: {settings}')
    return kind, runs, settings[0]


def pair(base: list[dict[str, Any]], new: list[dict[str, Any]]
         ) -> tuple[Kind, list[tuple[Any, ...]], Runs, Runs, list[str]]:
    """Both files' kind, the keys of the runs both hold (in ``base``'s order), each file's runs by key, notes.

    The notes: the settings (or the warning that they are unknown). Raises :class:`Unpairable` (module
    docstring, Pairing).
    """
    kind, base_runs, base_settings = index(base, 'base')
    new_kind, new_runs, new_settings = index(new, 'new')
    if new_kind != kind:
        raise Unpairable(f'base holds {kind.benchmark} records, new {new_kind.benchmark} records: other episodes '
                         '(one object against two), never paired')
    notes = []
    if base_settings is None or new_settings is None:
        unknown = ' and '.join(n for n, s in (('base', base_settings), ('new', new_settings)) if s is None)
        notes.append(f'warning: the settings of {unknown} are unknown (records written before they carried them): '
                     f'paired on the episodes\' {kind.episode_name} alone')
    else:
        differ = [f'{f} {base_settings.get(f)} -> {new_settings.get(f)}' for f in kind.episode_settings
                  if base_settings.get(f) != new_settings.get(f)]
        if differ:
            raise Unpairable(f'the runs make other episodes: {"; ".join(differ)}')
        loop = [f'{f} {base_settings.get(f)} -> {new_settings.get(f)}' for f in sorted({*base_settings, *new_settings})
                if f not in kind.episode_settings and base_settings.get(f) != new_settings.get(f)]
        shown = ', '.join(f'{f} {base_settings[f]}' for f in kind.episode_settings)
        notes.append(f'settings: {shown}; the loop\'s: {"; ".join(loop) if loop else "the same"}')
    keys = [k for k in base_runs if k in new_runs]
    if not keys:
        raise Unpairable('no run is in both files (other objects, operators, conditions or episodes)')
    other = [k for k in keys if any(base_runs[k][f] != new_runs[k][f] for f in kind.episode)]
    if other:
        raise Unpairable(f'{len(other)} of {len(keys)} pairs have another {kind.episode_name} (first: '
                         f'{"/".join(map(str, other[0]))}): the runs are not of the same episodes')
    return kind, keys, base_runs, new_runs, notes


def identical(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two runs have the same outcome (:data:`OUTCOME`, and ``swept`` where both carry it)."""
    return all(a[f] == b[f] for f in OUTCOME) and ('swept' not in a or 'swept' not in b or a['swept'] == b['swept'])


def compare(base: list[dict[str, Any]], new: list[dict[str, Any]]) -> tuple[Kind, list[Cell], list[str], int]:
    """Both files' kind; every cell both hold, paired (module docstring); the settings' notes; the pairs.

    Raises :class:`Unpairable` (module docstring, Pairing).
    """
    kind, keys, base_runs, new_runs, notes = pair(base, new)
    grouped = len(kind.groups)
    cells = []
    for group, c in itertools.product(itertools.product(*(order for _, order in kind.groups)), kind.conditions):
        cell = [k for k in keys if k[:grouped] == group and k[-1] == c]
        if not cell:
            continue
        a, b = [new_runs[k] for k in cell], [base_runs[k] for k in cell]
        fig_a, fig_b = kind.figures(a), kind.figures(b)
        diff = sim.paired_difference({f: v[c] for f, v in fig_a.items()}, {f: v[c] for f, v in fig_b.items()},
                                     np.random.default_rng(0), np.random.default_rng(1))
        mean = {f: (float(np.mean(list(fig_b[f][c].values()))), float(np.mean(list(fig_a[f][c].values()))))
                for f in fig_a if f in fig_b and f != 'time'}
        cells.append(Cell(group, c, len(cell), sum(identical(x, y) for x, y in zip(a, b)),
                          len({k[-3] for k in cell}), len({k[-2] for k in cell}), diff, mean['success'],
                          mean.get('clear'), (float(np.median([r['time'] for r in b])),
                                              float(np.median([r['time'] for r in a]))),
                          (sum(not r['closed'] for r in b), sum(not r['closed'] for r in a))))
    return kind, cells, notes, len(keys)


def report(cell: Cell) -> str:
    """The lines printed for one cell."""
    d = cell.diff
    points = '{:+5.1f} points [{:+5.1f}, {:+5.1f}]'.format
    clear = ('' if cell.clear is None else f'\n  clear success {cell.clear[0]:.3f} -> {cell.clear[1]:.3f}  '
             + points(100 * d['clear_diff'], *(100 * x for x in d['clear_ci'])))
    verdict = '**regression**' if cell.regression else 'no regression'
    return (f'[{cell.name}] {cell.pairs} pairs ({cell.episodes} episodes x '
            f'{cell.repeats} repeats), {cell.identical} identical: {verdict}\n'
            f'  success {cell.success[0]:.3f} -> {cell.success[1]:.3f}  '
            + points(100 * d['success_diff'], *(100 * x for x in d['ci'])) + clear +
            f'\n  time to grasp: new / base {d["time_ratio"]:.3f} [{d["time_ratio_ci"][0]:.3f}, '
            f'{d["time_ratio_ci"][1]:.3f}], median {cell.median_time[0]:.2f} -> {cell.median_time[1]:.2f} s, never '
            f'closed {cell.never_closed[0]} -> {cell.never_closed[1]} of {cell.pairs}')


def write_reference(records: list[dict[str, Any]], path: str) -> None:
    """Write ``records`` as a reference file: their kind's :attr:`Kind.reference_fields` alone.

    One line per episode (per object and operator, or per operator, as the benchmark's ``--records`` writes them),
    in the records' order. Gzip-compressed with no time stamp, so the same records give the same bytes. Raises
    :class:`Unpairable` when the records are of no known kind, when a record lacks a field of :attr:`Kind.needed`
    or the run's settings, or a run appears twice.
    """
    kind, _, settings = index(records, 'the records')
    if settings is None:
        raise Unpairable('the records carry no run settings (written before records carried them): a reference '
                         'must say which episodes it holds')
    episodes: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in records:
        episodes.setdefault(tuple(r[f] for f in kind.key[:-2]), []).append(
            {f: r[f] for f in kind.reference_fields if f in r})
    with open(path, 'wb') as raw, gzip.GzipFile('', 'wb', fileobj=raw, mtime=0) as f:
        f.write(''.join(json.dumps(line) + '\n' for line in episodes.values()).encode())


def main(argv: Sequence[str] | None = None) -> int:
    """Compare; the exit status (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('base', help='the reference run\'s --records file (.jsonl or .jsonl.gz)')
    parser.add_argument('new', nargs='?', help='the --records file of the run to check')
    parser.add_argument('--write-reference', metavar='OUT', help='compare nothing: write BASE\'s records as a '
                        'reference file, OUT (.jsonl.gz), with the fields a comparison and --summarise read')
    args = parser.parse_args(argv)
    if (args.new is None) == (args.write_reference is None):
        parser.error('give BASE and NEW, or BASE and --write-reference OUT')
    try:
        if args.write_reference:
            write_reference(sim.read_records(args.base), args.write_reference)
            return 0
        base, new = sim.read_records(args.base), sim.read_records(args.new)
        kind, cells, notes, pairs = compare(base, new)
    except (OSError, ValueError) as e:  # Unpairable is a ValueError
        print(f'compare_records: refused: {e}', file=sys.stderr)
        return 2
    print(f'compare_records: {kind.benchmark} records, base {args.base} ({len(base)} runs), new {args.new} '
          f'({len(new)} runs): {pairs} pairs '
          f'in {len(cells)} cells; runs in one file only: base {len(base) - pairs}, new {len(new) - pairs}')
    for note in notes:
        print(note)
    for cell in cells:
        print(report(cell))
    flagged = [c.name for c in cells if c.regression]
    measures = 'success or clear-path' if any(c.clear is not None for c in cells) else 'success'
    print(f'\n{len(flagged)} of {len(cells)} cells regress ({measures} CI wholly below '
          f'{100 * REGRESSION_POINTS:+.0f} points, or the time ratio\'s wholly above {REGRESSION_RATIO:.1f})'
          + (f': {", ".join(flagged)}' if flagged else ''))
    return 1 if flagged else 0


if __name__ == '__main__':
    sys.exit(main())
