"""The parameters of the nodes of the paper's method: the intent interpreter's and the model server's.

Each table is a tuple of :class:`~grasp_intent_ros.parameters.ParamSpec`, declared on a node by
:func:`grasp_intent_ros.ros.params.declare_parameters`; config/<node>.yaml documents each parameter with its
description (test/ros/test_config_files.py) and docs/nodes.md's table lists them
(test/unit/test_parameter_docs.py).
:data:`TASK_NAMES` is a parameter of every node that reads w or serves a model.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import InvalidIntentError
from ..parameters import ParamSpec
from .intent import DEFAULT_CLARIFICATION_THRESHOLD, DEFAULT_TASKS, MAX_TASKS, all_zones

__all__ = ['check_task_names', 'TASK_NAMES', 'check_threshold', 'INTENT_INTERPRETER', 'MODEL_SERVER']


def check_task_names(names: Sequence[str]) -> None:
    """1..MAX_TASKS unique, non-empty names without commas. Raises InvalidIntentError."""
    all_zones(len(names))
    if any(not n or ',' in n or n != n.strip() for n in names):
        raise InvalidIntentError(f'task names must be non-empty, without commas or surrounding spaces: '
                                 f'{list(names)}')
    if len(set(names)) != len(names):
        raise InvalidIntentError(f'task names must be unique: {list(names)}')


TASK_NAMES = ParamSpec(
    'task_names', DEFAULT_TASKS,
    'Names of the m principal tasks, in the order of the entries of w (m = expected length of w). The same '
    'list on every node of the suite: a model of other tasks is refused.',
    validator=check_task_names, constraints=f'1..{MAX_TASKS} unique names without commas')
"""The suite's tasks: the interpreter reads w by them; every node serves only models of these tasks."""


def check_threshold(value: float) -> None:
    """The threshold must be > 0 (the upper bound 1 is enforced by the descriptor's range)."""
    if not value > 0.0:
        raise InvalidIntentError(f'must lie in (0, 1], got {value}')


INTENT_INTERPRETER = (
    TASK_NAMES,
    ParamSpec('clarification_threshold', DEFAULT_CLARIFICATION_THRESHOLD,
              'Ask for clarification instead of publishing v when P(no task) >= this probability.',
              range=(0.0, 1.0), validator=check_threshold, constraints='in (0, 1]'),
)
"""The intent interpreter node's parameters (:mod:`grasp_intent_ros.nodes.intent_interpreter`)."""

MODEL_SERVER = (
    ParamSpec('model', 'cup_7zone',
              'Active grasp model: the file stem of a model YAML in models_dir (e.g. cup_7zone).'),
    ParamSpec('models_dir', '',
              "Directory of the trained models (*.yaml); '' means the package's config/models.",
              read_only=True),
    TASK_NAMES,
)
"""The model server node's parameters (:mod:`grasp_intent_ros.nodes.model_server`)."""
