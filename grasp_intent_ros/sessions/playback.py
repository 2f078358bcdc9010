"""A recorded session in the viewer's page, with a time slider.

Run: ``python -m grasp_intent_ros playback BAG [--port 8080] [--host 127.0.0.1]``, then open the URL it
prints. Needs the ``viewer`` extra (viser); no ROS graph: the bag is read with :mod:`grasp_intent_ros.sessions.bag`.

The page is the live viewer's (:class:`~grasp_intent_ros.scene.page.ScenePage`) plus a slider over the
session's time (receive time, s from the first message) and buttons that jump to the previous or next plan
(:attr:`Timeline.plans`). At a time t the page shows the state after every message received up to t
(:class:`Timeline`, built once with :func:`grasp_intent_ros.scene.state.apply`), so each grasp is seen with
the intent, posterior and arm of its moment. A message that cannot be read is skipped and counted (shown on
the page). Topics are found in the session's namespace, or, in a bag of a scene of several objects
(:func:`~grasp_intent_ros.sessions.scenes.detect_scene`), in each object's chain and the arm's namespace: the page
then shows every object as the live viewer does (an :class:`~grasp_intent_ros.scene.state.ObjectsState`).

Exit codes: 0 stopped by SIGINT/SIGTERM; 2 the bag is missing or unreadable, or the page cannot be served.
"""

from __future__ import annotations

import argparse
import bisect
import signal
import sys
import threading
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType

from ..errors import GraspIntentError
from ..latest_only import LatestOnlyWorker
from ..scene.geometry import ArmModel
from ..scene.page import DEFAULT_HOST, ScenePage
from ..scene.state import ObjectsState, SceneState, apply_to, followed_topics
from ..wire.arrays import Stamp
from .bag import BagError, BagMessage, read_messages, topics_info
from .outputs import SessionError
from .scenes import Scene, detect_scene

__all__ = ['Timeline', 'load_timeline', 'main']

SLIDER_STEP = 0.05
"""The time slider's step, s."""


@dataclass
class Timeline:
    """The viewer's state after each message of a session.

    Attributes
    ----------
    times : list of int
        Receive times (ns since the epoch), non-decreasing; ``states[i]`` is the state after the message of
        ``times[i]``.
    states : list of SceneState or ObjectsState
        One :class:`~grasp_intent_ros.scene.state.SceneState` each for a session of one chain, one
        :class:`~grasp_intent_ros.scene.state.ObjectsState` each for a scene of several objects.
    plans : list of int
        Receive times of the plans: when the last of a plan's pose, joint targets, features and posterior
        arrived (:attr:`~grasp_intent_ros.scene.state.SceneState.plan_stamp`), in any chain.
    unreadable : Counter
        Messages skipped, by topic.
    empty : SceneState or ObjectsState
        The state before the first message.
    """

    times: list[int] = field(default_factory=list)
    states: list[SceneState | ObjectsState] = field(default_factory=list)
    plans: list[int] = field(default_factory=list)
    unreadable: Counter[str] = field(default_factory=Counter)
    empty: SceneState | ObjectsState = field(default_factory=SceneState)

    @property
    def start(self) -> int:
        """The first receive time (ns); 0 for an empty session."""
        return self.times[0] if self.times else 0

    @property
    def duration(self) -> float:
        """Seconds from the first to the last message."""
        return (self.times[-1] - self.times[0]) * 1e-9 if self.times else 0.0

    def at(self, seconds: float) -> SceneState | ObjectsState:
        """The state after every message received up to ``seconds`` of session time (:attr:`empty` before the first)."""
        i = bisect.bisect_right(self.times, self.start + round(seconds * 1e9))
        return self.states[i - 1] if i else self.empty

    def plan_index(self, seconds: float) -> int:
        """How many plans were received up to ``seconds`` of session time."""
        return bisect.bisect_right(self.plans, self.start + round(seconds * 1e9))


class _Reader:
    """A session's topics as the viewer's (chain, relative topic), and the state after each of their messages."""

    def __init__(self, scene: Scene) -> None:
        paths = {} if scene.one_chain else {chain.rpartition('/')[2]: chain for chain in scene.chains}
        self.empty: SceneState | ObjectsState = ObjectsState.empty(list(paths), scene.namespace) if paths \
            else SceneState()

        def absolute(chain: str | None, topic: str) -> str:
            if chain is not None:
                return f'{paths[chain]}/{topic}'
            return topic if topic.startswith('/') else f'{scene.namespace}/{topic}'

        self.topics: dict[str, tuple[str | None, str]] = {
            absolute(chain, topic): (chain, topic) for chain, topic in followed_topics(list(paths))}

    def apply(self, state: SceneState | ObjectsState, message: BagMessage) -> SceneState | ObjectsState:
        chain, topic = self.topics[message.topic]
        return apply_to(state, chain, topic, message.decode())


def _plan_stamps(state: SceneState | ObjectsState) -> tuple[Stamp | None, ...]:
    """The stamp of each chain's newest complete plan."""
    chains = state.chains.values() if isinstance(state, ObjectsState) else (state,)
    return tuple(chain.plan_stamp for chain in chains)


def load_timeline(path: Path) -> Timeline:
    """Read a session bag, of one chain or of a scene of several objects, into a :class:`Timeline`.

    Raises
    ------
    BagError
        The bag is missing or cannot be read.
    SessionError
        It holds no session topic, or session topics in several namespaces that are not a scene
        (:func:`~grasp_intent_ros.sessions.scenes.detect_scene`).
    """
    names = topics_info(path)
    reader = _Reader(detect_scene(names))
    timeline = Timeline(empty=reader.empty)
    state = reader.empty
    plans = _plan_stamps(state)
    for message in read_messages(path, topics=[t for t in reader.topics if t in names]):
        try:
            state = reader.apply(state, message)
        except (GraspIntentError, BagError, AttributeError, TypeError) as exc:
            timeline.unreadable[f'{message.topic} ({type(exc).__name__})'] += 1
            continue
        timeline.times.append(message.timestamp_ns)
        timeline.states.append(state)
        newest = _plan_stamps(state)
        if any(stamp is not None and stamp != before for stamp, before in zip(newest, plans)):
            timeline.plans.append(message.timestamp_ns)
        plans = tuple(stamp if stamp is not None else before for stamp, before in zip(newest, plans))
    return timeline


class _Player:
    """The page, its slider and plan buttons; draws the slider's moment in a latest-only thread."""

    def __init__(self, timeline: Timeline, page: ScenePage, name: str) -> None:
        self.timeline, self.page, self.name = timeline, page, name
        gui = page.server.gui
        self.slider = gui.add_slider('session time (s)', min=0.0, max=max(timeline.duration, SLIDER_STEP),
                                     step=SLIDER_STEP, initial_value=0.0, order=-2.0)
        previous, following = gui.add_button('◀ previous plan', order=-1.5), gui.add_button('next plan ▶',
                                                                                             order=-1.0)
        self._drawer: LatestOnlyWorker[float] = LatestOnlyWorker(0.0, self._draw, name='playback_draw')
        self.slider.on_update(lambda _event: self.show(float(self.slider.value)))
        previous.on_click(lambda _event: self._jump(-1))
        following.on_click(lambda _event: self._jump(+1))

    def show(self, seconds: float) -> None:
        """Draw the moment ``seconds`` (in the drawing thread; a newer request replaces an undrawn one)."""
        self._drawer.update(lambda _: seconds)

    def _jump(self, direction: int) -> None:
        plans = [(t - self.timeline.start) * 1e-9 for t in self.timeline.plans]
        now = float(self.slider.value)
        targets = [t for t in plans if t > now + 1e-6] if direction > 0 else [t for t in plans if t < now - 1e-6]
        if targets:
            # its on_update draws it (viser declares the setter, which mypy does not see through the generic handle)
            self.slider.value = min(targets) if direction > 0 else max(targets)  # type: ignore[misc]

    def _draw(self, seconds: float) -> None:
        timeline = self.timeline
        text = (f'{self.name}: {seconds:.2f} s of {timeline.duration:.2f} s, plan {timeline.plan_index(seconds)} '
                f'of {len(timeline.plans)}')
        if timeline.unreadable:
            text += f'; {sum(timeline.unreadable.values())} unreadable messages skipped'
        try:
            self.page.show(timeline.at(seconds), time_text=text)
        except GraspIntentError as exc:  # a state that cannot be drawn: say so, keep serving
            print(f'playback: cannot draw {seconds:.2f} s: {exc}', file=sys.stderr)

    def stop(self) -> None:
        self._drawer.stop()


def _stop(stopped: threading.Event) -> None:
    def handler(signum: int, frame: FrameType | None) -> None:
        stopped.set()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (0 after SIGINT/SIGTERM, 2 for a bad bag or an unservable page)."""
    parser = argparse.ArgumentParser(description='A recorded session in the viewer\'s page, with a time slider.')
    parser.add_argument('bag', type=Path, help='rosbag2 directory (with metadata.yaml)')
    parser.add_argument('--host', default=DEFAULT_HOST, help='address served (default %(default)s: this machine)')
    parser.add_argument('--port', type=int, default=8080, help='TCP port (0: any free one; default %(default)s)')
    options = parser.parse_args(argv)
    try:
        timeline = load_timeline(options.bag)
    except (BagError, SessionError) as exc:
        print(f'playback: error: {options.bag}: {exc}', file=sys.stderr)
        return 2
    stopped = threading.Event()
    _stop(stopped)
    try:
        page = ScenePage(ArmModel(), host=options.host, port=options.port, title=f'session {options.bag.name}')
    except OSError as exc:
        print(f'playback: error: cannot serve on {options.host}:{options.port}: {exc}', file=sys.stderr)
        return 2
    player = _Player(timeline, page, options.bag.name)
    player.show(0.0)
    scene = timeline.empty
    objects = f' of the objects {", ".join(scene.chains)}' if isinstance(scene, ObjectsState) else ''
    print(f'playback: {len(timeline.times)} messages, {len(timeline.plans)} plans{objects} over '
          f'{timeline.duration:.1f} s on http://{options.host}:{page.port}', flush=True)
    try:
        stopped.wait()
    finally:
        player.stop()
        page.stop()
    return 0


if __name__ == '__main__':
    sys.exit(main())
