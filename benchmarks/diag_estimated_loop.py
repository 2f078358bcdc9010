r"""Why a closed-loop run fails: the loop's trace per run, and the failed runs classified (a diagnostic, not a test).

Runs the episodes of bench_shared_control_sim.py (same seeds, same code: its ``run_task`` with the trace on; its
persistent intent, or ``--intent sharpening``) for the given conditions (default: direct, the suite with scripted
w, the suite with estimated w), or reads the records of an earlier run (``--records FILE`` is appended to as runs
finish; ``--from FILE`` only reads), and prints per object x operator:

- the failed runs of each condition by class (first match, in this order):

  - ``timeout``: the hand never closed (25 s);
  - ``wrong plan``: closed on the shown grasp, which as planned does not serve the true set T (the rules' label
    of its planned features; the operator takes a shown grasp within 6 cm / 0.8 rad of its own). Split by the
    w the plan came from, at the close: ``w wrong`` (the tasks with w_i > 0.5 are not T) or ``w right``;
  - ``right plan, rules fail``: closed on a shown grasp that as planned serves T, and a rule of T fails at the
    reached grasp (the tracker's error, the closure error, a grasp in the rules' threshold band);
  - ``own, rules fail``: closed on its own grasp, a rule fails.

- the estimated-w runs lost against the scripted-w suite (estimated failed, suite succeeded on the same episode
  and repeat) by the same classes, and the rules that failed;
- the loop's state over time, median over the runs of a condition: how often w's set (w_i > 0.5) is T, the
  alpha, the wrong-set pull (alpha while the shown grasp as planned does not serve T), the number of proposals
  (the shown grasp moving by more than 2 cm or 0.2 rad: what restarts the agreement), the w set's first
  time equal to T for good (``settled``).

The judge's rules are read here only after the runs. One command, reusable on other models:

    .venv/bin/python benchmarks/diag_estimated_loop.py [--episodes 50] [--jobs 2] [--objects cup] \
        [--operators joystick] [--intent persistent] [--conditions direct suite estimated] \
        [--estimator rationality=300] [--records runs.jsonl] [--from runs.jsonl]
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from typing import Any

import numpy as np
from _bench import uptime
from _bench.closed_loop import OBJECTS
from bench_shared_control_sim import ESTIMATED, OPERATORS, RUN, Task, estimator_fields, read_records, run_tasks

from grasp_intent_ros.mico.frames import rotation_angle

CLASSES = ('timeout', 'wrong plan, w wrong', 'wrong plan, w right', 'right plan, rules fail', 'own, rules fail')
CORRIDOR = (0.02, 0.2)
"""A shown grasp that moves by more than this (m, rad) is a new proposal (the assistance's corridor)."""


def w_set(w: list[float]) -> int:
    """The task set of the tasks with w_i > 0.5 (bitmask)."""
    return sum(1 << i for i, x in enumerate(w) if x > 0.5)


def classify(run: dict[str, Any]) -> str | None:
    """The class of a failed run (module docstring), None for a success."""
    if run['success']:
        return None
    if not run['closed']:
        return 'timeout'
    trace, T = run['trace'], run['task_set']
    last = trace[-1]
    if run['pursued'] == 'shown':
        shown = last['shown_label']
        if shown is None or shown & T != T:
            return 'wrong plan, w wrong' if w_set(last['w']) != T else 'wrong plan, w right'
        return 'right plan, rules fail'
    return 'own, rules fail'


def proposals(trace: list[dict[str, Any]]) -> int:
    """How many grasps were proposed: the shown grasp's moves beyond the corridor, plus the first."""
    count, last = 0, None
    for row in trace:
        if row['shown_p'] is None:
            continue
        p, R = np.asarray(row['shown_p']), np.asarray(row['shown_R']).reshape(3, 3)
        if last is not None:
            moved = float(np.linalg.norm(p - last[0]))
            angle = rotation_angle(last[1], R)
            if moved <= CORRIDOR[0] and angle <= CORRIDOR[1]:
                continue
        count, last = count + 1, (p, R)
    return count


def loop_state(run: dict[str, Any]) -> dict[str, float]:
    """One run's w, alpha and plan figures (module docstring)."""
    trace = run['trace']
    right = [w_set(r['w']) == r['T'] for r in trace]
    settled = next((r['t'] for i, r in enumerate(trace) if all(right[i:])), float('nan'))
    wrong = [r['shown_label'] is None or r['shown_label'] & r['T'] != r['T'] for r in trace]
    wrong_pull = sum(0.1 * r['alpha'] for r, bad in zip(trace, wrong) if bad)
    return {'w right share': float(np.mean(right)) if right else float('nan'),
            'alpha mean': float(np.mean([r['alpha'] for r in trace])) if trace else float('nan'),
            'wrong-set pull (alpha s)': wrong_pull, 'proposals': float(proposals(trace)),
            'settled (s)': settled, 'shown wrong share': float(np.mean(wrong)) if wrong else float('nan')}


def report(records: list[dict[str, Any]]) -> None:
    """Print the tables of the module docstring for every cell of ``records``."""
    conditions = [c for c in RUN if any(r['condition'] == c for r in records)]
    for o in OBJECTS:
        for op in OPERATORS:
            cell = [r for r in records if r['object'] == o and r['operator'] == op]
            if not cell:
                continue
            print(f'\n[{o} / {op}] {len({r["episode"] for r in cell})} episodes')
            print(f'  {"class":26s}' + ''.join(f'{c:>11s}' for c in conditions))
            counts = {c: Counter(classify(r) for r in cell if r['condition'] == c) for c in conditions}
            for k in CLASSES:
                print(f'  {k:26s}' + ''.join(f'{counts[c][k]:11d}' for c in conditions))
            print(f'  {"success":26s}' + ''.join(f'{counts[c][None]:11d}' for c in conditions))
            by = {(r['condition'], r['episode'], r['repeat']): r for r in cell}
            if ESTIMATED in conditions and 'suite' in conditions:
                lost = [r for (c, e, k), r in by.items() if c == ESTIMATED and not r['success']
                        and by.get(('suite', e, k), {}).get('success')]
                won = [r for (c, e, k), r in by.items() if c == ESTIMATED and r['success']
                       and not by.get(('suite', e, k), {}).get('success', True)]
                lost_classes = Counter(classify(r) for r in lost)
                rules = Counter(f for r in lost for f in r['failed'])
                print(f'  estimated lost / won against scripted w: {len(lost)} / {len(won)}; lost by class: '
                      + ', '.join(f'{k} {n}' for k, n in lost_classes.most_common())
                      + '; failed rules: ' + ', '.join(f'{k} {n}' for k, n in rules.most_common(4)))
            for c in conditions:
                states = [loop_state(r) for r in cell if r['condition'] == c]
                keys = list(states[0])
                print(f'  {c:12s} ' + '  '.join(f'{k} {np.nanmedian([s[k] for s in states]):.2f}'
                                                 f' (mean {np.nanmean([s[k] for s in states]):.2f})' for k in keys))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--episodes', type=int, default=50)
    parser.add_argument('--repeats', type=int, default=1)
    parser.add_argument('--objects', nargs='+', default=list(OBJECTS), choices=list(OBJECTS))
    parser.add_argument('--operators', nargs='+', default=list(OPERATORS), choices=list(OPERATORS))
    parser.add_argument('--intent', default='persistent', choices=('persistent', 'sharpening'),
                        help='the episodes\' intent script, as bench_shared_control_sim.py\'s --intent')
    parser.add_argument('--conditions', nargs='+', default=['direct', 'suite', ESTIMATED], choices=list(RUN))
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--estimator', nargs='*', default=[], metavar='FIELD=VALUE',
                        help='EstimatorConfig fields for the estimated condition (default: the node\'s defaults)')
    parser.add_argument('--records', help='append each episode\'s traced records here (JSON lines)')
    parser.add_argument('--from', dest='source', metavar='JSONL', help='run nothing: classify these records '
                        '(.jsonl or .jsonl.gz)')
    args = parser.parse_args()
    if args.source:
        report(read_records(args.source))
        return
    tasks = [Task(o, op, i, args.seed, args.repeats, args.intent, 25.0, 5.0, 3.0,
                  tuple(c for c in RUN if c in args.conditions),
                  estimator=estimator_fields(args.estimator), trace=True)
             for i in range(args.episodes) for o in args.objects for op in args.operators]
    print(f'diag_estimated_loop: {len(tasks)} episodes, conditions {args.conditions}; {uptime()}', flush=True)
    t0 = time.monotonic()
    records = run_tasks(tasks, args.jobs, args.records)
    report(records)
    print(f'\ndone in {time.monotonic() - t0:.0f} s; {uptime()}')


if __name__ == '__main__':
    main()
