"""In-process tests of the viewer node: it draws what arrives, rejects bad input with a reason and keeps serving.

With ``objects``: every object's chain in one scene, a bad message on one chain stopping none.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped
from numpy.testing import assert_allclose
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray, String

from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q
from grasp_intent_ros.nodes.viewer import Viewer
from grasp_intent_ros.ros.conversions import array_to_msg, model_to_msg
from grasp_intent_ros.ros.params import ParameterError
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg

REPO = Path(__file__).resolve().parents[2]


def viewer_values(statuses: list[Any]) -> dict[str, str]:
    status = next((s for s in reversed(statuses) if s.name.endswith('viewer: viewer')), None)
    return {} if status is None else {kv.key: kv.value for kv in status.values}


def viewer_status(statuses: list[Any]) -> Any:
    return next((s for s in reversed(statuses) if s.name.endswith('viewer: viewer')), None)


def test_the_viewer_draws_good_input_and_counts_bad_input_without_stopping(ros) -> None:
    statuses = ros.diagnostics()
    viewer = ros.add(Viewer(context=ros.context, parameter_overrides=[Parameter('port', value=0)]))
    assert ros.wait_for(lambda: viewer_values(statuses).get('url', '').startswith('http://127.0.0.1:'), 10.0)
    pose_pub = ros.publisher(PoseStamped, 'object/pose')
    alpha_pub = ros.publisher(Float64, 'assistance/alpha')
    arm_pub = ros.publisher(JointState, 'joint_states')
    bad_pose = PoseStamped()
    bad_pose.header.frame_id = 'world'  # not the arm's base frame
    assert ros.publish_until(pose_pub, bad_pose, lambda: int(viewer_values(statuses).get('messages rejected', 0)) >= 1,
                             10.0)
    assert ros.publish_until(alpha_pub, Float64(data=float('inf')),
                             lambda: int(viewer_values(statuses).get('messages rejected', 0)) >= 2, 10.0)
    home = joint_state_msg(ARM_JOINTS, HOME_Q, stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(arm_pub, home, lambda: viewer._worker.latest.q_live is not None, 10.0)
    assert ros.wait_for(lambda: int(viewer_values(statuses).get('frames drawn', 0)) >= 1, 10.0)
    assert viewer._worker.latest.base_T_obj is None and viewer._worker.latest.alpha is None


def test_a_missing_urdf_is_a_configuration_error(ros, tmp_path) -> None:
    with pytest.raises(ParameterError, match='urdf_path'):
        Viewer(context=ros.context, parameter_overrides=[Parameter('port', value=0),
                                                         Parameter('urdf_path', value=str(tmp_path / 'none.urdf'))])


def test_a_viewer_of_two_objects_draws_both_chains_and_a_bad_message_on_one_warns_and_stops_neither(ros) -> None:
    """The viewer at /robot1, the cup's and the flashlight's chains below it, the arm's joint states at /robot1."""
    statuses = ros.diagnostics()
    # the object the assistance follows, latched: sent before the viewer started, shown all the same
    ros.publisher(String, '/robot1/assistance/object', latched_qos()).publish(String(data='cup'))
    viewer = ros.add(Viewer(context=ros.context, namespace='/robot1', parameter_overrides=[
        Parameter('port', value=0), Parameter('objects', value=['cup', 'flashlight'])]))
    assert ros.wait_for(lambda: viewer_values(statuses).get('url', '').startswith('http://127.0.0.1:'), 10.0)
    poses = {'cup': pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0]),
             'flashlight': pose_to_matrix([0.35, 0.25, 0.0], [0.0, 0.0, 0.0, 1.0])}
    stamp = ros.node.get_clock().now().to_msg()
    pose_pubs = {name: ros.publisher(PoseStamped, f'/robot1/{name}/object/pose') for name in poses}
    for name in poses:
        model = GraspModel.load(REPO / 'config' / 'models' / f'{name}_7zone.yaml')
        ros.publisher(String, f'/robot1/{name}/model/active', latched_qos()).publish(
            model_to_msg(model, name=f'{name}_7zone', version=1))

    def chain(name: str) -> Any:
        return viewer._worker.latest.chains[name]

    for name, base_T_obj in poses.items():
        msg = matrix_to_pose_msg(base_T_obj, frame_id=BASE_FRAME, stamp=stamp)
        assert ros.publish_until(pose_pubs[name], msg, lambda name=name: chain(name).base_T_obj is not None, 10.0)
    assert ros.wait_for(lambda: all(chain(name).model is not None for name in poses), 10.0)
    assert {name: chain(name).model.name for name in poses} == {'cup': 'cup_7zone', 'flashlight': 'flashlight_7zone'}
    for name, base_T_obj in poses.items():
        assert_allclose(chain(name).base_T_obj, base_T_obj, atol=1e-12)
    arm_pub = ros.publisher(JointState, '/robot1/joint_states')
    home = joint_state_msg(ARM_JOINTS, HOME_Q, stamp=stamp)
    assert ros.publish_until(arm_pub, home, lambda: viewer._worker.latest.arm.q_live is not None, 10.0)
    drawn = viewer._page._chains
    assert ros.wait_for(lambda: all(name in drawn and drawn[name]._body_pose is not None for name in poses), 10.0)

    # a pose in another frame on the flashlight's chain: rejected, named, WARN; nothing of either chain changes
    bad = matrix_to_pose_msg(np.eye(4), frame_id='world', stamp=stamp)
    assert ros.publish_until(pose_pubs['flashlight'], bad,
                             lambda: int(viewer_values(statuses).get('messages rejected', 0)) >= 1, 10.0)
    status = viewer_status(statuses)
    assert status.level == DiagnosticStatus.WARN and 'flashlight/object/pose: ' in status.message, status
    assert_allclose(chain('flashlight').base_T_obj, poses['flashlight'], atol=1e-12)
    # the cup moved after that: drawn at its new pose, the flashlight where it was
    moved = pose_to_matrix([0.25, -0.35, 0.0], [0.0, 0.0, 1.0, 0.0])
    assert ros.publish_until(pose_pubs['cup'], matrix_to_pose_msg(moved, frame_id=BASE_FRAME, stamp=stamp),
                             lambda: drawn['cup']._body_pose is not None and
                             np.allclose(drawn['cup']._body_pose, moved, atol=1e-12), 10.0)
    assert_allclose(drawn['flashlight']._body_pose, poses['flashlight'], atol=1e-12)
    assert {kv.key: kv.value for kv in status.values}['messages rejected'] == '1'
    # the intent estimator's P(o), at the viewer's namespace
    p_o = array_to_msg([0.7, 0.3], [['cup', 'flashlight']])
    assert ros.publish_until(ros.publisher(Float64MultiArray, '/robot1/intent/objects'), p_o,
                             lambda: viewer._worker.latest.object_probabilities == {'cup': 0.7, 'flashlight': 0.3},
                             10.0)
    assert ros.wait_for(lambda: viewer._worker.latest.followed == 'cup', 10.0)


def test_object_names_that_cannot_name_a_chain_are_a_configuration_error(ros) -> None:
    reason = r"objects: object name 'grasp' is a folder.*; object 'cup' is named twice"
    with pytest.raises(ParameterError, match=reason):
        Viewer(context=ros.context, parameter_overrides=[Parameter('port', value=0),
                                                         Parameter('objects', value=['cup', 'grasp', 'cup'])])


def test_an_oversized_message_is_rejected_by_its_size_and_the_viewer_keeps_serving(ros) -> None:
    """Every input has its topic's size cap, checked before decoding: the assistance's twist as the object's pose."""
    statuses = ros.diagnostics()
    viewer = ros.add(Viewer(context=ros.context, parameter_overrides=[Parameter('port', value=0)]))
    assert ros.wait_for(lambda: viewer_values(statuses).get('url', '').startswith('http://127.0.0.1:'), 10.0)
    rejected = lambda: int(viewer_values(statuses).get('messages rejected', 0))  # noqa: E731
    for n, (msg_type, topic) in enumerate([(PoseStamped, 'object/pose'), (TwistStamped, 'assistance/twist')], 1):
        big = msg_type()
        big.header.frame_id = BASE_FRAME + ' ' * 5000  # over the topic's 4 kB cap
        assert ros.publish_until(ros.publisher(msg_type, topic), big, lambda n=n: rejected() >= n, 10.0)
        status = viewer_status(statuses)
        assert status.level == DiagnosticStatus.WARN and f'{topic}: oversized message' in status.message, status
    assert viewer._worker.latest.base_T_obj is None and viewer._worker.latest.assistance_twist is None
    base_T_obj = pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0])
    good = matrix_to_pose_msg(base_T_obj, frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(ros.publisher(PoseStamped, 'object/pose'), good,
                             lambda: viewer._worker.latest.base_T_obj is not None, 10.0)
    assert_allclose(viewer._worker.latest.base_T_obj, base_T_obj, atol=1e-12)
    assert rejected() == 2
