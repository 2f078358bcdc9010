"""In-process tests of the viewer node: it draws what arrives, rejects bad input with a reason and keeps serving."""

from __future__ import annotations

from typing import Any

import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from grasp_intent_ros.mico.kinematics import ARM_JOINTS, HOME_Q
from grasp_intent_ros.nodes.viewer import Viewer
from grasp_intent_ros.ros.params import ParameterError
from grasp_intent_ros.ros.robot import joint_state_msg


def viewer_values(statuses: list[Any]) -> dict[str, str]:
    status = next((s for s in reversed(statuses) if s.name.endswith('viewer: viewer')), None)
    return {} if status is None else {kv.key: kv.value for kv in status.values}


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
