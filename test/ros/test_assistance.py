"""In-process tests of the assistance node (private Context per test, see test/conftest.py)."""

from __future__ import annotations

import errno
import functools
import os
import time

import held_search
import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, String
from std_srvs.srv import SetBool
from twists import as_array, twist_msg

from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes.assistance import ENABLE_SERVICE, AssistanceNode
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.conversions import array_to_msg, posterior_to_msg
from grasp_intent_ros.ros.realtime import thread_policies
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg
from grasp_intent_ros.shared_control import path_search
from grasp_intent_ros.shared_control.robot_twist import joint_space_twist
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import WARN
from grasp_intent_ros.wire.model_document import ModelDocument

LABELS = ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
TASKS = ('usage', 'transfer', 'handover')


class Loop:
    """The assistance node with a probe feeding it a hand at Home, a grasp below it, a certain v."""

    def __init__(self, ros, operator_type=TwistStamped, **params) -> None:
        overrides = [Parameter(k, value=v) for k, v in params.items()]
        self.node = ros.add(AssistanceNode(context=ros.context, parameter_overrides=overrides))
        self.ros = ros
        self.twists = ros.subscribe(TwistStamped, topics.ASSISTANCE_TWIST)
        self.alphas = ros.subscribe(Float64, topics.ASSISTANCE_ALPHA)
        self.operator = ros.publisher(operator_type, topics.OPERATOR_TWIST)
        self.pubs = {topic: ros.publisher(type_, topic) for topic, type_ in (
            (topics.JOINT_STATES, JointState), (topics.GRASP_POSE, PoseStamped),
            (topics.GRASP_POSTERIOR, type(array_to_msg([1.0], [['a']]))),
            (topics.INTENT_V, type(array_to_msg([1.0], [['a']]))),
            (topics.INTENT_CLARIFICATION, String))}
        self.hand = MicoKinematics().fk(HOME_Q)
        self.grasp = self.hand.copy()
        self.grasp[:3, 3] += 0.2 * self.hand[:3, 2]  # 0.2 m ahead along the approach axis: in the corridor

    def feed(self, v=np.eye(7)[0]) -> None:
        stamp = self.ros.node.get_clock().now().to_msg()
        messages = {
            topics.JOINT_STATES: joint_state_msg(ARM_JOINTS, HOME_Q, stamp=stamp),
            topics.GRASP_POSE: matrix_to_pose_msg(self.grasp, frame_id=BASE_FRAME, stamp=stamp),
            topics.GRASP_POSTERIOR: posterior_to_msg(v, np.array([1.0, 0.0, 0.0]), LABELS, TASKS, stamp=stamp),
            topics.INTENT_V: array_to_msg(v, [LABELS]),
        }
        for topic, msg in messages.items():
            self.pubs[topic].publish(msg)

    def assisted(self) -> bool:  # the recent outputs: one may be a stale input's stop on a loaded machine
        return any(a.data > 0.5 for a in self.alphas[-10:])

    def toward(self, speed: float = 0.02) -> TwistStamped:
        """The operator's twist straight at the grasp (agreement 1)."""
        return twist_msg(linear=tuple(speed * self.hand[:3, 2]))

    def assist(self) -> None:
        deadline = time.monotonic() + 10.0
        while not self.assisted() and time.monotonic() < deadline:
            self.feed()
            self.operator.publish(self.toward())
            self.ros.wait_for(self.assisted, 0.02)
        assert self.assisted(), 'no assistance after the grasp, v and the joint state'


def test_the_blend_pulls_toward_the_grasp_and_alpha_drops_while_clarifying(ros) -> None:
    loop = Loop(ros)
    assert ros.wait_for(lambda: loop.alphas, 10.0)  # the timer's output, before any operator input
    assert loop.alphas[-1].data == 0.0 and not np.any(as_array(loop.twists[-1]))
    loop.assist()
    assert max(a.data for a in loop.alphas[-10:]) == pytest.approx(0.9)
    # the operator heading at the grasp: the robot's part, the hand's motion under the joints moving toward the
    # grasp's IK, blended with it, reached within the acceleration limits
    kin = MicoKinematics()
    q = np.asarray(HOME_Q)
    robot = joint_space_twist(kin.jacobian(q), q, kin.ik(loop.grasp, q, restarts=0).q, gain=2.0, max_linear=0.15,
                              max_angular=0.8)
    assert ros.publish_until(loop.operator, loop.toward(), lambda: np.allclose(
        as_array(loop.twists[-1]), 0.9 * robot + 0.1 * as_array(loop.toward()), rtol=0.0, atol=1e-9), 10.0,
        period=0.01)
    twist = as_array(loop.twists[-1])
    assert twist[:3] @ loop.hand[:3, 2] > 0.5 * np.linalg.norm(twist[:3])  # toward the grasp
    # a clarification: alpha 0 at once, the output the operator's alone for as long as it is pending
    count = len(loop.alphas)
    loop.pubs[topics.INTENT_CLARIFICATION].publish(String(data='which task?'))
    assert ros.wait_for(lambda: len(loop.alphas) > count and loop.alphas[-1].data == 0.0, 5.0)
    pending = len(loop.alphas) - 1
    assert ros.publish_until(loop.operator, twist_msg(linear=(0.02, 0.0, 0.0)), lambda: np.allclose(
        as_array(loop.twists[-1]), [0.02, 0, 0, 0, 0, 0], rtol=0.0, atol=1e-12), 10.0, period=0.01)
    assert [a.data for a in loop.alphas[pending:]] == [0.0] * (len(loop.alphas) - pending)
    loop.feed()  # the next grasp answers it
    assert ros.publish_until(loop.operator, loop.toward(), lambda: loop.alphas[-1].data > 0.5, 5.0, period=0.01)


def test_the_operator_wins_holding_still_moves_nothing_and_the_switch_gives_the_operator_alone(ros) -> None:
    loop = Loop(ros)
    loop.assist()
    # no input: no assistance, the output is the operator's zero twist (after the acceleration limit's ramp)
    assert ros.publish_until(loop.operator, twist_msg(), lambda: loop.alphas[-1].data == 0.0 and not np.any(
        as_array(loop.twists[-1])), 5.0, period=0.01)
    # sustained opposition: the robot yields (alpha 0) and stays yielded while the operator opposes
    loop.assist()
    away = loop.toward(-0.05)
    assert ros.publish_until(loop.operator, away, lambda: loop.node._assist.yielded, 5.0, period=0.01)
    count = len(loop.alphas)
    assert ros.publish_until(loop.operator, away, lambda: len(loop.alphas) > count + 10, 5.0, period=0.01)
    assert all(a.data == 0.0 for a in loop.alphas[count + 1:])
    # the switch: off, the operator's twist exactly (beyond the output's limits too); on, assisted again
    client = ros.node.create_client(SetBool, ENABLE_SERVICE)
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(SetBool.Request(data=False))
    assert ros.wait_for(future.done, 10.0) and future.result().success
    fast = twist_msg(linear=(0.5, -0.3, 0.1), angular=(2.0, 0.0, -1.5))
    assert ros.publish_until(loop.operator, fast, lambda: np.array_equal(as_array(loop.twists[-1]), as_array(fast)),
                             5.0, period=0.01)
    assert loop.alphas[-1].data == 0.0
    future = client.call_async(SetBool.Request(data=True))
    assert ros.wait_for(future.done, 10.0) and future.result().success
    loop.feed()
    moved = loop.grasp.copy()
    moved[:3, 3] += 0.05  # a new proposal: no longer yielded
    loop.grasp = moved
    loop.assist()


def test_a_stale_operator_input_gives_the_zero_twist_and_it_goes_on(ros) -> None:
    """The node side (the zero twist within the timeout, own clock: test/unit/shared_control/test_assistance.py)."""
    loop = Loop(ros, operator_timeout=0.1)
    moving = twist_msg(linear=(0.05, 0.0, 0.0))
    up_to_speed = lambda: loop.twists and loop.twists[-1].twist.linear.x >= 0.049  # noqa: E731 (acceleration-limited)
    assert ros.publish_until(loop.operator, moving, up_to_speed, 10.0, period=0.01)
    # no more input: the output falls to the zero twist and stays there, at the timer's rate
    assert ros.wait_for(lambda: len(loop.twists) > 10 and not any(np.any(as_array(m)) for m in loop.twists[-10:]),
                        5.0)


def test_a_plain_twist_source_in_the_hand_frame(ros) -> None:
    loop = Loop(ros, Twist, operator_message_type='Twist', operator_frame='m1n6s300_end_effector')
    msg = Twist()
    msg.linear.z = 0.01  # along the hand axis
    assert ros.publish_until(loop.pubs[topics.JOINT_STATES], joint_state_msg(
        ARM_JOINTS, HOME_Q, stamp=ros.node.get_clock().now().to_msg()), lambda: loop.node._assist.base_T_ee is not None)
    assert ros.publish_until(loop.operator, msg, lambda: loop.twists and np.any(as_array(loop.twists[-1])), 10.0,
                             period=0.01)
    along_the_hand_axis = 0.01 * loop.hand[:3, 2]  # once the output's acceleration limit has let it reach it
    assert ros.publish_until(loop.operator, msg, lambda: np.allclose(as_array(loop.twists[-1])[:3], along_the_hand_axis,
                                                                     rtol=0.0, atol=1e-9), 10.0, period=0.01), \
        as_array(loop.twists[-1])


def test_bad_inputs_are_rejected_and_the_node_serves_on(ros, status_finder) -> None:
    loop = Loop(ros)
    statuses = ros.diagnostics()
    warn = bytes([WARN])
    for bad, reason in ((twist_msg(linear=(float('nan'), 0.0, 0.0)), 'finite'),
                        (twist_msg(frame='map'), 'no TF')):
        assert ros.publish_until(loop.operator, bad, lambda r=reason: status_finder(
            statuses, ': assistance', level=warn, text=r), 10.0)
    bad_pose = matrix_to_pose_msg(pose_to_matrix((0.3, -0.3, 0.1), (0.0, 0.0, 0.0, 1.0)), frame_id='map',
                                  stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(loop.pubs[topics.GRASP_POSE], bad_pose,
                             lambda: status_finder(statuses, ': assistance', level=warn, text='no TF'), 10.0)
    count = len(loop.twists)
    loop.operator.publish(twist_msg(linear=(0.01, 0.0, 0.0)))
    assert ros.wait_for(lambda: len(loop.twists) > count + 5, 5.0)


def test_the_object_pose_sets_the_path_clearance_and_a_bad_one_is_rejected(ros, status_finder) -> None:
    # no model: no body, no check, and the node serves; a model with a body (the cup's) at the object pose: the
    # robot's path is checked against it; a pose out of the workspace is rejected and the node serves on
    loop = Loop(ros)
    loop.assist()
    assert loop.node._assist.clearance is None
    pose = pose_to_matrix((0.35, -0.25, 0.0), (0.0, 0.0, 0.0, 1.0))
    cup = ModelFiles(config_dir() / 'models').load('cup_7zone')
    loop.node._chains[0]._use_model(ModelDocument('cup_7zone', 1, '0' * 64, cup))
    object_pose = ros.publisher(PoseStamped, topics.OBJECT_POSE)
    msg = matrix_to_pose_msg(pose, frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(object_pose, msg, lambda: loop.node._assist.clearance is not None and np.allclose(
        loop.node._assist.clearance.obj_T_base @ pose, np.eye(4), atol=1e-12), 10.0)
    statuses = ros.diagnostics()
    far = matrix_to_pose_msg(pose_to_matrix((3.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), frame_id=BASE_FRAME,
                             stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(object_pose, far, lambda: status_finder(statuses, ': assistance', level=bytes([WARN]),
                                                                    text='from the base'), 10.0)
    assert np.allclose(loop.node._assist.clearance.obj_T_base @ pose, np.eye(4), atol=1e-12)  # the last good pose
    loop.assist()


def test_the_output_keeps_coming_while_the_path_is_sought_in_a_process_of_its_own(ros, monkeypatch,
                                                                                  tmp_path) -> None:
    # the node's path search held until released (a slow clearance, as long as need be), in its own process: the
    # outputs go on at alpha 0 (the operator's twist alone) while it runs; released, the path comes in over the
    # pipe and the robot assists; the node destroyed, the process has ended
    monkeypatch.setattr(path_search, 'seek_path', functools.partial(held_search.held, tmp_path))
    monkeypatch.setattr(path_search, 'STOP_TIMEOUT', 60.0)  # the node's 1 s would kill it on a loaded machine
    loop = Loop(ros)
    worker = loop.node._paths
    (tmp_path / 'armed').touch()  # after the warm-up, which seeks in this process
    try:
        deadline = time.monotonic() + 30.0
        while not (tmp_path / 'started').exists() and time.monotonic() < deadline:
            loop.feed()
            loop.operator.publish(loop.toward())
            ros.wait_for(lambda: (tmp_path / 'started').exists(), 0.02)
        assert (tmp_path / 'started').exists(), 'no path sought after the grasp, v and the joint state'
        assert int((tmp_path / 'started').read_text()) == worker.pid != os.getpid()
        count = len(loop.alphas)
        assert ros.publish_until(loop.operator, loop.toward(), lambda: len(loop.alphas) > count + 20, 10.0,
                                 period=0.01)
        assert [a.data for a in loop.alphas[count:]] == [0.0] * (len(loop.alphas) - count)
    finally:
        (tmp_path / 'release').touch()
    loop.assist()
    ros.remove(loop.node)
    assert worker.returncode == 0  # stopped by the node's destruction, not killed


def test_a_thread_priority_it_may_not_set_is_a_warning_and_the_node_serves_on(ros, monkeypatch, status_finder) -> None:
    def refused(pid: int, policy: int, param: os.sched_param) -> None:
        raise PermissionError(errno.EPERM, 'Operation not permitted')

    monkeypatch.setattr(os, 'sched_setscheduler', refused)
    statuses = ros.diagnostics()
    loop = Loop(ros, thread_priority=50)
    assert ros.wait_for(lambda: status_finder(statuses, ': assistance', level=bytes([WARN]),
                                              text='thread_priority 50 not set (PermissionError'), 10.0)
    assert os.SCHED_FIFO not in thread_policies().values()
    loop.assist()


@pytest.mark.parametrize('priority', [-1, 100])
def test_a_thread_priority_out_of_range_fails_construction(ros, priority: int) -> None:
    with pytest.raises(InvalidParameterValueException, match='thread_priority'):
        AssistanceNode(context=ros.context, parameter_overrides=[Parameter('thread_priority', value=priority)])
