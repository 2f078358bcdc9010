"""Several objects in one scene: one planning chain per object, each under ``<namespace>/<object>/``.

A chain is :data:`~grasp_intent_ros.launch.suite.SUITE_NODES` (the interpreter, the model server with the
object's model, the planner) in the object's namespace, so it has its own ``intent/w``, ``object/pose``,
``model/active``, ``intent/v`` and ``grasp/*``. The arm is one: every chain reads the suite namespace's
``joint_states`` (:func:`chain_remappings`); ``/diagnostics`` is absolute already, and each status is named
by its node's fully qualified name (``/cup/grasp_planner: planning``). docs/several_objects.md gives the
design and what is not built yet: the shared-control loop and most optional nodes serve one object, so
:func:`refuse_unbuilt` refuses them beside objects; those of :data:`SCENE_NODES` serve the whole scene, started once
at the suite's namespace with the objects' names (:func:`scene_parameters`).

- :func:`parse_objects`: the ``NAME=MODEL`` specs of ``suite --object``, checked before anything starts.
- :class:`SceneObject`: one object, its namespace and its chain's process names.

Never imports rclpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import GraspIntentError, ModelError
from ..method.registry import ModelFiles
from ..wire.topics import JOINT_STATES, object_name_problem

__all__ = ['SCENE_NODES', 'SceneObject', 'parse_objects', 'chain_remappings', 'scene_parameters', 'refuse_unbuilt']

SCENE_NODES = ('viewer',)
"""The optional nodes that serve a scene of several objects: one process at the suite's namespace, given the
objects' names (:func:`scene_parameters`), following every chain."""

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
        Each ``NAME=MODEL``: NAME an object's name (:func:`~grasp_intent_ros.wire.topics.object_name_problem`:
        one ROS name token, not a folder of the suite's topics such as ``grasp``), MODEL the stem of a YAML file
        in ``models_dir``.
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
        elif problem := object_name_problem(name):
            problems.append(problem)
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


def scene_parameters(objects: Sequence[SceneObject]) -> tuple[str, ...]:
    """The ``--ros-args`` of a :data:`SCENE_NODES` node beside ``objects``: its ``objects`` parameter, their names."""
    return ('-p', f'objects:=[{",".join(obj.name for obj in objects)}]')


def refuse_unbuilt(optional: Sequence[str]) -> None:
    """Refuse optional nodes beside objects but :data:`SCENE_NODES`.

    Each of them serves one object, and which one is not designed in code yet.

    Raises
    ------
    GraspIntentError
        If ``optional`` (node module names) holds any but :data:`SCENE_NODES`, naming them and the design note.
    """
    if unbuilt := [name for name in optional if name not in SCENE_NODES]:
        raise GraspIntentError(
            f'{", ".join(unbuilt)} with --object: not built yet (the shared-control loop, the intent estimator and '
            'the scripted operator each serve one object; docs/several_objects.md says what each needs); --object '
            f'starts the planning chains and {", ".join(SCENE_NODES)} only')
