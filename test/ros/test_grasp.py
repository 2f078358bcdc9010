"""grasp_intent_ros.ros.grasp: the messages of one planned grasp."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from numpy.testing import assert_allclose

from grasp_intent_ros import protocol
from grasp_intent_ros.core import intent
from grasp_intent_ros.core.frames import pose_to_matrix
from grasp_intent_ros.core.grasp import JOINT_NAMES, Grasp, plan_grasp
from grasp_intent_ros.core.kinematics import BASE_FRAME, MicoKinematics
from grasp_intent_ros.core.model import GraspModel
from grasp_intent_ros.core.resources import config_dir
from grasp_intent_ros.protocol import ModelDocument
from grasp_intent_ros.ros.conversions import posterior_from_msg, stamped_array_from_msg
from grasp_intent_ros.ros.grasp import grasp_messages
from grasp_intent_ros.ros.robot import pose_msg_to_matrix


def test_every_output_of_one_plan_carries_its_stamp() -> None:
    model = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    base_T_obj = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
    grasp = plan_grasp(model, intent.interpret((0.9, 0.9, 0.1)).v, intent.all_zones(3), base_T_obj,
                       MicoKinematics())
    assert isinstance(grasp, Grasp), grasp.note
    stamp = Time(sec=5, nanosec=6)
    doc = ModelDocument('cup_7zone', 1, '0' * 64, model)
    messages = grasp_messages(grasp, doc, base_T_obj, stamp=stamp, object_size=(0.08, 0.1))
    assert set(messages) == {*protocol.PLAN_TOPICS, protocol.GRASP_MARKERS}
    assert posterior_from_msg(messages[protocol.GRASP_POSTERIOR]).stamp == stamp
    assert stamped_array_from_msg(messages[protocol.GRASP_FEATURES])[0] == stamp
    for topic in (protocol.GRASP_POSE, protocol.GRASP_JOINT_TARGETS):
        assert messages[topic].header.stamp == stamp, topic
    assert messages[protocol.GRASP_TRAJECTORY].header.stamp == Time(), 'zero: start now'
    topics = list(messages)
    assert topics.index(protocol.GRASP_TRAJECTORY) == topics.index(protocol.GRASP_JOINT_TARGETS) + 1
    assert all(m.header.stamp == stamp for m in messages[protocol.GRASP_MARKERS].markers)
    assert_allclose(pose_msg_to_matrix(messages[protocol.GRASP_POSE], frame_id=BASE_FRAME), grasp.base_T_ee,
                    atol=1e-9)
    joints = messages[protocol.GRASP_JOINT_TARGETS]
    assert tuple(joints.name) == JOINT_NAMES and np.allclose(joints.position, grasp.positions)
    assert_allclose(posterior_from_msg(messages[protocol.GRASP_POSTERIOR]).p, grasp.result.posterior)
