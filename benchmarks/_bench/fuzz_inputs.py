"""Malformed inputs for every input topic of the suite, as hypothesis strategies, and a driver that counts them.

Used by the fuzz system test (test/system/test_fuzz.py, a few thousand cases) and by ``benchmarks/fuzz_nodes.py``
(10,000+ cases and the oversized-message memory check).

A :class:`Case` is one message for one topic of one *family* (NaN/Inf, 1e308, -0.0, empty and 5,000-element
arrays, bogus layouts and offsets, bad quaternions and frames, length mismatches, duplicate names, oversized
strings and name lists, absurd joint positions and object poses, undecodable bytes) and says whether the
node must reject it: most must be, a few are edge cases a node must accept (a w or v with -0.0 entries, a joint state
without arm joints). :class:`Fuzzer` publishes cases one at a time and waits for each verdict (the
rejection on ``/diagnostics``, published at once, or the answer to an accepted input), so it counts every
rejection exactly and loses no message to a keep-last queue.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from hypothesis import strategies as st
from rclpy.node import Node
from rclpy.serialization import serialize_message
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from grasp_intent_ros.method.intent import DEFAULT_TASKS, all_zones, interpret, zone_labels
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q
from grasp_intent_ros.ros.qos import input_qos
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import KEY_CLARIFICATIONS, KEY_PLANS, KEY_REJECTED, status_values

COMPONENTS = {
    topics.INTENT_W: 'intent_interpreter: intent',
    topics.INTENT_V: 'grasp_planner: inputs',
    topics.OBJECT_POSE: 'grasp_planner: inputs',
    topics.JOINT_STATES: 'grasp_planner: inputs',
    topics.MODEL_QUERY: 'model_server: model',
}
"""The diagnostics component (status name after the node namespace) that counts each input topic."""
TOPICS = tuple(COMPONENTS)
FAMILIES = ('NaN/Inf', '1e308', '-0.0', 'empty array', '5000-element array', 'bogus layout', 'bogus offset',
            'bad quaternion', 'bad frame', 'length mismatch', 'duplicate names', 'oversized strings',
            'absurd joint positions', 'absurd object pose', 'undecodable bytes')
"""The families of malformed input (the names :attr:`Case.family` takes)."""
N_TASKS, N_ZONES, N_FEATURES = 3, 7, 10


@dataclass(frozen=True)
class Case:
    """One fuzz message: ``msg`` (a message object, or bytes published serialized) for ``topic``."""

    family: str
    topic: str
    msg: Any
    rejected: bool = True

    def __repr__(self) -> str:  # hypothesis prints failing cases: keep 500 kB messages out of the report
        text = repr(self.msg)
        return f'Case({self.family!r}, {self.topic!r}, rejected={self.rejected}, msg={text[:300]}...)'


# ------------------------------------------------------------------------------------------ messages
def array_msg(values: Any, dims: tuple[tuple[str, int, int], ...] = (), offset: int = 0) -> Float64MultiArray:
    msg = Float64MultiArray(data=[float(v) for v in values])
    msg.layout.dim = [MultiArrayDimension(label=label, size=size, stride=stride) for label, size, stride in dims]
    msg.layout.data_offset = offset
    return msg


def pose_msg(position: Any, xyzw: Any, frame_id: str = BASE_FRAME) -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(c) for c in position)
    o.x, o.y, o.z, o.w = (float(c) for c in xyzw)
    return msg


def joint_msg(names: Any, positions: Any) -> JointState:
    return JointState(name=list(names), position=[float(q) for q in positions])


OBJECT_XYZW = (0.0, 0.0, 1.0, 0.0)
OBJECT_POSITION = (0.3, -0.3, 0.0)
LONG = 5000
"""Characters of an oversized string."""

nonfinite = st.sampled_from([math.nan, math.inf, -math.inf])
absurd = st.one_of(st.sampled_from([1e308, -1e308, 1.7976931348623157e308, 1e6, -1e6, 2e9, 1e10, 1e14]),
                   st.floats(min_value=1e6, max_value=1e308).flatmap(lambda x: st.sampled_from([x, -x])))
unit = st.floats(min_value=0.0, max_value=1.0)


def _replace_one(values: list[float], bad: st.SearchStrategy[float]) -> st.SearchStrategy[list[float]]:
    return st.tuples(st.integers(0, len(values) - 1), bad).map(
        lambda ib: [ib[1] if i == ib[0] else v for i, v in enumerate(values)])


def _arrays(topic: str, valid: st.SearchStrategy[list[float]], n: int, *,
            out_of_range: st.SearchStrategy[float] | None) -> st.SearchStrategy[Case]:
    """The families every Float64MultiArray input shares; ``valid`` draws a valid value list of length ``n``.

    ``out_of_range`` draws a value that makes a valid list invalid (None: no such value, family left out).
    """
    def case(family: str) -> Callable[[Any], Case]:
        return lambda msg: Case(family, topic, msg)

    big = max(topics.MAX_MESSAGE_BYTES[topic] // 8 + 8, LONG)
    out = [] if out_of_range is None else [
        valid.flatmap(lambda vs: _replace_one(vs, out_of_range)).map(array_msg).map(case('1e308'))]
    return st.one_of(
        *out,
        valid.flatmap(lambda vs: _replace_one(vs, nonfinite)).map(array_msg).map(case('NaN/Inf')),
        st.just(array_msg([])).map(case('empty array')),
        valid.flatmap(lambda vs: st.integers(len(vs), 2**32 - 1).map(lambda off: array_msg(vs, offset=off)))
        .map(case('bogus offset')),
        st.tuples(valid, st.integers(0, 2**32 - 1).filter(lambda size: size != n), st.integers(0, 2**32 - 1))
        .map(lambda t: array_msg(t[0], (('', t[1], t[2]),))).map(case('bogus layout')),
        valid.map(lambda vs: array_msg(vs, (('', 1, n), ('', n, n)))).map(case('bogus layout')),
        st.tuples(unit, st.sampled_from([LONG, big])).map(lambda t: array_msg([t[0]] * t[1]))
        .map(case('5000-element array')),
        st.integers(1, 40).filter(lambda k: k != n).map(lambda k: array_msg([1.0 / k] * k))
        .map(case('length mismatch')),
        st.tuples(valid, st.integers(topics.MAX_MESSAGE_BYTES[topic], 2 * topics.MAX_MESSAGE_BYTES[topic]))
        .map(lambda t: array_msg(t[0], (('x' * t[1], n, n),))).map(case('oversized strings')),
    )


def w_cases() -> st.SearchStrategy[Case]:
    valid = st.lists(unit, min_size=N_TASKS, max_size=N_TASKS)
    out_of_range = st.one_of(absurd, st.floats(min_value=1.0, max_value=1e300, exclude_min=True),
                             st.floats(max_value=-1e-300))
    negzero = valid.flatmap(lambda vs: _replace_one(vs, st.just(-0.0)))
    return st.one_of(_arrays(topics.INTENT_W, valid, N_TASKS, out_of_range=out_of_range),
                     negzero.map(lambda vs: Case('-0.0', topics.INTENT_W, array_msg(vs), rejected=False)))


def _v(w: list[float]) -> list[float]:
    result = interpret(w)
    return list(result.v) if result.v is not None else [1.0] + [0.0] * (N_ZONES - 1)


def v_cases() -> st.SearchStrategy[Case]:
    valid = st.lists(st.floats(0.05, 1.0), min_size=N_TASKS, max_size=N_TASKS).map(_v)
    one_hot = st.integers(0, N_ZONES - 1).map(lambda k: [1.0 if i == k else -0.0 for i in range(N_ZONES)])
    return st.one_of(_arrays(topics.INTENT_V, valid, N_ZONES, out_of_range=absurd),
                     one_hot.map(lambda vs: Case('-0.0', topics.INTENT_V, array_msg(vs), rejected=False)))


def query_cases() -> st.SearchStrategy[Case]:
    valid = st.lists(st.floats(-1.0, 1.0), min_size=N_FEATURES, max_size=N_FEATURES)
    huge = st.sampled_from([1e308, -1e308, 1.7976931348623157e308])  # one huge feature may still give a finite P
    return st.one_of(
        _arrays(topics.MODEL_QUERY, valid, N_FEATURES, out_of_range=None),
        huge.map(lambda x: Case('1e308', topics.MODEL_QUERY, array_msg([x] * N_FEATURES))))


def pose_cases() -> st.SearchStrategy[Case]:
    topic = topics.OBJECT_POSE
    finite = st.floats(-1.0, 1.0)
    far = st.tuples(st.integers(0, 2), absurd).map(
        lambda t: [t[1] if i == t[0] else OBJECT_POSITION[i] for i in range(3)])
    unit_q = st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
        lambda q: np.linalg.norm(q) > 0.1).map(lambda q: list(np.asarray(q) / np.linalg.norm(q)))
    scale = st.one_of(st.floats(0.0, 0.99), st.floats(1.01, 1e6))
    return st.one_of(
        st.tuples(st.integers(0, 6), nonfinite).map(lambda t: [*OBJECT_POSITION, *OBJECT_XYZW][:t[0]] + [t[1]]
                                                    + [*OBJECT_POSITION, *OBJECT_XYZW][t[0] + 1:])
        .map(lambda vs: Case('NaN/Inf', topic, pose_msg(vs[:3], vs[3:]))),
        far.map(lambda p: Case('absurd object pose', topic, pose_msg(p, OBJECT_XYZW))),
        st.tuples(unit_q, scale).map(lambda t: Case('bad quaternion', topic,
                                                    pose_msg(OBJECT_POSITION, np.asarray(t[0]) * t[1]))),
        st.text(max_size=60).filter(lambda f: f != BASE_FRAME).map(
            lambda f: Case('bad frame', topic, pose_msg(OBJECT_POSITION, OBJECT_XYZW, f))),
        st.integers(topics.MAX_MESSAGE_BYTES[topic], 4 * topics.MAX_MESSAGE_BYTES[topic]).map(
            lambda k: Case('oversized strings', topic, pose_msg(OBJECT_POSITION, OBJECT_XYZW, 'f' * k))),
        st.tuples(finite, finite).map(lambda t: Case('-0.0', topic, pose_msg((0.3 + 0.02 * t[0], -0.3 + 0.02 * t[1],
                                                                              -0.0), (-0.0, -0.0, 1.0, -0.0)),
                                                     rejected=False)),
    )


_JUST_OUTSIDE = [(1, math.radians(50) - 0.15), (1, math.radians(310) + 0.15), (2, math.radians(35) - 0.15),
                 (2, math.radians(325) + 0.15), (0, 4 * math.pi + 0.15), (5, -4 * math.pi - 0.15)]
"""(joint index, reading) 0.15 rad outside a joint limit, beyond the planner's 0.1 rad margin."""


def joint_cases() -> st.SearchStrategy[Case]:
    topic = topics.JOINT_STATES
    arm = list(ARM_JOINTS)
    home = [float(q) for q in HOME_Q]
    return st.one_of(
        _replace_one(home, nonfinite).map(lambda q: Case('NaN/Inf', topic, joint_msg(arm, q))),
        _replace_one([0.0] * 6, absurd).map(lambda x: Case('absurd joint positions', topic,
                                                           joint_msg(arm, np.add(home, x)))),
        st.sampled_from(_JUST_OUTSIDE).map(lambda jq: Case('absurd joint positions', topic, joint_msg(
            arm, [jq[1] if j == jq[0] else q for j, q in enumerate(home)]))),
        st.just(Case('empty array', topic, joint_msg([], []), rejected=False)),
        st.integers(7, LONG).map(lambda k: Case('5000-element array', topic, joint_msg(arm, [0.5] * k))),
        st.integers(0, 5).map(lambda k: Case('length mismatch', topic, joint_msg(arm, home[:k]))),
        st.integers(0, 5).map(lambda i: Case('duplicate names', topic, joint_msg(arm + [arm[i]], [*home, 0.0]))),
        st.tuples(st.integers(1, 100), st.integers(topics.MAX_NAME_LENGTH + 1, 600)).map(
            lambda t: Case('oversized strings', topic, joint_msg(['j' * t[1]] * t[0], [0.0] * t[0]))),
        st.integers(20, 120).map(lambda k: Case('oversized strings', topic,
                                                joint_msg(['m1n6s300_joint_1' + 'x' * LONG] * k, [0.0] * k))),
        st.integers(topics.MAX_JOINTS + 1, 500).map(
            lambda k: Case('oversized strings', topic, joint_msg([f'j{i}' for i in range(k)], [0.0] * k))),
        st.just(Case('-0.0', topic, joint_msg(list(FINGER_JOINTS), [-0.0] * 3), rejected=False)),
        st.binary(min_size=1, max_size=64).map(lambda b: Case('undecodable bytes', topic, _CDR_HEADER + b))
        .filter(_undecodable),
    )


_CDR_HEADER = b'\x00\x01\x00\x00'
"""The encapsulation header of little-endian CDR, which every serialized message starts with."""


def _undecodable(case: Case) -> bool:
    from rclpy.serialization import deserialize_message

    try:
        deserialize_message(case.msg, JointState)
    except Exception:  # noqa: BLE001 - what the node's decoder raises for it
        return True
    return False


def cases() -> st.SearchStrategy[Case]:
    """A case of any family on any input topic."""
    return st.one_of(w_cases(), v_cases(), pose_cases(), joint_cases(), query_cases())


# ------------------------------------------------------------------------------------------ driver
def valid_w() -> Float64MultiArray:
    return array_msg([0.9, 0.9, 0.1])


INTERPRETER_V_LABEL = ','.join(zone_labels(all_zones(N_TASKS), DEFAULT_TASKS))
"""The label of the one dimension of the interpreter's v (the fuzzed v never carry it)."""
SETTLE_W = (0.9, 0.1, 0.9)
"""The w :meth:`Fuzzer.settle` sends (a v other than that of :func:`valid_w`, and a grasp)."""
INTERPRETER_CLARIFICATIONS = KEY_CLARIFICATIONS
"""Status value: the interpreter's clarification requests so far."""
PLANNING = 'grasp_planner: planning'
"""The planner's diagnostics component for its plans."""
PLANNER_CLARIFICATIONS = KEY_CLARIFICATIONS
"""Status value: the planner's clarification requests so far (one per v and model at most)."""


class Fuzzer:
    """Publishes cases from a probe node and follows each node's verdicts on /diagnostics and its outputs.

    Every verdict is attributed to its case exactly, so that no earlier case's answer can stand for a later
    one and nothing a case set off is still on its way when the next is sent. That matters beyond the
    counts: the planner reads ``intent/v`` keep-last 1, so a fuzzed v sent while the interpreter's answer
    to an accepted w was still on its way could be replaced by that answer in the planner's queue and
    never be counted (33 of 300 NaN v sent 0-4 ms after a valid w were never counted, load 7; none of 500
    sent once the interpreter's v had arrived). Hence:

    - a rejection is the reading node's ``messages rejected`` count, which only grows (the largest value
      seen is used: a periodic status may arrive after a newer one published from another thread);
    - the interpreter's answer is a v it published (its zone-labelled layout and writer sequence number:
      the probe's own fuzzed v are echoed to it too) or its ``clarifications`` count;
    - the planner's answer is a grasp stamped after the case was sent (the stamp is the arrival of the
      plan's newest input), its ``clarifications requested`` count, or, for a clarification it had
      already requested for the same v (asked once per v), its ``plans`` count with the status saying so.

    An accepted w that the interpreter answers with a v is finished only when the planner has answered
    that v too. Call :meth:`settle` once the nodes answer, before the first case.

    Parameters
    ----------
    node : Node
        The probe (its executor is spun by ``wait_for``).
    wait_for : callable
        ``wait_for(predicate, timeout) -> bool``: spin until the predicate holds.
    namespace : str
        Of the nodes ('' or e.g. '/robot1').
    """

    def __init__(self, node: Node, wait_for: Callable[[Callable[[], object], float], bool],
                 namespace: str = '') -> None:
        self._wait_for = wait_for
        self._ns = namespace
        self.latest: dict[str, dict[str, str]] = {}
        """The last status values per component name."""
        self._messages: dict[str, str] = {}
        """The last status message per component name."""
        self._counts: dict[tuple[str, str], int] = {}
        """The largest value seen per (component name, counter key)."""
        self.sent: Counter[tuple[str, str]] = Counter()
        """Messages sent per (topic, family)."""
        self.rejected: Counter[tuple[str, str]] = Counter()
        """Rejections counted per (topic, family)."""
        self.v_seq = 0
        """Writer sequence number of the newest v the interpreter published (0: none seen)."""
        self._v_ns, self._v_data = 0, np.zeros(0)
        """Publication time (ns) and values of that v."""
        self.grasp_ns = 0
        """Stamp (ns) of the newest grasp/pose."""
        self._pubs = {topic: node.create_publisher(_type(topic), topic, input_qos()) for topic in TOPICS}
        self._clock = node.get_clock()
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics, 1000)
        node.create_subscription(_type(topics.INTENT_V), topics.INTENT_V, self._on_v, 100)
        node.create_subscription(PoseStamped, topics.GRASP_POSE, self._on_grasp, 100)

    def component(self, topic: str) -> str:
        return f'{self._ns}/{COMPONENTS[topic]}'

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = status_values(status)
            self.latest[status.name] = values
            self._messages[status.name] = status.message
            for key, value in values.items():
                if value.isdigit():
                    self._counts[(status.name, key)] = max(int(value), self._counts.get((status.name, key), 0))

    def _on_v(self, msg: Any, info: dict[str, Any]) -> None:
        seq = int(info['publication_sequence_number'])
        if [dim.label for dim in msg.layout.dim] == [INTERPRETER_V_LABEL] and seq > self.v_seq:  # not an echo
            self.v_seq, self._v_ns, self._v_data = seq, int(info['source_timestamp']), np.asarray(msg.data)

    def _on_grasp(self, msg: PoseStamped) -> None:
        self.grasp_ns = max(self.grasp_ns, Time.from_msg(msg.header.stamp).nanoseconds)

    def count(self, topic: str, key: str = KEY_REJECTED) -> int:
        """The largest value of ``key`` seen in the statuses of the component that reads ``topic`` (-1: none)."""
        return self._counts.get((self.component(topic), key), -1)

    def _planning(self, key: str) -> int:
        return self._counts.get((f'{self._ns}/{PLANNING}', key), 0)

    def send(self, case: Case, timeout: float = 10.0) -> None:
        """Publish ``case`` and wait for its verdict (see the class docstring).

        Raises
        ------
        AssertionError
            If a rejected case is not counted as exactly one rejection within ``timeout``, or an accepted one
            is not answered within ``timeout`` (w: by the interpreter, and a v it published by the planner;
            v and object poses: by the planner) or is rejected.
        """
        rejected_before = self.count(case.topic)
        self.sent[(case.topic, case.family)] += 1
        if case.rejected:
            self._pubs[case.topic].publish(case.msg)
            counted = self._wait_for(lambda: self.count(case.topic) > rejected_before, timeout)
            assert counted, f'{case!r}: no rejection counted by {self.component(case.topic)} within {timeout} s'
            assert self.count(case.topic) == rejected_before + 1, f'{case!r}: counted as several rejections'
            self.rejected[(case.topic, case.family)] += 1
            return
        if case.topic == topics.INTENT_W:
            self.answer_w(case.msg, timeout, what=repr(case))
        elif case.topic == topics.JOINT_STATES:  # a joint state is stored, not answered
            self._pubs[case.topic].publish(case.msg)
        else:
            self._planner_answers(lambda: self._pubs[case.topic].publish(case.msg), timeout, what=repr(case))
        assert self.count(case.topic) == rejected_before, f'{case!r}: an accepted input was rejected'

    def answer_w(self, msg: Any, timeout: float = 10.0, *, what: str = 'w', v: Any = None) -> None:
        """Publish the w ``msg``; wait for the interpreter's answer and the planner's answer to a v.

        ``v``: the answer must be a v with these values (the interpreter publishes in order: every v
        it published before has arrived too). Raises AssertionError as :meth:`send`.
        """
        seq, asked = self.v_seq, self.count(topics.INTENT_W, INTERPRETER_CLARIFICATIONS)
        if v is None:
            answered = lambda: self.v_seq > seq or self.count(topics.INTENT_W, INTERPRETER_CLARIFICATIONS) > asked  # noqa: E731
        else:
            answered = lambda: self.v_seq > seq and np.allclose(self._v_data, v, rtol=0, atol=1e-12)  # noqa: E731
        planner = self._planner_counts()
        self._pubs[topics.INTENT_W].publish(msg)
        assert self._wait_for(answered, timeout), f'{what}: accepted input not answered within {timeout} s'
        if self.v_seq > seq:  # the planner takes it after its publication
            planned = self._planner_answered(planner, self._v_ns)
            assert self._wait_for(planned, timeout), f'{what}: its v not answered by the planner within {timeout} s'

    def _planner_answers(self, publish: Callable[[], object], timeout: float, *, what: str) -> None:
        planned = self._planner_answered(self._planner_counts(), self._clock.now().nanoseconds)
        publish()
        assert self._wait_for(planned, timeout), f'{what}: accepted input not answered within {timeout} s'

    def _planner_counts(self) -> tuple[int, int]:
        return self._planning(PLANNER_CLARIFICATIONS), self._planning(KEY_PLANS)

    def _planner_answered(self, counts: tuple[int, int], sent_ns: int) -> Callable[[], bool]:
        """A predicate: the planner has answered an input sent at ``sent_ns`` (ns) or later.

        ``counts``: :meth:`_planner_counts` before it was sent.
        """
        asked, plans = counts
        planning = f'{self._ns}/{PLANNING}'
        return lambda: (self.grasp_ns >= sent_ns or self._planning(PLANNER_CLARIFICATIONS) > asked
                        or (self._planning(KEY_PLANS) > plans
                            and self._messages.get(planning, '').startswith('clarification requested')))

    def settle(self, timeout: float = 10.0) -> None:
        """Wait until nothing sent before is still on its way (e.g. the w published until the nodes answered).

        Sends one more w, :data:`SETTLE_W`, whose v differs from that of :func:`valid_w`: once it has
        arrived, so has every v the interpreter published before it; then the planner's answer to it.
        """
        self.answer_w(array_msg(SETTLE_W), timeout, what='w ' + str(SETTLE_W), v=_v(list(SETTLE_W)))

    def publish(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` (a message or serialized bytes) on ``topic`` without waiting for a verdict."""
        self._pubs[topic].publish(msg)


def _type(topic: str) -> Any:
    from grasp_intent_ros.ros.conversions import message_class

    return message_class(topic)


def serialized(msg: Any) -> bytes:
    """``msg`` serialized (published as is, so a stream of big messages costs the sender no encoding)."""
    return serialize_message(msg)
