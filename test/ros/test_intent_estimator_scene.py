"""In-process tests of the intent estimator node over two objects (its ``objects`` parameter; docs/several_objects.md).

A cup (``cup_7zone``) and a flashlight (``flashlight_7zone``) on either side of the arm, each with its latched
``<object>/model/active`` and its ``<object>/object/pose``; the arm's ``joint_states`` and ``operator/twist`` at the
node's namespace. Private Context per test (test/conftest.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from estimator_inputs import PRIOR
from geometry_msgs.msg import PoseStamped, TwistStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from twists import twist_msg

from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.nodes.intent_estimator import IntentEstimatorNode
from grasp_intent_ros.parameters import ParameterError
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.clock import now_seconds
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg
from grasp_intent_ros.shared_control.estimator import IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.arrays import msg_labels
from grasp_intent_ros.wire.diagnostics import WARN
from grasp_intent_ros.wire.model_document import model_document

MODELS = {'cup': 'cup_7zone', 'flashlight': 'flashlight_7zone'}
POSES = {'cup': pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0)),
         'flashlight': pose_to_matrix((0.3, 0.3, 0.0), (0.0, 0.0, 1.0, 0.0))}


class Scene:
    """The estimator node over the cup and the flashlight, both models latched, both objects placed."""

    def __init__(self, ros) -> None:
        self.ros = ros
        self.node = ros.add(IntentEstimatorNode(context=ros.context, parameter_overrides=[
            Parameter('objects', value=list(MODELS))]))
        self.w = {name: ros.subscribe(Float64MultiArray, f'{name}/{topics.INTENT_W}') for name in MODELS}
        self.p = ros.subscribe(Float64MultiArray, topics.INTENT_OBJECTS)
        self.statuses = ros.diagnostics()
        self.models = ModelFiles(config_dir() / 'models')
        self.model_pubs = {name: ros.publisher(String, f'{name}/{topics.MODEL_ACTIVE}', latched_qos())
                           for name in MODELS}
        self.poses = {name: ros.publisher(PoseStamped, f'{name}/{topics.OBJECT_POSE}') for name in MODELS}
        self.joints = ros.publisher(JointState, topics.JOINT_STATES)
        self.operator = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)
        self.hand = MicoKinematics().fk(HOME_Q)

    def activate(self, name: str, model: str, version: int) -> None:
        self.model_pubs[name].publish(String(data=model_document(self.models.load(model), name=model,
                                                                 version=version)))

    def place(self, name: str) -> None:
        msg = matrix_to_pose_msg(POSES[name], frame_id=BASE_FRAME, stamp=self.ros.node.get_clock().now().to_msg())
        goals = self.node._scene.objects[name]
        assert self.ros.publish_until(self.poses[name], msg,
                                      lambda: np.array_equal(goals.base_T_obj, POSES[name]), 10.0, period=0.05)

    def at_home(self) -> None:
        stamp = self.ros.node.get_clock().now().to_msg()
        assert self.ros.publish_until(self.joints, joint_state_msg(ARM_JOINTS, HOME_Q, stamp=stamp),
                                      lambda: self.node._q is not None, 10.0)

    def toward_cup(self, task_set: int) -> np.ndarray:
        """A twist at 0.1 m/s from the hand at Home toward the cup's first goal serving exactly ``task_set``."""
        goals = goals_at(self.models.load('cup_7zone'), POSES['cup'])
        direction = goals.positions[int(np.flatnonzero(goals.task_sets == task_set)[0])] - self.hand[:3, 3]
        return 0.1 * direction / np.linalg.norm(direction)

    def still(self) -> bool:
        """No twist waiting, and the last one older than the operator timeout: the estimate no longer changes."""
        last = self.node._timing.arrival
        return len(self.node._inputs) == 0 and last is not None and \
            now_seconds(self.node) - last > self.node._params['operator_timeout']

    def p_of(self, msg: Float64MultiArray) -> dict[str, float]:
        (names,) = msg_labels(msg)
        return dict(zip(names, msg.data, strict=True))


@pytest.fixture
def scene(ros) -> Scene:
    scene = Scene(ros)
    for name in MODELS:
        scene.place(name)
        scene.activate(name, MODELS[name], 1)
    assert ros.wait_for(lambda: all(scene.w.values()) and scene.p and len(scene.p[-1].data) == 2, 120.0), \
        'no prior w of both objects'
    return scene


def in_range(scene: Scene) -> bool:
    """Every w and P(o) received is a probability strictly within (0, 1); each P(o) sums to 1."""
    ws = [v for msgs in scene.w.values() for msg in msgs for v in msg.data]
    ps = [msg.data for msg in scene.p]
    return all(0.0 < v < 1.0 for v in ws) and all(0.0 < v <= 1.0 for p in ps for v in p) \
        and all(abs(sum(p) - 1.0) < 1e-12 for p in ps)


def test_a_reach_for_the_cups_usage_grasp_raises_p_cup_and_its_w_usage(ros, scene: Scene) -> None:
    assert scene.p_of(scene.p[-1]) == pytest.approx({'cup': 0.5, 'flashlight': 0.5}, abs=1e-12)
    for name in MODELS:
        np.testing.assert_allclose(scene.w[name][-1].data, [PRIOR] * 3, rtol=1e-12)
    scene.at_home()
    flashlight_count = len(scene.w['flashlight'])
    assert ros.publish_until(scene.operator, twist_msg(scene.toward_cup(1)),
                             lambda: scene.w['cup'][-1].data[0] > PRIOR + 0.1
                             and scene.p_of(scene.p[-1])['cup'] > 0.9, 20.0, period=0.01)
    assert len(scene.w['flashlight']) > flashlight_count, 'the flashlight\'s w goes out with the cup\'s'
    assert in_range(scene)
    assert scene.node._scene.objects['cup'].restarts == scene.node._scene.objects['flashlight'].restarts == 1


def test_a_new_model_on_one_object_restarts_that_object_only(ros, scene: Scene) -> None:
    scene.at_home()
    assert ros.publish_until(scene.operator, twist_msg(scene.toward_cup(1)),
                             lambda: scene.p_of(scene.p[-1])['cup'] > 0.9, 20.0, period=0.01)
    objects = scene.node._scene.objects
    flashlight = objects['flashlight'].estimator
    assert flashlight is not None and flashlight.updates > 0
    assert ros.wait_for(scene.still, 10.0)
    evidence = flashlight.evidence.copy()
    count = len(scene.p)  # no more while the operator is still
    scene.activate('cup', 'cup_5zone', 2)
    assert ros.wait_for(lambda: objects['cup'].restarts == 2 and len(scene.p) > count, 60.0)
    assert ros.wait_for(lambda: scene.p_of(scene.p[-1]).keys() == set(MODELS), 10.0)  # the cup back with its prior
    assert objects['flashlight'].restarts == 1 and objects['flashlight'].estimator is flashlight
    np.testing.assert_array_equal(flashlight.evidence, evidence)  # kept: no twist since
    assert objects['cup'].estimator is not None and objects['cup'].estimator.updates == 0
    prior = IntentEstimator(goals_at(scene.models.load('cup_5zone'), POSES['cup'])).w  # every goal reachable
    np.testing.assert_allclose(scene.w['cup'][-1].data, prior, rtol=1e-12)  # the cup's restart: its prior
    # the cup's evidence is gone (log mass 0), the flashlight's kept: P(o) is the softmax of the two
    log_p = flashlight.log_prior + flashlight.evidence
    mass = log_p.max() + np.log(np.exp(log_p - log_p.max()).sum())
    assert abs(mass) > 1.0, 'the flashlight\'s evidence must tell P(o) from 1/2 (and the labels apart)'
    assert scene.p_of(scene.p[-1]) == pytest.approx({'cup': 1 / (1 + np.exp(mass)),
                                                     'flashlight': 1 / (1 + np.exp(-mass))}, rel=1e-9, abs=1e-300)


def test_bad_input_on_one_object_is_a_warning_and_the_other_is_served(ros, scene: Scene, status_finder) -> None:
    warn = bytes([WARN])
    far = matrix_to_pose_msg(pose_to_matrix((30.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), frame_id=BASE_FRAME,
                             stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(scene.poses['flashlight'], far, lambda: status_finder(
        scene.statuses, ': intent estimator', level=warn, text='flashlight/object/pose'), 10.0)
    prior = ros.publisher(Float64MultiArray, f'flashlight/{topics.INTENT_PRIOR}')
    assert ros.publish_until(prior, Float64MultiArray(data=[np.nan, 0.5, 0.5]), lambda: status_finder(
        scene.statuses, ': intent estimator', level=warn, text='flashlight/intent/prior'), 10.0)
    scene.model_pubs['flashlight'].publish(String(data='not a model document'))
    assert ros.wait_for(lambda: status_finder(scene.statuses, ': intent estimator', text='flashlight/model/active'),
                        10.0)
    objects = scene.node._scene.objects
    assert objects['flashlight'].estimator is not None, 'a refused document keeps the model served'
    np.testing.assert_array_equal(objects['flashlight'].base_T_obj, POSES['flashlight'])
    scene.at_home()
    assert ros.publish_until(scene.operator, twist_msg(scene.toward_cup(1)),
                             lambda: scene.w['cup'][-1].data[0] > PRIOR + 0.1, 20.0, period=0.01)
    assert in_range(scene)
    assert scene.node._scene.objects['cup'].restarts == 1
    # another publisher on one object's w is named
    ros.publisher(Float64MultiArray, f'cup/{topics.INTENT_W}')
    assert ros.wait_for(lambda: status_finder(scene.statuses, ': intent estimator', level=warn,
                                              text=f'other publisher(s) on cup/{topics.INTENT_W}'), 10.0)


def test_until_an_objects_goals_are_ready_p_is_over_the_ready_objects_only(ros) -> None:
    scene = Scene(ros)
    scene.place('cup')
    scene.activate('cup', 'cup_7zone', 1)
    assert ros.wait_for(lambda: scene.w['cup'] and scene.p, 60.0)
    assert scene.p_of(scene.p[-1]) == {'cup': 1.0}
    assert not scene.w['flashlight']
    scene.at_home()
    assert ros.publish_until(scene.operator, twist_msg(scene.toward_cup(1)),
                             lambda: scene.w['cup'][-1].data[0] > PRIOR + 0.1, 20.0, period=0.01)
    assert all(scene.p_of(msg) == {'cup': 1.0} for msg in scene.p) and not scene.w['flashlight']
    status = scene.node._diag.status()
    values = {kv.key: kv.value for kv in status.values}
    assert values['flashlight: P(o)'].startswith('none') and values['cup: P(o)'] == '1'
    assert 'flashlight: waiting for flashlight/model/active' in status.message


def test_object_names_that_cannot_be_namespaces_are_refused_at_start(ros) -> None:
    with pytest.raises(ParameterError, match=r"'grasp' is a folder of the suite's topics.*'cup' is named twice"):
        IntentEstimatorNode(context=ros.context, parameter_overrides=[
            Parameter('objects', value=['grasp', 'cup', 'cup'])])
