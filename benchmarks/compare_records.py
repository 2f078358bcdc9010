r"""Did a change make the simulated closed loop worse? Two runs of bench_shared_control_sim paired, run by run.

Reads two ``--records`` files of ``bench_shared_control_sim.py`` (``.jsonl`` or ``.jsonl.gz``; e.g. the shipped
reference, ``benchmarks/reference/``, and a run of your change) and pairs their runs: a pair is the same object,
operator, episode, repeat and condition in both. Per object x operator x condition present in both it prints the
pairs and how many are identical (the same success, closing, time to grasp and, where both carry it, sweep);
success and success with a clear path, new minus base in points, paired over episodes (each episode's mean over
the repeats both files hold), with 95% bootstrap CIs; time to grasp as the paired geometric-mean ratio new / base
with its CI, and the medians (a run that never closed counts as the timeout: its record's ``time``; so a ratio
cannot tell a run that closed at the timeout from one that never did, and the never-closed counts are printed
beside it). The statistics are the benchmark's own (:func:`bench_shared_control_sim.paired_difference`: the
seeded bootstrap of ``_bench.bootstrap_ci``, success first, then time, on ``default_rng(0)``; clear on
``default_rng(1)``), fresh per cell.

Verdict per cell: **regression** when the success or the clear-path difference has its CI wholly below -2 points,
or the time ratio its CI wholly above 1.0 (any slowdown the CI is sure of). A flag for a person to look at, not a
gate: a change that alters the runs without making the loop worse can cross it by chance in one of 36 cells.
Fewer episodes widen the CIs, but with very few (under about 10) the percentile bootstrap's interval is narrower
than it should be (one episode gives a point): a small run's flag is a hint to confirm on the full run.

Pairing. The records carry the run's settings (``run``: :func:`bench_shared_control_sim.run_settings`); the
files are refused when one file holds runs of more than one setting or a run twice, when their
:data:`~bench_shared_control_sim.EPISODE_SETTINGS` differ (other seeds, intent, tracker or operator errors,
timeout: other episodes), when any pair's true task set differs (the episodes are not the same: this check needs
no settings, so files written before records carried ``run`` are still checked by it, with a warning that their
settings are unknown), or when no run pairs. The loop's settings (the grasp command's execution, the planner's
noise and margin, the estimator's fields) may differ: they are printed as what the comparison measures.

Exit status: 0 no cell regresses, 1 some cell regresses, 2 the input was refused.

A reference file (``--write-reference OUT``, e.g. the shipped ``benchmarks/reference/persistent.jsonl.gz``):
a records file with the fields a comparison and the benchmark's ``--summarise`` read alone
(:data:`REFERENCE_FIELDS`), gzip-compressed; only records that carry their run's settings make one.

    .venv/bin/python benchmarks/compare_records.py benchmarks/reference/persistent.jsonl.gz mine.jsonl
    .venv/bin/python benchmarks/compare_records.py full_run.jsonl --write-reference persistent.jsonl.gz
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from _bench.closed_loop import OBJECTS
from bench_shared_control_sim import (
    EPISODE_SETTINGS,
    OPERATORS,
    RUN,
    episode_figures,
    paired_difference,
    read_records,
)

REGRESSION_POINTS = -0.02
"""A success or clear-path difference whose CI lies wholly below this (a share: -2 points) flags its cell."""
REGRESSION_RATIO = 1.0
"""A time ratio (new / base) whose CI lies wholly above this flags its cell."""
KEY = ('object', 'operator', 'episode', 'repeat', 'condition')
"""The fields that name a run: a pair is one key in both files."""
OUTCOME = ('success', 'closed', 'time')
"""The fields two identical runs agree on (and ``swept`` where both carry it)."""
NEEDED = (*KEY, 'task_set', *OUTCOME)
REFERENCE_FIELDS = (*NEEDED, 'swept', 'in_at_closing', 'effort_linear', 'wrong_pull', 'run')
"""What a reference file keeps of each record (those it carries): what this comparison and the benchmark's
``--summarise`` read."""


Runs = dict[tuple[Any, ...], dict[str, Any]]
"""A file's runs by :data:`KEY`."""


class Unpairable(ValueError):
    """The two record files cannot be compared run by run (the message says why)."""


@dataclass(frozen=True)
class Cell:
    """One object x operator x condition of both files: its pairs and the paired figures."""

    object: str
    operator: str
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
    def regression(self) -> bool:
        """Whether the cell regresses (module docstring)."""
        return (self.diff['ci'][1] < REGRESSION_POINTS or self.diff['time_ratio_ci'][0] > REGRESSION_RATIO
                or ('clear_ci' in self.diff and self.diff['clear_ci'][1] < REGRESSION_POINTS))


def index(records: list[dict[str, Any]], name: str) -> tuple[Runs, Any]:
    """``records`` by :data:`KEY`, and the settings their ``run`` gives (None: they carry none).

    Raises :class:`Unpairable` when a record lacks a field of :data:`NEEDED`, when a key appears twice (two runs
    appended to one file) or when the records carry more than one run's settings.
    """
    runs: Runs = {}
    settings = []
    for r in records:
        missing = [f for f in NEEDED if f not in r]
        if missing:
            raise Unpairable(f'{name}: a record lacks {", ".join(missing)} (not bench_shared_control_sim records?)')
        key = tuple(r[f] for f in KEY)
        if key in runs:
            raise Unpairable(f'{name}: the run {"/".join(map(str, key))} appears twice (two runs in one file?)')
        runs[key] = r
        if r.get('run') not in settings:
            settings.append(r.get('run'))
    if len(settings) > 1:
        raise Unpairable(f'{name}: its records carry more than one run\'s settings: {settings}')
    return runs, settings[0] if settings else None


def pair(base: list[dict[str, Any]], new: list[dict[str, Any]]) -> tuple[list[tuple[Any, ...]], Runs, Runs, list[str]]:
    """The keys of the runs both hold (in ``base``'s order), each file's runs by key, notes on the settings.

    Raises :class:`Unpairable` (module docstring, Pairing).
    """
    base_runs, base_settings = index(base, 'base')
    new_runs, new_settings = index(new, 'new')
    notes = []
    if base_settings is None or new_settings is None:
        unknown = ' and '.join(n for n, s in (('base', base_settings), ('new', new_settings)) if s is None)
        notes.append(f'warning: the settings of {unknown} are unknown (records written before they carried them): '
                     'paired on the episodes\' task sets alone')
    else:
        differ = [f'{f} {base_settings.get(f)} -> {new_settings.get(f)}' for f in EPISODE_SETTINGS
                  if base_settings.get(f) != new_settings.get(f)]
        if differ:
            raise Unpairable(f'the runs make other episodes: {"; ".join(differ)}')
        loop = [f'{f} {base_settings.get(f)} -> {new_settings.get(f)}' for f in sorted({*base_settings, *new_settings})
                if f not in EPISODE_SETTINGS and base_settings.get(f) != new_settings.get(f)]
        shown = ', '.join(f'{f} {base_settings[f]}' for f in EPISODE_SETTINGS)
        notes.append(f'settings: {shown}; the loop\'s: {"; ".join(loop) if loop else "the same"}')
    keys = [k for k in base_runs if k in new_runs]
    if not keys:
        raise Unpairable('no run is in both files (other objects, operators, conditions or episodes)')
    other = [k for k in keys if base_runs[k]['task_set'] != new_runs[k]['task_set']]
    if other:
        raise Unpairable(f'{len(other)} of {len(keys)} pairs have another true task set (first: '
                         f'{"/".join(map(str, other[0]))}): the runs are not of the same episodes')
    return keys, base_runs, new_runs, notes


def identical(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two runs have the same outcome (:data:`OUTCOME`, and ``swept`` where both carry it)."""
    return all(a[f] == b[f] for f in OUTCOME) and ('swept' not in a or 'swept' not in b or a['swept'] == b['swept'])


def compare(base: list[dict[str, Any]], new: list[dict[str, Any]]) -> tuple[list[Cell], list[str], int]:
    """Every object x operator x condition both hold, paired (module docstring); the settings' notes; the pairs.

    Raises :class:`Unpairable` (module docstring, Pairing).
    """
    keys, base_runs, new_runs, notes = pair(base, new)
    cells = []
    for o in [o for o in OBJECTS if any(k[0] == o for k in keys)]:
        for op in [op for op in OPERATORS if any(k[:2] == (o, op) for k in keys)]:
            for c in [c for c in RUN if any(k[:2] == (o, op) and k[4] == c for k in keys)]:
                cell = [k for k in keys if k[:2] == (o, op) and k[4] == c]
                a, b = [new_runs[k] for k in cell], [base_runs[k] for k in cell]
                fig_a, fig_b = episode_figures(a), episode_figures(b)
                diff = paired_difference({f: v[c] for f, v in fig_a.items()}, {f: v[c] for f, v in fig_b.items()},
                                         np.random.default_rng(0), np.random.default_rng(1))
                mean = {f: (float(np.mean(list(fig_b[f][c].values()))), float(np.mean(list(fig_a[f][c].values()))))
                        for f in fig_a if f in fig_b and f != 'time'}
                cells.append(Cell(o, op, c, len(cell), sum(identical(x, y) for x, y in zip(a, b)),
                                  len({k[2] for k in cell}), len({k[3] for k in cell}), diff, mean['success'],
                                  mean.get('clear'), (float(np.median([r['time'] for r in b])),
                                                      float(np.median([r['time'] for r in a]))),
                                  (sum(not r['closed'] for r in b), sum(not r['closed'] for r in a))))
    return cells, notes, len(keys)


def report(cell: Cell) -> str:
    """The lines printed for one cell."""
    d = cell.diff
    points = '{:+5.1f} points [{:+5.1f}, {:+5.1f}]'.format
    clear = ('' if cell.clear is None else f'\n  clear success {cell.clear[0]:.3f} -> {cell.clear[1]:.3f}  '
             + points(100 * d['clear_diff'], *(100 * x for x in d['clear_ci'])))
    verdict = '**regression**' if cell.regression else 'no regression'
    return (f'[{cell.object} / {cell.operator} / {cell.condition}] {cell.pairs} pairs ({cell.episodes} episodes x '
            f'{cell.repeats} repeats), {cell.identical} identical: {verdict}\n'
            f'  success {cell.success[0]:.3f} -> {cell.success[1]:.3f}  '
            + points(100 * d['success_diff'], *(100 * x for x in d['ci'])) + clear +
            f'\n  time to grasp: new / base {d["time_ratio"]:.3f} [{d["time_ratio_ci"][0]:.3f}, '
            f'{d["time_ratio_ci"][1]:.3f}], median {cell.median_time[0]:.2f} -> {cell.median_time[1]:.2f} s, never '
            f'closed {cell.never_closed[0]} -> {cell.never_closed[1]} of {cell.pairs}')


def write_reference(records: list[dict[str, Any]], path: str) -> None:
    """Write ``records`` as a reference file: :data:`REFERENCE_FIELDS` alone, one line per episode.

    Gzip-compressed with no time stamp, so the same records give the same bytes. Raises :class:`Unpairable`
    when a record lacks a field of :data:`NEEDED` or the run's settings, or a run appears twice.
    """
    _, settings = index(records, 'the records')
    if settings is None:
        raise Unpairable('the records carry no run settings (written before records carried them): a reference '
                         'must say which episodes it holds')
    episodes: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in records:
        episodes.setdefault((r['object'], r['operator'], r['episode']), []).append(
            {f: r[f] for f in REFERENCE_FIELDS if f in r})
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
            write_reference(read_records(args.base), args.write_reference)
            return 0
        base, new = read_records(args.base), read_records(args.new)
        cells, notes, pairs = compare(base, new)
    except (OSError, ValueError) as e:  # Unpairable is a ValueError
        print(f'compare_records: refused: {e}', file=sys.stderr)
        return 2
    print(f'compare_records: base {args.base} ({len(base)} runs), new {args.new} ({len(new)} runs): {pairs} pairs '
          f'in {len(cells)} cells; runs in one file only: base {len(base) - pairs}, new {len(new) - pairs}')
    for note in notes:
        print(note)
    for cell in cells:
        print(report(cell))
    flagged = [f'{c.object} / {c.operator} / {c.condition}' for c in cells if c.regression]
    print(f'\n{len(flagged)} of {len(cells)} cells regress (success or clear-path CI wholly below '
          f'{100 * REGRESSION_POINTS:+.0f} points, or the time ratio\'s wholly above {REGRESSION_RATIO:.1f})'
          + (f': {", ".join(flagged)}' if flagged else ''))
    return 1 if flagged else 0


if __name__ == '__main__':
    sys.exit(main())
