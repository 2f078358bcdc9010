"""Share of a demonstration set the arm reaches from home with the object at its default pose, per task set.

    python benchmarks/bench_reach.py [--csv config/data/cup.csv ...] [--n 140] [--seed 0]

ROS-free. For ``n`` rows drawn at random (seeded) from each CSV, placed at the default object pose
(``mico.frames.default_base_T_obj``, the planner's default and the closed-loop benchmarks' pose), it reports per
task set the share that passes each of the generator's arm checks (``mico.reach.ArmReach``): IK from Home
(8 restarts), IK and the approach corridor, all of them with the servo from Home through the pre-grasp; and,
apart, a servo from Home straight to the grasp (no pre-grasp, as a person heading for the grasp). Then the
share with q5 > 0 in the IK answer (Home's side of the wrist singularity) and the run's time.
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
from grasp_intent_ros.method.intent import zone_label  # noqa: E402
from grasp_intent_ros.mico.frames import default_base_T_obj  # noqa: E402
from grasp_intent_ros.mico.kinematics import MicoKinematics  # noqa: E402
from grasp_intent_ros.mico.reach import ArmReach, servo_reaches  # noqa: E402
from grasp_intent_ros.resources import config_dir  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--csv', type=Path, nargs='+',
                        default=[config_dir() / 'data' / 'cup.csv', config_dir() / 'data' / 'flashlight.csv'])
    parser.add_argument('--n', type=int, default=140, help='rows drawn per CSV (default 140)')
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    kin = MicoKinematics()
    print(uptime())
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


if __name__ == '__main__':
    main()
