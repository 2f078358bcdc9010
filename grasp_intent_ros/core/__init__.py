"""The method, free of ROS: intent interpretation, multi-task grasp models, the planner, ambiguity.

Importing this package never imports rclpy. Submodules load on first use, so importing
``grasp_intent_ros.core.errors`` alone does not pull in scipy:
``from grasp_intent_ros.core import intent, model, planner, ambiguity``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ['ambiguity', 'arm', 'assistance', 'body', 'data', 'errors', 'estimator', 'features', 'frames', 'grasp',
           'intent', 'kinematics', 'model', 'planner', 'registry', 'resources', 'safe_yaml']


def __getattr__(name: str) -> ModuleType:
    if name in __all__:
        return importlib.import_module(f'{__name__}.{name}')
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
