"""Generate the rule-based demonstration sets (and optionally the shipped models). No ROS needed.

    python -m grasp_intent_ros generate_data [--object cup|flashlight|all] [--count N] [--seed S]
                                             [--out DIR] [--train [--models-out DIR]]

Writes ``DIR/cup.csv`` and/or ``DIR/flashlight.csv`` (default DIR: ``<config>/data``), N demonstrations
for each of the 7 task sets, each one the MICO's hand takes clear of the table and the object (see
:mod:`grasp_intent_ros.objects.demos` for the rules and prototypes).
With ``--train`` it also fits the shipped models into ``<config>/models``: cup_7zone, cup_5zone,
cup_4zone and flashlight_7zone, each naming its object. The same seed always gives byte-identical data
files; the models are fitted to those same demonstrations (their ``data_hash``), but their covariances can
differ in the last bits between machines, whose BLAS kernels sum in other orders (``OPENBLAS_CORETYPE``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..cli.user_errors import report_user_errors
from ..method.data import save_csv
from ..method.intent import all_zones, zone_labels
from ..resources import config_dir
from . import demos as demo_rules
from .train import summary, train

__all__ = ['SHIPPED_MODELS', 'COUNT_RANGE', 'DEFAULT_SEED', 'main']

SHIPPED_MODELS: dict[str, tuple[str, ...]] = {'cup': ('7zone', '5zone', '4zone'), 'flashlight': ('7zone',)}
"""Zone structures trained by ``--train``, per object."""

COUNT_RANGE = (40, 150)
"""Allowed demonstrations per task set."""

DEFAULT_SEED = 0


def _count(text: str) -> int:
    value = int(text)
    if not COUNT_RANGE[0] <= value <= COUNT_RANGE[1]:
        raise argparse.ArgumentTypeError(f'must be in {COUNT_RANGE[0]}..{COUNT_RANGE[1]}, got {value}')
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--object', choices=(*demo_rules.OBJECTS, 'all'), default='all')
    parser.add_argument('--count', type=_count, default=demo_rules.DEFAULT_COUNT,
                        help=f'demonstrations per task set, {COUNT_RANGE[0]}..{COUNT_RANGE[1]} '
                             f'(default {demo_rules.DEFAULT_COUNT})')
    parser.add_argument('--seed', type=int, default=DEFAULT_SEED, help=f'default {DEFAULT_SEED}')
    parser.add_argument('--out', type=Path, default=None, help='output directory (default <config>/data)')
    parser.add_argument('--train', action='store_true', help='also train the shipped models')
    parser.add_argument('--models-out', type=Path, default=None,
                        help='model directory for --train (default <config>/models)')
    args = parser.parse_args(argv)
    names = list(demo_rules.OBJECTS) if args.object == 'all' else [args.object]

    def body() -> None:
        data_dir = args.out if args.out is not None else config_dir() / 'data'
        for name in names:
            rules = demo_rules.OBJECTS[name]
            demos = demo_rules.generate(rules, args.count, seed=args.seed)
            path = data_dir / f'{name}.csv'
            save_csv(demos, path)
            own = demos.counts()
            sets = all_zones(len(demos.task_names))
            counts = ', '.join(f'{label} {own.get(z, 0)}'
                               for z, label in zip(sets, zone_labels(sets, demos.task_names)))
            print(f'{path}: {len(demos)} demonstrations (seed {args.seed}; {counts})')
        if args.train:
            models_dir = args.models_out if args.models_out is not None else config_dir() / 'models'
            for name in names:
                for structure in SHIPPED_MODELS[name]:
                    model, demos, path = train(data_dir / f'{name}.csv', structure,
                                               out=models_dir / f'{name}_{structure}.yaml',
                                               body=demo_rules.OBJECTS[name].body, object_name=name)
                    print(summary(model, demos))
                    print(f'  wrote {path}')

    return report_user_errors(body)


if __name__ == '__main__':
    sys.exit(main())
