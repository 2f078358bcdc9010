"""Planner latency benchmark (issue 2): prints figures, asserts nothing.

Workload 1, as the issue states it: 500 seeded random w (uniform in [0, 1]^3; w with P(no task) >= 0.5
are redrawn, they ask for clarification instead of a plan) on the cup 7-zone model. Every plan starts
afresh. Configurations: the default planner (3 starts, vectorised projected Levenberg-Marquardt,
analytic gradient), the same with SLSQP, and a paper-faithful baseline: one start (Algorithm 1),
SLSQP, finite-difference gradient.

Workload 2, teleoperation: 500 w of a random walk (each entry moves by N(0, 0.01) per step, as a new w
every 10 ms from a smooth intent estimate), warm-started from the previous plan plus one demonstration
start.

    python benchmarks/bench_planner.py [--model config/models/cup_7zone.yaml] [--n 500] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from grasp_intent_ros.core import intent, planner
from grasp_intent_ros.core.model import GraspModel
from grasp_intent_ros.core.resources import config_dir

BASELINE = 'baseline: 1 start, SLSQP, finite differences'


def random_targets(n: int, seed: int, zones: tuple[int, ...]) -> list[np.ndarray]:
    """n target vectors from independent uniform w (clarification cases redrawn)."""
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    while len(out) < n:
        r = intent.interpret(rng.uniform(0.0, 1.0, 3), zones)
        if r.v is not None:
            out.append(r.v)
    return out


def walk_targets(n: int, seed: int, zones: tuple[int, ...]) -> list[np.ndarray]:
    """n target vectors from a random walk of w (steps N(0, 0.01), kept in [0.02, 0.98])."""
    rng = np.random.default_rng(seed)
    w = np.array([0.9, 0.5, 0.2])
    out: list[np.ndarray] = []
    while len(out) < n:
        w = np.clip(w + rng.normal(0.0, 0.01, 3), 0.02, 0.98)
        r = intent.interpret(w, zones)
        if r.v is not None:
            out.append(r.v)
    return out


def run(model: GraspModel, targets: list[np.ndarray], *, warm: bool = False,
        **options: Any) -> tuple[np.ndarray, np.ndarray]:
    """Plan every target; return wall times (ms) and objectives."""
    times, objectives = [], []
    previous = None
    for v in targets:
        t0 = time.perf_counter()
        res = planner.plan(model, v, warm_start=previous if warm else None, **options)
        times.append(time.perf_counter() - t0)
        objectives.append(res.objective)
        previous = res.x
    return np.array(times) * 1e3, np.array(objectives)


def _row(name: str, t: np.ndarray, f: np.ndarray) -> None:
    print(f'  {name:50s} {np.median(t):9.3f} {np.percentile(t, 99):9.3f} {f.mean():12.3e}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--model', default=str(config_dir() / 'models' / 'cup_7zone.yaml'))
    parser.add_argument('--n', type=int, default=500)
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    model = GraspModel.load(args.model)
    targets = random_targets(args.n, args.seed, model.zones)
    planner.plan(model, targets[0])  # imports and caches
    configs: dict[str, dict[str, Any]] = {
        'planner default: 3 starts, LM, analytic': {},
        'planner: 3 starts, SLSQP, analytic': {'method': 'slsqp'},
        BASELINE: {'method': 'slsqp', 'n_starts': 1, 'top_zones': 1, 'gradient': '2-point'},
    }
    print(f'model {args.model}: {len(model.zones)} zones; seed {args.seed}')
    print(f'workload 1: {args.n} independent random w')
    print(f'  {"configuration":50s} {"median ms":>9s} {"p99 ms":>9s} {"mean f":>12s}')
    results = {name: run(model, targets, **opts) for name, opts in configs.items()}
    for name, (t, f) in results.items():
        _row(name, t, f)
    base_t, base_f = results[BASELINE]
    for name, (t, f) in results.items():
        if name == BASELINE:
            continue
        worse = f > base_f + 1e-9
        print(f'  {name}: median x{np.median(base_t) / np.median(t):.1f} faster than the baseline; '
              f'mean objective {f.mean():.3e} vs {base_f.mean():.3e}; worse than the baseline in '
              f'{int(worse.sum())}/{len(f)} cases (largest excess {max(0.0, float(np.max(f - base_f))):.2e})')
    walk = walk_targets(args.n, args.seed, model.zones)
    print(f'workload 2: teleoperation stream, {args.n} w of a random walk, warm start + 1 demonstration start')
    _row('LM, warm-started', *run(model, walk, warm=True, n_starts=1))
    _row('SLSQP, warm-started', *run(model, walk, warm=True, n_starts=1, method='slsqp'))


if __name__ == '__main__':
    main()
