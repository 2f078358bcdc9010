"""In-process tests of the scripted operator node (private Context per test, see test/conftest.py).

The test side plays the rest of the loop: the cup model latched on ``model/active``, a joint state stream at 100
Hz (the arm held where the test puts it), the grasp shown on ``grasp/pose``, the planner's ``grasp/trajectory``,
and the mock arm's ``grasp/execute`` and ``grasp/close`` (a fake that answers at once and records when).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from grasp_intent_ros.latest_only import left_running
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import PRE_GRASP_STANDOFF, pose_to_matrix, pre_grasp
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes import scripted_operator
from grasp_intent_ros.nodes.mock_arm import GRASP_CLOSE, GRASP_EXECUTE
from grasp_intent_ros.nodes.scripted_operator import ScriptedOperatorNode
from grasp_intent_ros.planning.options import node_default_options
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import joint_state_msg, joint_trajectory_msg, matrix_to_pose_msg
from grasp_intent_ros.ros.run import SHUTDOWN_GRACE
from grasp_intent_ros.shared_control.simulator import certain_grasp
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import ERROR, OPERATOR_COMPONENT, WARN
from grasp_intent_ros.wire.model_document import model_document

BASE_T_OBJ = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
"""The object pose of config/scripted_operator.yaml (and the planner's)."""
UT = 0b011


@pytest.fixture(scope='module')
def own() -> Grasp:
    """The operator's own grasp for usage and transfer (the node's default task set), planned as the node does."""
    model = ModelFiles(config_dir() / 'models').load('cup_7zone')
    return certain_grasp(model, UT, BASE_T_OBJ, MicoKinematics(), options=node_default_options())


def moved(pose: np.ndarray, by: tuple[float, float, float]) -> np.ndarray:
    out = pose.copy()
    out[:3, 3] += by
    return out


class Rig:
    """The node with the cup model latched, the arm at ``q`` (Home at first), the mock arm's calls recorded.

    ``chain``: the planning chain's topics (the model, the shown grasp, w) in that namespace, the arm's at the root.
    """

    def __init__(self, ros: Any, chain: str = '', **params: Any) -> None:
        self.ros = ros
        self.chain = chain
        overrides = [Parameter(k, value=v) for k, v in {'start_delay': 0.0, 'hold': 0.0, **params}.items()]
        self.node = ros.add(ScriptedOperatorNode(context=ros.context, parameter_overrides=overrides))
        self.twists = ros.subscribe(TwistStamped, topics.OPERATOR_TWIST)
        self.w = ros.subscribe(Float64MultiArray, self.topic(topics.INTENT_W))
        self.statuses = ros.diagnostics()
        self.calls: list[tuple[str, float]] = []  # (service, monotonic time of the call)
        for name in (GRASP_EXECUTE, GRASP_CLOSE):
            ros.node.create_service(Trigger, name, lambda request, response, name=name: self._call(name, response))
        self.shown = ros.publisher(PoseStamped, self.topic(topics.GRASP_POSE))
        self.q = HOME_Q.copy()
        joints = ros.publisher(JointState, topics.JOINT_STATES)
        ros.node.create_timer(0.01, lambda: joints.publish(joint_state_msg(
            ARM_JOINTS, self.q, stamp=ros.node.get_clock().now().to_msg())))
        models = ros.publisher(String, self.topic(topics.MODEL_ACTIVE), latched_qos())
        models.publish(String(data=model_document(ModelFiles(config_dir() / 'models').load('cup_7zone'),
                                                  name='cup_7zone', version=1)))

    def topic(self, name: str) -> str:
        """A topic of the planning chain."""
        return f'{self.chain}/{name}' if self.chain else name

    @property
    def closes(self) -> int:
        return sum(name == GRASP_CLOSE for name, _ in self.calls)

    def _call(self, name: str, response: Trigger.Response) -> Trigger.Response:
        self.calls.append((name, time.monotonic()))
        response.success, response.message = True, name
        return response

    def show(self, base_T_grasp: np.ndarray, until: Any, timeout: float = 10.0) -> bool:
        msg = matrix_to_pose_msg(base_T_grasp, frame_id=BASE_FRAME, stamp=self.ros.node.get_clock().now().to_msg())
        return bool(self.ros.publish_until(self.shown, msg, until, timeout, period=0.1))

    def status(self, level: bytes | None = None, text: str = '') -> Any:
        for status in reversed(self.statuses):
            if status.name.endswith(OPERATOR_COMPONENT) and (level is None or status.level == level) \
                    and text in status.message:
                return status
        return None


def linear(msg: TwistStamped) -> np.ndarray:
    return np.array([msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z])


def test_at_home_it_holds_w_and_steers_to_the_shown_grasps_pre_grasp(ros: Any, own: Grasp) -> None:
    rig = Rig(ros)
    loop = rig.node._loop
    assert ros.wait_for(lambda: loop.state == 'reaching', 30.0), rig.status()
    assert rig.show(own.base_T_ee, lambda: loop.pursued == 'shown')
    count = len(rig.twists)
    assert ros.wait_for(lambda: len(rig.twists) > count + 20, 5.0)
    hand = MicoKinematics().fk(HOME_Q)
    toward = pre_grasp(own.base_T_ee, PRE_GRASP_STANDOFF)[:3, 3] - hand[:3, 3]
    for msg in rig.twists[count:]:  # 0.12 m/s toward it, the noise's 0.01 m/s RMS on top
        assert msg.header.frame_id == BASE_FRAME
        assert float(linear(msg) @ toward) / (np.linalg.norm(linear(msg)) * np.linalg.norm(toward)) > 0.95
    assert rig.w and all(len(m.data) == 3 for m in rig.w)
    assert np.allclose(np.mean([m.data for m in rig.w], axis=0), [0.9, 0.9, 0.1], atol=0.1)
    assert ros.wait_for(lambda: rig.status(text='reaching the shown grasp'), 5.0) and rig.closes == 0


def test_it_follows_the_shown_grasp_only_near_its_own_and_closes_once_at_it(ros: Any, own: Grasp) -> None:
    rig = Rig(ros, intent='none', execute_shown=False)  # the shown grasp closed where the hand is, not executed
    loop = rig.node._loop
    assert ros.wait_for(lambda: loop.state == 'reaching', 30.0), rig.status()
    assert rig.show(moved(own.base_T_ee, (0.0, 0.0, 0.15)), lambda: loop.pursued == 'own')
    near = moved(own.base_T_ee, (0.0, 0.0, 0.003))
    assert rig.show(near, lambda: loop.pursued == 'shown')
    rig.q = own.positions[:6]  # the arm at its own grasp: 3 mm from the shown one, which it pursues
    assert ros.wait_for(lambda: rig.closes == 1 and loop.state == 'done', 5.0), (rig.calls, loop.state)
    assert [name for name, _ in rig.calls] == [GRASP_CLOSE] and not loop.closed[0].executed
    assert loop.closed[0].pursued == 'shown'
    np.testing.assert_allclose(loop.closed[0].goal, near, atol=1e-12)  # as the message carried it
    assert ros.wait_for(lambda: rig.status(text='done: episode 1 reached the shown grasp') is not None, 5.0)
    count = len(rig.twists)
    assert ros.wait_for(lambda: len(rig.twists) > count + 20, 5.0)  # it still publishes
    assert rig.closes == 1 and not any(linear(m).any() for m in rig.twists[count:])  # done: it holds still
    assert not rig.w  # intent none: another source gives w


def test_on_the_shown_grasp_it_executes_then_closes_once_the_trajectory_has_had_its_time(ros: Any, own: Grasp) -> None:
    rig = Rig(ros, intent='none')
    loop = rig.node._loop
    trajectories = ros.publisher(JointTrajectory, topics.GRASP_TRAJECTORY)
    assert ros.wait_for(lambda: loop.state == 'reaching', 30.0), rig.status()
    assert ros.publish_until(trajectories, joint_trajectory_msg(ARM_JOINTS, own.positions[:6], 0.5),
                             lambda: rig.node._calls.trajectory_time == 0.5, 10.0)
    assert rig.show(moved(own.base_T_ee, (0.0, 0.0, 0.003)), lambda: loop.pursued == 'shown')
    rig.q = own.positions[:6]
    # 'done' comes with the close's request; the rig's server counts it once its callback has run
    assert ros.wait_for(lambda: rig.closes == 1 and loop.state == 'done', 10.0), (rig.calls, loop.state)
    assert [name for name, _ in rig.calls] == [GRASP_EXECUTE, GRASP_CLOSE]
    assert rig.calls[1][1] - rig.calls[0][1] >= 0.5  # the close after the trajectory's 0.5 s (+ SETTLE)
    assert loop.closed[0].executed and loop.closed[0].pursued == 'shown'
    assert ros.wait_for(lambda: rig.status(text='reached the shown grasp') is not None, 5.0)
    assert 'execute' in {v.key for v in rig.status(text='reached the shown grasp').values}


def test_over_a_scene_it_reaches_for_its_objects_grasp_from_that_chain_and_commands_the_arm_at_the_root(
        ros: Any, own: Grasp) -> None:
    """``object: cup``: the cup chain's model, shown grasp, trajectory and pose; w on cup/intent/w; the arm's at /."""
    rig = Rig(ros, chain='cup', object='cup')
    loop = rig.node._loop
    assert ros.wait_for(lambda: loop.state == 'reaching', 30.0), rig.status()
    assert ros.wait_for(lambda: len(rig.w) >= 3, 5.0) and all(len(m.data) == 3 for m in rig.w)  # the cup's held w
    trajectories = ros.publisher(JointTrajectory, rig.topic(topics.GRASP_TRAJECTORY))
    assert ros.publish_until(trajectories, joint_trajectory_msg(ARM_JOINTS, own.positions[:6], 0.5),
                             lambda: rig.node._calls.trajectory_time == 0.5, 10.0)
    assert rig.show(moved(own.base_T_ee, (0.0, 0.0, 0.003)), lambda: loop.pursued == 'shown')
    rig.q = own.positions[:6]
    assert ros.wait_for(lambda: rig.closes == 1 and loop.state == 'done', 10.0), (rig.calls, loop.state)
    assert [name for name, _ in rig.calls] == [GRASP_EXECUTE, GRASP_CLOSE]  # the arm's services, at the root
    # the cup moved: its own grasp is planned again at the cup chain's object/pose
    poses = ros.publisher(PoseStamped, rig.topic(topics.OBJECT_POSE))
    moved_cup = moved(BASE_T_OBJ, (0.0, 0.05, 0.0))
    pose = matrix_to_pose_msg(moved_cup, frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(poses, pose,
                             lambda: np.allclose(rig.node._scenes.latest.base_T_obj, moved_cup, atol=1e-12), 10.0)


def test_an_object_that_cannot_name_a_chain_is_a_configuration_error(ros: Any) -> None:
    with pytest.raises(ValueError, match="object name 'grasp' is a folder"):
        ScriptedOperatorNode(context=ros.context, parameter_overrides=[Parameter('object', value='grasp')])


def test_on_its_own_grasp_it_closes_without_executing(ros: Any, own: Grasp) -> None:
    rig = Rig(ros, intent='none')
    loop = rig.node._loop
    assert ros.wait_for(lambda: loop.state == 'reaching', 30.0), rig.status()
    assert rig.show(moved(own.base_T_ee, (0.0, 0.0, 0.15)), lambda: loop.pursued == 'own')
    rig.q = own.positions[:6]
    assert ros.wait_for(lambda: rig.closes == 1 and loop.state == 'done', 5.0), (rig.calls, loop.state)
    assert [name for name, _ in rig.calls] == [GRASP_CLOSE] and not loop.closed[0].executed


def test_a_task_the_model_lacks_and_bad_inputs_give_diagnostics_not_a_crash(ros: Any) -> None:
    rig = Rig(ros, task_set=['usage', 'pouring'])
    error = bytes([ERROR])
    assert ros.wait_for(lambda: rig.status(error, 'no task pouring; its tasks are usage, transfer, handover'), 30.0), \
        rig.status()
    assert rig.node._loop.state == 'waiting' and not rig.w  # no grasp, no w: it waits
    assert rig.node.set_parameters([Parameter('task_set', value=['handover'])])[0].successful
    assert ros.wait_for(lambda: rig.node._loop.state == 'reaching' and rig.w, 30.0), rig.status()
    bad = matrix_to_pose_msg(np.eye(4), frame_id='map', stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(rig.shown, bad, lambda: rig.status(bytes([WARN]), 'frame'), 10.0)
    rig.q = np.full(6, np.nan)
    assert ros.wait_for(lambda: rig.status(bytes([WARN]), 'finite'), 10.0)
    count = len(rig.twists)
    assert ros.wait_for(lambda: len(rig.twists) > count + 10, 5.0)  # still publishing


def test_stopped_while_its_own_grasp_is_planned_it_is_destroyed_within_the_grace_and_publishes_nothing_after(
        ros: Any, own: Grasp, monkeypatch: pytest.MonkeyPatch) -> None:
    """The first own grasp of a model computes its robustness estimate (seconds at load): a stop does not wait for it.

    Here the plan blocks until the test releases it, after the node is destroyed; it then ends in its thread.
    """
    planning, release = threading.Event(), threading.Event()

    def slow_own_grasp(*_: Any) -> tuple[int, Grasp]:
        planning.set()
        release.wait(30.0)  # far beyond the grace: the node must be destroyed without it
        return UT, own

    monkeypatch.setattr(scripted_operator, 'own_grasp', slow_own_grasp)
    rig = Rig(ros)
    try:
        assert ros.wait_for(planning.is_set, 30.0), rig.status()
        assert ros.wait_for(lambda: len(rig.twists) > 2, 5.0)  # it runs meanwhile: zero twists, no own grasp
        start = time.monotonic()
        stop_stamp = ros.node.get_clock().now()
        ros.remove(rig.node)
        took = time.monotonic() - start
        assert took < SHUTDOWN_GRACE, f'{took:.1f} s: the stop waited for the plan'
        assert 'scripted_operator_goal' in left_running()
    finally:
        release.set()
    assert ros.wait_for(lambda: 'scripted_operator_goal' not in left_running(), 10.0)
    assert rig.node._loop.own is not None, 'the plan ended in its thread, into the destroyed node, without an error'
    assert not [m for m in rig.twists if Time.from_msg(m.header.stamp) > stop_stamp]
