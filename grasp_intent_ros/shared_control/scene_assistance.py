"""One arm's assistance over several objects: the followed object's inputs fed to one :class:`~.assistance.Assistance`.

ROS-free. :class:`SceneAssistance` keeps every object's newest inputs (its chain's grasp, posterior, v, task set,
clarification, object pose and body) and the operator's agreement with each object's grasp, scores the objects and
follows one (:mod:`.scene_target`), and feeds that object's inputs to the one :class:`~.assistance.Assistance` of
the arm: its limits, filter, yield rule, switch, zero-input rule and joint paths are the one-object assistance's,
unchanged, with ``Assistance.object_probability`` set to the followed object's P(o) before each command, so
alpha = alpha_max * P(o) * P(grasp serves T | w^o) * o_o.

**A switch** to another object loads its inputs into the assistance: its object pose and body (the clearance),
its posterior, v and task set, then its grasp, a new proposal whenever it lies beyond the approach corridor of the
old one (:meth:`~.assistance.Assistance.set_grasp`: the agreement held and the yielding start afresh), and its
pending clarification. Its joint path is sought anew, and until it is found the output is the operator's twist
alone (alpha 0, phase ``seeking a path``), as for any new grasp; the output's limiter is the one arm's, so the
twist changes within the acceleration limits. Inputs of an object not followed are kept, not used.

A scene of one object gives the one-object assistance's alpha and twist to the last bit: the object is followed
from its first grasp, its P(o) is 1 exactly (:func:`~.scene_target.object_probabilities`), and its inputs reach
the assistance in the same order.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..method.body import ObjectBody
from .arbitration import ServingMemo, approach_agreement, new_proposal
from .assistance import Assistance, Command
from .robot_twist import assistance_target
from .scene_target import Follower, FollowRule, object_probabilities

__all__ = ['ObjectInputs', 'ObjectChannel', 'SceneAssistance']


@dataclass
class ObjectInputs:
    """One object's newest inputs (as :class:`~.assistance.Assistance` takes them) and the operator's agreement."""

    grasp: NDArray[np.float64] | None = None
    posterior: tuple[NDArray[np.float64], tuple[str, ...], tuple[str, ...]] | None = None
    v: tuple[NDArray[np.float64], tuple[str, ...]] | None = None
    task_set: int | None = None
    clarification_pending: bool = False
    base_T_obj: NDArray[np.float64] | None = None
    body: ObjectBody | None = None
    agreement: tuple[float, float] = field(default=(1.0, 1.0))
    """Held linear and angular agreement with this grasp's approach target (reset by a grasp beyond the corridor)."""
    serving_memo: ServingMemo = field(default_factory=ServingMemo, repr=False, compare=False)
    """:meth:`serving`'s answer kept with its inputs."""

    def serving(self) -> float:
        """P(this grasp serves T | w^o): :func:`~.arbitration.serving_probability`; 0 without v or a posterior."""
        if self.v is None or self.posterior is None:
            return 0.0
        posterior, zone_labels, task_names = self.posterior
        return self.serving_memo(self.v[0], self.v[1], task_names, task_set=self.task_set, posterior=posterior,
                                 zone_labels=zone_labels)


class ObjectChannel:
    """One object's inputs into a :class:`SceneAssistance`, with :class:`~.assistance.Assistance`'s setters."""

    def __init__(self, scene: SceneAssistance, name: str) -> None:
        self._scene, self.name = scene, name

    def _forward(self) -> Assistance | None:
        return self._scene.assistance if self._scene.followed == self.name else None

    @property
    def inputs(self) -> ObjectInputs:
        """The object's newest inputs."""
        return self._scene.objects[self.name]

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None:
        """The object's planned grasp (base frame): as :meth:`.Assistance.set_grasp`."""
        inputs, cfg = self.inputs, self._scene.assistance.config
        if inputs.grasp is not None and not np.array_equal(inputs.grasp, base_T_grasp) and new_proposal(
                cfg, inputs.grasp, base_T_grasp):
            inputs.agreement = (1.0, 1.0)
        inputs.grasp, inputs.clarification_pending = base_T_grasp, False
        if (assist := self._forward()) is not None:
            assist.set_grasp(base_T_grasp)

    def set_posterior(self, posterior: NDArray[np.float64], zone_labels: Sequence[str],
                      task_names: Sequence[str]) -> None:
        """As :meth:`.Assistance.set_posterior`."""
        self.inputs.posterior = (posterior, tuple(zone_labels), tuple(task_names))
        if (assist := self._forward()) is not None:
            assist.set_posterior(posterior, zone_labels, task_names)

    def set_v(self, v: NDArray[np.float64], labels: Sequence[str]) -> None:
        """As :meth:`.Assistance.set_v`."""
        self.inputs.v = (v, tuple(labels))
        if (assist := self._forward()) is not None:
            assist.set_v(v, labels)

    def set_task_set(self, task_set: int | None) -> None:
        """As :meth:`.Assistance.set_task_set`."""
        self.inputs.task_set = task_set
        if (assist := self._forward()) is not None:
            assist.set_task_set(task_set)

    def clarification(self) -> None:
        """As :meth:`.Assistance.clarification`: no assistance toward this object until its next grasp."""
        self.inputs.clarification_pending = True
        if (assist := self._forward()) is not None:
            assist.clarification()

    def set_object(self, base_T_obj: NDArray[np.float64] | None, body: ObjectBody | None) -> None:
        """As :meth:`.Assistance.set_object` (KinematicsError when followed and not rigid)."""
        if (assist := self._forward()) is not None:
            assist.set_object(base_T_obj, body)
        self.inputs.base_T_obj, self.inputs.body = base_T_obj, body


class SceneAssistance:
    """The assistance of one arm over the objects ``names`` (module docstring).

    Parameters
    ----------
    assistance : Assistance
        The arm's; it takes the operator, the joints and the switch (``enabled``) directly, and only the followed
        object's inputs (through :meth:`channel`'s setters).
    names : sequence of str
        The objects.
    rule : FollowRule, optional
        The hysteresis (:class:`~.scene_target.Follower`).
    """

    def __init__(self, assistance: Assistance, names: Sequence[str], rule: FollowRule | None = None) -> None:
        self.assistance = assistance
        self.names = tuple(names)
        self.objects = {name: ObjectInputs() for name in self.names}
        self.follower = Follower(rule)
        self.received: dict[str, float] | None = None
        """The newest P(o) received (``intent/objects``), None before any."""
        self.scores: dict[str, float] = {}
        """Each scored object's c_o (objects with a grasp) at the last :meth:`command`."""
        self.probabilities: dict[str, float] = {}
        """Each scored object's P(o) at the last :meth:`command`."""
        self.serving: dict[str, float] = {}
        """Each scored object's s_o = P(o) P(grasp_o serves T | w^o) at the last :meth:`command`."""
        self._operator: tuple[NDArray[np.float64], float] | None = None

    @property
    def followed(self) -> str | None:
        """The object followed (None before any has a grasp)."""
        return self.follower.followed

    def channel(self, name: str) -> ObjectChannel:
        """Object ``name``'s inputs (KeyError: not one of the objects)."""
        if name not in self.objects:
            raise KeyError(name)
        return ObjectChannel(self, name)

    def set_probabilities(self, probabilities: Mapping[str, float]) -> None:
        """P(o) by object (``intent/objects``). GraspIntentError: a name not an object's, a value outside [0, 1]."""
        if unknown := sorted(set(probabilities) - set(self.names)):
            raise GraspIntentError(f'P(o) of unknown objects {unknown}; the objects are {list(self.names)}')
        if not all(0.0 <= float(p) <= 1.0 for p in probabilities.values()):
            raise GraspIntentError('every P(o) must be in [0, 1]')
        self.received = {name: float(p) for name, p in probabilities.items()}

    def set_operator(self, twist: NDArray[np.float64], now: float) -> None:
        """The operator's twist (shape (6,), base frame) at ``now``: as :meth:`.Assistance.set_operator`."""
        self._operator = (twist, now)
        self.assistance.set_operator(twist, now)

    def command(self, now: float) -> Command:
        """The agreements updated, the object followed (a switch loads its inputs), then the assistance's command."""
        self._update_agreements(now)
        grasped = [name for name in self.names if self.objects[name].grasp is not None]
        self.probabilities = object_probabilities(grasped, self.received, len(self.names)) if grasped else {}
        self.serving = {name: self.probabilities[name] * self.objects[name].serving() for name in grasped}
        self.scores = {name: self.serving[name] * min(self.objects[name].agreement) for name in grasped}
        before = self.follower.followed
        if (after := self.follower.update(self.scores, now)) != before and after is not None:
            self._load(after)
        if after is not None:
            self.assistance.object_probability = self.probabilities[after]
        return self.assistance.command(now)

    def _update_agreements(self, now: float) -> None:
        """Each grasp's held agreement with a fresh operator twist (:func:`~.arbitration.approach_agreement`)."""
        assist, cfg = self.assistance, self.assistance.config
        if self._operator is None or not assist.operator_fresh(now) or assist.base_T_ee is None:
            return
        for inputs in self.objects.values():
            if inputs.grasp is not None:
                target, _ = assistance_target(assist.base_T_ee, inputs.grasp, standoff=cfg.standoff,
                                              corridor_radius=cfg.corridor_radius, corridor_angle=cfg.corridor_angle)
                measured = approach_agreement(cfg, self._operator[0], assist.base_T_ee, target)
                held = inputs.agreement
                inputs.agreement = (held[0] if measured[0] is None else measured[0],
                                    held[1] if measured[1] is None else measured[1])

    def _load(self, name: str) -> None:
        """Object ``name``'s inputs into the assistance (module docstring: a switch)."""
        inputs, assist = self.objects[name], self.assistance
        assist.set_object(inputs.base_T_obj, inputs.body)
        if inputs.posterior is not None:
            assist.set_posterior(*inputs.posterior)
        if inputs.v is not None:
            assist.set_v(*inputs.v)
        assist.set_task_set(inputs.task_set)
        assert inputs.grasp is not None  # only objects with a grasp are followed
        assist.set_grasp(inputs.grasp)
        if inputs.clarification_pending:
            assist.clarification()
