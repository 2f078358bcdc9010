"""The replay's client node: it publishes a session's inputs and collects the live outputs.

The engine that paces the inputs and checks each answer through it is :mod:`.replayers`; the command line is
:mod:`grasp_intent_ros.sessions.replay`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from std_msgs.msg import String

from ..ros.conversions import message_class
from ..ros.qos import DEFAULT_DEPTH, STREAM_DEPTH, input_qos, latched_qos, output_qos
from ..wire.diagnostics import KEY_KERNELS_LOAD_TIME
from ..wire.model_document import ModelHeader
from ..wire.topics import (
    ASSISTANCE_ALPHA,
    ASSISTANCE_TWIST,
    DIAGNOSTICS,
    INPUT_TOPICS,
    INTENT_W,
    JOINT_STATES,
    MODEL_ACTIVE,
    MSGTYPES,
    OUTPUT_TOPICS,
)
from .closed_loop import ESTIMATED_REPLAYED, RENAMED, REPLAYED, Tracer
from .outputs import Output, RejectionTracker, SessionError, decode, output_of

__all__ = ['SUITE_SETTLE_S', 'SessionClient']

SUITE_SETTLE_S = 3.0
"""With --start-suite: seconds every node must have been visible before the first input (see
:meth:`SessionClient.settled`)."""


# ---------------------------------------------------------------------------------------- the client
class SessionClient(Node):
    """Publishes session inputs, collects the live outputs, sets the model server's ``model`` parameter.

    Outputs are :class:`~grasp_intent_ros.sessions.outputs.Output` (serialized, decoded like the recorded ones).

    Parameters
    ----------
    model_server
        Name of the model server node, relative to this node's namespace.
    node_name
        This node's name; ``kwargs`` go to ``rclpy.node.Node`` (``context``, ``namespace``).
    closed_loop
        Replay a closed-loop session: publish :data:`~.closed_loop.REPLAYED` and trace the loop.
    estimated
        With ``closed_loop``, a session whose w came from the intent estimator: publish
        :data:`~.closed_loop.ESTIMATED_REPLAYED` (the recorded hand included) and trace the live w.
    arm_namespace
        None for a one-chain session. For a chain of a scene (this node in the chain's namespace), the scene's
        namespace: ``joint_states`` is published there (the arm's), and only the rejections of nodes in
        this node's namespace are outputs (:class:`~.outputs.RejectionTracker`).
    """

    def __init__(self, *, model_server: str = 'model_server', node_name: str = 'replay', closed_loop: bool = False,
                 estimated: bool = False, arm_namespace: str | None = None, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.closed_loop = closed_loop
        """Whether this client replays a closed-loop session (:mod:`grasp_intent_ros.sessions.closed_loop`)."""
        self.tracer = Tracer()
        """With ``closed_loop``: the live loop's joint states, grasps, alphas and blended twists."""
        self.outputs: list[Output] = []
        """Live outputs in arrival order (model/active documents and rejections included)."""
        self.model: ModelHeader | None = None
        """The newest live model document."""
        self.statuses: set[str] = set()
        """Names of the diagnostic statuses seen."""
        self.loading: set[str] = set()
        """Names of the planners' statuses that do not report their kernels loaded yet (not ready)."""
        self.diagnostics_received = 0
        """Number of /diagnostics messages received."""
        self.last_status: dict[str, str] = {}
        """Per diagnostic status name, its latest message and values, for error reports."""
        self._tracker = RejectionTracker(nodes_in=None if arm_namespace is None else self.get_namespace().rstrip('/'))
        self._first_seen: dict[str, float] = {}
        sent, traced = ((INPUT_TOPICS, ()) if not closed_loop else (ESTIMATED_REPLAYED, (INTENT_W,)) if estimated
                        else (REPLAYED, (JOINT_STATES, ASSISTANCE_TWIST, ASSISTANCE_ALPHA)))
        qos = output_qos(STREAM_DEPTH if estimated else DEFAULT_DEPTH)  # the estimator takes every message
        renamed = {**RENAMED, **({} if arm_namespace is None else {JOINT_STATES: f'{arm_namespace}/{JOINT_STATES}'})}
        self._input_pubs = {t: self.create_publisher(message_class(t), renamed.get(t, t), qos) for t in sent}
        self._loop_subs = {
            topic: self.create_subscription(message_class(topic), topic, self._tracer_receiver(topic), input_qos(1000),
                                            raw=True)
            for topic in traced}
        self._output_subs = {
            topic: self.create_subscription(message_class(topic), topic, self._receiver(topic), input_qos(100),
                                            raw=True)
            for topic in OUTPUT_TOPICS}
        self._output_subs[MODEL_ACTIVE] = self.create_subscription(
            String, MODEL_ACTIVE, self._receiver(MODEL_ACTIVE), latched_qos(), raw=True)
        self._diag_sub = self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics,
                                                  input_qos(100), raw=True)
        self._param_client = self.create_client(SetParameters, f'{model_server}/set_parameters')

    def _now_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def _receiver(self, topic: str) -> Callable[[bytes], None]:
        def receive(cdr: bytes) -> None:
            out = output_of(topic, self._now_ns(), cdr)  # never raises
            if self.closed_loop:
                self.tracer.add(topic, out.t_ns, cdr)
            if isinstance(out.value, ModelHeader):
                self.model = out.value
            self.outputs.append(out)
        return receive

    def _tracer_receiver(self, topic: str) -> Callable[[bytes], None]:
        return lambda cdr: self.tracer.add(topic, self._now_ns(), cdr)

    def _on_diagnostics(self, cdr: bytes) -> None:
        try:
            msg = decode(MSGTYPES[DIAGNOSTICS], cdr)
        except SessionError:
            return
        self.diagnostics_received += 1
        for status in msg.status:
            self.last_status[str(status.name)] = (
                f'{status.message} ({", ".join(f"{kv.key}: {kv.value}" for kv in status.values)})')
        self.statuses.update(str(s.name) for s in msg.status)
        for status in msg.status:  # a planner is ready once its kernels are loaded (it reports their load time)
            if str(status.name).endswith(': planning'):
                if any(kv.key == KEY_KERNELS_LOAD_TIME for kv in status.values):
                    self.loading.discard(str(status.name))
                else:
                    self.loading.add(str(status.name))
        now = self._now_ns()
        self.outputs.extend(Output(DIAGNOSTICS, now, r) for r in self._tracker.update(msg))

    def publish(self, topic: str, message: bytes | Any) -> None:
        """Publish on an input topic (relative name) a message object or its CDR bytes."""
        self._input_pubs[topic].publish(message)

    def set_model(self, name: str) -> Future:
        """Ask the model server to activate ``name``; the future's result is a SetParameters response."""
        request = SetParameters.Request(parameters=[Parameter('model', value=name).to_parameter_msg()])
        return self._param_client.call_async(request)

    def settled(self, seconds: float) -> bool:
        """Whether every node in the graph has been visible to this node for at least ``seconds``.

        Nodes started together discover each other through periodic announcements (Fast DDS: every 3 s),
        so two suite nodes may still miss each other when both are visible here; after one announcement
        period every pair has met, and a first output between them is no longer lost.
        """
        now = time.monotonic()
        for name, namespace in self.get_node_names_and_namespaces():
            self._first_seen.setdefault(f'{namespace.rstrip("/")}/{name}', now)
        return all(now - t >= seconds for t in self._first_seen.values())

    def missing(self, *, need_parameters: bool) -> list[str]:
        """What the live system still lacks to be replayed into ([] when ready).

        A model document,
        matched subscribers of the inputs, matched publishers of the outputs, a status from every
        /diagnostics publisher, every planner's kernels loaded, the parameter service.
        """
        lacking = []
        if self.model is None:
            lacking.append(f'no {MODEL_ACTIVE} received')
        lacking += [f'no subscriber on {t}' for t, p in self._input_pubs.items() if p.get_subscription_count() == 0]
        lacking += [f'no publisher on {t}' for t, s in (*self._output_subs.items(), *self._loop_subs.items())
                    if s.get_publisher_count() == 0]
        publishers = self._diag_sub.get_publisher_count()
        if publishers == 0 or len(self.statuses) < publishers:
            lacking.append(f'{len(self.statuses)} diagnostic statuses from {publishers} /diagnostics publishers')
        lacking += [f'{name}: compiled kernels still loading' for name in sorted(self.loading)]
        if need_parameters and not self._param_client.service_is_ready():
            lacking.append(f'no parameter service {self._param_client.srv_name}')
        return lacking
