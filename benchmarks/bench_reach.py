"""Share of a demonstration set the arm reaches from home with the object at its default pose, per task set.

    python benchmarks/bench_reach.py [--csv config/data/cup.csv ...] [--n 140] [--seed 0]
    python benchmarks/bench_reach.py --turned 150 [--models cup_7zone flashlight_7zone] [--seed 0]

ROS-free. For ``n`` rows drawn at random (seeded) from each CSV, placed at the default object pose
(``mico.frames.default_base_T_obj``, the planner's default and the closed-loop benchmarks' pose), it reports per
task set the share that passes each of the generator's arm checks (``mico.reach.ArmReach``): IK from Home
(8 restarts), IK and the approach corridor, all of them with the servo from Home through the pre-grasp; and,
apart, a servo from Home straight to the grasp (no pre-grasp, as a person heading for the grasp). Then the
share with q5 > 0 in the IK answer (Home's side of the wrist singularity) and the run's time.

``--turned N``: the planner node's policy (``mico.grasp.plan_grasp`` with the node's default options and the
hand's collision check, the arm at Home) for N seeded random w (uniform in [0, 1]^3) per model, the object at
the default pose turned about its vertical by a yaw uniform in [-pi, pi] and moved by up to 10 cm in x and y:
how many plans take one of the first 32 candidates the constraint is asked, one past them (the rest of the
best tier, ``planning.task``), or are refused, and each group's plan time (median and max; the model's first
plan pays its one-off costs).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import uptime  # noqa: E402

from grasp_intent_ros.method.data import load_csv  # noqa: E402
from grasp_intent_ros.method.intent import Interpretation, interpret, zone_label  # noqa: E402
from grasp_intent_ros.method.model import GraspModel  # noqa: E402
from grasp_intent_ros.mico.collision import HandCollision  # noqa: E402
from grasp_intent_ros.mico.frames import default_base_T_obj  # noqa: E402
from grasp_intent_ros.mico.grasp import Grasp, NoReachableGrasp, plan_grasp  # noqa: E402
from grasp_intent_ros.mico.kinematics import MicoKinematics  # noqa: E402
from grasp_intent_ros.mico.reach import ArmReach, servo_reaches  # noqa: E402
from grasp_intent_ros.planning.options import node_default_options  # noqa: E402
from grasp_intent_ros.planning.task import FIRST_CANDIDATES  # noqa: E402
from grasp_intent_ros.resources import config_dir  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--csv', type=Path, nargs='+',
                        default=[config_dir() / 'data' / 'cup.csv', config_dir() / 'data' / 'flashlight.csv'])
    parser.add_argument('--n', type=int, default=140, help='rows drawn per CSV (default 140)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--turned', type=int, default=0, help='plans at turned object poses per model (see above)')
    parser.add_argument('--models', nargs='+', default=['cup_7zone', 'flashlight_7zone'])
    args = parser.parse_args()
    kin = MicoKinematics()
    print(uptime())
    if args.turned:
        for name in args.models:
            turned_plans(GraspModel.load(config_dir() / 'models' / f'{name}.yaml'), kin, args.turned, args.seed)
        return
    for path in args.csv:
        demos = load_csv(path)
        rows = np.random.default_rng(args.seed).permutation(len(demos))[:args.n]
        arm = ArmReach(kin, default_base_T_obj())
        found: dict[int, list[tuple[bool, bool, bool, bool, bool]]] = defaultdict(list)
        start = time.perf_counter()
        for i in rows:
            x, task_set = demos.x[i], int(demos.task_sets[i])
            ik = arm.reach(x)
            approach = ik and arm.approach(x)
            direct = servo_reaches(kin, arm.reach.q_seed, (arm.reach.target(x),))
            found[task_set].append((ik, approach, approach and arm.fault(x) is None, direct,
                                    bool(arm.reach.answer(x).q[4] > 0.0)))
        print(f'{path} ({len(rows)} rows, {time.perf_counter() - start:.0f} s): share per task set of '
              f'IK / IK+approach / all checks / servo straight to the grasp / q5 > 0')
        for task_set in sorted(found, key=lambda z: (bin(z).count('1'), z)):
            share = np.mean(found[task_set], axis=0)
            print(f'  {zone_label(task_set, demos.task_names):<4} n {len(found[task_set]):3d}  '
                  + '  '.join(f'{s:.2f}' for s in share))


def turned_plans(model: GraspModel, kin: MicoKinematics, n: int, seed: int) -> None:
    """The ``--turned`` count (module docstring) for one model."""
    rng = np.random.default_rng(seed)
    hand, options = HandCollision(), node_default_options()
    times: dict[str, list[float]] = defaultdict(list)
    asked_for_clarification = 0
    for _ in range(n):
        yaw, dx, dy = rng.uniform(-np.pi, np.pi), *rng.uniform(-0.1, 0.1, 2)
        turn = np.eye(4)
        turn[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        base_T_obj = default_base_T_obj() @ turn
        base_T_obj[:2, 3] += (dx, dy)
        read = interpret(rng.uniform(0.0, 1.0, 3), model.zones)
        if not isinstance(read, Interpretation):
            asked_for_clarification += 1
            continue
        start = time.perf_counter()
        grasp = plan_grasp(model, read.v, model.zones, base_T_obj, kin, options=options, hand=hand)
        elapsed = time.perf_counter() - start
        assert isinstance(grasp, (Grasp, NoReachableGrasp))
        group = ('refused' if isinstance(grasp, NoReachableGrasp)
                 else 'first' if grasp.result.rejected < FIRST_CANDIDATES else 'past the first')
        times[group].append(elapsed)
    print(f'{model.name}: {n} w, {asked_for_clarification} asked for clarification by the interpreter')
    for group in ('first', 'past the first', 'refused'):
        t = np.array(times[group]) * 1e3
        label = group if group == 'refused' else f'{group} {FIRST_CANDIDATES}'
        print(f'  {label:<18} {t.size:4d} plans' + (f', {np.median(t):.0f} ms median, {t.max():.0f} ms max'
                                                      if t.size else ''))


if __name__ == '__main__':
    main()
