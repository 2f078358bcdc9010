"""In-process tests of the assistance node over two objects (its ``objects`` parameter; docs/several_objects.md)."""

from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray, String
from std_srvs.srv import SetBool
from twists import as_array, twist_msg

from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes.assistance import ENABLE_SERVICE, AssistanceNode
from grasp_intent_ros.ros.conversions import array_to_msg, posterior_to_msg
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import WARN

LABELS = ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
TASKS = ('usage', 'transfer', 'handover')
OBJECTS = ('cup', 'flashlight')
CHAIN_TOPICS = ((topics.GRASP_POSE, PoseStamped), (topics.GRASP_POSTERIOR, Float64MultiArray),
                (topics.INTENT_V, Float64MultiArray))


class Scene:
    """The node over the cup and the flashlight, the hand at Home.

    The cup's grasp 0.2 m ahead along the approach axis (in the corridor), the flashlight's 0.2 m to the side of the
    hand (its pre-grasp off the cup's way).
    """

    def __init__(self, ros, **params) -> None:
        overrides = [Parameter('objects', value=list(OBJECTS)), *(Parameter(k, value=v) for k, v in params.items())]
        self.node = ros.add(AssistanceNode(context=ros.context, parameter_overrides=overrides))
        self.ros = ros
        self.twists = ros.subscribe(TwistStamped, topics.ASSISTANCE_TWIST)
        self.alphas = ros.subscribe(Float64, topics.ASSISTANCE_ALPHA)
        self.followed = ros.subscribe(String, topics.ASSISTANCE_OBJECT, latched_qos())
        self.operator = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)
        self.joints = ros.publisher(JointState, topics.JOINT_STATES)
        self.objects = ros.publisher(Float64MultiArray, topics.INTENT_OBJECTS)
        self.pubs = {(name, topic): ros.publisher(type_, f'{name}/{topic}') for name in OBJECTS
                     for topic, type_ in CHAIN_TOPICS}
        self.hand = MicoKinematics().fk(HOME_Q)
        self.grasps = {name: self.hand.copy() for name in OBJECTS}
        self.grasps['cup'][:3, 3] += 0.2 * self.hand[:3, 2]
        self.grasps['flashlight'][:3, 3] += 0.2 * self.hand[:3, 0]

    def feed(self, p_cup: float, v=np.eye(7)[0]) -> None:
        """Every chain's grasp, posterior and v, the hand at Home, and P(o)."""
        stamp = self.ros.node.get_clock().now().to_msg()
        self.joints.publish(joint_state_msg(ARM_JOINTS, HOME_Q, stamp=stamp))
        for name in OBJECTS:
            self.pubs[name, topics.GRASP_POSE].publish(matrix_to_pose_msg(self.grasps[name], frame_id=BASE_FRAME,
                                                                          stamp=stamp))
            self.pubs[name, topics.GRASP_POSTERIOR].publish(posterior_to_msg(v, np.array([1.0, 0.0, 0.0]), LABELS,
                                                                             TASKS, stamp=stamp))
            self.pubs[name, topics.INTENT_V].publish(array_to_msg(v, [LABELS]))
        self.objects.publish(array_to_msg([p_cup, 1.0 - p_cup], [list(OBJECTS)]))

    def toward(self, name: str, speed: float = 0.02) -> TwistStamped:
        """The operator's twist straight at ``name``'s grasp from the hand."""
        step = self.grasps[name][:3, 3] - self.hand[:3, 3]
        return twist_msg(linear=tuple(speed * step / np.linalg.norm(step)))

    def drive(self, name: str, p_cup: float, until, timeout: float = 10.0) -> bool:
        """Feed the scene and head for ``name`` every 10 ms until ``until()`` (False at the timeout)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.feed(p_cup)
            self.operator.publish(self.toward(name))
            if self.ros.wait_for(until, 0.01):
                return True
        return False


def test_the_cup_is_followed_and_assisted_then_the_flashlight_after_the_hold_time(ros) -> None:
    scene = Scene(ros)
    assert scene.drive('cup', 0.9, lambda: any(a.data > 0.5 for a in scene.alphas[-5:]))
    assert ros.wait_for(lambda: scene.followed and scene.followed[-1].data == 'cup', 5.0)  # a topic of its own
    assert max(a.data for a in scene.alphas[-5:]) <= 0.9 * 0.9 + 1e-12  # alpha_max P(cup) s o, s = o = 1
    # the operator turns to the flashlight and the intent follows: the flashlight after the hold time
    start = time.monotonic()
    assert scene.drive('flashlight', 0.1, lambda: scene.followed[-1].data == 'flashlight')
    switch = time.monotonic() - start
    assert switch >= 0.3  # follow_hold_time: never before it (after it by the executor's latency)
    assert scene.drive('flashlight', 0.1, lambda: any(a.data > 0.5 for a in scene.alphas[-5:]))
    assert [m.data for m in scene.followed][-2:] == ['cup', 'flashlight']  # (the first grasp in may be either)
    statuses = ros.diagnostics()
    assert ros.wait_for(lambda: any(v.key == 'following' and v.value == 'flashlight' for status in statuses[-5:]
                                    if status.name.endswith(': assistance') for v in status.values), 5.0)
    values = {v.key: v.value for v in statuses[-1].values}
    assert float(values['flashlight: s']) == 0.9 and float(values['cup: s']) == 0.1  # P(o) s, s = 1 for each grasp
    print(f'switch {switch:.3f} s after the turn')


def test_bad_input_on_one_chain_warns_naming_its_topic_and_the_other_is_served(ros, status_finder) -> None:
    scene = Scene(ros)
    statuses = ros.diagnostics()
    bad = array_to_msg(-np.ones(7), [LABELS])  # negative
    assert ros.publish_until(scene.pubs['flashlight', topics.INTENT_V], bad, lambda: status_finder(
        statuses, ': assistance', level=bytes([WARN]), text='flashlight/intent/v'), 10.0)
    assert scene.drive('cup', 0.9, lambda: any(a.data > 0.5 for a in scene.alphas[-5:]))
    assert ros.wait_for(lambda: scene.followed and scene.followed[-1].data == 'cup', 5.0)
    unknown = array_to_msg([1.0], [['mug']])
    assert ros.publish_until(scene.objects, unknown, lambda: status_finder(
        statuses, ': assistance', level=bytes([WARN]), text='mug'), 10.0)


def test_switched_off_the_output_is_the_operators_twist_exactly(ros) -> None:
    scene = Scene(ros)
    assert scene.drive('cup', 0.9, lambda: any(a.data > 0.5 for a in scene.alphas[-5:]))
    client = ros.node.create_client(SetBool, ENABLE_SERVICE)
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(SetBool.Request(data=False))
    assert ros.wait_for(future.done, 10.0) and future.result().success
    fast = twist_msg(linear=(0.5, -0.3, 0.1), angular=(2.0, 0.0, -1.5))
    assert ros.publish_until(scene.operator, fast, lambda: np.array_equal(as_array(scene.twists[-1]), as_array(fast)),
                             5.0, period=0.01)
    assert ros.wait_for(lambda: scene.alphas[-1].data == 0.0, 5.0)
    # no operator input: the zero twist (the zero-input rule), whatever the scene
    future = client.call_async(SetBool.Request(data=True))
    assert ros.wait_for(future.done, 10.0) and future.result().success
    assert ros.publish_until(scene.operator, twist_msg(), lambda: scene.alphas[-1].data == 0.0 and not np.any(
        as_array(scene.twists[-1])), 5.0, period=0.01)
