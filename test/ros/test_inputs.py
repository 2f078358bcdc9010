"""grasp_intent_ros.ros.inputs: input subscriptions that reject oversized messages before decoding them."""

from __future__ import annotations

import time

import pytest
import rclpy
from rclpy.qos import ReliabilityPolicy
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from grasp_intent_ros.mico.kinematics import ARM_JOINTS, FINGER_JOINTS, HOME_Q
from grasp_intent_ros.ros.diagnostics import NodeDiagnostics
from grasp_intent_ros.ros.inputs import subscribe_arm, subscribe_input
from grasp_intent_ros.ros.qos import input_qos
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import KEY_DROPPED, KEY_RECEIVED, KEY_REJECTED, WARN, level_value, status_values
from grasp_intent_ros.wire.joint_states import STALE_AFTER, JointReading


def w_with_label(label: str) -> Float64MultiArray:
    msg = Float64MultiArray(data=[0.5, 0.5, 0.5])
    msg.layout.dim = [MultiArrayDimension(label=label, size=3, stride=3)]
    return msg


def test_oversized_and_undecodable_messages_are_rejected_and_the_rest_decoded(ros) -> None:
    node = ros.add(rclpy.create_node('inputs_probe', context=ros.context))
    diag = NodeDiagnostics(node, 'inputs')
    received: list[Float64MultiArray] = []
    subscribe_input(node, topics.INTENT_W, received.append, input_qos(), diag)
    pub = ros.publisher(Float64MultiArray, topics.INTENT_W)

    def counts() -> tuple[str, str]:
        values = status_values(diag.status())
        return values[KEY_RECEIVED], values[KEY_REJECTED]

    cap = topics.MAX_MESSAGE_BYTES[topics.INTENT_W]
    size = {n: len(serialize_message(w_with_label('x' * n))) for n in range(cap - 100, cap)}
    at_cap = w_with_label('x' * max(n for n, k in size.items() if k <= cap))  # CDR pads: the largest that fits
    over = w_with_label('x' * min(n for n, k in size.items() if k > cap))
    over_size = len(serialize_message(over))
    assert cap - 8 < len(serialize_message(at_cap)) <= cap < over_size
    assert ros.publish_until(pub, at_cap, lambda: received)  # the first after discovery may be lost
    assert received[0].layout.dim[0].label == at_cap.layout.dim[0].label and list(received[0].data) == [0.5] * 3
    n_received, _ = counts()

    pub.publish(over)
    assert ros.wait_for(lambda: counts() == (str(int(n_received) + 1), '1'))
    assert diag.status().message == (f'rejected input: {topics.INTENT_W}: oversized message of {over_size} bytes, '
                                     f'the limit is {cap} bytes')
    pub.publish(b'\x00\x01\x00\x00\xff\xff\xff\x7f')  # a CDR sequence length of 2^31 and no data
    assert ros.wait_for(lambda: counts() == (str(int(n_received) + 2), '2'))
    assert 'intent/w: undecodable message' in diag.status().message
    assert len(received) == int(n_received)  # neither reached the callback


def test_the_arm_from_joint_states_split_partial_stale_and_malformed(ros) -> None:
    """The arm's joints over two messages and the fingers in a third: the arm once both halves came.

    The halves reordered, one with an extra joint, no velocities. A half alone is noted (never named; then stale
    after STALE_AFTER s of other messages); a malformed message is a rejection that changes nothing.
    """
    node = ros.add(rclpy.create_node('inputs_probe', context=ros.context))
    diag = NodeDiagnostics(node, 'inputs')
    arms: list[JointReading] = []
    subscribe_arm(node, arms.append, input_qos(), diag)
    pub = ros.publisher(JointState, topics.JOINT_STATES)
    fingers = JointState(name=list(FINGER_JOINTS), position=[0.1, 0.2, 0.3])
    first = JointState(name=['m1n6s300_joint_extra', *ARM_JOINTS[2::-1]], position=[5.0, *HOME_Q[2::-1]])
    second = JointState(name=list(ARM_JOINTS[:2:-1]), position=HOME_Q[:2:-1].tolist())

    def noted(text: str) -> bool:
        status = diag.status()
        return level_value(status.level) == WARN and status.message.startswith(f'joint state not used: {text}')

    assert ros.publish_until(pub, first, lambda: noted('never named: ' + ', '.join(ARM_JOINTS[3:])))
    pub.publish(fingers)
    pub.publish(second)
    assert ros.wait_for(lambda: arms) and len(arms) == 1  # the fingers' message brought nothing new
    assert arms[0].positions.tolist() == list(HOME_Q) and arms[0].stamp_ns is None
    assert ros.publish_until(pub, JointState(name=list(ARM_JOINTS), position=[0.0] * 5),
                             lambda: 'rejected input: joint state has 6 names but 5 positions' in diag.status().message)
    assert len(arms) == 1

    since = time.monotonic()  # the arm's second half stops; the fingers' publisher goes on
    assert ros.publish_until(pub, fingers, lambda: time.monotonic() > since + STALE_AFTER + 0.1, period=0.05)
    assert ros.publish_until(pub, first, lambda: noted('stale (not named for more than 1 s while other joints were): '
                                                       + ', '.join(ARM_JOINTS[3:])))
    pub.publish(second)
    assert ros.wait_for(lambda: len(arms) == 2)


def test_a_topic_without_a_cap_is_refused(ros) -> None:
    node = ros.add(rclpy.create_node('inputs_probe', context=ros.context))
    with pytest.raises(KeyError, match='not an input topic with a size cap'):
        subscribe_input(node, topics.GRASP_MARKERS, print, input_qos(), NodeDiagnostics(node, "inputs"))


def test_an_input_thread_takes_a_burst_in_order_counted_and_off_the_executor(ros) -> None:
    import threading

    from grasp_intent_ros.ros.worker import InputThread

    sink = ros.add(rclpy.create_node('inputs_sink', context=ros.context))
    inputs = InputThread(ros.context, name='test_inputs')
    try:
        diag = NodeDiagnostics(sink, 'inputs')
        taken: list[tuple[float, str]] = []
        inputs.take(subscribe_input(sink, topics.INTENT_W,
                                    lambda m: taken.append((m.data[0], threading.current_thread().name)),
                                    input_qos(depth=50), diag, count_dropped=True,
                                    callback_group=inputs.callback_group))
        pub = ros.publisher(Float64MultiArray, topics.INTENT_W)
        assert ros.wait_for(lambda: pub.get_subscription_count() == 1)
        for i in range(30):
            pub.publish(Float64MultiArray(data=[float(i)]))
        assert ros.wait_for(lambda: len(taken) == 30, 10.0), taken
        assert taken == [(float(i), 'test_inputs') for i in range(30)]
        values = status_values(diag.status())
        assert (values[KEY_RECEIVED], values[KEY_DROPPED]) == ('30', '0')
    finally:
        inputs.stop()


def test_a_publisher_with_incompatible_qos_is_named_in_the_log(ros, capfd) -> None:
    node = ros.add(rclpy.create_node('inputs_probe', context=ros.context))
    subscribe_input(node, topics.INTENT_W, print, input_qos(), NodeDiagnostics(node, 'inputs'))
    best_effort = input_qos()
    best_effort.reliability = ReliabilityPolicy.BEST_EFFORT  # the subscription asks for reliable
    ros.publisher(Float64MultiArray, topics.INTENT_W, best_effort)
    err: list[str] = []
    # the probe's publisher logs its own side of the mismatch too, and may do so first: wait for the subscription's
    expected = ("New publisher discovered on topic 'intent/w', offering incompatible QoS. No messages will be "
                'received from it. Last incompatible policy: RELIABILITY')
    assert ros.wait_for(lambda: err.append(capfd.readouterr().err) or expected in ''.join(err), 10.0), ''.join(err)
