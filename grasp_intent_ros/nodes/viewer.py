"""Viewer node: the live suite in a browser (the MICO, its planned grasp, w / v / P and the plan's status).

Run: ``python -m grasp_intent_ros.nodes.viewer [--ros-args -p port:=8080]``, then open ``http://127.0.0.1:8080``.
Needs the ``viewer`` extra (``pip install 'grasp_intent_ros[viewer]'``: viser).

Topics (relative; all inputs, :data:`~grasp_intent_ros.scene.state.VIEWER_TOPICS`)
    ``joint_states``, ``grasp/joint_targets``, ``object/pose``, ``model/active`` (latched), ``grasp/pose``,
    ``grasp/features``, ``grasp/posterior``, ``intent/w``, ``intent/v``, ``intent/clarification``,
    ``/diagnostics`` (the planner's ``last plan status``), and the assistance node's ``operator/twist``,
    ``assistance/twist``, ``assistance/alpha`` when it runs. Publishes only its own ``/diagnostics``
    (``viewer``: ``url``, ``browsers connected``, ``frames drawn``, every rejected message).

Behaviour
    A message only replaces the newest state (:func:`grasp_intent_ros.scene.state.apply`; ``model/active``
    is read off the executor, :class:`~grasp_intent_ros.ros.model_follower.ModelFollower`); a thread of its
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

from ..method.features import MICO_3F
from ..method.model import ModelRequirements
from ..mico.parameters import URDF_PATH
from ..parameters import ParameterError, ParamSpec
from ..ros.conversions import type_class
from ..ros.diagnostics import NodeDiagnostics
from ..ros.model_follower import ModelFollower
from ..ros.params import declare_parameters
from ..ros.qos import input_qos
from ..ros.run import guard_exit, run_node
from ..ros.worker import LatestOnlyWorker
from ..scene.geometry import ArmModel
from ..scene.page import DEFAULT_HOST, ScenePage
from ..scene.state import VIEWER_TOPICS, SceneState, apply
from ..wire.diagnostics import OK, WARN
from ..wire.model_document import ModelDocument
from ..wire.topics import DIAGNOSTICS, JOINT_STATES, MODEL_ACTIVE

__all__ = ['Viewer', 'PARAMETERS', 'main']

PARAMETERS = (
    ParamSpec('host', DEFAULT_HOST, "Address the page is served on; '0.0.0.0' serves every interface "
              '(anyone who can reach this machine then sees the page).', read_only=True),
    ParamSpec('port', 8080, 'TCP port of the page (0: any free port; a port in use: the next free one).',
              range=(0, 65535), read_only=True),
    ParamSpec('rate', 20.0, 'Most frames drawn per second, Hz (the newest state each time).', range=(1.0, 60.0)),
    URDF_PATH,
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
        self._worker = LatestOnlyWorker(SceneState(), self._diag.guard(self._draw, counts_received=False),
                                        name=f'{node_name}_draw',
                                        min_period=lambda: 1.0 / float(self._params['rate']))
        self.context.on_shutdown(self._worker.stop_soon)
        # any tasks (the page names the model's own zones); the MICO's features, which the scene draws
        self._models = ModelFollower(self, self._diag, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: ModelRequirements(feature_names=MICO_3F.names))
        for topic, msgtype in VIEWER_TOPICS.items():
            if topic == MODEL_ACTIVE:
                continue
            depth = 10 if topic in (JOINT_STATES, DIAGNOSTICS) else 1  # several publishers on these
            self.create_subscription(type_class(msgtype), topic, self._diag.guard(self._on_message(topic)),
                                     input_qos(depth=depth))

    def _on_message(self, topic: str) -> Any:
        def on_message(msg: Any) -> None:
            self._worker.update(lambda state: apply(state, topic, msg))
        on_message.__name__ = f'on {topic}'
        return on_message

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread
        self._worker.update(lambda state: replace(state, model=doc))

    def _draw(self, state: SceneState) -> None:  # in the drawing thread
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
        self._models.stop()
        self._worker.stop()
        self._page.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point: serve the page until SIGINT/SIGTERM."""
    run_node(Viewer, args)
    guard_exit()


if __name__ == '__main__':
    main()
