"""Closed-loop sessions: teleoperation recorded with the assistance and an arm in the loop (ROS-free).

A session is *closed-loop* when it holds operator twists (``operator/twist``). Its ``joint_states`` are then
the arm's answer to the blended twist, not inputs: a replay cannot publish them again without fighting the
live arm, and the blended twist depends on the arm, on the planner's grasps and on the time between
messages (the operator timeout, the acceleration limits), all on the wall clock. So a closed-loop session is
replayed as the operator lived it: its ``intent/w``, ``object/pose``, model switches and operator twists go
out at the recorded pace into a live suite with the assistance and an arm, and what is compared is the
*outcome*, which the loop itself makes robust to timing:

- the last grasp planned (v and w depend on nothing but the inputs, so it must be the recorded one, within
  the replay's pose tolerances);
- where the hand ends: within :data:`REACH_POS` and :data:`REACH_ROT` of that grasp when the recorded hand
  ended there (the benchmark's "reached");
- the arm's first joint state (the live arm must start where the recorded one did);
- the last w, within :data:`W_TOLERANCE` (exact when w is an input).

A session recorded with the intent estimator running (its status on ``/diagnostics``: :func:`estimated`) had
its w from the operator's motion: w is then an output, never sent. Such a session is replayed on the recorded
hand (:data:`ESTIMATED_REPLAYED`: the operator twists *and* the arm's joint states, at the recorded pace, into
the estimator, the interpreter and the planner, without the assistance and the arm; the recorded grasps, the
proposals the estimator took, into the estimator alone; joint states and grasps :data:`AHEAD_NS` early), and
the live estimator's last w is compared (the start too; the grasp and where the hand ends are reported, not
compared). The estimator pairs its inputs by their stamps, so that replay is deterministic
(:data:`W_TOLERANCE`). A live arm
would not do: the estimator's input is the hand, and the loop hand -> w -> plan -> assistance -> hand
amplifies the wall clock's millimetres into another goal (the last w of three live-arm replays of one
recording differed from it by 0.12-0.22). Nor is the last grasp a function of the last w alone: the planner
warm-starts from its previous plan, and which of the estimator's 25 w a second it planned is the wall
clock's choice, so for one w near (0.99, 0.99, 0.09) it ended on either of two grasps 7 mm and 0.42 rad
apart (the recording on one, three replays on the other, their last w within 0.006 of the recorded).

Times to reach the grasp and mean alpha are reported side by side, not compared: they are wall-clock figures.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..mico.frames import REACH_POS, REACH_ROT, offset, pose_to_matrix, reached
from ..mico.kinematics import ARM_JOINTS, MicoKinematics
from ..wire.diagnostics import ESTIMATOR_COMPONENT, KEY_GOALS
from ..wire.joint_states import JointStates
from ..wire.model_document import ModelHeader
from ..wire.topics import (
    ASSISTANCE_ALPHA,
    ASSISTANCE_TWIST,
    DIAGNOSTICS,
    GRASP_POSE,
    INTENT_PRIOR,
    INTENT_W,
    JOINT_STATES,
    MODEL_ACTIVE,
    MSGTYPES,
    OBJECT_POSE,
    OPERATOR_TWIST,
)
from .bag.reader import read_messages, topics_info
from .outputs import Pose, RawMessage, SessionError, decode, output_of
from .pairing import ModelSwitches, detect_namespace

__all__ = ['REACH_POS', 'REACH_ROT', 'REPLAYED', 'ESTIMATED_REPLAYED', 'AHEAD_TOPICS', 'AHEAD_NS', 'W_TOLERANCE',
           'Send', 'Trace', 'Outcome',
           'RECORDED_GRASP_POSE', 'ESTIMATOR_REMAPPING', 'RENAMED', 'ClosedLoopSession', 'offset', 'reached',
           'is_closed_loop', 'estimated', 'estimator_ready',
           'split_messages', 'ahead', 'load_closed_loop', 'Tracer', 'outcome', 'compare_outcomes', 'describe']

START_TOLERANCE: Final = 1e-3
"""Largest difference (rad) between the recorded and the live arm's first joint state."""
REPLAYED: Final = (INTENT_W, OBJECT_POSE, OPERATOR_TWIST)
"""Topics a closed-loop replay publishes again (and the model switches); ``joint_states`` is the arm's, and
``intent/w`` the estimator's in an estimated session."""
ESTIMATED_REPLAYED: Final = (OBJECT_POSE, OPERATOR_TWIST, JOINT_STATES, GRASP_POSE, INTENT_PRIOR)
"""What the replay of an estimated session publishes again (and the model switches): the estimator's inputs
(a classifier's w on ``intent/prior`` among them, when the session had one), the recorded grasps (the proposals
its operator was shown) on :data:`RECORDED_GRASP_POSE`."""
RECORDED_GRASP_POSE: Final = 'recorded/grasp/pose'
"""Where the replay of an estimated session sends the recorded grasps, and the live estimator, remapped
(:data:`ESTIMATOR_REMAPPING`), reads them: the live planner's grasps, planned on the wall clock's choice of w,
would make the estimate depend on it."""
AHEAD_TOPICS: Final = (JOINT_STATES, GRASP_POSE)
"""What the replay of an estimated session sends :data:`AHEAD_NS` before its recorded time."""
AHEAD_NS: Final = 200_000_000
"""How early (ns). The estimator takes each operator twist with the joint state and the grasp stamped at or
before it (:mod:`grasp_intent_ros.shared_control.stamped_inputs`), so those sent early change nothing but that
they are there when the twist is taken. Sent at the recorded pace, a grasp (received after its stamp by the
planning time, longer on a loaded machine) raced the twists stamped after it. The live trace's times are the
recorded ones (the lead added back). What was measured: docs/intent_estimation.md, the closed-loop bag."""
ESTIMATOR_REMAPPING: Final = f'{GRASP_POSE}:={RECORDED_GRASP_POSE}'
"""The live estimator's remapping in the replay of an estimated session."""
RENAMED: Final = {GRASP_POSE: RECORDED_GRASP_POSE}
"""Replayed topics sent under another name (only an estimated session's replay sends ``grasp/pose``)."""
W_TOLERANCE: Final = 0.002
"""Largest difference of any w_i between the recorded and the live last w. The replay itself adds nothing: the
estimator takes each operator twist with the joint state and the grasp stamped at or before it, all in the bag
and sent ahead (:data:`AHEAD_NS`), so its replays end on one w to the last bit. What remains is the recording's
own: its live estimator took the twists stamped just after a new grasp before that grasp arrived, which no bag
records (docs/intent_estimation.md, the closed-loop bag, says what it measured). A recording whose replay
misses this tolerance is recorded again."""


@dataclass(frozen=True)
class Send:
    """One message a closed-loop replay sends: ``lead_ns`` before ``t_ns`` (its recorded receive time), on ``topic``.

    ``topic`` is one of :data:`REPLAYED` (``cdr`` the serialized message) or ``model/active`` for a
    model switch (``model`` the name to activate, ``cdr`` empty).
    """

    t_ns: int
    topic: str
    cdr: bytes
    model: str | None = None
    lead_ns: int = 0


class Tracer:
    """Collects what a closed loop did, from recorded or live messages on the session's topics.

    Feed it with :meth:`add` (relative topic, receive time ns, CDR) and read :meth:`trace`. The arm is read from
    ``joint_states`` as the nodes read it (:class:`~grasp_intent_ros.wire.joint_states.JointStates` of the arm
    joints, on the receive times: each joint's latest position from whichever message named it last, the fingers
    and the arm's joints perhaps in separate messages): a message that names an arm joint while every arm joint is
    known and not stale adds the arm's reading at its receive time; a malformed one changes nothing.
    """

    def __init__(self) -> None:
        self._arm = JointStates(ARM_JOINTS)
        self._joints: list[tuple[int, NDArray[np.float64]]] = []
        self._grasps: list[tuple[int, NDArray[np.float64]]] = []
        self._alphas: list[tuple[int, float]] = []
        self._operator: list[int] = []
        self._blended: list[int] = []
        self._w: list[tuple[int, NDArray[np.float64]]] = []

    def restart(self) -> None:
        """Forget everything but the newest arm reading (the arm's state when a replay starts) and its joints."""
        self._joints[:-1] = []
        self._grasps.clear()
        self._alphas.clear()
        self._operator.clear()
        self._blended.clear()
        self._w.clear()

    def add(self, topic: str, t_ns: int, cdr: bytes) -> None:
        """Take one message; messages on other topics and undecodable ones are ignored."""
        if topic == JOINT_STATES:
            try:
                named = self._arm.add(decode(MSGTYPES[JOINT_STATES], cdr), t_ns * 1e-9)
            except (SessionError, GraspIntentError):
                return
            if named and (arm := self._arm.read()) is not None:
                self._joints.append((t_ns, arm.positions))
        elif topic == GRASP_POSE:
            value = output_of(topic, t_ns, cdr).value
            if isinstance(value, Pose):
                self._grasps.append((t_ns, pose_to_matrix(value.position, value.orientation)))
        elif topic == ASSISTANCE_ALPHA:
            try:
                self._alphas.append((t_ns, float(decode(MSGTYPES[ASSISTANCE_ALPHA], cdr).data)))
            except SessionError:
                pass
        elif topic == ASSISTANCE_TWIST:
            self._blended.append(t_ns)
        elif topic == OPERATOR_TWIST:
            self._operator.append(t_ns)
        elif topic == INTENT_W:
            try:
                w = np.asarray(decode(MSGTYPES[INTENT_W], cdr).data, dtype=np.float64)
            except SessionError:
                return
            self._w.append((t_ns, w))

    def trace(self) -> Trace:
        """What was collected so far."""
        return Trace(tuple(self._joints), tuple(self._grasps), tuple(self._alphas), tuple(self._blended),
                     tuple(self._operator), tuple(self._w))


@dataclass(frozen=True)
class Trace:
    """A closed loop's messages by receive time (ns): arm joints, grasps, alphas, blended and operator twists, w."""

    joints: tuple[tuple[int, NDArray[np.float64]], ...]
    grasps: tuple[tuple[int, NDArray[np.float64]], ...]
    alphas: tuple[tuple[int, float], ...]
    blended: tuple[int, ...]
    operator: tuple[int, ...]
    w: tuple[tuple[int, NDArray[np.float64]], ...] = ()


@dataclass(frozen=True)
class Outcome:
    """What a closed loop achieved.

    Attributes
    ----------
    final_grasp
        The last planned grasp (base_T_grasp), None without one.
    final_hand
        The hand's last pose (base_T_ee), None without a joint state.
    start_q
        The arm's first joint state (6,), None without one.
    reached_s
        Seconds from the first operator twist to the first joint state with the hand within
        :data:`REACH_POS` / :data:`REACH_ROT` of ``final_grasp``; None if it never got there.
    ends_at_grasp
        Whether the hand's last pose is within those tolerances of ``final_grasp``.
    alpha_mean
        Mean of the published alphas from the first operator twist on (nan without any).
    blended
        Number of blended twists from the first operator twist to the last.
    final_w
        The last w, shape (m,); None without one.
    """

    final_grasp: NDArray[np.float64] | None
    final_hand: NDArray[np.float64] | None
    start_q: NDArray[np.float64] | None
    reached_s: float | None
    ends_at_grasp: bool
    alpha_mean: float
    blended: int
    final_w: NDArray[np.float64] | None = None


def outcome(trace: Trace, kin: MicoKinematics) -> Outcome:
    """The :class:`Outcome` of a trace (forward kinematics by ``kin``)."""
    start_ns = trace.operator[0] if trace.operator else (trace.joints[0][0] if trace.joints else 0)
    end_ns = trace.operator[-1] if trace.operator else start_ns
    grasp = trace.grasps[-1][1] if trace.grasps else None
    hand = kin.fk(trace.joints[-1][1]) if trace.joints else None
    reached_s = None
    if grasp is not None:
        for t_ns, q in trace.joints:
            if t_ns >= start_ns and reached(kin.fk(q), grasp):
                reached_s = 1e-9 * (t_ns - start_ns)
                break
    alphas = [a for t, a in trace.alphas if t >= start_ns]
    return Outcome(grasp, hand, trace.joints[0][1] if trace.joints else None, reached_s,
                   grasp is not None and hand is not None and reached(hand, grasp),
                   float(np.mean(alphas)) if alphas else float('nan'),
                   sum(start_ns <= t <= end_ns for t in trace.blended), trace.w[-1][1] if trace.w else None)


def compare_outcomes(recorded: Outcome, live: Outcome, *, position_m: float = 1e-3,
                     rotation_rad: float = 1e-2, grasp: bool = True) -> list[str]:
    """What differs between a recorded and a live outcome, one line each ([] when they agree).

    The first joint state within :data:`START_TOLERANCE`; the last w within :data:`W_TOLERANCE`; with
    ``grasp``, the last grasp within ``position_m`` / ``rotation_rad`` (the replay's pose tolerances) and a
    live hand at that grasp when the recorded one ended there.
    """
    problems = []
    if recorded.start_q is not None and live.start_q is not None:
        gap = float(np.max(np.abs(recorded.start_q - live.start_q)))
        if gap > START_TOLERANCE:
            problems.append(f'the live arm started {gap:.3g} rad from the recorded start '
                            f'(tolerance {START_TOLERANCE:g}): start it where the recording did')
    if recorded.final_w is not None:
        if live.final_w is None or live.final_w.shape != recorded.final_w.shape:
            problems.append(f'last w: recorded {np.round(recorded.final_w, 3).tolist()}, live '
                            f'{None if live.final_w is None else np.round(live.final_w, 3).tolist()}')
        elif (gap := float(np.max(np.abs(live.final_w - recorded.final_w)))) > W_TOLERANCE:
            problems.append(f'last w: live {np.round(live.final_w, 3).tolist()}, recorded '
                            f'{np.round(recorded.final_w, 3).tolist()} ({gap:.3g} apart; tolerance {W_TOLERANCE:g})')
    if recorded.final_grasp is None or not grasp:
        return problems
    if live.final_grasp is None:
        return [*problems, 'no grasp was planned live']
    distance, angle = offset(recorded.final_grasp, live.final_grasp)
    if distance > position_m or angle > rotation_rad:
        problems.append(f'last grasp: live {distance * 1e3:.2f} mm and {angle:.3g} rad from the recorded one '
                        f'(tolerance {position_m * 1e3:g} mm, {rotation_rad:g} rad)')
    if recorded.ends_at_grasp and not live.ends_at_grasp:
        where = 'no joint state' if live.final_hand is None else '{:.1f} mm, {:.3f} rad away'.format(
            *np.multiply(offset(live.final_hand, live.final_grasp), (1e3, 1.0)))
        problems.append(f'the recorded hand ended at the grasp; the live one did not ({where}; tolerance '
                        f'{REACH_POS * 1e3:g} mm, {REACH_ROT:g} rad)')
    return problems


@dataclass(frozen=True)
class ClosedLoopSession:
    """A closed-loop session bag read for replay.

    Attributes
    ----------
    path, namespace, initial_model
        As :class:`~grasp_intent_ros.sessions.pairing.PairedSession`.
    sends
        What a replay sends, in recorded order.
    trace
        What the recorded loop did.
    estimated
        Whether w came from the intent estimator (:func:`estimated`): replayed on the recorded hand, w compared.
    """

    path: Path
    namespace: str
    initial_model: ModelHeader | None
    sends: tuple[Send, ...]
    trace: Trace
    estimated: bool = False

    @property
    def duration_s(self) -> float:
        """Time from the first to the last message sent (s)."""
        return 1e-9 * (self.sends[-1].t_ns - self.sends[0].t_ns) if self.sends else 0.0


def _relative(messages: Iterable[RawMessage], namespace: str) -> Iterable[tuple[str, RawMessage]]:
    prefix = f'{namespace}/'
    for msg in messages:
        if msg.topic.startswith(prefix):
            yield msg.topic[len(prefix):], msg


def is_closed_loop(path: str | os.PathLike[str], *, namespace: str | None = None) -> bool:
    """Whether the session bag at ``path`` holds operator twists (raises BagReadError / SessionError)."""
    infos = topics_info(path)
    ns = detect_namespace(infos) if namespace is None else namespace.rstrip('/')
    info = infos.get(f'{ns}/{OPERATOR_TWIST}')
    return info is not None and info.count > 0


def estimated(messages: Iterable[RawMessage], namespace: str = '') -> bool:
    """Whether ``/diagnostics`` among ``messages`` holds an intent estimator's status (a node in ``namespace``)."""
    prefix, suffix = f'{namespace}/', f': {ESTIMATOR_COMPONENT}'
    for msg in messages:
        if msg.topic == DIAGNOSTICS:
            try:
                names = [str(status.name) for status in decode(MSGTYPES[DIAGNOSTICS], bytes(msg.cdr)).status]
                if any(name.startswith(prefix) and name.endswith(suffix) for name in names):
                    return True
            except SessionError:
                continue
    return False


def estimator_ready(statuses: Mapping[str, str]) -> bool:
    """Whether an intent estimator's status (name -> its message and values, as text) reports its goals ready."""
    return any(name.endswith(f': {ESTIMATOR_COMPONENT}') and f'{KEY_GOALS}: ' in text
               for name, text in statuses.items())


def split_messages(messages: Iterable[RawMessage], namespace: str = '', *,
                   replayed: tuple[str, ...] = REPLAYED) -> tuple[ModelHeader | None, tuple[Send, ...], Trace]:
    """Split a closed-loop session's time-ordered messages into (initial model, sends of ``replayed``, trace)."""
    models = ModelSwitches()
    sends: list[Send] = []
    tracer = Tracer()
    for rel, msg in _relative(messages, namespace):
        if rel == MODEL_ACTIVE:
            if (header := models.take(msg)) is not None:
                sends.append(Send(msg.timestamp_ns, MODEL_ACTIVE, b'', header.name))
            continue
        if rel in replayed:
            sends.append(Send(msg.timestamp_ns, rel, bytes(msg.cdr)))
        tracer.add(rel, msg.timestamp_ns, bytes(msg.cdr))
    return models.initial, tuple(sends), tracer.trace()


def ahead(sends: Iterable[Send], topics: tuple[str, ...] = AHEAD_TOPICS, lead_ns: int = AHEAD_NS) -> tuple[Send, ...]:
    """``sends`` with those on ``topics`` sent ``lead_ns`` early, in the order of sending (ties: as given)."""
    moved = [Send(send.t_ns, send.topic, send.cdr, send.model, lead_ns) if send.topic in topics else send
             for send in sends]
    return tuple(sorted(moved, key=lambda send: send.t_ns - send.lead_ns))


def load_closed_loop(path: str | os.PathLike[str], *, namespace: str | None = None) -> ClosedLoopSession:
    """Read a closed-loop session bag (raises BagReadError, or SessionError without operator twists).

    An estimated session's joint states and grasps are sent :data:`AHEAD_NS` early (:func:`ahead`).
    """
    bag = Path(path)
    ns = detect_namespace(topics_info(bag)) if namespace is None else namespace.rstrip('/')
    messages = list(read_messages(bag))
    from_estimator = estimated(messages, ns)
    initial, sends, trace = split_messages(messages, ns, replayed=ESTIMATED_REPLAYED if from_estimator else REPLAYED)
    if from_estimator:
        sends = ahead(sends)
    if not trace.operator:
        raise SessionError(f'bag {bag} holds no {OPERATOR_TWIST}: not a closed-loop session')
    return ClosedLoopSession(bag, ns, initial, sends, trace, from_estimator)


def describe(outcome_: Outcome) -> str:
    """One line: reached after, ends at the grasp, mean alpha, blended twists while the operator sent."""
    reached = 'never' if outcome_.reached_s is None else f'after {outcome_.reached_s:.2f} s'
    w = '' if outcome_.final_w is None else f'; last w ({", ".join(f"{v:.3f}" for v in outcome_.final_w)})'
    return (f'hand at the last grasp {reached}, {"ends there" if outcome_.ends_at_grasp else "does not end there"}; '
            f'mean alpha {outcome_.alpha_mean:.2f}; {outcome_.blended} blended twists while the operator sent{w}')

