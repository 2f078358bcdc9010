"""The viewer's scene: posed primitives, the state built from messages, the panel and the page (no browser).

In test/ros because the state reads rclpy messages (through :mod:`grasp_intent_ros.ros.robot`); nothing
here creates a node.
"""

from __future__ import annotations

import socket
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import TwistStamped
from numpy.testing import assert_allclose
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray, String

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.method.features import FINGERS, MICO_3F
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, matrix_to_pose, pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.objects.demos import CUP, CUP_PROTOTYPES, CUP_RULES, grasp_features
from grasp_intent_ros.ros.conversions import array_to_msg, model_to_msg, posterior_to_msg, stamped_array_to_msg
from grasp_intent_ros.ros.robot import joint_state_msg, matrix_to_pose_msg
from grasp_intent_ros.scene.geometry import ArmModel, body_shapes, table_shape
from grasp_intent_ros.scene.page import ScenePage
from grasp_intent_ros.scene.panel import panel_html
from grasp_intent_ros.scene.plan import served_tasks
from grasp_intent_ros.scene.state import (
    ARM_TOPICS,
    CHAIN_TOPICS,
    SCENE_TOPICS,
    VIEWER_TOPICS,
    ObjectsState,
    SceneState,
    apply,
    apply_objects,
    apply_to,
    followed_topics,
)
from grasp_intent_ros.sessions.playback import load_timeline
from grasp_intent_ros.sessions.report_data import load_report_data
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.arrays import Posterior

REPO = Path(__file__).resolve().parents[2]
STAMP = Time(sec=12, nanosec=345)


@pytest.fixture(scope='module')
def arm() -> ArmModel:
    return ArmModel()


@pytest.fixture(scope='module')
def cup() -> GraspModel:
    return GraspModel.load(REPO / 'config' / 'models' / 'cup_7zone.yaml')


def prototype_x(task_set: int) -> np.ndarray:
    proto = CUP_PROTOTYPES[task_set][0]
    return grasp_features(proto.aim, proto.azimuth, proto.elevation, proto.standoff, proto.roll, proto.closures)


# ------------------------------------------------------------------------------------------ geometry
def test_the_arm_is_drawn_where_the_planner_s_kinematics_put_it(arm: ArmModel) -> None:
    kin = MicoKinematics()
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(kin.lower, kin.upper)
        assert_allclose(arm.ee_pose(q), kin.fk(q), atol=1e-12)
    shapes = arm.shapes(HOME_Q)
    assert len(shapes) == 18 and {s.kind for s in shapes} == {'box', 'cylinder'}
    base = next(s for s in shapes if s.name.startswith('m1n6s300_link_base'))
    assert_allclose(base.base_T_shape[:3, 3], [0.0, 0.0, 0.05], atol=1e-12)  # the URDF's visual origin
    assert base.size == pytest.approx((0.05, 0.05, 0.10))


def test_fingers_close_as_told_and_the_arm_does_not_move(arm: ArmModel) -> None:
    open_, closed = arm.shapes(HOME_Q, [0.0, 0.0, 0.0]), arm.shapes(HOME_Q, [1.2, 1.2, 1.2])
    for a, b in zip(open_, closed):
        moved = not np.allclose(a.base_T_shape, b.base_T_shape, atol=1e-9)
        assert moved == ('finger' in a.name), a.name
    with pytest.raises(GraspIntentError):
        arm.shapes([np.nan] * 6)


def test_the_cup_s_body_stands_on_the_object_frame(cup: GraspModel) -> None:
    assert cup.body is not None
    base_T_obj = pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0])
    shape, *handle = body_shapes(cup.body, base_T_obj)
    assert shape.kind == 'cylinder' and shape.size == pytest.approx((0.04, 0.04, 0.10))
    assert [s.kind for s in handle] == ['box'] * 3
    assert_allclose(shape.base_T_shape[:3, 3], [0.3, -0.3, 0.05], atol=1e-12)
    assert_allclose(shape.base_T_shape[:3, 2], [0.0, 0.0, 1.0], atol=1e-12)


def test_the_handle_and_the_table_are_drawn_where_the_collision_check_has_them() -> None:
    base_T_obj = pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0])  # the handle turned toward the arm: -x
    shapes = body_shapes(CUP.body(), base_T_obj)
    assert [s.kind for s in shapes] == ['cylinder', 'box', 'box', 'box']
    outer = shapes[2]  # the handle's outer bar: x from 0.062 to 0.070 m in the object frame, turned by pi
    assert_allclose(outer.base_T_shape[:3, 3], [0.3 - 0.066, -0.3, 0.05], atol=1e-12)
    table = table_shape(base_T_obj)
    assert table.kind == 'box' and table.base_T_shape[2, 3] + 0.5 * table.size[2] == pytest.approx(0.0, abs=1e-15)


# ------------------------------------------------------------------------------------------ state
def test_a_plan_s_messages_give_the_arm_targets_grasp_and_the_object_pose_it_implies(cup: GraspModel) -> None:
    base_T_obj = pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0])
    x = prototype_x(0b011)
    base_T_ee = base_T_obj @ features_to_obj_T_ee(x)
    state = apply(SceneState(), topics.MODEL_ACTIVE, model_to_msg(cup, name='cup_7zone', version=2))
    state = apply(state, topics.GRASP_POSE, matrix_to_pose_msg(base_T_ee, frame_id=BASE_FRAME, stamp=STAMP))
    assert state.object_pose is None  # the features of that plan have not arrived
    state = apply(state, topics.GRASP_FEATURES, stamped_array_to_msg(x, list(MICO_3F.names), stamp=STAMP))
    assert state.object_pose is not None
    assert_allclose(state.object_pose, base_T_obj, atol=1e-9)
    targets = joint_state_msg(ARM_JOINTS + FINGER_JOINTS, [*HOME_Q, *x[FINGERS]], stamp=STAMP)
    state = apply(state, topics.GRASP_JOINT_TARGETS, targets)
    assert_allclose(state.q_target, HOME_Q)
    assert_allclose(state.fingers_target, x[FINGERS])
    assert state.served == tuple(n for i, n in enumerate(cup.task_names) if CUP_RULES.label(x) >> i & 1)
    assert state.model is not None and state.model.version == 2


def test_joint_states_from_two_publishers_fill_arm_and_fingers() -> None:
    state = apply(SceneState(), topics.JOINT_STATES, joint_state_msg(ARM_JOINTS, HOME_Q, stamp=STAMP))
    state = apply(state, topics.JOINT_STATES, joint_state_msg(FINGER_JOINTS, [0.1, 0.2, 0.3], stamp=STAMP))
    assert_allclose(state.q_live, HOME_Q)
    assert_allclose(state.fingers_live, [0.1, 0.2, 0.3])


def test_joint_states_naming_some_joints_each_fill_the_arm_once_every_joint_was_named() -> None:
    """A driver that publishes the arm's joints in two messages, in other orders, among joints it does not know."""
    q = HOME_Q + 0.1
    first = JointState(name=['m1n6s300_joint_extra', *ARM_JOINTS[2::-1]], position=[7.0, *q[2::-1]])
    state = apply(SceneState(), topics.JOINT_STATES, first)
    assert state.q_live is None and state.fingers_live is None
    state = apply(state, topics.JOINT_STATES, JointState(name=list(ARM_JOINTS[:2:-1]), position=q[:2:-1].tolist()))
    assert_allclose(state.q_live, q, rtol=0.0, atol=0.0)
    state = apply(state, topics.JOINT_STATES, JointState(name=[ARM_JOINTS[4]], position=[0.5]))
    assert_allclose(state.q_live, [*q[:4], 0.5, q[5]], rtol=0.0, atol=0.0)
    assert state.fingers_live is None


def test_bad_messages_raise_and_leave_the_state_as_it_was() -> None:
    state = apply(SceneState(), topics.OPERATOR_TWIST, TwistStamped())
    bad_pose = matrix_to_pose_msg(np.eye(4), frame_id='world', stamp=STAMP)
    bad_alpha = Float64(data=float('nan'))
    bad_targets = joint_state_msg(FINGER_JOINTS, [0.0, 0.0, 0.0], stamp=STAMP)
    for topic, msg in ((topics.OBJECT_POSE, bad_pose), (topics.ASSISTANCE_ALPHA, bad_alpha),
                       (topics.GRASP_JOINT_TARGETS, bad_targets), (topics.MODEL_ACTIVE, String(data='no model'))):
        with pytest.raises(GraspIntentError):
            apply(state, topic, msg)
    assert state.operator_twist is not None and not state.operator_twist.any()


def test_the_plan_status_is_the_planner_s_and_others_are_ignored() -> None:
    def array(name: str, key: str, value: str) -> DiagnosticArray:
        return DiagnosticArray(status=[DiagnosticStatus(name=name, values=[KeyValue(key=key, value=value)])])
    state = apply(SceneState(), topics.DIAGNOSTICS, array('/grasp_planner: planning', 'last plan status', 'ok'))
    state = apply(state, topics.DIAGNOSTICS, array('/intent_interpreter: intent', 'last plan status', 'other'))
    assert state.plan_status == 'ok'


def test_tasks_are_served_by_the_object_s_rules_only_when_the_object_is_known(cup: GraspModel) -> None:
    """The object is the one the model document names (its ``object``), never guessed from the model's name."""
    x = prototype_x(0b001)
    tasks = CUP_RULES.task_names
    expected = tuple(n for i, n in enumerate(tasks) if CUP_RULES.label(x) >> i & 1)
    assert cup.object_name == 'cup'
    assert served_tasks(cup, x) == served_tasks(replace(cup, name='mug_7zone'), x) == expected
    assert served_tasks(replace(cup, object_name='mug'), x) is None
    assert served_tasks(replace(cup, object_name=''), x) is None
    assert served_tasks(replace(cup, task_names=('a', 'b', 'c')), x) is None


# ------------------------------------------------------------------------------------------ panel and page
def test_the_panel_names_every_zone_with_v_and_p_and_escapes_text(cup: GraspModel) -> None:
    p = np.linspace(0.0, 0.6, 7)
    state = SceneState(posterior=Posterior(None, cup.zone_labels, p, cup.task_names, np.array([.9, .8, .1])),
                       v=p + 0.35, v_labels=cup.zone_labels, clarification='<b>which task?</b>')
    html = panel_html(state)
    for label, v_k, p_k in zip(cup.zone_labels, p + 0.35, p):
        row = html[html.index(f'>{label}<'):]
        assert row.index(f'{v_k:.2f}') < row.index(f'{p_k:.2f}') < row.index('</tr>')
    assert '&lt;b&gt;which task?&lt;/b&gt;' in html and '<b>which task?</b>' not in html
    assert 'waiting for the suite' in panel_html(SceneState())


def test_the_panel_names_the_green_ghost_only_when_a_plan_drew_it(cup: GraspModel) -> None:
    state = apply(SceneState(), topics.MODEL_ACTIVE, model_to_msg(cup, name='cup_7zone', version=1))
    assert 'no joint_states yet' in panel_html(state) and 'ghost' not in panel_html(state)  # a bag's t = 0
    planned = replace(state, q_target=HOME_Q, fingers_target=np.zeros(3))
    assert 'no joint_states yet (the green ghost is the plan)' in panel_html(planned)


def test_the_page_is_served_on_loopback_and_draws_any_state(arm: ArmModel, cup: GraspModel) -> None:
    page = ScenePage(arm, port=0)
    try:
        assert page.server.get_host() == '127.0.0.1'
        assert page.server.request_share_url() is None  # no tunnel from viser's public relay
        with socket.create_connection(('127.0.0.1', page.port), timeout=5):
            pass
        x = prototype_x(0b011)
        state = apply(SceneState(), topics.MODEL_ACTIVE, model_to_msg(cup, name='cup_7zone', version=1))
        page.show(state)
        state = apply(state, topics.JOINT_STATES, joint_state_msg(ARM_JOINTS, HOME_Q, stamp=STAMP))
        state = apply(state, topics.GRASP_POSTERIOR, posterior_to_msg(np.full(7, 1 / 7), [.5, .5, .5],
                                                                      cup.zone_labels, cup.task_names, stamp=STAMP))
        state = apply(state, topics.GRASP_POSE, matrix_to_pose_msg(features_to_obj_T_ee(x), frame_id=BASE_FRAME,
                                                                   stamp=STAMP))
        state = apply(state, topics.GRASP_FEATURES, stamped_array_to_msg(x, list(MICO_3F.names), stamp=STAMP))
        state = apply(state, topics.OPERATOR_TWIST, TwistStamped())
        page.show(state)
        page.show(state, time_text='t = 1.0 s')
        assert 'UTH' in page._panel.content and 't = 1.0 s' in page._panel.content
    finally:
        page.stop()


# ------------------------------------------------------------------------------------------ several objects
CUP_POSE = pose_to_matrix([0.3, -0.3, 0.0], [0.0, 0.0, 1.0, 0.0])
FLASHLIGHT_POSE = pose_to_matrix([0.35, 0.25, 0.0], [0.0, 0.0, 0.0, 1.0])


@pytest.fixture(scope='module')
def flashlight() -> GraspModel:
    return GraspModel.load(REPO / 'config' / 'models' / 'flashlight_7zone.yaml')


def diagnostic(name: str, status: str) -> DiagnosticArray:
    values = [KeyValue(key='last plan status', value=status)]
    return DiagnosticArray(status=[DiagnosticStatus(name=name, values=values)])


def chain_messages(model: GraspModel, name: str, base_T_obj: np.ndarray, x: np.ndarray, stamp: Time
                   ) -> list[tuple[str, object]]:
    """One chain's model, object pose, v and a complete plan of grasp ``x`` (object frame) at ``base_T_obj``."""
    p = np.linspace(0.05, 0.25, len(model.zone_labels))
    return [
        (topics.MODEL_ACTIVE, model_to_msg(model, name=name, version=1)),
        (topics.OBJECT_POSE, matrix_to_pose_msg(base_T_obj, frame_id=BASE_FRAME, stamp=stamp)),
        (topics.INTENT_V, array_to_msg(p + 0.5, [list(model.zone_labels)])),
        (topics.GRASP_POSTERIOR, posterior_to_msg(p, [0.5, 0.5, 0.5], model.zone_labels, model.task_names,
                                                  stamp=stamp)),
        (topics.GRASP_POSE, matrix_to_pose_msg(base_T_obj @ features_to_obj_T_ee(x), frame_id=BASE_FRAME,
                                               stamp=stamp)),
        (topics.GRASP_FEATURES, stamped_array_to_msg(x, list(MICO_3F.names), stamp=stamp)),
        (topics.GRASP_JOINT_TARGETS, joint_state_msg(ARM_JOINTS + FINGER_JOINTS, [*HOME_Q, *x[FINGERS]], stamp=stamp)),
    ]


def two_objects(cup: GraspModel, flashlight: GraspModel) -> ObjectsState:
    """The cup's and the flashlight's chains at /robot1, their messages interleaved, the arm's joint state once."""
    state = ObjectsState.empty(['cup', 'flashlight'], '/robot1')
    cup_msgs = chain_messages(cup, 'cup_7zone', CUP_POSE, prototype_x(0b011), STAMP)
    flashlight_msgs = chain_messages(flashlight, 'flashlight_7zone', FLASHLIGHT_POSE, prototype_x(0b001),
                                     Time(sec=13, nanosec=0))
    for (topic, msg), (other_topic, other) in zip(cup_msgs, flashlight_msgs):
        state = apply_objects(apply_objects(state, 'cup', topic, msg), 'flashlight', other_topic, other)
    return apply_objects(state, None, topics.JOINT_STATES, joint_state_msg(ARM_JOINTS, HOME_Q, stamp=STAMP))


def test_each_object_s_chain_keeps_its_own_state_and_the_arm_is_one(cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    chains = state.chains
    assert list(chains) == ['cup', 'flashlight'] and state.chain_namespace('cup') == '/robot1/cup'
    assert chains['cup'].model.name == 'cup_7zone' and chains['flashlight'].model.name == 'flashlight_7zone'
    assert_allclose(chains['cup'].object_pose, CUP_POSE, atol=1e-12)
    assert_allclose(chains['flashlight'].object_pose, FLASHLIGHT_POSE, atol=1e-12)
    assert_allclose(chains['cup'].x, prototype_x(0b011)) and chains['cup'].plan_stamp == (12, 345)
    assert_allclose(chains['flashlight'].x, prototype_x(0b001)) and chains['flashlight'].plan_stamp == (13, 0)
    assert_allclose(state.arm.q_live, HOME_Q)
    assert all(chain.q_live is None for chain in chains.values()), 'the arm is one, not a chain\'s'
    # a topic of the arm given to a chain, a chain's given to the arm: neither changes anything
    moved_arm = joint_state_msg(ARM_JOINTS, HOME_Q + 0.1, stamp=STAMP)
    assert apply_objects(state, 'cup', topics.JOINT_STATES, moved_arm) is state
    assert apply_objects(state, None, topics.INTENT_W, Float64MultiArray(data=[0.5] * 3)) is state


def test_the_followed_topics_are_the_viewer_s_for_one_chain_and_the_arm_s_once_in_a_scene() -> None:
    assert followed_topics([]) == tuple((None, topic) for topic in VIEWER_TOPICS)
    pairs = followed_topics(['cup', 'flashlight'])
    shared = [topic for chain, topic in pairs if chain is None]
    assert sorted(shared) == sorted([*ARM_TOPICS, *SCENE_TOPICS, topics.DIAGNOSTICS])
    for name in ('cup', 'flashlight'):
        assert [topic for chain, topic in pairs if chain == name] == list(CHAIN_TOPICS)
    assert len(pairs) == len(set(pairs)) == len(shared) + 2 * len(CHAIN_TOPICS)


def test_every_topic_the_viewer_follows_has_the_suite_s_type_and_a_size_cap() -> None:
    """The live viewer reads each with its type and cap from wire.topics (ros.inputs.subscribe_input)."""
    for topic, msgtype in {**VIEWER_TOPICS, **SCENE_TOPICS}.items():
        assert topics.MSGTYPES[topic] == msgtype and topic in topics.MAX_MESSAGE_BYTES, topic


def test_apply_to_gives_a_scene_s_message_to_its_chain_and_one_chain_s_to_it(cup: GraspModel,
                                                                            flashlight: GraspModel) -> None:
    pose = matrix_to_pose_msg(CUP_POSE, frame_id=BASE_FRAME, stamp=STAMP)
    moved = apply_to(two_objects(cup, flashlight), 'flashlight', topics.OBJECT_POSE, pose)
    assert isinstance(moved, ObjectsState)
    assert_allclose(moved.chains['flashlight'].object_pose, CUP_POSE, atol=1e-12)
    assert_allclose(moved.chains['cup'].object_pose, CUP_POSE, atol=1e-12)  # as it was
    one = apply_to(SceneState(), None, topics.OBJECT_POSE, pose)
    assert isinstance(one, SceneState) and one.object_pose is not None
    assert_allclose(one.object_pose, CUP_POSE, atol=1e-12)


def test_each_chain_shows_its_own_planner_s_status(cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    for name, status in (('/robot1/flashlight/grasp_planner: planning', 'no reachable grasp'),
                         ('/robot1/cup/grasp_planner: planning', 'ok'),
                         ('/cup/grasp_planner: planning', 'another suite\'s'),
                         ('/robot1/cup/intent_interpreter: intent', 'not a planner\'s')):
        state = apply_objects(state, None, topics.DIAGNOSTICS, diagnostic(name, status))
    assert {name: chain.plan_status for name, chain in state.chains.items()} == {
        'cup': 'ok', 'flashlight': 'no reachable grasp'}
    assert apply_objects(state, None, topics.DIAGNOSTICS, diagnostic('/robot1/cup/model_server: model', 'x')) is state


def test_a_bad_message_on_one_chain_changes_no_chain(cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    bad_pose = matrix_to_pose_msg(np.eye(4), frame_id='world', stamp=STAMP)
    with pytest.raises(GraspIntentError):
        apply_objects(state, 'flashlight', topics.OBJECT_POSE, bad_pose)
    moved = apply_objects(state, 'cup', topics.OBJECT_POSE, matrix_to_pose_msg(FLASHLIGHT_POSE, frame_id=BASE_FRAME,
                                                                                  stamp=STAMP))
    assert_allclose(moved.chains['cup'].object_pose, FLASHLIGHT_POSE, atol=1e-12)
    assert moved.chains['flashlight'] is state.chains['flashlight'] and moved.arm is state.arm


def test_the_panel_shows_each_object_s_v_p_and_w_under_its_name(cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    state = apply_objects(state, None, topics.DIAGNOSTICS, diagnostic('/robot1/flashlight/grasp_planner: planning',
                                                                      'no reachable grasp'))
    html = panel_html(state)
    cup_part = html[html.index('object <b>cup</b> (/robot1/cup)'):html.index('object <b>flashlight</b>')]
    flashlight_part = html[html.index('object <b>flashlight</b> (/robot1/flashlight)'):]
    for part, model, name in ((cup_part, cup, 'cup_7zone'), (flashlight_part, flashlight, 'flashlight_7zone')):
        assert f'model <b>{name}</b>' in part
        for label, p_k in zip(model.zone_labels, np.linspace(0.05, 0.25, len(model.zone_labels))):
            row = part[part.index(f'>{label}<'):]
            assert row.index(f'{p_k + 0.5:.2f}') < row.index(f'{p_k:.2f}') < row.index('</tr>')
    assert 'plan: no reachable grasp' in flashlight_part and 'plan:' not in cup_part
    assert 'no joint_states yet' not in html and 'ghost' not in html
    empty = ObjectsState.empty(['cup', 'flashlight'])
    assert 'waiting for the suite' in panel_html(empty) and 'object <b>cup' not in panel_html(empty)
    one = empty.with_chain('flashlight', lambda s: replace(s, clarification='which task?'))
    assert 'object <b>cup</b> (/cup)</div><div>no model, intent or plan yet' in panel_html(one)
    assert 'live arm: no joint_states yet' in panel_html(one)


def test_the_intent_estimator_s_p_of_each_object_is_shown_beside_its_name(cup: GraspModel,
                                                                          flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    assert state.object_probabilities == {} and 'P(o)' not in panel_html(state)
    seen = apply_objects(state, None, topics.INTENT_OBJECTS, array_to_msg([0.83, 0.17], [['cup', 'flashlight']]))
    assert seen.object_probabilities == {'cup': 0.83, 'flashlight': 0.17} and seen.chains is state.chains
    html = panel_html(seen)
    assert 'object <b>cup</b> (/robot1/cup, P(o) = 0.83)' in html
    assert 'object <b>flashlight</b> (/robot1/flashlight, P(o) = 0.17)' in html
    # the flashlight's goals not ready: only the cup is in the estimate, and only the cup shows one
    one = apply_objects(seen, None, topics.INTENT_OBJECTS, array_to_msg([1.0], [['cup']]))
    assert one.object_probabilities == {'cup': 1.0}
    assert 'object <b>flashlight</b> (/robot1/flashlight)<' in panel_html(one)
    for bad in (array_to_msg([0.5, 0.5], [['cup', 'bottle']]),  # not an object of this scene
                array_to_msg([1.2, -0.2], [['cup', 'flashlight']]),  # not probabilities
                Float64MultiArray(data=[0.5, 0.5])):  # no names
        with pytest.raises(GraspIntentError, match='intent/objects'):
            apply_objects(seen, None, topics.INTENT_OBJECTS, bad)


def test_the_object_the_assistance_follows_is_marked_beside_its_name(cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    assert state.followed == '' and 'follows' not in panel_html(state)
    cup_followed = apply_objects(state, None, topics.ASSISTANCE_OBJECT, String(data='cup'))
    assert cup_followed.followed == 'cup' and cup_followed.chains is state.chains
    html = panel_html(cup_followed)
    assert 'object <b>cup</b> (/robot1/cup) ◀ the assistance follows it</div>' in html
    assert 'object <b>flashlight</b> (/robot1/flashlight)</div>' in html
    switched = apply_objects(cup_followed, None, topics.ASSISTANCE_OBJECT, String(data='flashlight'))
    assert 'object <b>flashlight</b> (/robot1/flashlight) ◀ the assistance follows it' in panel_html(switched)
    assert 'object <b>cup</b> (/robot1/cup)</div>' in panel_html(switched)
    with pytest.raises(GraspIntentError, match="'bottle' is not one of the objects"):
        apply_objects(switched, None, topics.ASSISTANCE_OBJECT, String(data='bottle'))


def test_the_page_draws_each_object_with_its_grasp_at_its_own_pose_and_the_arm_once(
        arm: ArmModel, cup: GraspModel, flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    page = ScenePage(arm, port=0)
    try:
        page.show(state)
        for name, base_T_obj, x in (('cup', CUP_POSE, prototype_x(0b011)),
                                    ('flashlight', FLASHLIGHT_POSE, prototype_x(0b001))):
            drawing = page._chains[name]
            position, xyzw = matrix_to_pose(base_T_obj @ features_to_obj_T_ee(x))
            assert drawing._grasp.visible and drawing._fingers is not None, name
            assert_allclose(drawing._grasp.position, position, atol=1e-6)
            assert_allclose(np.abs(np.dot(drawing._grasp.wxyz, np.roll(xyzw, 1))), 1.0, atol=1e-6)
            body = body_shapes(state.chains[name].model.model.body, base_T_obj)
            assert len(drawing._body) == len(body), name
            for handle, shape in zip(drawing._body, body):
                assert handle.visible and handle.name.startswith(f'/objects/{name}/object/')
                assert_allclose(handle.position, shape.base_T_shape[:3, 3], atol=1e-6)
            assert_allclose(drawing._table.position, table_shape(base_T_obj).base_T_shape[:3, 3], atol=1e-6)
            assert drawing._label.visible and drawing._label.position[:2] == pytest.approx(base_T_obj[:2, 3])
        assert all(handle.visible for handle in page._live)
        assert not any(handle.visible for handle in page._ghost), 'no planned arm in a scene of several objects'
        assert 'object <b>cup</b>' in page._panel.content and 'object <b>flashlight</b>' in page._panel.content
    finally:
        page.stop()


def test_a_chain_that_cannot_be_drawn_leaves_the_others_drawn(arm: ArmModel, cup: GraspModel,
                                                              flashlight: GraspModel) -> None:
    state = two_objects(cup, flashlight)
    bad = state.with_chain('cup', lambda s: replace(s, base_T_ee=np.full((4, 4), np.nan)))
    page = ScenePage(arm, port=0)
    try:
        with pytest.raises(GraspIntentError, match='^cannot draw cup: '):
            page.show(bad)
        assert page._chains['flashlight']._grasp.visible and not page._chains['cup']._grasp.visible
        page.show(state)  # the next state is drawn whole
        assert page._chains['cup']._grasp.visible
    finally:
        page.stop()


# ------------------------------------------------------------------------------------------ playback
def test_a_session_s_timeline_holds_each_plan_complete_at_its_time() -> None:
    bag = REPO / 'bags' / 'cup_paper_cases'
    timeline = load_timeline(bag)
    posteriors = [post for _, post in load_report_data(bag).posteriors]  # the report's own reading
    assert len(timeline.plans) == len(posteriors) and not timeline.unreadable
    for k, (t_ns, post) in enumerate(zip(timeline.plans, posteriors), start=1):
        seconds = (t_ns - timeline.start) * 1e-9
        state = timeline.at(seconds)
        assert state.plan_stamp == post.stamp and timeline.plan_index(seconds) == k
        assert_allclose(state.posterior.p, post.p, rtol=0, atol=0)
        assert state.q_target is not None and state.object_pose is not None
    assert timeline.at(-1.0) == SceneState() and timeline.plan_index(-1.0) == 0
    assert timeline.at(timeline.duration) is timeline.states[-1]


def test_unreadable_messages_of_a_session_are_skipped_and_counted() -> None:
    timeline = load_timeline(REPO / 'bags' / 'bad_inputs')
    assert sum(timeline.unreadable.values()) > 0 and len(timeline.plans) > 0
