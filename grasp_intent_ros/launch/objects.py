"""Several objects in one scene: one planning chain per object, each under ``<namespace>/<object>/``.

A chain is :data:`~grasp_intent_ros.launch.suite.SUITE_NODES` (the interpreter, the model server with the
object's model, the planner) in the object's namespace, so it has its own ``intent/w``, ``object/pose``,
``model/active``, ``intent/v`` and ``grasp/*``. The arm is one: every chain reads the suite namespace's
``joint_states`` (:func:`chain_remappings`); ``/diagnostics`` is absolute already, and each status is named
by its node's fully qualified name (``/cup/grasp_planner: planning``). docs/several_objects.md gives the
design. Every optional node runs once, at the suite's namespace, over the chains (:func:`scene_node_args`): the
shared-control loop (the mock arm and the assistance), the intent estimator and the viewer serve every chain, the
scripted operator reaches for one object (:func:`operator_object`).

- :func:`parse_objects`: the ``NAME=MODEL`` specs of ``suite --object``, checked before anything starts.
- :class:`SceneObject`: one object, its namespace and its chain's process names.

Never imports rclpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import GraspIntentError, ModelError
from ..method.registry import ModelFiles
from ..wire.topics import JOINT_STATES, OBJECT_NAME, object_name_problem

__all__ = ['OBJECT_NAME', 'SceneObject', 'parse_objects', 'chain_remappings', 'operator_object', 'scene_node_args']


@dataclass(frozen=True)
class SceneObject:
    """One object of the scene: its name (the chain's namespace token) and its model (a models_dir stem)."""

    name: str
    model: str

    def namespace(self, suite_namespace: str = '') -> str:
        """The chain's namespace: ``<suite_namespace>/<name>`` (``suite_namespace`` '' or absolute)."""
        return f'{suite_namespace}/{self.name}'

    def process_name(self, module: str) -> str:
        """The name of the chain's ``module`` process in the suite's messages and logs: ``<name>/<module>``."""
        return f'{self.name}/{module}'


def parse_objects(specs: Sequence[str], *, models_dir: str = '') -> tuple[SceneObject, ...]:
    """The objects of ``suite --object NAME=MODEL ...``, in the given order.

    Parameters
    ----------
    specs
        Each ``NAME=MODEL``: NAME matches :data:`OBJECT_NAME` and is not one of
        :data:`~grasp_intent_ros.wire.topics.TOPIC_FOLDERS` (``grasp``, ``intent``, ...), MODEL is the stem of
        a YAML file in ``models_dir``.
    models_dir
        Where the models are ('' means the package's ``config/models``, the model server's default).

    Raises
    ------
    GraspIntentError
        Naming every bad spec at once: not ``NAME=MODEL``, a NAME that is not a ROS name token or is a folder
        of the suite's topics, a NAME given twice, or a MODEL that ``models_dir`` does not hold (the message
        lists those it holds).
    """
    problems: list[str] = []
    objects: list[SceneObject] = []
    try:
        known: tuple[str, ...] | None = ModelFiles.at(models_dir).names()
    except ModelError as exc:
        problems.append(str(exc))
        known = None
    for spec in specs:
        name, equals, model = spec.partition('=')
        if not equals or not name or not model:
            problems.append(f'{spec!r} is not NAME=MODEL, e.g. cup=cup_7zone')
        elif object_name_problem(name):
            problems.append(object_name_problem(name))
        elif name in {o.name for o in objects}:
            problems.append(f'object {name!r} is named twice')
        elif known is not None and model not in known:
            problems.append(f'object {name!r}: no model {model!r}; there are: {", ".join(known) or "none"}')
        else:
            objects.append(SceneObject(name, model))
    if problems:
        raise GraspIntentError('; '.join(problems))
    return tuple(objects)


def chain_remappings(suite_namespace: str = '') -> tuple[str, ...]:
    """The remappings of every chain node: ``joint_states`` read from the suite's namespace, the arm's own."""
    return (f'{JOINT_STATES}:={suite_namespace}/{JOINT_STATES}',)


def operator_object(objects: Sequence[SceneObject], name: str = '') -> SceneObject:
    """The object the scripted operator reaches for: the one named ``name``, or the first ('', the default).

    Raises
    ------
    GraspIntentError
        For a ``name`` that is none of ``objects`` (naming them), or no objects.
    """
    if not objects:
        raise GraspIntentError('no objects: the scripted operator reaches for one of the scene\'s objects')
    for obj in objects:
        if obj.name == (name or objects[0].name):
            return obj
    raise GraspIntentError(f'the scripted operator\'s object {name!r} is not one of the objects '
                           f'{", ".join(o.name for o in objects)}')


def scene_node_args(module: str, objects: Sequence[SceneObject], *, operator: str = '') -> tuple[str, ...]:
    """The ``--ros-args`` that make optional node ``module`` serve the scene of ``objects``.

    The scripted operator: its ``object``, :func:`operator_object` of ``operator``. Any other: its ``objects``
    parameter, every object. Each name is quoted: the value is read as YAML, where a name
    such as ``on`` or ``null`` would not be a string.

    Raises
    ------
    GraspIntentError
        As :func:`operator_object`, for the scripted operator.
    """
    if module == 'scripted_operator':
        return ('-p', f"object:='{operator_object(objects, operator).name}'")
    return ('-p', 'objects:=[' + ','.join(f"'{obj.name}'" for obj in objects) + ']')
