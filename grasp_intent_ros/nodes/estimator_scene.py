"""The intent estimator node over several objects: each object's w on ``<object>/intent/w``, P(o) on ``intent/objects``.

A part of :mod:`.intent_estimator` (no node of its own). docs/several_objects.md ("The intent estimator: goals
across objects") gives the design, and
:mod:`grasp_intent_ros.shared_control.scene_estimator` the maths: one posterior over the goals of every object.
:class:`SceneIntent` is what the node (:mod:`grasp_intent_ros.nodes.intent_estimator`, with its ``objects``
parameter) does for a scene: one :class:`~.estimator_goals.ObjectGoals` per object, in the object's namespace
(``cup/model/active``, ``cup/object/pose``, ``cup/grasp/pose``, ``cup/intent/prior``), each renewing only its own
object's goals (a restart of that object alone: the others keep their evidence), and the outputs:

- ``<object>/intent/w``: w^o, the object's task probabilities given that the operator wants it, for the object's
  chain (its interpreter reads it as the one-object suite's ``intent/w``);
- ``intent/objects``: P(o), one value per object in the order of the ``objects`` parameter, one dimension labelled
  with their names (:func:`grasp_intent_ros.ros.conversions.array_to_msg`).

Both go out together, with the node's rule for w (every ``publish_period`` while the operator moves, and after a new
``intent/prior``); a restarted object's w and P(o) go out at once (its prior). **Objects whose goals are not ready**
(no model yet, being prepared, none reachable, a model refused) have no w and are not in the scene: ``intent/objects``
gives P(o) over the ready objects only (its labels say which), and nothing is published while no object is ready.
Bad input on one object's topic is a WARN rejection naming the topic; the others are served on.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..mico.kinematics import MicoKinematics
from ..ros.conversions import array_to_msg
from ..ros.diagnostics import NodeDiagnostics
from ..ros.qos import output_publisher
from ..ros.run import publish_all
from ..shared_control.estimator import IntentEstimator
from ..shared_control.scene_estimator import SceneEstimator
from ..shared_control.stamped_inputs import StampedInputs
from ..wire.diagnostics import OK, WARN
from ..wire.topics import INTENT_OBJECTS, INTENT_W, MODEL_ACTIVE
from .estimator_goals import ObjectGoals

__all__ = ['SceneIntent']


class SceneIntent:
    """P(o) and each object's w over the objects ``names`` (module docstring).

    Parameters
    ----------
    node, diagnostics, params, kin, inputs, arm
        As for :class:`~.estimator_goals.ObjectGoals`.
    names : sequence of str
        The objects, each a relative namespace of the node's (checked by the node's ``objects`` parameter).
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, params: Mapping[str, Any], kin: MicoKinematics,
                 inputs: StampedInputs[Any], *, arm: Callable[[], NDArray[np.float64] | None],
                 names: Sequence[str]) -> None:
        self._node, self._diag, self._params = node, diagnostics, params
        self.names = tuple(names)
        self._scene = SceneEstimator()
        self._lock = threading.Lock()  # the scene: changed in the goal threads, updated and read on the executor
        self._states = {name: (OK, f'waiting for {name}/{MODEL_ACTIVE}') for name in self.names}
        self._others: dict[str, int] = {}  # other publishers per w topic, as last counted
        self._state_lock = threading.Lock()
        self.fresh = False
        """The estimate changed since the outputs last went out."""
        self._published = 0
        self._w_topics = {name: f'{name}/{INTENT_W}' for name in self.names}
        self._pubs = {topic: output_publisher(node, Float64MultiArray, topic)
                      for topic in (*self._w_topics.values(), INTENT_OBJECTS)}
        self.objects = {name: ObjectGoals(node, diagnostics, params, kin, inputs, arm=arm, namespace=name,
                                          ready=partial(self._ready, name), refresh=self._refresh,
                                          report=partial(self._report, name)) for name in self.names}
        self._show_state()

    def stop(self) -> None:
        """Stop every object's threads (:meth:`.estimator_goals.ObjectGoals.stop`)."""
        for goals in self.objects.values():
            goals.stop()

    def configure(self, changed: Mapping[str, Any]) -> None:
        """The node's parameters changed: every object's settings (:meth:`.estimator_goals.ObjectGoals.configure`)."""
        with self._lock:
            for goals in self.objects.values():
                goals.configure(changed)

    def take(self, hand: NDArray[np.float64], twist: NDArray[np.float64], dt: float,
             proposals: Mapping[str, NDArray[np.float64] | None]) -> bool:
        """One operator twist (base frame, held ``dt`` s, the hand at ``hand``) with each object's grasp shown then.

        Returns False, changing nothing, while no object is ready. Raises as
        :meth:`~grasp_intent_ros.shared_control.scene_estimator.SceneEstimator.update` (nothing changed).
        """
        with self._lock:
            if not len(self._scene):
                return False
            for name in self._scene:
                self.objects[name].show(self._scene[name], proposals.get(name))
            self._scene.update(hand, twist, dt)
        self.fresh = True
        return True

    def publish(self, only: str | None = None) -> None:
        """Every ready object's w (or object ``only``'s) and P(o) over the ready objects; nothing if none is ready."""
        with self._lock:
            ready = [name for name in self.names if name in self._scene]
            if not ready:
                return
            w = {name: self._scene.w(name) for name in ready if only in (None, name)}
            p = dict(zip(self._scene, self._scene.object_probabilities, strict=True))
            likely = {name: self._scene[name].likely_sets(self._params['task_names']) for name in w}
            updates = self._scene.updates
        self.fresh = False
        messages = {self._w_topics[name]: Float64MultiArray(data=values.tolist()) for name, values in w.items()}
        messages[INTENT_OBJECTS] = array_to_msg([p[name] for name in ready], [ready])
        publish_all(self._node, self._pubs, messages)
        self._published += 1
        self._diag.set_values({'published': self._published, 'updates': updates,
                               **{f'{name}: w': ', '.join(f'{v:.3f}' for v in values) for name, values in w.items()},
                               **{f'{name}: likely task sets': sets for name, sets in likely.items()},
                               **{f'{name}: P(o)': f'{p[name]:.3g}' if name in p else 'none (goals not ready)'
                                  for name in self.names}})

    def check_publishers(self) -> None:
        """Count the other publishers on each object's ``intent/w`` and say so in the node's state (WARN)."""
        others = {topic: count for topic in self._w_topics.values()
                  if (count := self._node.count_publishers(topic) - 1) > 0}
        with self._state_lock:
            self._others = others
        self._show_state()

    def _ready(self, name: str, estimator: IntentEstimator | None) -> None:  # in the object's goal thread
        with self._lock:
            if estimator is None:
                if name in self._scene:
                    self._scene.remove(name)
                return
            self._scene.set_object(name, estimator)
        self.publish(only=name)  # its prior, and P(o) with it

    def _refresh(self) -> None:
        self.fresh = True

    def _report(self, name: str, level: int, message: str) -> None:
        with self._state_lock:
            self._states[name] = (level, message)
        self._show_state()

    def _show_state(self) -> None:
        """The node's state: each object's standing condition, and other publishers on an object's w."""
        with self._state_lock:
            states, others = dict(self._states), dict(self._others)
        level = max([OK, *(lvl for lvl, _ in states.values()), *([WARN] if others else [])])
        self._diag.set_state(level, '; '.join(
            [f'{name}: {message}' for name, (_, message) in states.items() if message]
            + [f'{count} other publisher(s) on {topic}: its interpreter answers each w in arrival order, so its plan '
               'follows whichever spoke last' for topic, count in others.items()]))
