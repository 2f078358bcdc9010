"""The judge: which tasks a grasp serves by its object's rules, never seen by the planner, estimator or operator.

The rules are Table I's (:data:`grasp_intent_ros.objects.demos.OBJECTS`, chosen by the model's ``object``). A
grasp is judged as a hand pose in the arm's base frame and three finger closures: the features are recovered
from the hand's pose relative to the object (``base_T_obj``) and the closures
(:func:`~grasp_intent_ros.mico.frames.obj_T_ee_to_features`). The one definition of a verdict on a grasp the hand
reached: the demo judges the planner's answers (the published end-effector pose and finger targets) and, in its
closed loop, where the mock arm's hand ended with the closures its fingers executed; the closed-loop benchmarks,
live and simulated, judge where each run's hand closed, at the true object pose, with the executed closures.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..method.intent import zone_label
from ..method.model import GraspModel
from ..mico.frames import obj_T_ee_to_features
from .demos import OBJECTS, object_of

__all__ = ['Judgement', 'SceneJudgement', 'judge', 'judge_scene', 'operator_verdict']


@dataclass(frozen=True)
class Judgement:
    """The rules' verdict on one grasp.

    Attributes
    ----------
    label : int or None
        The task set the rules give (bitmask over the model's ``task_names``; 0: no task); None when the model
        names no object the rules know.
    text : str
        For a reader: e.g. 'usage, transfer (UT)', 'no task (failed: usage: rim clear; ...)', or why unknown.
    failed : mapping of str to tuple of str
        Per task of the rules, the names of its conditions the grasp fails (empty for a task it serves; no
        task when the rules are unknown).
    """

    label: int | None
    text: str
    failed: Mapping[str, tuple[str, ...]]

    def serves(self, task_set: int) -> bool:
        """Whether the grasp serves every task of ``task_set`` (a bitmask as ``label``); False when unknown."""
        return self.label is not None and self.label & task_set == task_set


def judge(model: GraspModel, base_T_obj: NDArray[np.float64], base_T_ee: NDArray[np.float64],
          closures: ArrayLike) -> Judgement:
    """The tasks the grasp serves by ``model``'s object's rules.

    Parameters
    ----------
    model : GraspModel
        Its ``object`` picks the rules, its ``task_names`` name the tasks.
    base_T_obj, base_T_ee : ndarray, shape (4, 4)
        The object's and the hand's (end effector's) poses in the arm's base frame.
    closures : array_like, shape (3,)
        The three fingers' closures, rad.
    """
    rules = object_of(model)
    if rules is None:
        return Judgement(None, f'unknown (model {model.name!r} names no object of {", ".join(OBJECTS)})', {})
    x = obj_T_ee_to_features(np.linalg.inv(base_T_obj) @ base_T_ee, np.asarray(closures, dtype=np.float64))
    label = rules.label(x)
    failed = {task: tuple(n for n, ok in checks.items() if not ok) for task, checks in rules.explain(x).items()}
    if not label:
        return Judgement(0, 'no task (failed: ' + '; '.join(f'{task}: {", ".join(names)}'
                                                           for task, names in failed.items()) + ')', failed)
    names = ', '.join(n for i, n in enumerate(model.task_names) if label >> i & 1)
    return Judgement(label, f'{names} ({zone_label(label, model.task_names)})', failed)


@dataclass(frozen=True)
class SceneJudgement:
    """The rules' verdicts on one grasp in a scene of several objects, for the operator's true object and task set.

    Attributes
    ----------
    verdicts : tuple of Judgement
        :func:`judge` at each object's pose by that object's rules (the scene's order).
    at : int
        The object the hand closed at: the one whose frame's origin is nearest the hand's (the end effector's)
        position, the first of equal ones. An object's rules may give a task to a grasp of another object lying
        within their wide feature bounds, so which object the hand is at is decided by the distance, not by them.
    true_object : int
        The index of the object the operator wanted.
    task_set : int
        The operator's true task set (bitmask over the true object's model's tasks).
    """

    verdicts: tuple[Judgement, ...]
    at: int
    true_object: int
    task_set: int

    @property
    def serves(self) -> bool:
        """Whether the hand closed at the true object with a grasp serving every task of the true set by its rules."""
        return self.at == self.true_object and self.verdicts[self.true_object].serves(self.task_set)

    @property
    def wrong_object(self) -> bool:
        """Whether the hand closed at another object than the true one (whatever its rules say of the grasp)."""
        return self.at != self.true_object


def judge_scene(objects: Sequence[tuple[GraspModel, NDArray[np.float64]]], true_object: int, task_set: int,
                base_T_ee: NDArray[np.float64], closures: ArrayLike) -> SceneJudgement:
    """The grasp judged in a scene: ``objects`` (model, true ``base_T_obj``) in order, each by :func:`judge`.

    The operator wanted object ``true_object`` for the tasks ``task_set``; :attr:`SceneJudgement.serves` holds only
    for a grasp at that object (:attr:`SceneJudgement.at`) serving them by its rules.
    """
    distances = [float(np.linalg.norm(base_T_obj[:3, 3] - base_T_ee[:3, 3])) for _, base_T_obj in objects]
    return SceneJudgement(tuple(judge(model, base_T_obj, base_T_ee, closures) for model, base_T_obj in objects),
                          int(np.argmin(distances)), true_object, task_set)


def operator_verdict(judgement: Judgement, wanted: Sequence[str], task_names: Sequence[str]) -> str:
    """Whether the judged grasp serves every task the operator wants (``wanted``, names of ``task_names``), in words.

    'the operator's tasks served', 'not the operator's transfer', or 'unknown' when the rules gave no label.
    """
    if judgement.label is None:
        return 'unknown'
    missing = [name for name in wanted if not judgement.label >> list(task_names).index(name) & 1]
    return "the operator's tasks served" if not missing else f"not the operator's {', '.join(missing)}"
