r"""How soon a node refuses a model document it will not serve, and what reading one costs. Prints figures.

Times :func:`grasp_intent_ros.wire.model_document.read_model_document` as a node's model follower calls it (the suite's
requirements, :func:`grasp_intent_ros.ros.model_follower.served_models`; garbage collection off and the
short GIL switch interval of :func:`~grasp_intent_ros.ros.model_follower.yielding_reader`) on documents a
hostile peer may latch on ``model/active``, each under the document cap:

- ``ten tasks``: a valid model of ten tasks with all 1,023 zones on the MICO features (not the suite's tasks);
- ``480 features``: a one-zone model of 480 features (another robot's, and over the 64 features a document
  may declare);
- ``bad last row``: the shipped cup model with demonstrations appended up to the cap, the last one of 11
  values: its declaration is served, so the whole document is parsed before the refusal (the worst case);
- ``cup_7zone``: the shipped model, accepted (for scale).

Each is read ``--repeats`` times (default 20); printed: size, verdict, median and max wall time (ms), and the
load average. No ROS traffic: the read is the node's whole work on a document (the follower's thread).

    .venv/bin/python benchmarks/bench_refusal.py [--repeats 20]
"""

from __future__ import annotations

import argparse
import hashlib
import statistics
import time
from typing import Any

import yaml
from _bench import REPO, uptime

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.method.intent import DEFAULT_TASKS, all_zones, zone_labels
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.safe_yaml import MAX_DOCUMENT_CHARS
from grasp_intent_ros.ros.model_follower import served_models, yielding_reader
from grasp_intent_ros.wire.model_document import read_model_document


def _document(body: str, name: str) -> str:
    sha = hashlib.sha256(body.encode()).hexdigest()
    return f'# model_name: {name}\n# model_version: 1\n# model_sha256: {sha}\n{body}'


def _yaml(doc: dict[str, Any]) -> str:
    return yaml.dump(doc, Dumper=yaml.CSafeDumper, sort_keys=False, width=120, default_flow_style=None)


def documents() -> dict[str, str]:
    """The documents timed, by name (module docstring)."""
    cup = GraspModel.load(REPO / 'config' / 'models' / 'cup_7zone.yaml')
    doc = cup.to_document()
    tasks = tuple('abcdefghij')
    labels = list(zone_labels(all_zones(len(tasks)), tasks))
    mean = [round(float(v), 3) for v in cup.means[0]]
    cov = [[round(float(v), 4) if i == j else 0.0 for j, v in enumerate(row)]
           for i, row in enumerate(cup.covariances[0])]

    def gaussian() -> dict[str, Any]:  # fresh lists each time: the dumper would write repeated ones as aliases
        return {'mean': list(mean), 'covariance': [list(r) for r in cov]}

    ten = {**doc, 'task_names': list(tasks), 'zones': labels,
           'zone_models': [{'zone': z, 'count': 1, 'prior': 1.0 / len(labels), **gaussian()} for z in labels],
           'task_models': [{'task': t, 'count': 1, **gaussian()} for t in tasks],
           'demonstrations': [{'tasks': 'a', 'x': list(mean)}]}
    ten.pop('body', None)
    d = 480
    wide = {**doc, 'features': [{'name': f'f{i}', 'unit': '1', 'lower': -1.0, 'upper': 1.0} for i in range(d)],
            'approach_features': [3, 6], 'zones': ['U'],
            'zone_models': [{'zone': 'U', 'count': 1, 'prior': 1.0, 'mean': [0.0] * d,
                             'covariance': [[int(i == j) for j in range(d)] for i in range(d)]}],
            'demonstrations': [{'tasks': 'U', 'x': [0.0] * d}]}
    wide.pop('body', None)
    texts = {'ten tasks': _yaml(ten), '480 features': _yaml(wide)}
    row = f'- tasks: UTH\n  x: [{", ".join(f"{v:.6f}" for v in cup.demo_x[0])}]\n'
    bad = f'- tasks: UTH\n  x: [{", ".join(["0.0"] * 11)}]\n'
    shipped = cup.to_yaml()
    assert '\ndemonstrations:\n- tasks: ' in shipped  # the last field, a block sequence: rows can follow
    room = MAX_DOCUMENT_CHARS - len(shipped) - len(bad) - 200
    texts['bad last row'] = shipped + row * (room // len(row)) + bad
    texts['cup_7zone'] = shipped
    return {name: _document(text, name.replace(' ', '_')) for name, text in texts.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--repeats', type=int, default=20)
    args = parser.parse_args()
    requires = served_models(DEFAULT_TASKS)
    print(uptime())
    for name, text in documents().items():
        times, verdict = [], ''
        for _ in range(args.repeats):
            start = time.perf_counter()
            try:
                with yielding_reader():
                    read_model_document(text, requires=requires)
                verdict = 'accepted'
            except GraspIntentError as exc:
                verdict = f'refused: {str(exc)[:110]}'
            times.append(1e3 * (time.perf_counter() - start))
        print(f'{name:13} {len(text) / 1e3:7.0f} kB  median {statistics.median(times):6.1f} ms, max '
              f'{max(times):6.1f} ms  {verdict}')
    print(uptime())


if __name__ == '__main__':
    main()
