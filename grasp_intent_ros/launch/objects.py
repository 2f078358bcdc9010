"""Several objects in one scene: one planning chain per object, each under ``<namespace>/<object>/``.

A chain is :data:`~grasp_intent_ros.launch.suite.SUITE_NODES` (the interpreter, the model server with the
object's model, the planner) in the object's namespace, so it has its own ``intent/w``, ``object/pose``,
``model/active``, ``intent/v`` and ``grasp/*``. The arm is one: every chain reads the suite namespace's
``joint_states`` (:func:`chain_remappings`); ``/diagnostics`` is absolute already, and each status is named
by its node's fully qualified name (``/cup/grasp_planner: planning``). docs/several_objects.md gives the
design and what is not built yet: the scripted operator serves one object, so :func:`refuse_unbuilt` refuses it
beside objects; the shared-control loop (the mock arm and the assistance), the intent estimator and the viewer serve
every chain from the suite's namespace (:data:`SCENE_NODES`).

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

__all__ = ['OBJECT_NAME', 'SceneObject', 'parse_objects', 'chain_remappings', 'refuse_unbuilt', 'SCENE_NODES',
           'scene_node_args']

SCENE_NODES = ('mock_arm', 'assistance', 'intent_estimator', 'viewer')
"""The optional nodes (``suite --shared-control``, ``--with``) that serve a scene of several objects: one process at
the suite's namespace over every chain (:func:`scene_node_args`). The assistance without the intent estimator takes
P(o) uniform over the objects with a grasp (:func:`~grasp_intent_ros.shared_control.scene_target.object_probabilities`).
"""


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


def refuse_unbuilt(optional: Sequence[str]) -> None:
    """Refuse optional nodes beside objects but :data:`SCENE_NODES`: each of the others serves one object.

    Raises
    ------
    GraspIntentError
        If ``optional`` (node module names) holds any other, naming them and the design note.
    """
    if unbuilt := [name for name in optional if name not in SCENE_NODES]:
        raise GraspIntentError(
            f'{", ".join(unbuilt)} with --object: not built yet (the scripted operator serves one object; '
            'docs/several_objects.md says what it needs); --object starts the planning chains and, with '
            f'--shared-control and --with, {", ".join(SCENE_NODES)} over all of them')


def scene_node_args(objects: Sequence[SceneObject]) -> tuple[str, ...]:
    """The ``--ros-args`` that make a :data:`SCENE_NODES` node serve ``objects``: its ``objects`` parameter.

    Each name is quoted: the value is read as YAML, where a name such as ``on`` or ``null`` would not be a string.
    """
    return ('-p', 'objects:=[' + ','.join(f"'{obj.name}'" for obj in objects) + ']')
