"""Planner latency benchmark (issue 2): prints figures, asserts nothing.

500 seeded random w on the cup 7-zone model (w with P(no task) >= 0.5 are redrawn, since they ask for
clarification instead of a plan). Compares the planner's default configuration (multi-start SLSQP,
analytic gradient) and the teleoperation configuration (warm-started from the previous plan, one
demonstration start) with a paper-faithful baseline: one start (Algorithm 1), SLSQP, finite-difference
gradient.

    python benchmarks/bench_planner.py [--model config/models/cup_7zone.yaml] [--n 500] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from grasp_intent_ros.core import intent, planner
from grasp_intent_ros.core.model import GraspModel
from grasp_intent_ros.core.resources import config_dir


def _targets(n: int, seed: int, zones: tuple[int, ...]) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    while len(out) < n:
        r = intent.interpret(rng.uniform(0.0, 1.0, 3), zones)
        if r.v is not None:
            out.append(r.v)
    return out


def _run(model: GraspModel, targets: list[np.ndarray], warm: bool, **options: object) -> tuple[np.ndarray, np.ndarray]:
    times, objectives = [], []
    previous = None
    for v in targets:
        t0 = time.perf_counter()
        res = planner.plan(model, v, warm_start=previous if warm else None, **options)  # type: ignore[arg-type]
        times.append(time.perf_counter() - t0)
        objectives.append(res.objective)
        previous = res.x
    return np.array(times) * 1e3, np.array(objectives)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--model', default=str(config_dir() / 'models' / 'cup_7zone.yaml'))
    parser.add_argument('--n', type=int, default=500)
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    model = GraspModel.load(args.model)
    targets = _targets(args.n, args.seed, model.zones)
    planner.plan(model, targets[0])  # warm caches and imports
    configs = {
        'planner (3 starts, SLSQP, analytic)': dict(warm=False),
        'teleop (warm start + 1 start, SLSQP, analytic)': dict(warm=True, n_starts=1),
        'baseline (1 start, SLSQP, finite differences)': dict(warm=False, n_starts=1, top_zones=1,
                                                            gradient='2-point'),
    }
    results = {name: _run(model, targets, **opts) for name, opts in configs.items()}  # type: ignore[arg-type]
    print(f'model {args.model}: {len(model.zones)} zones, {args.n} random w (seed {args.seed})')
    print(f'{"configuration":50s} {"median ms":>10s} {"p99 ms":>8s} {"mean objective":>15s}')
    for name, (t, f) in results.items():
        print(f'{name:50s} {np.median(t):10.3f} {np.percentile(t, 99):8.3f} {f.mean():15.3e}')
    base_t, base_f = results['baseline (1 start, SLSQP, finite differences)']
    for name, (t, f) in list(results.items())[:2]:
        worse = int(np.sum(f > base_f + 1e-9))
        print(f'{name}: median speed-up x{np.median(base_t) / np.median(t):.2f} over the baseline; '
              f'objective worse than the baseline\'s in {worse}/{len(f)} cases '
              f'(max excess {max(0.0, float(np.max(f - base_f))):.2e})')


if __name__ == '__main__':
    main()
