r"""The intent estimator over several objects, ROS-free: one posterior over every object's goals -> P(o) and each w^o.

docs/several_objects.md ("Intent over objects", "The intent estimator: goals across objects") gives the design;
:mod:`.estimator` the one-object method, which this module reuses whole: one :class:`~.estimator.IntentEstimator`
per object holds that object's goals (its reachable demonstrations at its pose), its evidence, its shown grasp and
its task prior.

**One posterior.** Over the goals of every object, the prior uniform over the objects, then over an object's task
sets, then over the goals of a set, ``pi_g = 1 / (n_objects n_sets(o) n_{S_g}(o))`` (or, for an object with a
task prior, that prior's ``pi_{g|o}`` (:mod:`.task_prior`) over ``n_objects``); the evidence ``E_g`` of each goal
is the one-object rule's, every object's goals updated by one motion. So

.. math::

    P(g) \propto \pi_g e^{E_g}, \qquad P(o) = \sum_{g \in o} P(g) = \operatorname{softmax}_o \Lambda_o, \quad
    \Lambda_o = \log \sum_{g \in o} \pi_{g | o} e^{E_g},

(the uniform ``1 / n_objects`` cancels), and ``w^o`` the task marginals of o's goals renormalised within o,
calibrated by o's map: exactly the one-object estimator's w over o's goals (:attr:`.IntentEstimator.w`), so a
scene of one object gives today's w to the last bit, and ``P(o) = 1``.

**The forgetting bounds P(o).** ``|E_g| <= beta L`` and ``pi_{g|o}`` sums to 1 within o, so ``|Lambda_o| <=
beta L``: the odds of two objects stay within ``exp(+-2 beta L)`` and ``P(o) >= 1 / (1 + (n - 1) exp(2 beta
L))``, about ``1.4e-87 / (n - 1)`` by default: never 0 (in float64 too), and 1 only to rounding. A change of mind
is followed as the one-object rule follows one: the new object's goal gains from ``E >= -beta L`` while the old
object's goals fade (:mod:`.estimator`, "Forgetting").

**The shown grasp, per object.** Each object's planner shows its own grasp; :meth:`IntentEstimator.set_proposal`
of that object's estimator sets it, and it credits only that object's goals near it with the progress toward it
(an operator taking the cup's shown grasp wants the cup: a flashlight goal lying near it is not credited). While
the hand is being placed on any object's shown grasp (:meth:`IntentEstimator.placing`: in its core, not moving
away from it), the motion is no evidence for **any** object's goals: the whole posterior, P(o) included, is held,
as the one-object rule holds its w (were the other objects' goals to fade or gain there, P(o) would move on the
fine motion of placing the hand).

**Objects come and go.** :meth:`SceneEstimator.set_object` adds an object or replaces its estimator (a new
model, or the object moved: a new estimator over the new goals, whose evidence starts at the prior, ``E = 0``,
``Lambda_o = 0``: no evidence for or against the object) while the other objects keep theirs. The objects'
settings must agree except in the calibration map (each model its own): one motion fades every goal's evidence
alike.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidIntentError
from ..method.log_space import log_sum_exp, softmax
from .estimator import EstimatorConfig, IntentEstimator, checked_motion

__all__ = ['SceneEstimator']


_OWN = frozenset({'calibration_slope', 'calibration_offset'})
"""The settings each object may have its own of: the calibration map (each model's)."""


def _shared(config: EstimatorConfig) -> tuple[object, ...]:
    """The settings every object must share: all but :data:`_OWN`."""
    return tuple(getattr(config, field.name) for field in dataclasses.fields(config) if field.name not in _OWN)


class SceneEstimator:
    """P(o) and each object's w from one posterior over the goals of several objects (module docstring).

    The objects are kept in the order they were first set. Each object's :class:`~.estimator.IntentEstimator`
    (``scene[name]``) takes that object's shown grasp and task prior; its :attr:`~.estimator.IntentEstimator.w` is
    w^o.
    """

    def __init__(self) -> None:
        self._objects: dict[str, IntentEstimator] = {}
        self.updates = 0
        """Twists taken (:meth:`update` calls that did not raise)."""

    def set_object(self, name: str, estimator: IntentEstimator) -> None:
        """Add object ``name`` with ``estimator`` (its goals, settings, shown grasp and task prior), or replace it.

        The estimator is taken as it is (a new one's goals start from the prior); the other objects keep their
        evidence. Raises InvalidIntentError for an empty name or settings that differ from the other objects' in
        more than the calibration map (the scene is then unchanged).
        """
        if not name:
            raise InvalidIntentError('an object needs a name')
        for other, existing in self._objects.items():
            if other != name and _shared(existing.config) != _shared(estimator.config):
                raise InvalidIntentError(f'the settings of object {name!r} differ from those of {other!r} in more than '
                                         'the calibration map: one motion must fade every goal alike')
        self._objects[name] = estimator

    def remove(self, name: str) -> None:
        """Forget object ``name`` (its share of P(o) goes to the others). Raises KeyError for an unknown name."""
        del self._objects[name]

    def __getitem__(self, name: str) -> IntentEstimator:
        """Object ``name``'s estimator. Raises KeyError for an unknown name."""
        return self._objects[name]

    def __contains__(self, name: object) -> bool:
        return name in self._objects

    def __iter__(self) -> Iterator[str]:
        return iter(self._objects)

    def __len__(self) -> int:
        return len(self._objects)

    def update(self, base_T_ee: ArrayLike, twist: ArrayLike, dt: float) -> None:
        """Take one operator twist held for ``dt`` s with the hand at ``base_T_ee``, for every object's goals.

        As :meth:`.IntentEstimator.update` for each object, but the placing test spans the objects (module docstring):
        with the hand being placed on any object's shown grasp, nothing changes. Raises KinematicsError for a
        malformed pose, twist or ``dt``, InvalidIntentError when the objects' settings no longer agree (module
        docstring) or there is no object (the estimate is then unchanged).
        """
        estimators = list(self._objects.values())
        if not estimators:
            raise InvalidIntentError('no object to estimate over')
        config = _shared(estimators[0].config)
        if any(_shared(est.config) != config for est in estimators[1:]):
            raise InvalidIntentError('the objects\' settings differ in more than the calibration map')
        hand, motion = checked_motion(base_T_ee, twist, dt, estimators[0].config)
        self.updates += 1
        for est in estimators:
            est.updates += 1
        if motion is None:
            return
        shown = [est.shown_progress(hand, motion) for est in estimators]
        if any(est.placing(hand, s) for est, s in zip(estimators, shown, strict=True)):
            return  # placing the hand on a shown grasp: no evidence for any object
        for est, s in zip(estimators, shown, strict=True):
            est.take(hand, motion, s)

    def reset(self) -> None:
        """Every object back to its prior (:meth:`.IntentEstimator.reset`: shown grasps forgotten, task priors kept)."""
        for est in self._objects.values():
            est.reset()
        self.updates = 0

    def log_masses(self) -> NDArray[np.float64]:
        """Lambda_o per object, in order (module docstring): log sum over o's goals of pi_{g|o} exp(E_g)."""
        out = np.empty(len(self._objects))
        for k, est in enumerate(self._objects.values()):
            out[k] = log_sum_exp(est.log_prior + est.evidence)
        return out

    @property
    def object_probabilities(self) -> NDArray[np.float64]:
        """P(o) per object, in order, shape (n,): positive, summing to 1 (to rounding); empty with no object."""
        if not self._objects:
            return np.zeros(0)
        return softmax(self.log_masses())

    def goal_posterior(self) -> dict[str, NDArray[np.float64]]:
        """P(g) over every object's goals, per object (the joint: all of them sum to 1), each shape (N_o,)."""
        return {name: p_o * est.posterior for (name, est), p_o in zip(self._objects.items(),
                                                                        self.object_probabilities, strict=True)}

    def w(self, name: str) -> NDArray[np.float64]:
        """w^o of object ``name``: its estimator's w (module docstring). Raises KeyError for an unknown name."""
        return self._objects[name].w
