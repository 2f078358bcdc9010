"""Which object a demonstrated close belongs to, its label's object, and a bag's topics of one object (ROS-free).

The rules are the ``demonstrations`` command's (:mod:`~grasp_intent_ros.sessions.demonstrations`' docstring: *The
grasp*, *A scene of several objects*, *Labels*); a one-chain session is a scene of one unnamed object (``''``),
whose pose topic is ``object/pose``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import DataError, GraspIntentError
from ..method.features import MICO_3F
from ..mico.frames import obj_T_ee_to_features
from ..mico.kinematics import BASE_FRAME
from ..wire.joint_states import Hand, receipt_ns
from ..wire.robot_state import pose_msg_to_matrix
from ..wire.topics import JOINT_STATES, MSGTYPES, OBJECT_POSE, OPERATOR_GRASP_TASKS
from .bag import BagReadError, topics_info
from .scenes import detect_scene

__all__ = ['pose_topic', 'Attribution', 'ObjectPoses', 'split_label', 'bag_topics']


def pose_topic(name: str) -> str:
    """The relative pose topic of object ``name``: ``object/pose`` for a one-chain session's (``''``)."""
    return f'{name}/{OBJECT_POSE}' if name else OBJECT_POSE


def _what(name: str) -> str:
    return name or 'object'


@dataclass(frozen=True)
class Attribution:
    """Whose a settled close is: the target's grasp (``x``), rejected (``reasons``), or ``other`` objects' (names)."""

    x: NDArray[np.float64] | None
    reasons: tuple[str, ...]
    other: tuple[str, ...]


class ObjectPoses:
    """The latest pose of each object of a bag (received time, ``base_T_obj`` or why it is malformed).

    ``objects``: a scene's objects, the one whose grasps are read (:attr:`target`) first; none for a one-chain
    session (its one object ``''``).
    """

    def __init__(self, objects: Sequence[str], max_pose_age: float) -> None:
        self.objects, self.max_pose_age = tuple(objects), max_pose_age
        self.target, self.others = (self.objects[0], self.objects[1:]) if self.objects else ('', ())
        self.latest: dict[str, tuple[float, NDArray[np.float64] | str]] = {}

    @property
    def topics(self) -> dict[str, str]:
        """Relative pose topic -> object, for the target and the others."""
        return {pose_topic(name): name for name in (self.target, *self.others)}

    def take(self, name: str, t: float, msg: Any) -> None:
        """Object ``name``'s pose message received at ``t`` s."""
        try:
            self.latest[name] = (t, pose_msg_to_matrix(msg, frame_id=BASE_FRAME))
        except GraspIntentError as exc:
            self.latest[name] = (t, str(exc))

    def _features(self, name: str, hand: Hand) -> NDArray[np.float64] | str | None:
        """The hand's features relative to the object's latest pose; its malformation; None without one."""
        if (latest := self.latest.get(name)) is None or isinstance(latest[1], str):
            return None if latest is None else latest[1]
        return obj_T_ee_to_features(np.linalg.inv(latest[1]) @ hand.base_T_ee, hand.fingers)

    def attribute(self, hand: Hand) -> Attribution:
        """Whose the close settled at ``hand`` is (the rules of the module docstring)."""
        what, latest = _what(self.target), self.latest.get(self.target)
        x = self._features(self.target, hand)
        if latest is None:
            return Attribution(None, (f'no {what} pose',), ())
        if isinstance(x, str):
            return Attribution(None, (f'the latest {what} pose, at {latest[0]:.3f} s, is malformed: {x}',), ())
        if receipt_ns(hand.received) - receipt_ns(latest[0]) > self.max_pose_age * 1e9:
            return Attribution(None, (f'stale {what} pose: the latest, at {latest[0]:.3f} s, is '
                                      f'{hand.received - latest[0]:.3f} s old (at most {self.max_pose_age:g} s)',), ())
        assert x is not None
        at = tuple(name for name in self.others
                   if isinstance(other := self._features(name, hand), np.ndarray) and not _outside(other))
        if outside := _outside(x):
            if at:
                return Attribution(None, (), at)
            return Attribution(None, (f'the hand is not at the {what}: ' + ', '.join(
                f'{name} = {value:.4f}' for name, value in outside) + ' outside the feature bounds',), ())
        if at:
            return Attribution(None, (f'ambiguous: within the feature bounds of {what} and {", ".join(at)}',), ())
        return Attribution(x, (), ())


def _outside(x: NDArray[np.float64]) -> list[tuple[str, float]]:
    """The features (name, value) of ``x`` outside the feature space's bounds."""
    return [(name, float(value)) for name, value, low, high in zip(MICO_3F.names, x, MICO_3F.lower, MICO_3F.upper)
            if not low <= value <= high]


def split_label(text: str, objects: Sequence[str]) -> tuple[str | None, str]:
    """A label's object (None when it names none) and its task list: ``'cup: usage'`` -> ``('cup', 'usage')``.

    Raises
    ------
    DataError
        For a label naming an object in a one-chain session (``objects`` empty) or one not among ``objects``.
    """
    name, colon, tasks = text.partition(':')
    if not colon:
        return None, text
    name = name.strip()
    if not objects:
        raise DataError(f'{text!r} names an object ({name}), but the bag is one chain, not a scene')
    if name not in objects:
        raise DataError(f'{text!r} names {name}, not an object of the scene ({", ".join(objects)})')
    return name, tasks


def bag_topics(path: Path, target: str | None) -> tuple[dict[str, str], tuple[str, ...]]:
    """The bag's topics read for ``target``'s grasps (-> relative topic) and the objects of its scene.

    A one-chain session (``target`` None): its namespace's ``joint_states``, ``object/pose`` and
    ``operator/grasp_tasks``, and no object. A scene (``target`` one of its objects): the arm's ``joint_states``
    and ``operator/grasp_tasks`` in the arm's namespace, and each object's ``<object>/object/pose``
    (:func:`pose_topic`), the target's first.

    Raises
    ------
    BagReadError
        A bag that cannot be read; a scene without ``target`` (naming its objects); a one-chain session with one;
        a target not in the scene; no ``joint_states``; one of these topics with another type.
    """
    infos = topics_info(path)
    scene = detect_scene(infos)
    names = tuple(chain.rpartition('/')[2] for chain in scene.chains)
    if target is None and not scene.one_chain:
        raise BagReadError(f'bag {path} is a scene of several objects (chains {", ".join(scene.chains)}): give '
                           f'--object with one of {", ".join(names)}')
    if target is not None and scene.one_chain:
        raise BagReadError(f'bag {path} is one chain (in {scene.namespace or "/"}), not a scene: --object reads one '
                           'object of a scene\'s bag; drop it')
    objects = () if target is None else (target, *(name for name in names if name != target))
    if target is not None and target not in names:
        raise BagReadError(f'bag {path} has no object {target}: its objects are {", ".join(names)}')
    ns = scene.namespace
    relative = {f'{ns}/{JOINT_STATES}': JOINT_STATES, f'{ns}/{OPERATOR_GRASP_TASKS}': OPERATOR_GRASP_TASKS,
                **{f'{ns}/{pose_topic(name)}': pose_topic(name) for name in objects or ('',)}}
    if f'{ns}/{JOINT_STATES}' not in infos:
        raise BagReadError(f'bag {path} has no {ns}/{JOINT_STATES}: record the arm with the recorder\'s '
                           'default topics')
    for topic, rel in relative.items():
        msgtype = MSGTYPES[OBJECT_POSE if rel.endswith(OBJECT_POSE) else rel]
        if topic in infos and infos[topic].msgtype != msgtype:
            raise BagReadError(f'bag {path}: {topic} holds {infos[topic].msgtype}, not {msgtype}')
    return relative, objects
