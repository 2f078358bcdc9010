"""Benchmark MicoKinematics.ik: timing near the answer, success rate from Home.

Targets are FK of random joint angles (joints 2, 3 uniform within limits, the others within pi of Home).
Run: ``.venv/bin/python benchmarks/bench_ik.py [--n 200] [--seed 0]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from numpy.typing import NDArray

from grasp_intent_ros.mico.ik import IkResult
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics

WIDE = [0, 3, 4, 5]


def random_q(kin: MicoKinematics, rng: np.random.Generator) -> NDArray[np.float64]:
    q = rng.uniform(kin.lower, kin.upper)
    q[WIDE] = HOME_Q[WIDE] + rng.uniform(-math.pi, math.pi, len(WIDE))
    return q


def timed(kin: MicoKinematics, target: NDArray[np.float64], seed: NDArray[np.float64],
          restarts: int) -> tuple[float, IkResult]:
    start = time.perf_counter()
    res = kin.ik(target, seed, restarts=restarts)
    return time.perf_counter() - start, res


def report(label: str, times: list[float], results: list[IkResult]) -> None:
    ms = np.array(times) * 1e3
    ok = sum(r.success for r in results)
    iters = np.mean([r.iterations for r in results])
    print(f'{label:<44} success {ok}/{len(results)} = {ok / len(results):6.1%}  '
          f'median {np.median(ms):6.3f} ms  p99 {np.percentile(ms, 99):7.3f} ms  '
          f'mean iterations {iters:5.1f}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--n', type=int, default=200, help='number of targets')
    parser.add_argument('--seed', type=int, default=0, help='random seed of the targets')
    args = parser.parse_args()

    kin = MicoKinematics()
    rng = np.random.default_rng(args.seed)
    qs = [random_q(kin, rng) for _ in range(args.n)]
    targets = [kin.fk(q) for q in qs]
    kin.ik(targets[0], qs[0])  # warm up

    cases = [
        ('seeded near the answer (q + N(0, 0.05 rad))',
         [np.clip(q + rng.normal(0.0, 0.05, 6), kin.lower, kin.upper) for q in qs], 8),
        ('seeded from Home, no restarts', [HOME_Q] * args.n, 0),
        ('seeded from Home, up to 8 restarts', [HOME_Q] * args.n, 8),
    ]
    for label, seeds, restarts in cases:
        runs = [timed(kin, target, seed, restarts) for target, seed in zip(targets, seeds)]
        report(label, [t for t, _ in runs], [r for _, r in runs])

    far = np.eye(4)
    far[:3, 3] = (2.0, 0.0, 0.3)
    elapsed, res = timed(kin, far, HOME_Q, 8)
    print(f'unreachable target (2 m): success={res.success} in {elapsed * 1e3:.1f} ms ({res.message})')


if __name__ == '__main__':
    main()
