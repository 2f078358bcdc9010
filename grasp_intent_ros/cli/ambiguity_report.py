"""Print model ambiguity (paper Table V) for several models side by side.

    python -m grasp_intent_ros ambiguity_report [MODEL.yaml ...]

Default: the cup 7-, 5- and 4-zone models. For each model: the nonsymmetric KL matrix (row = true
population, column = inference), the symmetric matrix, Pinsker bounds on the statistical distance and
the eigenvalues. No ROS is needed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..method import ambiguity
from ..method.intent import zone_labels
from ..method.model import GraspModel
from ..resources import config_dir
from .user_errors import report_user_errors

DEFAULT_MODELS = ('cup_7zone', 'cup_5zone', 'cup_4zone')


def _matrix_rows(title: str, matrix: np.ndarray, tasks: Sequence[str]) -> list[str]:
    width = 8 * len(tasks) + 3
    rows = [f'{title:<{width}s}', f'{"":3s}' + ''.join(f'{t:>8s}' for t in tasks)]
    for t, row in zip(tasks, matrix):
        rows.append(f'{t:3s}' + ''.join(f'{v:8.2f}' for v in row))
    return rows


def format_reports(models: Sequence[GraspModel]) -> str:
    """Side-by-side text of the ambiguity figures of several models (same task names expected)."""
    blocks: list[list[str]] = []
    for m in models:
        rep = ambiguity.report(m)
        tasks = [zone_labels((1 << i,), m.task_names)[0] for i in range(len(m.task_names))]
        block = [f'{m.name} ({len(m.zones)} zones)', '']
        block += _matrix_rows('KL(row || column)', rep.kl, tasks) + ['']
        block += _matrix_rows('symmetric KL', rep.symmetric, tasks) + ['']
        block += _matrix_rows('Pinsker bound', rep.pinsker, tasks) + ['']
        block += ['eigenvalues KL: ' + ', '.join(f'{e.real:.2f}' + (f'{e.imag:+.2f}j' if abs(e.imag) > 1e-9 else '')
                                               for e in rep.eigenvalues)]
        block += ['eigenvalues sym: ' + ', '.join(f'{e:.2f}' for e in rep.symmetric_eigenvalues)]
        blocks.append(block)
    width = max(len(line) for b in blocks for line in b) + 4
    height = max(len(b) for b in blocks)
    lines = []
    for i in range(height):
        lines.append(''.join(f'{(b[i] if i < len(b) else ""):<{width}s}' for b in blocks).rstrip())
    return '\n'.join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('models', nargs='*', type=Path, help='model YAML files (default: the cup models)')
    args = parser.parse_args(argv)
    paths = args.models or [config_dir() / 'models' / f'{n}.yaml' for n in DEFAULT_MODELS]
    return report_user_errors(lambda: print(format_reports([GraspModel.load(p) for p in paths])))


if __name__ == '__main__':
    sys.exit(main())
