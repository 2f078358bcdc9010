"""grasp_intent_ros.ros.grasp_messages: the messages of one planned grasp, its markers included."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from native_memory import growth_over, malloc_in_use
from numpy.testing import assert_allclose
from visualization_msgs.msg import Marker

from grasp_intent_ros.method import intent
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, finger_segments, pose_to_matrix
from grasp_intent_ros.mico.grasp import JOINT_NAMES, Grasp, plan_grasp
from grasp_intent_ros.mico.kinematics import BASE_FRAME, MicoKinematics
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.conversions import posterior_from_msg, stamped_array_from_msg
from grasp_intent_ros.ros.grasp_messages import grasp_markers, grasp_messages, zone_summary
from grasp_intent_ros.wire.model_document import ModelDocument
from grasp_intent_ros.wire.robot_state import pose_msg_to_matrix
from grasp_intent_ros.wire.topics import (
    GRASP_FEATURES,
    GRASP_JOINT_TARGETS,
    GRASP_MARKERS,
    GRASP_POSE,
    GRASP_POSTERIOR,
    GRASP_TRAJECTORY,
    PLAN_TOPICS,
)

BASE_T_OBJ = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))


@pytest.fixture(scope='module')
def planned() -> tuple[Grasp, ModelDocument]:
    model = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    grasp = plan_grasp(model, intent.interpret((0.9, 0.9, 0.1)).v, intent.all_zones(3), BASE_T_OBJ,
                       MicoKinematics())
    assert isinstance(grasp, Grasp), grasp.note
    return grasp, ModelDocument('cup_7zone', 1, '0' * 64, model)


def test_every_output_of_one_plan_carries_its_stamp(planned: tuple[Grasp, ModelDocument]) -> None:
    grasp, doc = planned
    stamp = Time(sec=5, nanosec=6)
    messages = grasp_messages(grasp, doc, BASE_T_OBJ, stamp=stamp, object_size=(0.08, 0.1))
    assert set(messages) == {*PLAN_TOPICS, GRASP_MARKERS}
    assert posterior_from_msg(messages[GRASP_POSTERIOR]).stamp == stamp
    assert stamped_array_from_msg(messages[GRASP_FEATURES])[0] == stamp
    for topic in (GRASP_POSE, GRASP_JOINT_TARGETS):
        assert messages[topic].header.stamp == stamp, topic
    assert messages[GRASP_TRAJECTORY].header.stamp == Time(), 'zero: start now'
    topics = list(messages)
    assert topics.index(GRASP_TRAJECTORY) == topics.index(GRASP_JOINT_TARGETS) + 1
    assert all(m.header.stamp == stamp for m in messages[GRASP_MARKERS].markers)
    assert_allclose(pose_msg_to_matrix(messages[GRASP_POSE], frame_id=BASE_FRAME), grasp.base_T_ee,
                    atol=1e-9)
    joints = messages[GRASP_JOINT_TARGETS]
    assert tuple(joints.name) == JOINT_NAMES and np.allclose(joints.position, grasp.positions)
    assert_allclose(posterior_from_msg(messages[GRASP_POSTERIOR]).p, grasp.result.posterior)


@pytest.mark.skipif(malloc_in_use() is None, reason='needs glibc mallinfo2')
def test_building_a_plans_messages_holds_no_native_memory(planned: tuple[Grasp, ModelDocument]) -> None:
    # the planner builds them per plan (markers every tenth here): grasp/pose leaked 80 bytes each (eigenpy)
    grasp, doc = planned
    growth = growth_over(lambda i: grasp_messages(grasp, doc, BASE_T_OBJ, stamp=Time(sec=i), object_size=(0.08, 0.1),
                                                  markers=i % 10 == 0), 2_000)
    assert growth is not None and growth < 50_000


def test_markers_draw_object_approach_the_shared_fingers_and_text() -> None:
    x = np.array([0.05, 0.0, 0.06, -1.0, 0.0, 0.0, 0.0, 0.4, 0.8, 1.2])
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = (0.3, -0.3, 0.0)
    base_T_ee = base_T_obj @ features_to_obj_T_ee(x)
    markers = grasp_markers(base_T_obj, base_T_ee, x[7:], 'cup\nUT  0.62', frame_id='base',
                            stamp=Time(sec=1), object_size=(0.08, 0.1)).markers
    assert [(m.id, m.type) for m in markers] == [(0, Marker.CYLINDER), (1, Marker.ARROW), (2, Marker.LINE_LIST),
                                                 (3, Marker.TEXT_VIEW_FACING)]
    assert all(m.header.frame_id == 'base' and m.header.stamp == Time(sec=1) for m in markers)
    assert_allclose([markers[0].scale.x, markers[0].scale.z], [0.08, 0.1])
    assert_allclose([markers[0].pose.position.x, markers[0].pose.position.z], [0.3, 0.05])
    tip = markers[1].points[1]
    assert_allclose([tip.x, tip.y, tip.z], base_T_ee[:3, 3], atol=1e-12)  # the arrow ends at the palm
    lines = np.array([[p.x, p.y, p.z] for p in markers[2].points]).reshape(3, 2, 3)
    ee_segments = finger_segments(x[7:])
    assert_allclose(lines, ee_segments @ base_T_ee[:3, :3].T + base_T_ee[:3, 3], atol=1e-12)
    assert markers[3].text == 'cup\nUT  0.62'


def test_zone_summary_lists_the_most_likely_zones() -> None:
    assert zone_summary(('U', 'T', 'UT'), [0.2, 0.1, 0.7], top=2) == 'UT  0.70\nU  0.20'
