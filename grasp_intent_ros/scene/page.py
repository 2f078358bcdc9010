"""The viewer's web page: a viser server drawing a :class:`~grasp_intent_ros.scene.state.SceneState`.

The scene (three.js, in the base frame ``m1n6s300_link_base``, +z up):

- ``/arm``: the MICO at ``joint_states``, drawn from the URDF's visual model
  (:class:`~grasp_intent_ros.scene.geometry.ArmModel`);
- ``/ghost``: a translucent MICO at the newest plan's ``grasp/joint_targets``;
- ``/object``: the active model's body at the object's pose (:attr:`SceneState.object_pose`), and the table
  it stands on (:func:`~grasp_intent_ros.scene.geometry.table_shape`);
- ``/grasp``: the planned grasp frame (``grasp/pose``) and the three fingers closed as planned
  (:func:`~grasp_intent_ros.mico.frames.finger_segments`);
- ``/twist``: the operator's (blue) and the blended (orange) linear velocity from the live hand, 1 m/s
  drawn as :data:`TWIST_SCALE` m;
- the side panel: :func:`~grasp_intent_ros.scene.panel.panel_html`.

A scene of several objects (an :class:`~grasp_intent_ros.scene.state.ObjectsState`) has the arm once, and per
object ``/objects/<name>/object`` and ``/objects/<name>/grasp`` as above, from its chain's state, with the
object's name written above it; no planned arm (``/ghost`` stays hidden): which chain's plan the arm would
follow is not decided (docs/several_objects.md). Each chain is drawn on its own: one that cannot be drawn
leaves the others drawn.

:meth:`ScenePage.show` sends only what changed since the last call, in one batch. It is called from one
thread at a time (the caller's renderer); viser serves every browser from its own threads and sends a
browser that connects the whole current scene. viser's share button, which would open a tunnel from its
public relay to the page, is hidden and its request refused: the page is served on ``host`` alone.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

try:
    import viser
except ModuleNotFoundError as exc:  # the optional extra
    raise ModuleNotFoundError(f"the viewer needs viser ({exc}): pip install 'grasp_intent_ros[viewer]'",
                              name=exc.name) from None

from ..errors import KinematicsError
from ..mico.frames import finger_segments, matrix_to_pose
from .geometry import ArmModel, Shape, body_shapes, table_shape
from .panel import panel_html
from .state import ObjectsState, SceneState

__all__ = ['ScenePage', 'TWIST_SCALE', 'DEFAULT_HOST']

DEFAULT_HOST = '127.0.0.1'
"""Address the page is served on unless told otherwise: this machine only."""
TWIST_SCALE = 0.5
"""Length (m) of the drawn arrow of a 1 m/s linear velocity."""
_GHOST_RGB = (80, 200, 120)
_GHOST_OPACITY = 0.35
_FINGER_RGB = (240, 140, 30)
_TWIST_RGB = {'operator': (60, 110, 230), 'assisted': (240, 140, 30)}
_LABEL_HEIGHT = 0.2
"""Height (m) above the object frame of an object's name in a scene of several objects."""


def _rgb(rgba: tuple[float, float, float, float]) -> tuple[int, int, int]:
    return int(255 * rgba[0]), int(255 * rgba[1]), int(255 * rgba[2])


def _pose(base_T: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(position, wxyz) of a 4x4 transform, as viser takes them."""
    position, xyzw = matrix_to_pose(base_T)
    return position, np.roll(xyzw, 1)


def _same(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is b
    return bool(np.array_equal(a, b))


def _add_shape(scene: Any, name: str, shape: Shape, rgb: tuple[int, int, int], opacity: float | None) -> Any:
    """A hidden viser box or cylinder of ``shape``, at its pose."""
    position, wxyz = _pose(shape.base_T_shape)
    if shape.kind == 'cylinder':
        return scene.add_cylinder(name, radius=shape.size[0], height=shape.size[2], color=rgb, opacity=opacity,
                                  position=position, wxyz=wxyz, visible=False, radial_segments=24)
    return scene.add_box(name, color=rgb, dimensions=shape.size, opacity=opacity, position=position,
                         wxyz=wxyz, visible=False)


def _pose_shapes(handles: list[Any], shapes: list[Shape]) -> None:
    for handle, shape in zip(handles, shapes):
        handle.position, handle.wxyz = _pose(shape.base_T_shape)
        handle.visible = True


class _ChainDrawing:
    """One chain's object (its body, its table), its grasp frame and fingers, under ``prefix``; ``label`` above it.

    :meth:`show` draws what changed since the last state it drew completely.
    """

    def __init__(self, server: Any, prefix: str, label: str = '') -> None:
        self._server, self._prefix = server, prefix
        scene = server.scene
        self._grasp = scene.add_frame(f'{prefix}/grasp', axes_length=0.06, axes_radius=0.003, visible=False)
        self._fingers: Any = None
        self._body: list[Any] = []
        table = table_shape(np.eye(4))
        self._table = _add_shape(scene, f'{prefix}/object/table', table, _rgb(table.rgba), table.rgba[3])
        self._label = scene.add_label(f'{prefix}/label', label, visible=False) if label else None
        self._body_key: tuple[str, str] | None = None
        self._body_pose: NDArray[np.float64] | None = None
        self._shown = SceneState()

    def show(self, state: SceneState) -> None:
        """Draw ``state``; KinematicsError for what cannot be drawn (the next call tries again)."""
        self._show_object(state)
        if not (_same(state.base_T_ee, self._shown.base_T_ee) and _same(state.x, self._shown.x)):
            self._show_grasp(state)
        self._shown = state

    def _show_object(self, state: SceneState) -> None:
        model, pose = state.model, state.object_pose
        body = None if model is None else model.model.body
        key = None if model is None else (model.name, model.sha256)
        if key != self._body_key:
            for handle in self._body:
                handle.remove()
            self._body_key, self._body_pose = key, None
            self._body = [] if body is None else [
                _add_shape(self._server.scene, f'{self._prefix}/object/{s.name}', s, _rgb(s.rgba), s.rgba[3])
                for s in body_shapes(body, np.eye(4))]
        if body is not None and pose is not None and not _same(pose, self._body_pose):
            _pose_shapes([*self._body, self._table], [*body_shapes(body, pose), table_shape(pose)])
            if self._label is not None:
                self._label.position = pose[:3, 3] + (0.0, 0.0, _LABEL_HEIGHT)
                self._label.visible = True
            self._body_pose = pose

    def _show_grasp(self, state: SceneState) -> None:
        if state.base_T_ee is None:
            return
        self._grasp.position, self._grasp.wxyz = _pose(state.base_T_ee)
        self._grasp.visible = True
        closures = state.fingers_target if state.fingers_target is not None else \
            state.x[-3:] if state.x is not None else None
        if closures is None:
            return
        segments = finger_segments(closures)
        points = np.concatenate([segments[:, :1], segments[:, 1:]], axis=1).astype(np.float32)
        if self._fingers is not None:
            self._fingers.remove()
        self._fingers = self._server.scene.add_line_segments(f'{self._prefix}/grasp/fingers', points, _FINGER_RGB,
                                                             thickness=0.006)


class ScenePage:
    """A viser server showing the scene; bound to ``host`` (default :data:`DEFAULT_HOST`) and ``port``.

    Parameters
    ----------
    arm : ArmModel
    host : str
    port : int
        0 picks a free port. viser moves to the next free port when ``port`` is taken: :attr:`port` is the
        one served.
    title : str
        The panel's title.

    Attributes
    ----------
    server : viser.ViserServer
    """

    def __init__(self, arm: ArmModel, *, host: str = DEFAULT_HOST, port: int = 8080, title: str = '') -> None:
        # a browser that opens a connection and drops it before the handshake (a preconnect, a closed tab) is
        # routine: websockets logs it as an error with a traceback, which would read as the process failing
        logging.getLogger('websockets').setLevel(logging.CRITICAL)
        self.server = viser.ViserServer(host=host, port=port, label=title or None, verbose=False)
        # viser's share button asks its public relay for a tunnel to this page: never (this machine only)
        self.server.gui.configure_theme(show_share_button=False)
        self.server.request_share_url = self._refuse_share_url  # type: ignore[method-assign]
        self._arm = arm
        scene = self.server.scene
        scene.set_up_direction('+z')
        scene.add_grid('/floor', width=1.6, height=1.6, cell_size=0.1, position=(0.3, 0.0, 0.0))
        scene.add_frame('/base', axes_length=0.1, axes_radius=0.004)
        self.server.initial_camera.fov = math.radians(40.0)
        self.server.initial_camera.position = (1.1, -1.2, 0.75)
        self.server.initial_camera.look_at = (0.2, -0.2, 0.2)
        shapes = arm.shapes(np.zeros(6))
        self._live = [_add_shape(scene, f'/arm/{s.name}', s, _rgb(s.rgba), None) for s in shapes]
        self._ghost = [_add_shape(scene, f'/ghost/{s.name}', s, _GHOST_RGB, _GHOST_OPACITY) for s in shapes]
        self._chains: dict[str, _ChainDrawing] = {}
        self._twists: dict[str, Any] = {}
        self._panel = self.server.gui.add_html(panel_html(SceneState()))
        self._shown = SceneState()  # the arm's and the planned arm's
        self._shown_panel: tuple[SceneState | ObjectsState, str] | None = None

    @staticmethod
    def _refuse_share_url(verbose: bool = True) -> None:
        """What a browser's request for a public share URL gets: none (the page stays on ``host``)."""
        logging.getLogger(__name__).warning('a browser asked for a public share URL of the page: refused')

    @property
    def port(self) -> int:
        """The port served."""
        return int(self.server.get_port())

    @property
    def clients(self) -> int:
        """Browsers connected now."""
        return len(self.server.get_clients())

    def show(self, state: SceneState | ObjectsState, *, time_text: str = '') -> None:
        """Draw ``state``: what changed since the last call, in one batch.

        Raises
        ------
        KinematicsError
            For joint angles or poses that cannot be drawn (non-finite), naming the objects whose chains cannot
            be drawn; what was drawn before stays, and every other chain is drawn.
        """
        if isinstance(state, ObjectsState):
            arm, ghost = state.arm, None
            chains = {name: (f'/objects/{name}', chain) for name, chain in state.chains.items()}
        else:
            arm, ghost, chains = state, state, {'': ('', state)}
        old = self._shown
        failed: list[str] = []
        with self.server.atomic():
            if not (_same(arm.q_live, old.q_live) and _same(arm.fingers_live, old.fingers_live)) \
                    and arm.q_live is not None:
                _pose_shapes(self._live, self._arm.shapes(arm.q_live, arm.fingers_live))
            if ghost is not None and ghost.q_target is not None and \
                    not (_same(ghost.q_target, old.q_target) and _same(ghost.fingers_target, old.fingers_target)):
                _pose_shapes(self._ghost, self._arm.shapes(ghost.q_target, ghost.fingers_target))
            for name, (prefix, chain) in chains.items():
                if name not in self._chains:
                    self._chains[name] = _ChainDrawing(self.server, prefix, name)
                try:
                    self._chains[name].show(chain)
                except KinematicsError as exc:
                    failed.append(f'{name or "the object"}: {exc}')
            self._show_twists(arm, old)
            if self._shown_panel is None or state is not self._shown_panel[0] or time_text != self._shown_panel[1]:
                self._panel.content = panel_html(state, time_text=time_text)
        self._shown = replace(arm, q_target=None if ghost is None else ghost.q_target,
                              fingers_target=None if ghost is None else ghost.fingers_target)
        self._shown_panel = (state, time_text)
        if failed:
            raise KinematicsError(f'cannot draw {"; ".join(failed)}')

    def _show_twists(self, state: SceneState, old: SceneState) -> None:
        base_T_ee = None if state.q_live is None else self._arm.ee_pose(state.q_live)
        for name, twist, before in (('operator', state.operator_twist, old.operator_twist),
                                    ('assisted', state.assistance_twist, old.assistance_twist)):
            if twist is None or base_T_ee is None or (_same(twist, before) and _same(state.q_live, old.q_live)):
                continue
            origin = base_T_ee[:3, 3]
            points = np.array([[origin, origin + TWIST_SCALE * twist[:3]]], dtype=np.float32)
            if name in self._twists:
                self._twists[name].remove()
            self._twists[name] = self.server.scene.add_line_segments(f'/twist/{name}', points, _TWIST_RGB[name],
                                                                     thickness=0.008)

    def on_client(self, connect: Callable[[], None], disconnect: Callable[[], None]) -> None:
        """Call ``connect()`` / ``disconnect()`` (in viser's threads) as browsers come and go."""
        self.server.on_client_connect(lambda _client: connect())
        self.server.on_client_disconnect(lambda _client: disconnect())

    def stop(self) -> None:
        """Stop serving (closes every browser's connection)."""
        self.server.stop()
