"""Intent interpreter node: task probabilities w -> target vector v over all zones (paper eqs. 3-4).

Run: ``python -m grasp_intent_ros.nodes.intent_interpreter``
     ``[--ros-args --params-file config/intent_interpreter.yaml]``

Topics (relative; ``-r __ns:=/robot1`` moves them)
    in   ``intent/w``              std_msgs/Float64MultiArray, m values in [0, 1], one per task
    in   ``model/active``          std_msgs/String, latched: the active model document (its zones)
    out  ``intent/v``              std_msgs/Float64MultiArray, 2^m - 1 values in core zone order,
                                   one dimension labelled with the zone labels ("U,T,H,UT,UH,TH,UTH")
    out  ``intent/clarification``  std_msgs/String, the reason, instead of v when P(no task) >= threshold,
                                   when w gives no zone of the active model any probability, or when the
                                   node has no model the suite serves because the newest was refused
    out  ``/diagnostics``          ``<node>: intent``: counts (w dropped from a full input queue too), the
                                   active model, the last outcome

Where the model's zones are known: v is published over all 2^m - 1 zones (so any model of the same
tasks can use it, and the planner renormalises it over its model's zones, eq. 4); the interpreter
follows the latched ``model/active`` only to decide whether the intent can be served at all. A model the
suite does not serve (:func:`~grasp_intent_ros.ros.model_follower.served_models`: tasks other than
``task_names``, another robot's features) is refused before it is built and the current one kept; with
none, every w is answered with a clarification giving the reason, and the status is ERROR
(:class:`~grasp_intent_ros.ros.model_follower.ModelFollower`). Before any document, v is published over all
zones.

Every w is answered, in order: a thread of its own (:class:`~grasp_intent_ros.ros.worker.InputThread`)
takes all waiting w (up to 100) at each wake-up, off the executor, which handles the parameters, the
arrival of model documents and the diagnostics timer.

Parameters: :data:`grasp_intent_ros.method.parameters.INTENT_INTERPRETER`, ``config/intent_interpreter.yaml``.
    ``task_names`` (string[], default usage, transfer, handover): names of the m tasks in w's order, the same
    list on every node of the suite (:data:`~grasp_intent_ros.method.parameters.TASK_NAMES`)
    ``clarification_threshold`` (float in (0, 1], default 0.5)
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..errors import InvalidIntentError
from ..method.intent import (
    MAX_TASKS,
    NeedsClarification,
    ZoneInterpreter,
    all_zones,
    support_zones,
    validate_w,
    zone_labels,
)
from ..method.parameters import INTENT_INTERPRETER
from ..ros.clarification import ClarificationRequests
from ..ros.conversions import SerializedArrays
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import decode_input, subscribe_input
from ..ros.model_follower import ModelFollower, served_models
from ..ros.params import declare_parameters
from ..ros.qos import input_qos, output_publisher
from ..ros.run import guard_exit, publish_all, run_node
from ..ros.worker import InputThread
from ..wire import topics
from ..wire.arrays import msg_to_array, serialized_vector
from ..wire.diagnostics import KEY_CLARIFICATIONS, KEY_LAST_OUTCOME, KEY_MODEL
from ..wire.model_document import ModelDocument

__all__ = ['IntentInterpreter', 'W_QUEUE_DEPTH', 'main']

W_QUEUE_DEPTH = 100
"""Keep-last depth of the ``intent/w`` subscription: 0.1 s of w at 1 kHz."""


class IntentInterpreter(Node):
    """Subscribes to w, publishes v (or a clarification request). ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'intent_interpreter', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diagnostics = NodeDiagnostics(self, 'intent')
        self._params = declare_parameters(self, INTENT_INTERPRETER, check=self._check, on_change=self._configure)
        self._pubs = {topics.INTENT_V: output_publisher(self, Float64MultiArray, topics.INTENT_V)}
        self._clarifications = ClarificationRequests(self, self._diagnostics, count_key=KEY_CLARIFICATIONS,
                                                     outcome_key=KEY_LAST_OUTCOME)
        self._model_lock = threading.RLock()
        self._model: tuple[ModelDocument | None, ZoneInterpreter] | None = None
        """The active model and the interpretation of w with the zones it supports, swapped together."""
        self._diagnostics.set_value(KEY_LAST_OUTCOME, '')
        # no document is read before the node spins: _configure below sets up what _use_model needs first
        self._models = ModelFollower(self, self._diagnostics, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: served_models(self._params['task_names']))
        self._configure(self._params)
        # every w is answered: a deeper queue than the default, taken off the executor by a thread of its own
        # (every waiting w in each wake-up), and each read from its serialized bytes (a flat w, as publishers
        # send it, never becomes a message)
        self._inputs = InputThread(self.context, name=f'{node_name}_w')
        self.context.on_shutdown(self._inputs.stop_soon)
        self._w_sub = subscribe_input(self, topics.INTENT_W, self._on_w, input_qos(depth=W_QUEUE_DEPTH),
                                      self._diagnostics, count_dropped=True, serialized=True,
                                      callback_group=self._inputs.callback_group)
        self._inputs.take(self._w_sub)

    def destroy_node(self) -> None:
        """Stop the w and model threads (after the w or the document at hand), then destroy the node."""
        self._inputs.stop()
        self._models.stop()
        super().destroy_node()

    def _check(self, values: Mapping[str, Any]) -> None:
        """task_names the active model does not have are refused (none is active while they are declared)."""
        if hasattr(self, '_models'):
            self._models.check(served_models(values['task_names']))

    def _configure(self, changed: Mapping[str, Any]) -> None:
        task_names = self._params['task_names']
        with self._model_lock:  # the w and model threads read and swap these meanwhile
            first = self._model is None
            self._zones = all_zones(len(task_names))
            self._v_messages = SerializedArrays((len(self._zones),), [zone_labels(self._zones, task_names)])
            self._use_model(None if self._model is None else self._model[0])
        self._diagnostics.set_value('tasks', ','.join(task_names))
        self._diagnostics.set_value('clarification threshold', self._params['clarification_threshold'])
        if not first and 'task_names' in changed:
            self._models.recheck()  # the model is served for other tasks, or now one refused is

    def _use_model(self, doc: ModelDocument | None) -> None:
        """Follow the active model: its zones decide whether an intent can be served.

        Called in the model follower's thread for a new model and on the executor for new parameters.
        """
        with self._model_lock:  # task_names may change on the executor meanwhile
            support = None if doc is None else support_zones(
                self._params['task_names'], doc.model.task_names, doc.model.zones)
            self._model = (doc, ZoneInterpreter(
                len(self._params['task_names']), self._zones, support=support,
                clarification_threshold=self._params['clarification_threshold']))
            if doc is None and self._models.refused:
                text = f'none: {self._models.refused}'
            elif doc is None:
                text = 'none yet (all zones)'
            elif support is None:
                text = (f'{doc.name}: its tasks {",".join(doc.model.task_names)} differ from task_names; '
                        'not used (all zones)')
            else:
                text = f'{doc.name} (zones {",".join(doc.model.zone_labels)})'
            self._diagnostics.set_value(KEY_MODEL, text)

    def _on_w(self, data: bytes) -> None:  # in the w thread
        w = serialized_vector(data, max_size=MAX_TASKS, error=InvalidIntentError, what='w')
        if w is None:  # not a flat vector: read it as a message (every layout, the same checks)
            w = msg_to_array(decode_input(topics.INTENT_W, data), max_size=MAX_TASKS, error=InvalidIntentError,
                             what='w')
        with self._model_lock:  # the model, its interpretation and v's layout of one configuration
            assert self._model is not None  # set in __init__
            (doc, interpreter), v_messages = self._model, self._v_messages
        if doc is None and (refused := self._models.refused):  # no model, and the newest was refused
            self._clarifications.request(f'cannot serve: {refused}')
            return
        result = interpreter.interpret_checked(validate_w(w, interpreter.m))
        if isinstance(result, NeedsClarification):
            reason = result.reason
            if result.p_none < interpreter.clarification_threshold and doc is not None:
                reason += f' (model {doc.name}: zones {",".join(doc.model.zone_labels)})'
            self._clarifications.request(reason)
        else:
            publish_all(self, self._pubs, {topics.INTENT_V: v_messages.serialize(result.v)})
            self._diagnostics.set_value(KEY_LAST_OUTCOME, 'v published')


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(IntentInterpreter, args)
    guard_exit()  # the interpreter's exit too must end, or leave the stacks


if __name__ == '__main__':
    main()
