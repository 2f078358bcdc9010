"""Print, for our models, what the paper's Tables II, III, IV and VI show.

    python -m grasp_intent_ros paper_tables [--models-dir DIR] [--method lm|slsqp|trust-constr|task]

For each case: the target vector v, the planned posterior P and the reconstructed w, with the
objective 1/2 |v - P|^2, and which tasks the grasp serves by the object's rules (Table I,
:data:`grasp_intent_ros.objects.demos.OBJECTS`). The tables are the paper's, so the default method is the
paper's planner, ``lm`` (P matched to v; slsqp and trust-constr are the paper's solvers); ``--method task``
shows the planner's default (what the demo and the planner node use: grasps that serve the likely tasks,
docs/planner.md), whose P does not match v. No ROS is needed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

from ..errors import GraspIntentError
from ..method import intent
from ..method.model import GraspModel
from ..objects.demos import OBJECTS
from ..planning import planner
from ..planning.options import Method
from ..resources import config_dir
from .user_errors import report_user_errors

CASES: list[tuple[str, tuple[float, float, float], tuple[str, ...]]] = [
    ('Tables II/III: inference ambiguity, single task', (0.9, 0.1, 0.1), ('cup_7zone',)),
    ('Tables II/III: inference ambiguity, two tasks', (0.9, 0.9, 0.1), ('cup_7zone',)),
    ('Tables II/III: inference ambiguity, three tasks', (0.9, 0.9, 0.9), ('cup_7zone',)),
    ('Tables IV/V: model ambiguity', (0.9, 0.1, 0.9), ('cup_7zone', 'cup_5zone', 'cup_4zone')),
    ('Table VI: object ambiguity', (0.9, 0.1, 0.1), ('cup_7zone', 'flashlight_7zone')),
]

def _fmt(values: Iterable[float]) -> str:
    return ' '.join(f'{v:7.4f}' for v in values)

def print_case(model: GraspModel, w: Sequence[float], method: Method) -> None:
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
    rules = next((r for name, r in OBJECTS.items() if model.name.startswith(name)), None)
    if rules is not None:
        label = rules.label(res.x)
        print(f'    serves (rules): {intent.zone_label(label, model.task_names) if label else "no task"}')

def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--models-dir', type=Path, default=None)
    parser.add_argument('--method', choices=('lm', 'slsqp', 'trust-constr', 'task'), default='lm',
                        help="planner method (default 'lm', the paper's planner, which these tables reproduce; "
                             "'task' is the planner node's default)")
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
