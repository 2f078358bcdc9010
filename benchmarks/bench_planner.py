"""Planner benchmark: optimality, stability, continuity, plausibility and speed. Prints figures, asserts nothing.

Sections (all seeded; ``--n`` random w per model, 500 by default; the targets are the README's planner rows):

Sections 2-5 measure ``--method`` (default: the planner's default, ``'task'``); section 1 the paper's planner
(``'lm'``), whose objective it checks. Task success: bench_task_success.py.

1. **Optimality.** For every shipped model, n random w (uniform in [0, 1]^3; w asking for clarification
   are redrawn) and, on both 7-zone models, the 7 cases (every task alone, every pair, all three): the
   planner's objective against :func:`grasp_intent_ros.planning.scipy_methods.reference_search` (60-start SLSQP:
   every zone mean, then seeded random points). Within max(1e-9, 1%) of the reference, or better.
2. **Stability.** The same w with v perturbed by 1e-12 (relative): the same grasp (palm within 1e-6 m,
   approach within 1e-6) on both 7-zone models.
3. **Continuity.** ``--walks`` random walks of w (steps N(0, 0.01) per task, 2,000 steps each, seeds
   ``--seed`` on, warm-started from the previous plan): the share of steps where the grasp jumps (palm
   > 20 mm or approach > 0.3 rad), and how many of those came while the previous solution's branch
   still matched v. Walks differ in how long they stay where no grasp matches v (flashlight: 238-966
   of 2,000 steps), where most jumps are.
4. **Plausibility.** Planned grasps with the palm centre inside the object's body, per object.
5. **Speed.** Fresh plans and warm-started streams, and the paper-faithful baseline (one start,
   SLSQP, finite differences) on the same w in a pass of its own, with the ratio. The streams are
   ``--walks`` random walks of n steps (seeds ``--seed`` on), each timed and then pooled: a single walk
   stays in one region of w, and how many of its steps have no exact match sets its cost. (Interleaved
   with the planner's plans, the baseline's 70-900 ms of scipy per plan evicted the planner's caches
   before each fresh plan: flashlight median 1.6 against 1.1 ms on the same code.)

    python benchmarks/bench_planner.py [--n 500] [--seed 0] [--sections 1,2,3,4,5] [--reference-starts 60]
        [--walks 5] [--models cup_7zone,flashlight_7zone]

The optimality section runs 60 SLSQP refinements per w: about 1-2 s per w on a 2-core machine.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Iterator

import numpy as np
from _bench import percentiles

from grasp_intent_ros.method import intent
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import common, planner, ranking, scipy_methods
from grasp_intent_ros.planning.options import DEFAULT_METHOD, Method, ScipyOptions
from grasp_intent_ros.resources import config_dir

MODELS = ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')
SEVEN = ('cup_7zone', 'flashlight_7zone')
CASES = [(0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9), (0.9, 0.9, 0.1), (0.9, 0.1, 0.9), (0.1, 0.9, 0.9),
         (0.9, 0.9, 0.9)]
BASELINE = {'method': 'slsqp', 'options': ScipyOptions(n_starts=1, top_zones=1, gradient='2-point')}


def load(name: str) -> GraspModel:
    return GraspModel.load(config_dir() / 'models' / f'{name}.yaml')


def random_targets(model: GraspModel, n: int, seed: int) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """N (w, v) pairs from independent uniform w; clarification cases redrawn."""
    rng = np.random.default_rng(seed)
    count = 0
    while count < n:
        w = rng.uniform(0.0, 1.0, 3)
        r = intent.interpret(w, model.zones)
        if r.v is not None:
            count += 1
            yield w, r.v


def walk_targets(model: GraspModel, n: int, seed: int) -> list[np.ndarray]:
    """N target vectors from a random walk of w (steps N(0, 0.01), kept in [0.02, 0.98])."""
    rng = np.random.default_rng(seed)
    w = np.array([0.9, 0.5, 0.2])
    out: list[np.ndarray] = []
    while len(out) < n:
        w = np.clip(w + rng.normal(0.0, 0.01, 3), 0.02, 0.98)
        r = intent.interpret(w, model.zones)
        if r.v is not None:
            out.append(r.v)
    return out


def optimality(n: int, seed: int, reference_starts: int, models: tuple[str, ...] = MODELS) -> None:
    print(f'1. optimality: planner vs {reference_starts}-start SLSQP search; within max(1e-9, 1%) counts as met')
    for name in models:
        model = load(name)
        sets = [('random', [v for _, v in random_targets(model, n, seed)])]
        if name in SEVEN:
            sets.append(('7 cases', [r.v for w in CASES if (r := intent.interpret(w, model.zones)).v is not None]))
        for label, targets in sets:
            met, better, worst, statuses = 0, 0, 0.0, {}
            for v in targets:
                res = planner.plan(model, v, method='lm')
                ref = scipy_methods.reference_search(model, v, n_starts=reference_starts)
                met += res.objective <= max(1e-9, 1.01 * ref)
                better += res.objective < ref - 1e-12
                worst = max(worst, res.objective - ref)
                statuses[res.status] = statuses.get(res.status, 0) + 1
            print(f'  {name:17s} {label:8s} met {met}/{len(targets)} ({100 * met / len(targets):.1f}%), better than '
                  f'the search in {better}, largest excess {worst:.2e}; status {statuses}')


def stability(n: int, seed: int, models: tuple[str, ...], method: Method) -> None:
    print('2. stability: v perturbed by 1e-12 (relative); same grasp = palm within 1e-6 m, approach within 1e-6')
    rng = np.random.default_rng(seed + 1)
    for name in (m for m in SEVEN if m in models):
        model = load(name)
        same = 0
        for _, v in random_targets(model, n, seed):
            vp = v * (1.0 + 1e-12 * rng.standard_normal(v.size))
            a, b = planner.plan(model, v, method=method), planner.plan(model, vp / vp.sum(), method=method)
            same += (np.abs(a.x[:3] - b.x[:3]).max() <= 1e-6) and (np.abs(a.x[3:6] - b.x[3:6]).max() <= 1e-6)
        print(f'  {name:17s} same grasp in {same}/{n} ({100 * same / n:.2f}%)')


def expected_success(model: GraspModel, v: np.ndarray, res: common.PlanResult) -> float:
    """The model's expected success of a 'task' plan: v's mass on the zones its demonstration serves."""
    assert res.chosen.demonstration is not None, "a 'task' plan's candidate is a demonstration"
    return float(ranking.expected_success(model.demo_sets[[res.chosen.demonstration]], model.zones, v)[0])


def kept_by_hysteresis(model: GraspModel, v: np.ndarray, res: common.PlanResult) -> bool:
    """Whether a stream's answer does or reads as a task outside the fresh likely set (so hysteresis kept it)."""
    likely = ranking.likely_tasks(model, v, int(common.zone_order(v)[0]), ranking.TAU, 0, ranking.HYSTERESIS)
    assert res.chosen.demonstration is not None, "a 'task' plan's candidate is a demonstration"
    tasks = int(model.demo_sets[res.chosen.demonstration]) | int(model.zones[int(np.argmax(res.chosen.posterior))])
    return bool(tasks & ~likely)


def continuity(steps: int, seed: int, walks: int, models: tuple[str, ...], method: Method) -> None:
    print(f'3. continuity: {walks} random walks of w (seeds {seed}-{seed + walks - 1}), {steps} steps each, '
          'warm-started; jump = palm > 20 mm or approach > 0.3 rad')
    if method == 'task':
        print(f'   and against a fresh plan at every step: the stream\'s expected success E (by the model) below the '
              f'fresh plan\'s by more than the band {ranking.BAND}, its residual |v - P| above the fresh one\'s by '
              f'more than the band {ranking.KEEP_BAND} (the bands hold where the stream\'s answer lies in the fresh '
              f'likely set; steps where it keeps a task by hysteresis, w_i within {ranking.HYSTERESIS} below tau, '
              'are counted apart), and the fit f of both')
    for name in (m for m in SEVEN if m in models):
        model = load(name)
        total = 0
        for walk_seed in range(seed, seed + walks):
            previous, jumps, branch_held, inexact = None, 0, 0, 0
            worse, unfit, held, f_warm, f_fresh = 0, 0, 0, [], []
            for v in walk_targets(model, steps, walk_seed):
                res = planner.plan(model, v, warm_start=None if previous is None else previous.x, method=method)
                inexact += not res.exact
                if method == 'task':
                    fresh = planner.plan(model, v, method=method)
                    if kept_by_hysteresis(model, v, res):
                        held += 1
                    else:
                        worse += expected_success(model, v, res) < expected_success(model, v, fresh) - ranking.BAND
                        unfit += np.sqrt(2.0 * res.objective) > np.sqrt(2.0 * fresh.objective) + ranking.KEEP_BAND
                    f_warm.append(res.objective)
                    f_fresh.append(fresh.objective)
                if previous is not None:
                    palm = np.linalg.norm(res.x[:3] - previous.x[:3])
                    angle = np.arccos(np.clip(res.x[3:6] @ previous.x[3:6], -1.0, 1.0))
                    if palm > 0.02 or angle > 0.3:
                        jumps += 1
                        # the warm start's own projection is candidate 0 when it matched v
                        branch_held += method == 'lm' and res.candidates[0].start_index == 0 and res.exact
                previous = res
            total += jumps
            detail = (f'outside the bands in {worse} (E) and {unfit} (fit) steps, {held} steps kept a task by '
                      f'hysteresis; mean f {np.mean(f_warm):.3e} '
                      f'(fresh {np.mean(f_fresh):.3e})' if method == 'task' else
                      f'{branch_held} of them while the previous branch still matched v; {inexact} steps with no '
                      'exact match')
            print(f'  {name:17s} seed {walk_seed}: jumps in {jumps}/{steps - 1} steps '
                  f'({100 * jumps / (steps - 1):.2f}%); {detail}')
        print(f'  {name:17s} all {walks} walks: jumps in {total}/{walks * (steps - 1)} steps '
              f'({100 * total / (walks * (steps - 1)):.2f}%)')


def plausibility(n: int, seed: int, models: tuple[str, ...], method: Method) -> None:
    print('4. plausibility: planned grasps with the palm centre inside the object body (margin included)')
    for name in (m for m in SEVEN if m in models):
        model = load(name)
        assert model.body is not None
        xs = np.array([planner.plan(model, v, method=method).x for _, v in random_targets(model, n, seed + 2)])
        inside = int(np.sum(model.body.distance(xs[:, :3])[0] < model.body.margin - 1e-9))
        print(f'  {name:17s} {inside}/{n} inside')


def speed(n: int, seed: int, walks: int, models: tuple[str, ...], method: Method) -> None:
    print('5. speed: wall time per plan (this process, this machine); the baseline on the same w, after the planner')
    for name in (m for m in SEVEN if m in models):
        model = load(name)
        targets = [v for _, v in random_targets(model, n, seed)]
        planner.plan(model, targets[0], method=method)
        fresh, base = [], []
        for v in targets:
            t0 = time.perf_counter()
            planner.plan(model, v, method=method)
            fresh.append(1e3 * (time.perf_counter() - t0))
        for v in targets:  # a pass of its own: 70-900 ms of scipy per plan would evict the planner's caches
            t0 = time.perf_counter()
            planner.plan(model, v, **BASELINE)  # type: ignore[arg-type]
            base.append(1e3 * (time.perf_counter() - t0))
        fresh_ms, base_ms = percentiles(fresh, digits=3), percentiles(base, digits=3)
        print(f'  {name:17s} fresh     {fresh_ms}  (baseline {base_ms}; median ratio '
              f'{np.median(base) / np.median(fresh):.2f}x)')
        pooled: list[float] = []
        for walk_seed in range(seed, seed + walks):  # one walk is one region of w: seed 0's spends 44 of 500 steps
            warm, previous, inexact = [], None, 0       # where no grasp matches v, seed 3's 296
            for v in walk_targets(model, n, walk_seed):
                t0 = time.perf_counter()
                res = planner.plan(model, v, warm_start=previous, method=method)
                warm.append(1e3 * (time.perf_counter() - t0))
                previous, inexact = res.x, inexact + (not res.exact)
            pooled += warm
            warm_ms = percentiles(warm, digits=3)
            print(f'  {name:17s} warm walk {warm_ms}  (seed {walk_seed}: {inexact}/{n} steps with no '
                  'exact match)')
        print(f'  {name:17s} warm, all {walks} walks {percentiles(pooled, digits=3)}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--n', type=int, default=500, help='random w per model (default 500)')
    parser.add_argument('--walk', type=int, default=2000, help='random-walk steps (default 2000)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--walks', type=int, default=5,
                        help='random walks of w, seeds --seed on (default 5): section 3 walks --walk steps '
                             'each, section 5 times --n steps each')
    parser.add_argument('--sections', default='1,2,3,4,5', help='comma-separated section numbers')
    parser.add_argument('--reference-starts', type=int, default=60)
    parser.add_argument('--method', default=DEFAULT_METHOD, choices=('task', 'lm'),
                        help="method of sections 2-5 (default: the planner's default); section 1 checks 'lm', the "
                             "paper's planner, whose objective it is")
    parser.add_argument('--models', default=','.join(MODELS),
                        help='comma-separated models (default: all four; sections 2-5 run the 7-zone ones among them)')
    args = parser.parse_args()
    sections = {int(s) for s in args.sections.split(',') if s.strip()}
    print(f'bench_planner: n={args.n}, walk={args.walk}, seed={args.seed}, method {args.method} (section 1: lm)')
    models = tuple(m for m in args.models.split(',') if m)
    runs = {1: lambda: optimality(args.n, args.seed, args.reference_starts, models),
            2: lambda: stability(args.n, args.seed, models, args.method),
            3: lambda: continuity(args.walk, args.seed, args.walks, models, args.method),
            4: lambda: plausibility(args.n, args.seed, models, args.method),
            5: lambda: speed(args.n, args.seed, args.walks, models, args.method)}
    for number, run in runs.items():
        if number in sections:
            run()
            print('  load average (1, 5, 15 min) after this section: ' + ', '.join(f'{a:.2f}' for a in os.getloadavg()))


if __name__ == '__main__':
    main()
