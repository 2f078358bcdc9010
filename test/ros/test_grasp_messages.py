"""grasp_intent_ros.ros.grasp_messages: the messages of one planned grasp."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from native_memory import growth_over, malloc_in_use
from numpy.testing import assert_allclose

from grasp_intent_ros.method import intent
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.grasp import JOINT_NAMES, Grasp, plan_grasp
from grasp_intent_ros.mico.kinematics import BASE_FRAME, MicoKinematics
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.conversions import posterior_from_msg, stamped_array_from_msg
from grasp_intent_ros.ros.grasp_messages import grasp_messages
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
