"""In-process tests of the intent estimator node (private Context per test, see test/conftest.py)."""

from __future__ import annotations

import numpy as np
import pytest
from estimator_inputs import PRIOR
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from twists import twist_msg

from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes.intent_estimator import IntentEstimatorNode
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.clock import now_seconds
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg
from grasp_intent_ros.shared_control.calibration import calibrate
from grasp_intent_ros.shared_control.estimator import IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import WARN
from grasp_intent_ros.wire.model_document import model_document

BASE_T_OBJ = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))


class Rig:
    """The estimator node with the cup model latched and the arm at Home."""

    def __init__(self, ros, **params) -> None:
        self.ros = ros
        overrides = [Parameter(k, value=v) for k, v in params.items()]
        self.node = ros.add(IntentEstimatorNode(context=ros.context, parameter_overrides=overrides))
        self.w = ros.subscribe(Float64MultiArray, topics.INTENT_W)
        self.statuses = ros.diagnostics()
        self.models = ModelFiles(config_dir() / 'models')
        self.model_pub = ros.publisher(String, topics.MODEL_ACTIVE, latched_qos())
        self.joints = ros.publisher(JointState, topics.JOINT_STATES)
        self.operator = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)
        self.object = ros.publisher(PoseStamped, topics.OBJECT_POSE)
        self.hand = MicoKinematics().fk(HOME_Q)

    def activate(self, name: str, version: int) -> None:
        self.model_pub.publish(String(data=model_document(self.models.load(name), name=name, version=version)))

    def at_home(self) -> None:
        stamp = self.ros.node.get_clock().now().to_msg()
        assert self.ros.publish_until(self.joints, joint_state_msg(ARM_JOINTS, HOME_Q, stamp=stamp),
                                      lambda: self.node._q is not None, 10.0)

    def toward(self, task_set: int) -> np.ndarray:
        """A twist at 0.1 m/s from the hand at Home toward the first goal serving exactly ``task_set``."""
        goals = goals_at(self.models.load('cup_7zone'), BASE_T_OBJ)
        direction = goals.positions[int(np.flatnonzero(goals.task_sets == task_set)[0])] - self.hand[:3, 3]
        return 0.1 * direction / np.linalg.norm(direction)


@pytest.fixture
def rig(ros) -> Rig:
    rig = Rig(ros)
    rig.activate('cup_7zone', 1)
    assert ros.wait_for(lambda: rig.w, 60.0), 'no prior w after the model'
    return rig


def test_the_prior_then_motion_toward_a_usage_grasp_raises_w_usage(ros, rig: Rig) -> None:
    np.testing.assert_allclose(rig.w[-1].data, [PRIOR] * 3, rtol=1e-12)
    rig.at_home()
    twist = twist_msg(rig.toward(1))
    assert ros.publish_until(rig.operator, twist, lambda: rig.w[-1].data[0] > PRIOR + 0.1, 20.0, period=0.01)
    assert all(0.0 < v < 1.0 for msg in rig.w for v in msg.data)
    # the operator lets go: w goes out until the last twist is operator_timeout old, then no more (the estimate kept);
    # read on the node's own clock and publish timer, so a loaded machine's late ticks only lengthen the wait
    node, published = rig.node, rig.node._published
    timeout, period = node._params['operator_timeout'], node._params['publish_period']
    timer = next(t for t in node.timers if t.timer_period_ns == round(period * 1e9))

    def last_tick() -> float:
        """The node-clock time (s) of the publish timer's last tick."""
        return now_seconds(node) - timer.time_since_last_call() * 1e-9

    assert ros.wait_for(lambda: last_tick() > node._timing.arrival + timeout and not node._fresh, 10.0)
    idle = node._published
    assert idle - published <= 5  # the ticks within operator_timeout of the last twist, and the last twist's
    since = last_tick()
    # the ticks of five more periods (five, or fewer when the machine is late: a late timer skips the missed ones)
    assert ros.wait_for(lambda: last_tick() > since + 5 * period, 10.0)
    assert node._published == idle, 'w went out after the operator let go'
    assert ros.wait_for(lambda: rig.w[-1].data.tolist() == node._estimator.w.tolist(), 10.0)  # the estimate kept


def test_a_moved_object_and_a_new_model_restart_from_the_prior(ros, rig: Rig) -> None:
    rig.at_home()
    assert ros.publish_until(rig.operator, twist_msg(rig.toward(1)), lambda: rig.w[-1].data[0] > PRIOR + 0.1,
                             20.0, period=0.01)
    assert rig.node._object.restarts == 1
    nudged = matrix_to_pose_msg(pose_to_matrix((0.3, -0.3, 0.005), (0.0, 0.0, 1.0, 0.0)), frame_id=BASE_FRAME,
                                stamp=ros.node.get_clock().now().to_msg())
    received = rig.node._diag._received
    assert ros.publish_until(rig.object, nudged, lambda: rig.node._diag._received > received + 2, 10.0, period=0.05)
    np.testing.assert_array_equal(rig.node._object.base_T_obj, BASE_T_OBJ)  # within the tolerance: kept
    moved = matrix_to_pose_msg(pose_to_matrix((0.3, -0.25, 0.0), (0.0, 0.0, 1.0, 0.0)), frame_id=BASE_FRAME,
                               stamp=ros.node.get_clock().now().to_msg())
    count = len(rig.w)
    rig.object.publish(moved)
    # the restart is counted just before its prior is published: wait for that w too
    assert ros.wait_for(lambda: rig.node._object.restarts == 2 and len(rig.w) > count, 60.0)
    np.testing.assert_allclose(rig.w[-1].data, [PRIOR] * 3, rtol=1e-12)
    rig.activate('cup_5zone', 2)
    assert ros.wait_for(lambda: rig.node._object.restarts == 3, 60.0)
    assert rig.node._estimator is not None and rig.node._estimator.updates == 0


def test_bad_input_is_rejected_and_another_w_publisher_is_reported(ros, rig: Rig, status_finder) -> None:
    warn = bytes([WARN])
    rig.at_home()
    bad = twist_msg(np.array([np.nan, 0.0, 0.0]))
    assert ros.publish_until(rig.operator, bad, lambda: status_finder(rig.statuses, ': intent estimator', level=warn,
                                                                       text='finite'), 10.0)
    far = matrix_to_pose_msg(pose_to_matrix((30.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), frame_id=BASE_FRAME,
                             stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(rig.object, far, lambda: status_finder(rig.statuses, ': intent estimator', level=warn,
                                                                    text='workspace'), 10.0)
    assert ros.publish_until(rig.operator, twist_msg(rig.toward(1)), lambda: rig.w[-1].data[0] > PRIOR + 0.05, 20.0,
                             period=0.01)
    ros.publisher(Float64MultiArray, topics.INTENT_W)
    assert ros.wait_for(lambda: status_finder(rig.statuses, ': intent estimator', level=warn,
                                              text='other publisher'), 10.0)


def prior_w(model: str, w: list[float]) -> np.ndarray:
    """The library's w at the start with the classifier's ``w`` as the prior (every goal reachable from Home)."""
    estimator = IntentEstimator(goals_at(ModelFiles(config_dir() / 'models').load(model), BASE_T_OBJ))
    estimator.set_task_prior(w)
    return estimator.w


def test_a_classifiers_w_on_intent_prior_is_the_prior_at_once_and_across_restarts(ros, rig: Rig,
                                                                                   status_finder) -> None:
    prior = ros.publisher(Float64MultiArray, topics.INTENT_PRIOR)
    expected = prior_w('cup_7zone', [0.9, 0.9, 0.1])
    assert expected[0] > 0.85 and expected[2] < 0.15
    assert ros.publish_until(prior, Float64MultiArray(data=[0.9, 0.9, 0.1]),
                             lambda: np.allclose(rig.w[-1].data, expected, rtol=1e-12, atol=0), 10.0), \
        'the posterior on the new prior goes out without any motion'
    warn = bytes([WARN])
    assert ros.publish_until(prior, Float64MultiArray(data=[1.5, 0.5, 0.5]),
                             lambda: status_finder(rig.statuses, ': intent estimator', level=warn, text='[0, 1]'), 10.0)
    assert ros.publish_until(prior, Float64MultiArray(data=[0.5, 0.5]),
                             lambda: status_finder(rig.statuses, ': intent estimator', level=warn, text='3 probab'),
                             10.0)
    np.testing.assert_array_equal(rig.node._object._task_prior, [0.9, 0.9, 0.1])  # the last good one is kept
    rig.activate('cup_5zone', 2)
    assert ros.wait_for(lambda: rig.node._object.restarts == 2 and np.allclose(rig.w[-1].data, prior_w('cup_5zone',
                        [0.9, 0.9, 0.1]), rtol=1e-12, atol=0), 60.0), 'the restart starts from the classifier\'s prior'


def test_stamped_twists_act_for_their_stamps_difference_whenever_they_arrive(ros, rig: Rig) -> None:
    rig.at_home()
    assert ros.wait_for(lambda: rig.node._estimator is not None, 60.0)
    estimator = rig.node._estimator
    reference = IntentEstimator(estimator.goals, estimator.config)
    linear = rig.toward(1)
    for k in range(5):  # stamped 0.01 s apart, delivered whenever the previous one was taken
        twist = twist_msg(linear)
        twist.header.stamp = Time(seconds=100.0 + 0.01 * k).to_msg()
        updates = estimator.updates
        rig.operator.publish(twist)
        assert ros.wait_for(lambda: estimator.updates > updates, 10.0)
        # the first twist has no previous stamp: it acts for max_dt
        reference.update(rig.hand, np.r_[linear, 0.0, 0.0, 0.0], estimator.config.max_dt if k == 0 else 0.01)
    # the stamps' difference is 0.01 s up to rounding at 100 s (about 1e-14 s); arrival times differ by ms
    np.testing.assert_allclose(estimator.evidence, reference.evidence, rtol=0.0, atol=1e-9)


def test_the_shown_grasp_is_the_proposal_and_survives_a_restart(ros, rig: Rig) -> None:
    """grasp/pose (the planner's grasp, on the operator's screen) reaches the estimate with the next twist.

    And the next estimate after a restart.

    A pose in another frame is rejected and changes nothing.
    """
    rig.at_home()
    goals = goals_at(rig.models.load('cup_7zone'), BASE_T_OBJ)
    shown = np.eye(4)
    shown[:3, :3], shown[:3, 3] = goals.rotations[0], goals.positions[0]
    grasps = ros.publisher(PoseStamped, topics.GRASP_POSE)

    def proposal() -> np.ndarray | None:
        estimator = rig.node._estimator
        return None if estimator is None or estimator._proposal is None else estimator._proposal[0][0]

    msg = matrix_to_pose_msg(shown, frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(grasps, msg, lambda: rig.node._object.proposal is not None, 10.0, period=0.05)
    assert proposal() is None  # taken with the twists
    assert ros.publish_until(rig.operator, twist_msg(np.zeros(3)), lambda: proposal() is not None, 10.0, period=0.05)
    np.testing.assert_allclose(proposal(), goals.positions[0], rtol=0, atol=1e-9)
    near = rig.node._estimator._proposal[2]
    assert near[0] and 1 < near.sum() < near.size, 'the shown goal and some, not all, others are near it'
    rig.activate('cup_5zone', 2)
    assert ros.wait_for(lambda: rig.node._object.restarts == 2, 60.0)
    np.testing.assert_allclose(proposal(), goals.positions[0], rtol=0, atol=1e-9)
    wrong = matrix_to_pose_msg(np.eye(4), frame_id='elsewhere', stamp=ros.node.get_clock().now().to_msg())
    rejected = rig.node._diag._rejected
    assert ros.publish_until(grasps, wrong, lambda: rig.node._diag._rejected > rejected, 10.0, period=0.05)
    np.testing.assert_allclose(proposal(), goals.positions[0], rtol=0, atol=1e-9)


def test_a_listed_models_marginals_are_mapped_and_another_models_not(ros) -> None:
    rig = Rig(ros, calibration_models=['cup_7zone'], calibration_slopes=[2.0], calibration_offsets=[0.5])
    rig.activate('cup_7zone', 1)
    assert ros.wait_for(lambda: rig.w, 60.0), 'no prior w after the model'
    np.testing.assert_allclose(rig.w[-1].data, [float(calibrate(PRIOR, 2.0, 0.5, 0.01))] * 3, rtol=1e-12)
    count = len(rig.w)
    rig.activate('cup_5zone', 2)  # no map listed: its prior unmapped
    assert ros.wait_for(lambda: len(rig.w) > count, 60.0)
    estimator = rig.node._estimator
    assert estimator is not None
    np.testing.assert_allclose(rig.w[-1].data, IntentEstimator(estimator.goals).w, rtol=0, atol=0)
