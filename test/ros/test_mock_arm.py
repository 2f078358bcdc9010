"""In-process tests of the mock MICO node (private Context per test, see test/conftest.py)."""

from __future__ import annotations

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import TwistStamped
from numpy.testing import assert_allclose
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from grasp_intent_ros.mico.grasp import JOINT_NAMES
from grasp_intent_ros.mico.kinematics import BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes.mock_arm import MockArmNode
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import WARN

Q0 = np.r_[HOME_Q, 0.0, 0.0, 0.0]
END = Q0 + np.r_[0.2, -0.1, 0.15, 0.3, -0.2, 0.1, 0.9, 0.9, 0.7]


def trajectory(names, points) -> JointTrajectory:
    msg = JointTrajectory(joint_names=list(names))
    for t, positions in points:
        sec, nanosec = divmod(int(t * 1e9), 10**9)
        msg.points.append(JointTrajectoryPoint(positions=list(positions), time_from_start=Duration(sec=sec,
                                                                                                  nanosec=nanosec)))
    return msg


def latest_positions(states: list[JointState]) -> np.ndarray:
    msg = states[-1]
    index = {name: i for i, name in enumerate(msg.name)}
    return np.array([msg.position[index[name]] for name in JOINT_NAMES])


def test_the_arm_follows_a_trajectory_and_rejects_bad_ones(ros, status_finder) -> None:
    ros.add(MockArmNode(context=ros.context))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    statuses = ros.diagnostics()
    assert ros.wait_for(lambda: states, 10.0)
    assert list(states[-1].name) == list(JOINT_NAMES)
    assert_allclose(latest_positions(states), Q0, atol=0)
    pub = ros.publisher(JointTrajectory, topics.ARM_TRAJECTORY_COMMAND)
    for bad, reason in (
            (trajectory([*JOINT_NAMES[:8], 'elbow'], [(1.0, END)]), 'does not have'),
            (trajectory(JOINT_NAMES, [(1.0, END), (1.0, END)]), 'strictly increasing')):
        warned = lambda r=reason: status_finder(statuses, ': arm', level=bytes([WARN]), text=r)  # noqa: E731
        assert ros.publish_until(pub, bad, warned, 10.0)
    assert_allclose(latest_positions(states), Q0, atol=0)  # nothing moved
    duration = 1.0
    assert ros.publish_until(pub, trajectory(JOINT_NAMES, [(0.5, (Q0 + END) / 2), (duration, END)]),
                      lambda: np.any(latest_positions(states) != Q0), 10.0)
    assert ros.wait_for(lambda: np.allclose(latest_positions(states), END, atol=1e-3, rtol=0), 15.0)
    assert_allclose(latest_positions(states), END, atol=1e-3)


def test_twists_move_the_hand_until_they_stop_and_reset(ros) -> None:
    ros.add(MockArmNode(context=ros.context))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    kin = MicoKinematics()
    assert ros.wait_for(lambda: states, 10.0)
    start = kin.fk(latest_positions(states)[:6])
    pub = ros.publisher(TwistStamped, topics.ARM_TWIST_COMMAND)
    twist = TwistStamped()
    twist.header.frame_id = BASE_FRAME
    twist.twist.linear.z = 0.05
    assert ros.publish_until(pub, twist, lambda: kin.fk(latest_positions(states)[:6])[2, 3] > start[2, 3] + 0.01,
                      10.0, period=0.02)
    hand = kin.fk(latest_positions(states)[:6])
    assert_allclose(hand[:2, 3], start[:2, 3], atol=1e-3)  # straight up
    stopped = len(states)
    assert ros.wait_for(lambda: len(states) > stopped + 30, 5.0)  # 0.3 s without a twist: at rest
    assert not np.any(np.asarray(states[-1].velocity))
    client = ros.node.create_client(Trigger, 'mock_arm/reset')
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and future.result().success
    assert ros.wait_for(lambda: np.array_equal(latest_positions(states), Q0), 5.0)


def test_the_hand_closes_to_the_plans_closures_with_its_own_error(ros) -> None:
    from rclpy.parameter import Parameter

    from grasp_intent_ros.mico.kinematics import FINGER_JOINTS
    from grasp_intent_ros.nodes.mock_arm import GRASP_CLOSE
    from grasp_intent_ros.ros.robot import joint_state_msg

    arm = ros.add(MockArmNode(context=ros.context, parameter_overrides=[Parameter('closure_error', value=0.05),
                                                                        Parameter('closure_seed', value=7)]))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    client = ros.node.create_client(Trigger, GRASP_CLOSE)
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and not future.result().success  # no plan yet: nothing to close to
    plan = np.array([0.9, 1.0, 0.6])
    targets = ros.publisher(JointState, topics.GRASP_JOINT_TARGETS)
    msg = joint_state_msg(JOINT_NAMES, np.r_[HOME_Q, plan], stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(targets, msg, lambda: arm._plans.closures()[0] is not None, 5.0)
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and future.result().success
    executed = np.random.default_rng(7).normal(0.0, 0.05, 3) + plan  # the seeded error, the same draws
    assert ros.wait_for(lambda: states and np.allclose(latest_positions(states)[6:], executed, atol=1e-12), 5.0)
    assert_allclose(latest_positions(states)[:6], HOME_Q, atol=0)  # only the fingers moved
    assert FINGER_JOINTS == JOINT_NAMES[6:]


def test_a_set_closure_seed_restarts_the_closure_errors_and_a_bad_seed_is_refused_with_the_reason(ros) -> None:
    """Set at run time, even to its value, ``closure_seed`` makes the next closes draw its errors from the start."""
    from rclpy.parameter import Parameter

    from grasp_intent_ros.nodes.mock_arm import GRASP_CLOSE
    from grasp_intent_ros.ros.robot import joint_state_msg

    arm = ros.add(MockArmNode(context=ros.context, parameter_overrides=[Parameter('closure_error', value=0.05)]))
    client = ros.node.create_client(Trigger, GRASP_CLOSE)
    assert client.wait_for_service(timeout_sec=5.0)
    plan = np.array([0.9, 1.0, 0.6])
    targets = ros.publisher(JointState, topics.GRASP_JOINT_TARGETS)
    msg = joint_state_msg(JOINT_NAMES, np.r_[HOME_Q, plan], stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(targets, msg, lambda: arm._plans.closures()[0] is not None, 5.0)

    def close() -> str:
        future = client.call_async(Trigger.Request())
        assert ros.wait_for(future.done, 5.0) and future.result().success
        return future.result().message

    def closes_after_seed(seed: int) -> list[str]:
        assert arm.set_parameters([Parameter('closure_seed', value=seed)])[0].successful
        return [close() for _ in range(3)]

    first = closes_after_seed(11)
    assert closes_after_seed(11) == first and len(set(first)) == 3  # restarted: the same three draws
    draws = np.random.default_rng(11)
    for message in first:  # 'closing to a, b, c rad', 4 decimals
        executed = [float(c) for c in message.removeprefix('closing to ').removesuffix(' rad').split(', ')]
        assert_allclose(executed, plan + draws.normal(0.0, 0.05, 3), atol=5e-5)
    assert closes_after_seed(12) != first
    assert closes_after_seed(11) == first
    for bad, reason in ((-1, 'out of range'), (2**31, 'out of range'), (3.5, 'Wrong parameter type'),
                        ('7', 'Wrong parameter type')):
        result = arm.set_parameters([Parameter('closure_seed', value=bad)])[0]
        assert not result.successful and reason in result.reason, result.reason
    assert arm._params['closure_seed'] == 11
    assert close() != first[0]  # refused sets restarted nothing: the fourth draw of seed 11


def test_a_tick_after_a_signal_ended_the_context_publishes_nothing_and_reports_no_error(ros) -> None:
    """A signal shuts the context down while the timer ticks: joint_states is dropped, not an internal error."""
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros.domain_id)
    node = MockArmNode(context=context)
    errors: list[str] = []
    node._diag.rejected = lambda reason, **kw: errors.append(reason)  # type: ignore[method-assign]
    rclpy.shutdown(context=context)
    node._on_timer()
    node.destroy_node()
    assert errors == []


def test_in_the_suites_shared_control_loop_a_trajectory_moves_the_arm_only_when_asked(ros) -> None:
    """The suite's mock arm (its config and remappings): the planner's trajectory waits for grasp/execute.

    No twist arrives at all (twists lapsed longer than the command timeout): the planner's trajectory must
    not move the arm. Asked, the arm follows it through the zero twists of an operator at rest, and the
    operator's first non-zero twist takes the arm back.
    """
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.nodes.mock_arm import GRASP_EXECUTE

    arm = ros.add(MockArmNode(context=ros.context, cli_args=['--ros-args', *NodeSuite.node_args('mock_arm')]))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    assert ros.wait_for(lambda: states, 10.0)
    client = ros.node.create_client(Trigger, GRASP_EXECUTE)
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and not future.result().success  # nothing received: nothing to execute
    plans = ros.publisher(JointTrajectory, topics.GRASP_TRAJECTORY)
    assert ros.publish_until(plans, trajectory(JOINT_NAMES, [(0.5, (Q0 + END) / 2), (1.0, END)]),
                             lambda: arm._plans.trajectory()[0] is not None, 10.0)
    kept_at = len(states)
    assert ros.wait_for(lambda: len(states) > kept_at + 50, 10.0)  # 0.5 s of ticks, half the trajectory's time
    assert_allclose(latest_positions(states), Q0, atol=0)  # nothing moved
    twists = ros.publisher(TwistStamped, topics.ASSISTANCE_TWIST)
    zero = TwistStamped()
    zero.header.frame_id = BASE_FRAME
    ros.node.create_timer(0.01, lambda: twists.publish(zero))  # an operator at rest, through the assistance
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and future.result().success
    assert ros.wait_for(lambda: np.allclose(latest_positions(states), END, atol=1e-3, rtol=0), 15.0)
    assert ros.publish_until(plans, trajectory(JOINT_NAMES, [(1.0, Q0)]),
                             lambda: np.array_equal(arm._plans.trajectory()[0].positions[0], Q0), 10.0)
    future = client.call_async(Trigger.Request())
    assert ros.wait_for(future.done, 5.0) and future.result().success
    assert ros.wait_for(lambda: not np.allclose(latest_positions(states), END, atol=1e-3, rtol=0), 5.0)
    zero.twist.linear.z = 0.02  # the operator moves: the trajectory ends, the twist drives
    assert ros.wait_for(lambda: arm._arm.mode == 'twist', 5.0)


def test_with_objects_the_hand_closes_to_the_plan_of_the_object_the_assistance_follows(ros) -> None:
    from rclpy.parameter import Parameter
    from std_msgs.msg import String

    from grasp_intent_ros.nodes.mock_arm import GRASP_CLOSE
    from grasp_intent_ros.ros.qos import latched_qos
    from grasp_intent_ros.ros.robot import joint_state_msg

    arm = ros.add(MockArmNode(context=ros.context, parameter_overrides=[
        Parameter('closure_error', value=0.0), Parameter('objects', value=['cup', 'flashlight']),
        Parameter('trajectory_execution', value='on_request')]))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    client = ros.node.create_client(Trigger, GRASP_CLOSE)
    assert client.wait_for_service(timeout_sec=5.0)

    def close() -> Trigger.Response:
        future = client.call_async(Trigger.Request())
        assert ros.wait_for(future.done, 5.0)
        return future.result()

    plans = {'cup': np.array([0.9, 1.0, 0.6]), 'flashlight': np.array([0.4, 0.5, 0.3])}
    stamp = ros.node.get_clock().now().to_msg()
    cup = ros.publisher(JointState, f'cup/{topics.GRASP_JOINT_TARGETS}')
    assert ros.publish_until(cup, joint_state_msg(JOINT_NAMES, np.r_[HOME_Q, plans['cup']], stamp=stamp),
                             lambda: arm._plans._closures.get('cup') is not None, 5.0)
    refused = close()  # a plan, but no object followed yet
    assert not refused.success and topics.ASSISTANCE_OBJECT in refused.message
    followed = ros.publisher(String, topics.ASSISTANCE_OBJECT, latched_qos())
    assert ros.publish_until(followed, String(data='flashlight'), lambda: arm._plans.followed == 'flashlight', 5.0)
    refused = close()  # the flashlight followed, planned never: the cup's plan is not used
    assert not refused.success and 'flashlight' in refused.message
    flashlight = ros.publisher(JointState, f'flashlight/{topics.GRASP_JOINT_TARGETS}')
    assert ros.publish_until(flashlight, joint_state_msg(JOINT_NAMES, np.r_[HOME_Q, plans['flashlight']],
                                                         stamp=stamp),
                             lambda: arm._plans._closures.get('flashlight') is not None, 5.0)
    closed = close()
    assert closed.success and "flashlight's plan" in closed.message
    assert ros.wait_for(lambda: states and np.allclose(latest_positions(states)[6:], plans['flashlight'], atol=1e-12),
                        5.0)
    assert ros.publish_until(followed, String(data='cup'), lambda: arm._plans.followed == 'cup', 5.0)
    assert close().success
    assert ros.wait_for(lambda: np.allclose(latest_positions(states)[6:], plans['cup'], atol=1e-12), 5.0)


def test_with_objects_grasp_execute_runs_the_trajectory_of_the_object_the_assistance_follows(ros) -> None:
    """The suite's mock arm over a scene (its config and remappings): each chain's grasp/trajectory kept.

    The followed object's is executed; refused before an object is followed and before a trajectory of that one.
    """
    from std_msgs.msg import String

    from grasp_intent_ros.launch.objects import SceneObject
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.nodes.mock_arm import GRASP_EXECUTE
    from grasp_intent_ros.ros.qos import latched_qos

    objects = [SceneObject('cup', 'cup_7zone'), SceneObject('flashlight', 'flashlight_7zone')]
    arm = ros.add(MockArmNode(context=ros.context, cli_args=['--ros-args', *NodeSuite.node_args('mock_arm',
                                                                                                objects=objects)]))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    client = ros.node.create_client(Trigger, GRASP_EXECUTE)
    assert client.wait_for_service(timeout_sec=5.0)

    def execute() -> Trigger.Response:
        future = client.call_async(Trigger.Request())
        assert ros.wait_for(future.done, 5.0)
        return future.result()

    ends = {'cup': END, 'flashlight': Q0 + np.r_[-0.2, 0.1, -0.1, -0.3, 0.2, -0.1, 0.5, 0.5, 0.5]}
    cup = ros.publisher(JointTrajectory, f'cup/{topics.GRASP_TRAJECTORY}')
    assert ros.publish_until(cup, trajectory(JOINT_NAMES, [(0.5, ends['cup'])]),
                             lambda: 'cup' in arm._plans._trajectories, 5.0)
    refused = execute()  # a trajectory, but no object followed yet
    assert not refused.success and topics.ASSISTANCE_OBJECT in refused.message
    followed = ros.publisher(String, topics.ASSISTANCE_OBJECT, latched_qos())
    assert ros.publish_until(followed, String(data='flashlight'), lambda: arm._plans.followed == 'flashlight', 5.0)
    refused = execute()  # the flashlight followed, no trajectory of it: the cup's is not run
    assert not refused.success and 'flashlight' in refused.message
    assert ros.wait_for(lambda: states, 5.0)
    assert_allclose(latest_positions(states), Q0, atol=0)  # nothing moved, nor on the cup's arrival
    flashlight = ros.publisher(JointTrajectory, f'flashlight/{topics.GRASP_TRAJECTORY}')
    assert ros.publish_until(flashlight, trajectory(JOINT_NAMES, [(0.5, ends['flashlight'])]),
                             lambda: 'flashlight' in arm._plans._trajectories, 5.0)
    done = execute()
    assert done.success and "flashlight's plan" in done.message
    assert ros.wait_for(lambda: np.allclose(latest_positions(states), ends['flashlight'], atol=1e-3, rtol=0), 10.0)
    assert ros.publish_until(followed, String(data='cup'), lambda: arm._plans.followed == 'cup', 5.0)
    assert execute().success
    assert ros.wait_for(lambda: np.allclose(latest_positions(states), ends['cup'], atol=1e-3, rtol=0), 10.0)


def test_objects_with_trajectories_on_arrival_are_refused_with_the_reason(ros) -> None:
    from rclpy.parameter import Parameter

    with pytest.raises(ValueError, match='on_request'):
        MockArmNode(context=ros.context, parameter_overrides=[Parameter('objects', value=['cup'])])


def test_twist_joint_limit_stop_holds_the_arm_at_a_limit_and_is_set_at_run_time(ros) -> None:
    """With the elbow at its limit, a twist down drives it outward: 'stop' holds the arm, 'clip' lets it drift."""
    from rclpy.parameter import Parameter

    kin = MicoKinematics()
    q0 = Q0.copy()
    q0[2] = kin.lower[2]
    arm = ros.add(MockArmNode(context=ros.context, parameter_overrides=[
        Parameter('initial_positions', value=q0.tolist()), Parameter('twist_joint_limit', value='stop')]))
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    pub = ros.publisher(TwistStamped, topics.ARM_TWIST_COMMAND)
    down = TwistStamped()
    down.header.frame_id = BASE_FRAME
    down.twist.linear.z = -0.05
    assert ros.wait_for(lambda: states, 10.0)
    assert ros.publish_until(pub, down, lambda: arm._arm.mode == 'twist' and len(states) > 50, 10.0, period=0.02)
    assert_allclose(latest_positions(states), q0, atol=0)  # driven at the limit: held, every joint
    refused = arm.set_parameters([Parameter('twist_joint_limit', value='halt')])[0]
    assert not refused.successful and 'twist_joint_limit' in refused.reason
    assert arm.set_parameters([Parameter('twist_joint_limit', value='clip')])[0].successful
    assert ros.publish_until(pub, down, lambda: np.any(latest_positions(states)[:6] != q0[:6]), 10.0, period=0.02)
    assert latest_positions(states)[2] == kin.lower[2]  # the elbow clipped at its limit, the others moving on
