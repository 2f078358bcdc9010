"""The diagnostics format (``/diagnostics``, diagnostic_msgs/DiagnosticArray): levels, status names, keys.

Each node component publishes one status named ``"<node fully-qualified name>: <component>"``
(:func:`status_name`) whose values carry the keys ``KEY_*`` below, each defined once here; levels are
:data:`OK`, :data:`WARN`, :data:`ERROR`, :data:`STALE` (rclpy gives them as a 1-byte ``bytes``:
:func:`level_value`). ROS-free: :mod:`grasp_intent_ros.ros.diagnostics` publishes them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Final

__all__ = [
    'OK', 'WARN', 'ERROR', 'STALE', 'LEVEL_NAMES', 'level_value', 'status_name', 'status_values',
    'KEY_RECEIVED', 'KEY_REJECTED', 'KEY_LAST_ERROR', 'KEY_PROCESSING_TIME', 'KEY_DROPPED', 'KEY_PLANS',
    'KEY_PLANNING_TIME', 'KEY_PLAN_STATUS', 'KEY_MODEL', 'KEY_CLARIFICATIONS', 'KEY_LAST_OUTCOME',
    'KEY_KERNELS_LOAD_TIME', 'KEY_KERNELS_LOADED_LATE', 'KEY_GOALS', 'ESTIMATOR_COMPONENT', 'OPERATOR_COMPONENT',
    'KEY_TIMES_TO_GRASP', 'KEY_EXECUTE',
]

OK: Final = 0
WARN: Final = 1
ERROR: Final = 2
STALE: Final = 3
LEVEL_NAMES: Final[Mapping[int, str]] = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR', STALE: 'STALE'}

KEY_RECEIVED: Final = 'messages received'
KEY_REJECTED: Final = 'messages rejected'
KEY_LAST_ERROR: Final = 'last error'
KEY_PROCESSING_TIME: Final = 'last processing time [ms]'
KEY_DROPPED: Final = 'messages dropped'
"""Messages of the tracked inputs the node never took: gaps in their publishers' sequence numbers."""
KEY_PLANS: Final = 'plans'
"""The planner's count of plans made."""
KEY_PLANNING_TIME: Final = 'last planning time [ms]'
KEY_PLAN_STATUS: Final = 'last plan status'
"""What the planner's last plan led to (``grasp published (...)``, ``clarification requested: ...``)."""
KEY_MODEL: Final = 'active model'
"""A node's active model: ``"<name> (version <n>, zones <labels>)"`` (the planner), the name (the model
server), the name and its zones or why it was refused (the interpreter)."""
KEY_CLARIFICATIONS: Final = 'clarifications requested'
"""How many clarification requests a node (the interpreter, the planner) has published."""
KEY_LAST_OUTCOME: Final = 'last outcome'
"""What the interpreter's last w led to (``v published``, ``clarification requested: ...``)."""
KEY_KERNELS_LOAD_TIME: Final = 'compiled kernels load time [ms]'
"""How long the planner's planning thread took at start, before it was ready, to load (or, with an empty
cache, compile) every compiled kernel."""
KEY_KERNELS_LOADED_LATE: Final = 'compiled kernels loaded after ready'
"""How many kernel signatures the planner compiled or loaded after it was ready (0: no plan waited on one)."""
KEY_GOALS: Final = 'goals'
"""How many of the model's demonstrations the intent estimator has as goals (reachable); set once they are ready."""
ESTIMATOR_COMPONENT: Final = 'intent estimator'
"""The intent estimator node's status component (:func:`status_name`); a closed-loop session holding it had
its w from the estimator."""
OPERATOR_COMPONENT: Final = 'scripted operator'
"""The scripted operator node's status component (its values include the two below)."""
KEY_TIMES_TO_GRASP: Final = 'times to grasp [s]'
"""The scripted operator's time to grasp of each episode closed so far (s, ', '-separated, two decimals): from its
reach's start to the fingers' close, an execution included."""
KEY_EXECUTE: Final = 'execute'
"""The scripted operator's last ``grasp/execute``: the answer's message with the trajectory's time, or ``refused:
<reason>``; absent before the first."""


def level_value(level: Any) -> int:
    """A DiagnosticStatus level as an int (rclpy gives a 1-byte ``bytes``, rosbags an int)."""
    return level[0] if isinstance(level, (bytes, bytearray)) else int(level)


def status_name(node: str, component: str) -> str:
    """The status name of a node component: ``"<node fully-qualified name>: <component>"``."""
    return f'{node}: {component}'


def status_values(status: Any) -> dict[str, str]:
    """The key/value pairs of a DiagnosticStatus as a dict."""
    return {str(kv.key): str(kv.value) for kv in status.values}
