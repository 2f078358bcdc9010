"""``python -m grasp_intent_ros.kernels``: compile (or load from the cache) every kernel ahead of time."""

from . import warm_up

warm_up()
