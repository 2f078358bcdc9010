"""The method as a library, without ROS: intent w -> target v -> planned grasp -> model ambiguity.

Run: ``python examples/plan_a_grasp.py [w_usage w_transfer w_handover]`` (test/unit/test_examples.py runs it).
"""

import sys

import numpy as np

from grasp_intent_ros.method import ambiguity, intent
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.planning import planner
from grasp_intent_ros.resources import config_dir


def main(w: list[float]) -> None:
    model = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    print('zones      ', ' '.join(f'{label:>6}' for label in model.zone_labels))

    # w -> v over the model's zones (paper eqs. 3-4), or a request for clarification
    result = intent.interpret(w, model.zones, clarification_threshold=0.5)
    if result.needs_clarification:
        print(f'w = {w}: clarification needed: {result.reason}')
        return
    print('target v   ', ' '.join(f'{p:6.3f}' for p in result.v))

    # the default planner: the demonstrated grasp that serves v's most likely zone, does only likely tasks
    # (w >= 0.3) and has the highest expected task success; P is the model's reading of it
    res = planner.plan(model, result.v)
    print('posterior P', ' '.join(f'{p:6.3f}' for p in res.posterior))
    print(f'status {res.status}, reads as {model.zone_labels[int(np.argmax(res.posterior))]}, '
          f'reconstructed w {np.round(res.w, 3).tolist()}')
    for name, value, unit in zip(model.features.names, res.x, model.features.units, strict=True):
        print(f'  {name:12s} {value:+.4f} {unit}')

    # the paper's planner (Algorithm 1): the grasp whose posterior P(zone | x) matches v, nearest the reference
    paper = planner.plan(model, result.v, method='lm')
    print('paper-P    ', ' '.join(f'{p:6.3f}' for p in paper.posterior))
    print(f'paper-status {paper.status}, exact match {paper.exact}')

    # model ambiguity (paper eqs. 5-8): KL(task i || task j) between the tasks' grasp distributions
    kl = ambiguity.kl_matrix(model)
    print('KL [nats], rows = true task:')
    for task, row in zip(model.task_names, kl, strict=True):
        print(f'  {task:9s}', ' '.join(f'{k:7.2f}' for k in row))


if __name__ == '__main__':
    main([float(a) for a in sys.argv[1:]] or [0.9, 0.9, 0.1])
