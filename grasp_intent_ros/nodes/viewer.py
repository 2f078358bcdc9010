"""Viewer node: the live suite in a browser (the MICO, its planned grasp, w / v / P and the plan's status).

Run: ``python -m grasp_intent_ros.nodes.viewer [--ros-args -p port:=8080]``, then open ``http://127.0.0.1:8080``.
Needs the ``viewer`` extra (``pip install 'grasp_intent_ros[viewer]'``: viser).

Topics (relative; all inputs, :data:`~grasp_intent_ros.scene.state.VIEWER_TOPICS`)
    ``joint_states``, ``grasp/joint_targets``, ``object/pose``, ``model/active`` (latched), ``grasp/pose``,
    ``grasp/features``, ``grasp/posterior``, ``intent/w``, ``intent/v``, ``intent/clarification``,
    ``/diagnostics`` (the planner's ``last plan status``), and the assistance node's ``operator/twist``,
    ``assistance/twist``, ``assistance/alpha`` when it runs. Publishes only its own ``/diagnostics``
    (``viewer``: ``url``, ``browsers connected``, ``frames drawn``, every rejected message).

    With ``objects`` (a scene of several objects, docs/several_objects.md; the viewer at the suite's namespace):
    each object's chain topics (:data:`~grasp_intent_ros.scene.state.CHAIN_TOPICS`) in ``<object>/``, e.g.
    ``cup/object/pose``, ``cup/model/active``, ``cup/grasp/pose``; the arm's
    (:data:`~grasp_intent_ros.scene.state.ARM_TOPICS`: ``joint_states``, the twists, alpha) and ``/diagnostics``
    once, each chain's plan status from its own planner (``/<namespace>/cup/grasp_planner: planning``), and
    :data:`~grasp_intent_ros.scene.state.SCENE_TOPICS` once: P(o) on ``intent/objects`` and the object the
    assistance follows on ``assistance/object`` (latched), marked in the panel.

Behaviour
    A message only replaces the newest state (:func:`grasp_intent_ros.scene.state.apply`; with ``objects``
    the state of its chain, :func:`~grasp_intent_ros.scene.state.apply_objects`; ``model/active`` is read off
    the executor, one :class:`~grasp_intent_ros.ros.model_follower.ModelFollower` per chain); a message that
    cannot be read, or larger than its topic's cap (:data:`~grasp_intent_ros.wire.topics.MAX_MESSAGE_BYTES`,
    checked before decoding, as every node's input: :func:`~grasp_intent_ros.ros.inputs.subscribe_input`), is a
    rejection naming its topic (WARN) and changes nothing, every other chain drawn as before. A thread of its
    own draws the newest state at most ``rate`` times a second and skips the states in between
    (:class:`~grasp_intent_ros.ros.worker.LatestOnlyWorker`). The viewer is a subscriber only, in a process
    of its own, with keep-last queues: a slow browser or viewer never holds up a publisher.
    The page (:class:`~grasp_intent_ros.scene.page.ScenePage`) is served on ``host`` (default 127.0.0.1:
    this machine only) at ``port``; viser takes the next free port when ``port`` is in use, and the node
    logs and reports the URL it serves.

Parameters: :data:`PARAMETERS`.
"""

from __future__ import annotations

import threading
from dataclasses import replace
from typing import Any

from rclpy.node import Node

from ..errors import GraspIntentError
from ..method.features import MICO_3F
from ..method.model import ModelRequirements
from ..mico.parameters import URDF_PATH
from ..parameters import ParameterError, ParamSpec
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.model_follower import ModelFollower
from ..ros.params import declare_parameters
from ..ros.qos import input_qos, latched_qos
from ..ros.run import guard_exit, run_node
from ..ros.worker import LatestOnlyWorker
from ..scene.geometry import ArmModel
from ..scene.page import DEFAULT_HOST, ScenePage
from ..scene.state import ObjectsState, SceneState, apply_to, followed_topics
from ..wire.diagnostics import OK, WARN
from ..wire.model_document import ModelDocument
from ..wire.topics import DIAGNOSTICS, JOINT_STATES, LATCHED_TOPICS, MODEL_ACTIVE, check_object_names

__all__ = ['Viewer', 'PARAMETERS', 'main']


PARAMETERS = (
    ParamSpec('host', DEFAULT_HOST, "Address the page is served on; '0.0.0.0' serves every interface "
              '(anyone who can reach this machine then sees the page).', read_only=True),
    ParamSpec('port', 8080, 'TCP port of the page (0: any free port; a port in use: the next free one).',
              range=(0, 65535), read_only=True),
    ParamSpec('rate', 20.0, 'Most frames drawn per second, Hz (the newest state each time).', range=(1.0, 60.0)),
    URDF_PATH,
    ParamSpec('objects', [], 'The objects of a scene of several objects (docs/several_objects.md), each with its '
              "planning chain in <the viewer's namespace>/<object>, as suite --object starts them (e.g. [cup, "
              "flashlight]); empty: one chain, in the viewer's own namespace.", item_type=str, read_only=True,
              validator=check_object_names),
)


class Viewer(Node):
    """Serves the scene page and keeps it at the newest state. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'viewer', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, 'viewer')
        self._params = declare_parameters(self, PARAMETERS)
        arm = self._params.build('urdf_path', lambda path: ArmModel(path or None))
        try:
            self._page = ScenePage(arm, host=self._params['host'], port=self._params['port'],
                                   title=f'grasp_intent_ros {self.get_fully_qualified_name()}')
        except OSError as exc:
            raise ParameterError(f'cannot serve on {self._params["host"]}:{self._params["port"]}: {exc}') from None
        self._frames = 0
        self._clients_lock = threading.Lock()
        self._page.on_client(self._count_clients, self._count_clients)
        url = f'http://{self._params["host"]}:{self._page.port}'
        self._diag.set_values({'url': url, 'browsers connected': 0, 'frames drawn': 0})
        self._diag.set_state(OK, '')
        moved = '' if self._params['port'] in (0, self._page.port) else \
            f' (port {self._params["port"]} was in use)'
        self.get_logger().info(f'serving the scene on {url}{moved}')
        objects = tuple(self._params['objects'])
        scene = ObjectsState.empty(objects, self.get_namespace().rstrip('/'))
        self._worker: LatestOnlyWorker[SceneState | ObjectsState] = LatestOnlyWorker(
            scene if objects else SceneState(), self._diag.guard(self._draw, counts_received=False),
            name=f'{node_name}_draw', min_period=lambda: 1.0 / float(self._params['rate']))
        self.context.on_shutdown(self._worker.stop_soon)
        # any tasks (the page names the model's own zones); the MICO's features, which the scene draws
        self._models = [ModelFollower(self, self._diag, self._use_model(chain),
                                      name=f'{node_name}_model' + (f'_{chain}' if chain else ''),
                                      requires=lambda: ModelRequirements(feature_names=MICO_3F.names),
                                      namespace=chain or '')
                        for chain in objects or (None,)]
        for chain, topic in followed_topics(objects):
            if topic == MODEL_ACTIVE:
                continue
            depth = 10 if topic in (JOINT_STATES, DIAGNOSTICS) else 1  # several publishers on these
            subscribe_input(self, topic, self._on_message(chain, topic),  # each topic's type and size cap
                            latched_qos() if topic in LATCHED_TOPICS else input_qos(depth=depth), self._diag,
                            namespace=chain or '')
        if objects:
            self.get_logger().info(f'following the chains {", ".join(map(scene.chain_namespace, objects))}')

    def _on_message(self, chain: str | None, topic: str) -> Any:
        def change(state: SceneState | ObjectsState, msg: Any) -> SceneState | ObjectsState:
            try:
                return apply_to(state, chain, topic, msg)
            except GraspIntentError as exc:  # the reason names the topic (subscribe_input names a chain's)
                if chain is not None:
                    raise
                raise GraspIntentError(f'{topic}: {exc}') from None

        def on_message(msg: Any) -> None:
            self._worker.update(lambda state: change(state, msg))
        on_message.__name__ = f'on {topic if chain is None else f"{chain}/{topic}"}'
        return on_message

    def _use_model(self, chain: str | None) -> Any:
        def change(state: SceneState | ObjectsState, doc: ModelDocument | None) -> SceneState | ObjectsState:
            if isinstance(state, ObjectsState):
                assert chain is not None  # one follower per chain
                return state.with_chain(chain, lambda s: replace(s, model=doc))
            return replace(state, model=doc)

        def use(doc: ModelDocument | None) -> None:  # in the model follower's thread
            self._worker.update(lambda state: change(state, doc))
        return use

    def _draw(self, state: SceneState | ObjectsState) -> None:  # in the drawing thread
        self._page.show(state)
        self._frames += 1
        self._diag.set_value('frames drawn', self._frames)

    def _count_clients(self) -> None:  # in viser's threads
        with self._clients_lock:
            clients = self._page.clients
            self._diag.set_value('browsers connected', clients)
            if clients > 20:
                self._diag.set_state(WARN, f'{clients} browsers connected: each costs the drawing thread')
            else:
                self._diag.set_state(OK, '')

    def destroy_node(self) -> None:
        """Stop drawing and reading models, close the page, then destroy the node."""
        for follower in self._models:
            follower.stop()
        self._worker.stop()
        self._page.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point: serve the page until SIGINT/SIGTERM."""
    run_node(Viewer, args)
    guard_exit()


if __name__ == '__main__':
    main()
