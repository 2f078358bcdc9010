"""Train a multi-task grasp model from demonstrations in CSV (no ROS needed).

    python -m grasp_intent_ros train CSV --zones 7zone|5zone|4zone|U,T,UT,...
                                     [--name NAME] [--out PATH] [--ridge R] [--body BODY.yaml] [--object NAME]

CSV is any file in the format of :mod:`grasp_intent_ros.method.data` (the 10 MICO features, then one 0/1
column per task), e.g. demonstrations recorded on your own robot. ``--zones`` names a structure of the
paper (7, 5 or 4 zones) or lists zone labels built from the task initials ('U,T,UT,UTH'; numbers such
as '1+3' when the initials are not unique). The model is written as YAML, by default to
``<config>/models/NAME.yaml`` with NAME = ``<csv stem>_<zones>``. Prints the demonstrations per zone
and the hash of the training data. Exit status 2, with the reason, for a bad CSV, an unknown zone or a
zone without demonstrations.

``--body`` names a YAML file describing the object's solid body (a ``body:`` mapping of cylinders and
boxes in the object frame, see :mod:`grasp_intent_ros.method.body`); it is stored in the model and the
planner keeps the palm centre outside it.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

from ..cli.user_errors import report_user_errors
from ..errors import DataError, ModelError, ModelFormatError
from ..method.body import ObjectBody
from ..method.data import Demonstrations, load_csv
from ..method.intent import zone_labels
from ..method.model import DEFAULT_RIDGE, ZONE_STRUCTURES, GraspModel, structure_zones
from ..method.safe_yaml import parse_document, read_document
from ..resources import config_dir

__all__ = ['parse_zones_option', 'default_model_name', 'load_body', 'train', 'summary', 'main']


def parse_zones_option(spec: str, task_names: Sequence[str]) -> tuple[int, ...]:
    """Zone bitmasks of a ``--zones`` value: a structure name or comma-separated zone labels.

    Raises
    ------
    ModelError, InvalidIntentError
        For an empty list, an unknown structure or an unknown zone label.
    """
    spec = spec.strip()
    if spec in ZONE_STRUCTURES:
        return structure_zones(spec, task_names)
    labels = [label.strip() for label in spec.split(',') if label.strip()]
    if not labels:
        raise ModelError(f'--zones must be one of {", ".join(ZONE_STRUCTURES)} or a list of zone labels')
    return structure_zones(labels, task_names)


def default_model_name(csv_path: str | Path, spec: str) -> str:
    """``<csv stem>_<structure>``, or the zone labels joined by '-' for a list of zones."""
    spec = spec.strip()
    suffix = spec if spec in ZONE_STRUCTURES else '-'.join(s.strip() for s in spec.split(',') if s.strip())
    return f'{Path(csv_path).stem}_{suffix}'


def load_body(path: str | Path) -> ObjectBody:
    """Read an object body from YAML: a ``body:`` mapping (or the mapping itself) of primitives.

    Read as safely as a model document (:func:`grasp_intent_ros.method.safe_yaml.parse_document`).

    Raises
    ------
    ModelFormatError
        For invalid YAML or a malformed body.
    OSError
        If the file cannot be read.
    """
    try:
        doc = parse_document(read_document(path))
    except ModelFormatError as exc:
        raise ModelFormatError(f'{path}: {exc}') from None
    if isinstance(doc, dict) and 'body' in doc:
        doc = doc['body']
    return ObjectBody.from_document(doc)


def train(csv_path: str | Path, zones: str, *, name: str | None = None, out: str | Path | None = None,
          ridge: float = DEFAULT_RIDGE, body: ObjectBody | None = None,
          object_name: str = '') -> tuple[GraspModel, Demonstrations, Path]:
    """Load demonstrations, fit a model with inclusive labeling and save it as YAML.

    ``object_name`` is the object the demonstrations grasp, stored as the document's ``object`` ('' : none).

    Returns
    -------
    model : GraspModel
    demos : Demonstrations
        Everything read from the CSV (the model keeps only the task sets that are zones).
    path : Path
        Where the model was written.

    Raises
    ------
    DataError
        For a malformed CSV.
    ModelError, InvalidIntentError
        For a bad ``zones`` value, a zone or task without demonstrations, or a non-positive ridge.
    OSError
        If the CSV cannot be read or the model cannot be written.
    """
    demos = load_csv(csv_path)
    zone_masks = parse_zones_option(zones, demos.task_names)
    model_name = name or default_model_name(csv_path, zones)
    model = GraspModel.fit(demos, zone_masks, name=model_name, ridge=ridge, body=body, object_name=object_name)
    path = Path(out) if out is not None else config_dir() / 'models' / f'{model_name}.yaml'
    model.save(path)
    return model, demos, path


def summary(model: GraspModel, demos: Demonstrations) -> str:
    """Per-zone demonstration counts (own task set / inclusive training count) and the data hash."""
    own = demos.counts()
    lines = [f'model {model.name!r}: {len(model.zones)} zones, tasks {", ".join(model.task_names)}',
             f'  {"zone":8s} {"own set":>8s} {"trained on":>11s} {"prior":>7s}']
    for label, zone, count, prior in zip(model.zone_labels, model.zones, model.counts, model.priors):
        lines.append(f'  {label:8s} {own.get(zone, 0):8d} {int(count):11d} {prior:7.3f}')
    left_out = {s: n for s, n in own.items() if s not in model.zones}
    if left_out:
        sets = ', '.join(f'{zone_labels((s,), demos.task_names)[0]}: {n}' for s, n in sorted(left_out.items()))
        lines.append(f'  left out (task set not a zone of the model): {sets}')
    lines.append(f'  data hash (sha256 of the training demonstrations): {model.data_hash}')
    return '\n'.join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('csv', type=Path, help='demonstrations in the data.py CSV format')
    parser.add_argument('--zones', required=True,
                        help=f'{"|".join(ZONE_STRUCTURES)} or comma-separated zone labels, e.g. U,T,UT,UTH')
    parser.add_argument('--name', default=None, help='model name (default: <csv stem>_<zones>)')
    parser.add_argument('--out', type=Path, default=None,
                        help='output YAML (default: <config>/models/NAME.yaml)')
    parser.add_argument('--ridge', type=float, default=DEFAULT_RIDGE,
                        help=f'covariance ridge as a fraction of each feature range (default {DEFAULT_RIDGE})')
    parser.add_argument('--object', default='', help="the object the demonstrations grasp, stored in the model "
                        "(e.g. cup: readers that know its rules judge the grasps by them)")
    parser.add_argument('--body', type=Path, default=None,
                        help="YAML file with the object's solid body (cylinders, boxes; see method.body)")
    args = parser.parse_args(argv)

    def body() -> None:
        solid = load_body(args.body) if args.body is not None else None
        try:
            model, demos, path = train(args.csv, args.zones, name=args.name, out=args.out, ridge=args.ridge,
                                       body=solid, object_name=args.object)
        except (UnicodeDecodeError, csv.Error) as exc:
            raise DataError(f'{args.csv}: not a readable CSV file ({exc})') from None
        print(summary(model, demos))
        print(f'  wrote {path}')

    return report_user_errors(body)


if __name__ == '__main__':
    sys.exit(main())
