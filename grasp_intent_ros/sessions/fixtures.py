"""The session fixtures in bags/: recorded from real runs of the node suite, replayed by the tests.

Two kinds, one recording machinery (:func:`recording`, :func:`compact_into`):

- **Input by input** (:data:`SESSIONS`, :func:`record`, :func:`main`; ``scripts/record_sessions.py`` calls
  :func:`main`). For each session: start the three nodes as ``python -m`` processes
  (:class:`grasp_intent_ros.launch.suite.NodeSuite`, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ROS_DOMAIN_ID
  from the environment, else derived from the pid), record with the in-process
  :class:`grasp_intent_ros.nodes.recorder.Recorder` (own executor and thread), drive the inputs one at a time,
  each sent once the previous one was answered and the recorder has written the answer, stop the nodes (by
  PID), then compact the bag (:func:`grasp_intent_ros.sessions.pairing.compact_session`: of /diagnostics
  only the rejections are kept) into ``<out>/<name>``, replacing the previous one.

  Every input declares the answer it must get ('v', 'plan', 'clarification', 'rejection', 'model' or
  none); a different answer stops the recording with what arrived instead (:class:`RecordingError`).
  Finally the bag is read back (:func:`grasp_intent_ros.sessions.pairing.load_paired_session`) and must pair
  into exactly the inputs sent, each with the outputs the driver saw live, equal within the replay
  tolerances (else it is recorded again, up to :data:`ATTEMPTS` times: see :class:`PairingError`).
- **Closed loop** (bags/shared_control_cup, bags/shared_control_cup_estimated): a scripted operator drives
  the five nodes; ``benchmarks/bench_shared_control.py --record``, where that operator lives, records it
  with :func:`recording` and :func:`compact_into`.

Talks ROS (the recorder is a node; the suite's nodes are processes): not part of the ROS-free sessions.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import shutil
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from ..launch.suite import NodeSuite, domain_id_from_environment, use_loopback_discovery
from ..mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q
from ..nodes.recorder import Recorder
from ..wire.topics import DIAGNOSTICS, MODEL_ACTIVE, PLAN_TOPICS
from .compare import compare_step, summarize
from .outputs import Joints, Output, Undecodable
from .pairing import Step, compact_session, load_paired_session
from .replay_client import SUITE_SETTLE_S, SessionClient
from .replayers import await_answer

RECORDED = ('intent/w', 'object/pose', 'joint_states', 'model/active', 'intent/v', 'intent/clarification',
            *PLAN_TOPICS, DIAGNOSTICS)
"""Topics recorded: inputs, the model, the compared outputs, diagnostics (compacted to rejections).
Markers, model/ambiguity and model/posterior are left out to keep the bags small."""
ANSWERS: dict[str, tuple[str, ...]] = {
    'v': ('intent/v',), 'clarification': ('intent/clarification',), 'plan': PLAN_TOPICS,
    'rejection': (DIAGNOSTICS,), 'model': (MODEL_ACTIVE,)}
"""Answer kinds -> the output topics (one message each) that make them up."""
ANSWER_TIMEOUT = 30.0
STARTUP_TIMEOUT = 60.0
ATTEMPTS = 3
"""Recordings of one session before giving up on a clean pairing (see :class:`PairingError`)."""
GAP = 0.05
"""Seconds between an answer written to the bag and the next input (stragglers land before it)."""


# ------------------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Send:
    """One input and the answer it must get.

    ``topic``: 'intent/w', 'object/pose', 'joint_states', or 'model' (then ``message`` is the model name);
    ``message`` may be a callable of the driver's latest outputs (e.g. joint states = the last targets).
    """

    topic: str
    message: Any
    expect: tuple[str, ...]


def w(*values: float, layout: int | None = None) -> Float64MultiArray:
    """intent/w; ``layout`` adds one dimension of that size (a wrong size makes a malformed layout)."""
    msg = Float64MultiArray(data=[float(v) for v in values])
    if layout is not None:
        msg.layout.dim.append(MultiArrayDimension(label='', size=layout, stride=layout))
    return msg


def pose(x: float, y: float, z: float, yaw: float = 0.0, *, q: Sequence[float] | None = None,
         frame_id: str = BASE_FRAME) -> PoseStamped:
    """object/pose: object frame at (x, y, z) m in ``frame_id``, turned by ``yaw`` about +z (or quaternion q)."""
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x, y, z
    qx, qy, qz, qw = q if q is not None else (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w = qx, qy, qz, qw
    return msg


def joints(positions: Iterable[float], names: Sequence[str] = ARM_JOINTS) -> JointState:
    return JointState(name=list(names), position=[float(p) for p in positions])


def follow_last_targets(outputs: Sequence[Output]) -> JointState:
    """The arm reached the last planned grasp: joint_states = the last grasp/joint_targets."""
    last = next(o.value for o in reversed(outputs) if o.topic == 'grasp/joint_targets')
    assert isinstance(last, Joints)
    return joints(last.positions, last.names)


PLAN = ('v', 'plan')
# The cup stands with its handle towards the arm (the planner's default pose); yaw turns it about +z.
CUP_HANDLE_TO_ARM = math.pi
SESSIONS: dict[str, tuple[str, list[Send]]] = {
    # The paper's intent cases (Tables II/III: one, two, three likely tasks; Table IV's (0.9, 0.1, 0.9)),
    # and the remaining single/double-task cases, on the cup 7-zone model.
    'cup_paper_cases': ('cup_7zone', [
        Send('joint_states', joints(HOME_Q), ()),
        Send('intent/w', w(0.9, 0.1, 0.1), PLAN),
        Send('intent/w', w(0.9, 0.9, 0.1), PLAN),
        Send('intent/w', w(0.9, 0.9, 0.9), PLAN),
        Send('intent/w', w(0.9, 0.1, 0.9), PLAN),
        Send('intent/w', w(0.1, 0.9, 0.1), PLAN),
        Send('intent/w', w(0.1, 0.1, 0.9), PLAN),
        Send('intent/w', w(0.1, 0.9, 0.9), PLAN),
    ]),
    # Table IV/V: the same ambiguous intent on the 7, 5 and 4-zone models, switched at run time
    # (each switch replans the current v).
    'model_ambiguity': ('cup_7zone', [
        Send('joint_states', joints(HOME_Q), ()),
        Send('intent/w', w(0.9, 0.1, 0.9), PLAN),
        Send('model', 'cup_5zone', ('model', 'plan')),
        Send('model', 'cup_4zone', ('model', 'plan')),
        Send('intent/w', w(0.9, 0.1, 0.9), PLAN),
    ]),
    # Table VI's object: a flashlight lying on the table, the paper's cases.
    'flashlight': ('flashlight_7zone', [
        Send('object/pose', pose(0.35, -0.25, 0.0, yaw=math.pi), ()),  # the body's -y side towards the arm
        Send('joint_states', joints(HOME_Q), ()),
        Send('intent/w', w(0.9, 0.1, 0.1), PLAN),
        Send('intent/w', w(0.1, 0.9, 0.1), PLAN),
        Send('intent/w', w(0.1, 0.1, 0.9), PLAN),
        Send('intent/w', w(0.9, 0.9, 0.1), PLAN),
        Send('intent/w', w(0.9, 0.1, 0.9), PLAN),
    ]),
    # Every kind of bad input, and a clarification, between valid ones: each bad input gets a WARN
    # rejection and nothing else, and the chain keeps serving.
    'bad_inputs': ('cup_7zone', [
        Send('intent/w', w(0.9, 0.9, 0.1), PLAN),
        Send('intent/w', w(0.5, math.nan, 0.5), ('rejection',)),
        Send('intent/w', w(0.9, math.inf, 0.1), ('rejection',)),
        Send('intent/w', w(0.9, 0.9), ('rejection',)),
        Send('intent/w', w(1.2, 0.5, 0.5), ('rejection',)),
        Send('intent/w', w(), ('rejection',)),
        Send('intent/w', w(*[0.5] * 11), ('rejection',)),
        Send('intent/w', w(0.9, 0.9, 0.1, layout=5), ('rejection',)),
        Send('intent/w', w(0.1, 0.1, 0.1), ('clarification',)),
        Send('intent/w', w(0.9, 0.1, 0.1), PLAN),
        Send('object/pose', pose(0.3, -0.3, 0.0, q=(0.0, 0.0, 0.9, 0.0)), ('rejection',)),
        Send('object/pose', pose(0.3, -0.3, 0.0, CUP_HANDLE_TO_ARM, frame_id='world'), ('rejection',)),
        Send('object/pose', pose(0.3, math.nan, 0.0, CUP_HANDLE_TO_ARM), ('rejection',)),
        Send('joint_states', JointState(name=list(ARM_JOINTS), position=[0.0] * 5), ('rejection',)),
        Send('joint_states', joints([*HOME_Q[:5], math.nan]), ('rejection',)),
        Send('intent/w', w(0.1, 0.9, 0.9), PLAN),
    ]),
    # The object moves between plans; after each plan the arm reaches the planned joint targets
    # (joint_states), which seed the next IK. At the last pose (turned 0.6 rad) the arm reaches few of the
    # usage + handover demonstrations (2 of 80 from home), none among the first 32 candidates a plan offers to
    # IK: the rest of the best tier is offered, and one of them is planned.
    'moving_object': ('cup_7zone', [
        Send('joint_states', joints(HOME_Q), ()),
        Send('intent/w', w(0.9, 0.9, 0.1), PLAN),
        *[send for k in range(5) for send in (
            Send('joint_states', follow_last_targets, ()),
            Send('object/pose', pose(0.28 + 0.03 * k, -0.34 + 0.05 * k, 0.0, CUP_HANDLE_TO_ARM - 0.15 * k), ('plan',)),
        )],
        Send('intent/w', w(0.9, 0.1, 0.9), PLAN),
    ]),
}


# ------------------------------------------------------------------------------------- recording
@contextlib.contextmanager
def recording(raw_bag: Path, topics: Iterable[str], context: Context, *,
              discovery_period: float) -> Iterator[Recorder]:
    """A :class:`~grasp_intent_ros.nodes.recorder.Recorder` into ``raw_bag``, spun on an executor and thread of its own.

    Its own executor, idle in its wait while an input goes out, takes (and timestamps) the input in a wait
    of its own, before the answer, which comes from another process, can be ready. (In one executor shared
    with the driver, an input and a fast answer such as a rejection can become ready in the same wait, and
    then the executor takes them in subscription order, /diagnostics first.) On exit the executor is shut
    down (before ``context`` may be), the recorder's summary printed and the bag closed.
    """
    executor = SingleThreadedExecutor(context=context)
    recorder = Recorder(raw_bag, topics=topics, discovery_period=discovery_period, context=context)
    thread = threading.Thread(target=executor.spin, name='recorder', daemon=True)
    try:
        executor.add_node(recorder)
        thread.start()
        yield recorder
    finally:
        executor.shutdown()
        if thread.ident is not None:
            thread.join()
        print(recorder.summary())
        recorder.destroy_node()  # closes the bag


def compact_into(raw_bag: Path, out: Path, *, keep_components: Iterable[str] = ()) -> tuple[dict[str, int], int]:
    """Compact ``raw_bag`` into the fixture ``out``, replacing it (:func:`~.pairing.compact_session`).

    Returns
    -------
    (messages written per topic, the fixture's size in bytes)
    """
    if out.exists():
        shutil.rmtree(out)
    counts = compact_session(raw_bag, out, keep_components=keep_components)
    return counts, sum(f.stat().st_size for f in out.iterdir())


# ------------------------------------------------------------------------------------- driver
class RecordingError(RuntimeError):
    """A session could not be recorded as declared."""


class PairingError(RecordingError):
    """The bag does not pair into the inputs and answers seen live.

    The recorder took an answer before its input (both ready in one wait of its executor; it stamps messages when
    its callback runs). Rare; the session is recorded again.
    """


class Driver:
    """Drives one recording: spins the client's executor here; the recorder spins in its own thread."""

    def __init__(self, client: SessionClient, recorder: Recorder, executor: SingleThreadedExecutor,
                 suite: NodeSuite) -> None:
        self.client, self.recorder, self.executor, self.suite = client, recorder, executor, suite
        self.observed: list[list[Output]] = []
        """Per input sent, the outputs the client saw for it."""
        self._inputs_sent: Counter[str] = Counter()

    def spin(self) -> None:
        self.executor.spin_once(timeout_sec=0.005)
        if problem := self.suite.died():
            raise RecordingError(problem)

    def spin_until(self, predicate: Callable[[], bool], timeout: float, what: Callable[[], str]) -> None:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() >= deadline:
                raise RecordingError(f'timed out after {timeout:g} s waiting for {what()}')
            self.spin()

    def written(self, topic: str) -> int:
        """Messages the recorder has written on ``topic`` (relative or absolute name)."""
        return self.recorder.counts.get(topic if topic.startswith('/') else f'/{topic}', 0)

    def wait_ready(self) -> None:
        def missing() -> list[str]:
            return self.client.missing(need_parameters=True)

        self.spin_until(lambda: not missing() and self.client.settled(SUITE_SETTLE_S), STARTUP_TIMEOUT,
                        lambda: 'the suite: ' + ('; '.join(missing()) or 'nodes still appearing'))
        wanted = {t if t.startswith('/') else f'/{t}' for t in RECORDED}
        self.spin_until(lambda: wanted <= set(self.recorder.recorded_topics), STARTUP_TIMEOUT,
                        lambda: f'the recorder to subscribe to {sorted(wanted - set(self.recorder.recorded_topics))}')
        # The recorder has the latched model and has been receiving from every /diagnostics publisher
        # for a while (its other subscriptions were made in the same discovery passes).
        base, publishers = self.written(DIAGNOSTICS), len(self.client.statuses)
        self.spin_until(lambda: self.written(DIAGNOSTICS) >= base + 2 * publishers
                        and self.written(MODEL_ACTIVE) >= 1, STARTUP_TIMEOUT, lambda: 'the recorder')

    def send(self, index: int, send: Send) -> None:
        """Send one input, wait for the declared answer, then for the recorder to have written it."""
        mark = len(self.client.outputs)
        diagnostics = (self.written(DIAGNOSTICS), self.client.diagnostics_received)
        future = None
        if send.topic == 'model':
            future = self.client.set_model(send.message)
        else:
            message = send.message(self.client.outputs) if callable(send.message) else send.message
            self.client.publish(send.topic, message)
            self._inputs_sent[send.topic] += 1
        expected = tuple(Output(topic, 0, Undecodable('expected')) for kind in send.expect for topic in ANSWERS[kind])
        step = Step(index, send.topic, 0, '', b'', expected, send.topic)
        live, problem = await_answer(self.spin, self.client.outputs, mark, step, future=future,
                                     timeout_s=ANSWER_TIMEOUT, quiet_s=0.3)
        got, want = Counter(o.topic for o in live), Counter(o.topic for o in expected)
        if problem or got != want:
            raise RecordingError(f'input #{index} ({send.topic} {send.message if send.topic == "model" else ""}): '
                                 f'{problem or "unexpected answer"}: expected {dict(want)}, got {dict(got)}: '
                                 + '; '.join(f'{o.topic}: {summarize(o.value)}' for o in live))
        totals = Counter(o.topic for o in self.client.outputs if o.topic != DIAGNOSTICS)
        self.spin_until(
            lambda: all(self.written(t) >= n for t, n in totals.items())
            and all(self.written(t) >= n for t, n in self._inputs_sent.items())
            and self.written(DIAGNOSTICS) - diagnostics[0] >= self.client.diagnostics_received - diagnostics[1],
            ANSWER_TIMEOUT, lambda: f'the recorder to write the answer to input #{index}')
        until = time.monotonic() + GAP
        self.spin_until(lambda: time.monotonic() >= until, GAP + 1.0, lambda: 'the gap')
        self.observed.append(list(self.client.outputs[mark:]))


def record(name: str, model: str, sends: list[Send], out_dir: Path, models_dir: Path | None,
           domain_id: int) -> Path:
    """Record one session into ``out_dir/name`` (replaced); returns the bag path.

    The recorder spins in its own executor and thread (:func:`recording`).

    Raises
    ------
    RecordingError
        If the suite does not start, an input does not get its declared answer, or a node did not stop.
    PairingError
        If the bag does not pair into the inputs sent and the answers seen live.
    """
    work = Path(tempfile.mkdtemp(prefix=f'record_{name}_'))
    raw_bag = work / 'raw'
    suite = NodeSuite(domain_id, log_dir=work / 'logs')
    suite.start_nodes(model=model, models_dir=models_dir)
    context = Context()
    rclpy.init(context=context, domain_id=domain_id, args=[])
    executor = SingleThreadedExecutor(context=context)
    client: SessionClient | None = None
    driver: Driver | None = None
    try:
        client = SessionClient(context=context, node_name='session_driver')
        executor.add_node(client)
        with recording(raw_bag, RECORDED, context, discovery_period=1.0) as recorder:
            driver = Driver(client, recorder, executor, suite)
            driver.wait_ready()
            for index, send in enumerate(sends, start=1):
                driver.send(index, send)
    finally:
        executor.shutdown()
        if client is not None:
            Node.destroy_node(client)  # rclpy's method (mypy takes untyped calls of rclpy's classes only)
        rclpy.try_shutdown(context=context)
        problems = suite.stop()
    if problems:
        raise RecordingError('; '.join(problems))
    target = out_dir / name
    counts, size = compact_into(raw_bag, target)
    shutil.rmtree(work)
    assert driver is not None  # every input was sent (else the recording raised)
    verify(target, sends, driver.observed)
    print(f'{target}: {len(sends)} inputs, {sum(counts.values())} messages, {size / 1024:.1f} KiB '
          f'({", ".join(f"{t} {n}" for t, n in sorted(counts.items()))})')
    return target


def verify(bag: Path, sends: list[Send], observed: list[list[Output]]) -> None:
    """The bag pairs into exactly the inputs sent, each with what the driver saw live."""
    session = load_paired_session(bag)
    if len(session.steps) != len(sends):
        raise PairingError(f'{bag}: {len(session.steps)} steps paired, {len(sends)} inputs sent')
    for step, send, live in zip(session.steps, sends, observed):
        topic = MODEL_ACTIVE if send.topic == 'model' else send.topic
        if step.topic != topic:
            raise PairingError(f'{bag}: input #{step.index} is {step.topic}, {topic} was sent')
        diffs = [d for d in compare_step(step, live) if d.fatal]
        if diffs:
            raise PairingError(f'{bag}: the bag does not pair as recorded live: ' + '; '.join(map(str, diffs[:5])))


def main(argv: Sequence[str] | None, *, bags: Path) -> int:
    """Record the input-by-input sessions (all, or ``--only``) into ``bags`` (or ``--out``); the exit status."""
    parser = argparse.ArgumentParser(prog='record_sessions', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--out', type=Path, default=bags, help=f'where the bags go (default {bags})')
    parser.add_argument('--only', nargs='+', choices=sorted(SESSIONS), help='record only these sessions')
    parser.add_argument('--models-dir', type=Path, default=None, help='models (default config/models)')
    args = parser.parse_args(argv)
    use_loopback_discovery()  # before any ROS context exists
    sys.setswitchinterval(5e-4)  # the recorder thread gets the GIL soon after its wait returns
    domain_id = domain_id_from_environment()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.only or SESSIONS:
        model, sends = SESSIONS[name]
        for attempt in range(1, ATTEMPTS + 1):
            try:
                record(name, model, sends, args.out, args.models_dir, domain_id)
                break
            except PairingError as exc:
                print(f'record_sessions: {name}, attempt {attempt} of {ATTEMPTS}: {exc}', file=sys.stderr)
            except RecordingError as exc:
                print(f'record_sessions: {name}: {exc}', file=sys.stderr)
                return 1
        else:
            return 1
    return 0

