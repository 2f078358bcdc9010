"""Print, for our models, what the paper's Tables II, III, IV and VI show.

    python -m grasp_intent_ros paper_tables [--models-dir DIR] [--method lm|slsqp|trust-constr]

For each case: the target vector v, the planned posterior P and the reconstructed w, with the
objective 1/2 |v - P|^2. The default method is the planner's default (what the demo and the planner
node use); slsqp and trust-constr are the paper's solvers. No ROS is needed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

from ..core import intent, planner
from ..core.errors import GraspIntentError
from ..core.model import GraspModel
from ..core.resources import config_dir
from .cli import report_user_errors

CASES: list[tuple[str, tuple[float, float, float], tuple[str, ...]]] = [
    ('Tables II/III: inference ambiguity, single task', (0.9, 0.1, 0.1), ('cup_7zone',)),
    ('Tables II/III: inference ambiguity, two tasks', (0.9, 0.9, 0.1), ('cup_7zone',)),
    ('Tables II/III: inference ambiguity, three tasks', (0.9, 0.9, 0.9), ('cup_7zone',)),
    ('Tables IV/V: model ambiguity', (0.9, 0.1, 0.9), ('cup_7zone', 'cup_5zone', 'cup_4zone')),
    ('Table VI: object ambiguity', (0.9, 0.1, 0.1), ('cup_7zone', 'flashlight_7zone')),
]

def _fmt(values: Iterable[float]) -> str:
    return ' '.join(f'{v:7.4f}' for v in values)

def print_case(model: GraspModel, w: Sequence[float], method: planner.Method) -> None:
    """Print v, P, reconstructed w and the objective for one model and one w."""
    r = intent.interpret(w, model.zones)
    print(f'  model {model.name} ({len(model.zones)} zones), w = {tuple(w)}')
    if isinstance(r, intent.NeedsClarification):
        print(f'    needs clarification: {r.reason}')
        return
    res = planner.plan(model, r.v, method=method)
    print(f'    {"zone":6s} {"target v":>9s} {"final P":>9s}')
    for label, v, p in zip(model.zone_labels, r.v, res.posterior):
        print(f'    {label:6s} {v:9.4f} {p:9.4f}')
    print(f'    {"task":9s} {"w in":>7s} {"w out":>7s}')
    for name, wi, wo in zip(model.task_names, w, res.w):
        print(f'    {name:9s} {wi:7.4f} {wo:7.4f}')
    print(f'    objective {res.objective:.3e}  ({res.status}, {res.iterations} iterations, '
          f'{res.wall_time_s * 1e3:.1f} ms)')
    print(f'    features x = [{_fmt(res.x)}]')

def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--models-dir', type=Path, default=None)
    parser.add_argument('--method', choices=('lm', 'slsqp', 'trust-constr'), default='lm',
                        help="planner method (default 'lm', the planner's default)")
    args = parser.parse_args(argv)
    models_dir = args.models_dir or config_dir() / 'models'

    def body() -> None:
        models = {p.stem: GraspModel.load(p) for p in sorted(models_dir.glob('*.yaml'))}
        for title, w, names in CASES:
            print(title)
            for name in names:
                if name not in models:
                    raise GraspIntentError(f'model {name!r} not found in {models_dir}')
                print_case(models[name], w, args.method)
            print()

    return report_user_errors(body)

if __name__ == '__main__':
    sys.exit(main())
