"""In-process tests of the grasp planner node (private Context per test, see test/conftest.py).

The model is config/models/cup_7zone.yaml when it exists, else a tiny model fitted here on seeded
demonstrations around seven reachable prototype grasps (the conftest tiny models have random features,
most of which the MICO cannot reach). Expected answers come from the core planner with the same
reachability constraint the node uses (IK seeded from Home, 8 restarts, seed 0).
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import math
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from numpy.testing import assert_allclose
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from grasp_intent_ros.method.data import Demonstrations
from grasp_intent_ros.method.features import FINGERS, MICO_3F
from grasp_intent_ros.method.intent import all_zones, interpret, restrict
from grasp_intent_ros.method.model import GraspModel, structure_zones
from grasp_intent_ros.mico.collision import CollisionFree, HandCollision
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pose_to_matrix, rotation_angle
from grasp_intent_ros.mico.grasp import MIN_TRAJECTORY_TIME, ApproachReach
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.parameters import GRASP_PLANNER
from grasp_intent_ros.mico.reachability import Reachability
from grasp_intent_ros.nodes.grasp_planner import GraspPlanner
from grasp_intent_ros.objects.demos import grasp_features
from grasp_intent_ros.planning import common, planner
from grasp_intent_ros.planning.options import node_options
from grasp_intent_ros.ros import model_follower
from grasp_intent_ros.ros.conversions import (
    array_to_msg,
    model_from_msg,
    model_to_msg,
    posterior_from_msg,
    stamped_array_from_msg,
)
from grasp_intent_ros.ros.params import ParameterError
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import matrix_to_pose_msg
from grasp_intent_ros.wire.diagnostics import KEY_KERNELS_LOAD_TIME, KEY_KERNELS_LOADED_LATE
from grasp_intent_ros.wire.model_document import read_model_document
from grasp_intent_ros.wire.robot_state import pose_msg_to_matrix

REPO = Path(__file__).resolve().parents[2]
TASKS = ('usage', 'transfer', 'handover')
LABELS_7 = 'U,T,H,UT,UH,TH,UTH'
DEFAULT_POSE = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
W_GOOD = (0.9, 0.9, 0.1)
TOPICS = ('pose', 'joints', 'trajectory', 'posterior', 'features', 'markers')
UNCHECKED = [Parameter('markers_period', value=0.0), Parameter('collision_check', value=False)]
"""The rig's parameters for the tiny models (:func:`reachable_tiny_models`): their grasps are not shaped for a table."""
ANSWER = 60.0
"""Seconds :meth:`Rig.request` waits for a plan (a deadline for the wait, not a speed requirement).

A node's first plan waits for its compiled kernels to load and, in a test process's first node to read the model,
for method 'task''s precomputation of it (candidates, robustness estimate): about 1.5 CPU-seconds from the node's
creation, which a loaded 2-core machine stretches more than tenfold.
"""
METHOD = next(spec.default for spec in GRASP_PLANNER if spec.name == 'method')
OPTIONS = node_options(METHOD, *(next(spec.default for spec in GRASP_PLANNER if spec.name == name)
                                 for name in ('n_starts', 'execution_noise')))


# ---------------------------------------------------------------------------------- models
_DEG = math.pi / 180.0
_PROTOTYPES = {  # task set -> (aim, azimuth, elevation, standoff, roll, closure), object frame
    1: ((0.05, 0.0, 0.05), 0.0, 10 * _DEG, 0.03, 0.0, 1.2),
    2: ((0.0, 0.0, 0.06), 0.0, 80 * _DEG, 0.03, 0.0, 1.3),
    4: ((0.0, 0.0, 0.10), 30 * _DEG, 60 * _DEG, 0.05, math.pi, 0.6),
    3: ((0.03, 0.0, 0.05), 0.0, 40 * _DEG, 0.03, 0.0, 1.1),
    5: ((0.05, 0.0, 0.05), -30 * _DEG, 20 * _DEG, 0.05, math.pi, 0.8),
    6: ((0.0, 0.0, 0.08), -45 * _DEG, 70 * _DEG, 0.04, math.pi, 0.9),
    7: ((0.03, 0.0, 0.06), 20 * _DEG, 45 * _DEG, 0.04, math.pi, 1.0),
}


def reachable_tiny_models(per_set: int = 10, seed: int = 3) -> dict[str, GraspModel]:
    """7- and 5-zone models fitted on noisy copies of prototype grasps the MICO reaches at DEFAULT_POSE.

    Their grasps are not shaped for a table (some open the hand below it): a node serving them runs with
    ``collision_check`` off (:data:`UNCHECKED`), and :func:`core_plan` is told so.
    """
    rng = np.random.default_rng(seed)
    rows, sets = [], []
    for task_set, (aim, azimuth, elevation, standoff, roll, closure) in _PROTOTYPES.items():
        for _ in range(per_set):
            x = grasp_features(np.add(aim, rng.normal(0.0, 0.005, 3)), azimuth + rng.normal(0.0, 3 * _DEG),
                               elevation + rng.normal(0.0, 3 * _DEG), standoff + rng.normal(0.0, 0.003),
                               roll + rng.normal(0.0, 0.05), closure + rng.normal(0.0, 0.05, 3))
            rows.append(np.clip(x, MICO_3F.lower, MICO_3F.upper))
            sets.append(task_set)
    demos = Demonstrations(np.array(rows), np.array(sets), TASKS)
    return {f'cup_{s}': GraspModel.fit(demos, structure_zones(s, TASKS), name=f'cup_{s}') for s in ('7zone', '5zone')}


def as_published(model: GraspModel) -> GraspModel:
    """The model as the node reads it from model/active.

    The document rounds demonstrations to 1e-6, which moves the planner's starts: compare with the core on
    this copy.
    """
    return model_from_msg(model_to_msg(model, name=model.name, version=1)).model


@pytest.fixture(scope='module')
def tiny() -> dict[str, GraspModel]:
    return {name: as_published(m) for name, m in reachable_tiny_models().items()}


@pytest.fixture(scope='module')
def model(tiny: dict[str, GraspModel]) -> GraspModel:
    """The cup 7-zone model of config/models when it exists, else the tiny one."""
    path = REPO / 'config' / 'models' / 'cup_7zone.yaml'
    return as_published(GraspModel.load(path)) if path.is_file() else tiny['cup_7zone']


@pytest.fixture(scope='module')
def kin() -> MicoKinematics:
    return MicoKinematics()


def core_plan(kin: MicoKinematics, model: GraspModel, v_all: Any, base_T_obj: Any = DEFAULT_POSE, *,
              warm_start: Any = None, q_seed: Any = HOME_Q, checked: bool = True) -> common.PlanResult:
    """What the node computes for v over all zones: restrict, then plan with its default checks.

    The hand clear of the object's table and body (unless not ``checked``), and the arm's reach of the grasp and
    its approach.
    """
    v = restrict(v_all, all_zones(len(model.task_names)), model.zones)
    clear = CollisionFree(hand(), model.body) if checked else lambda x: True
    approach = ApproachReach(Reachability(kin, base_T_obj, q_seed, restarts=8))
    return planner.plan(model, v, method=METHOD, options=OPTIONS, warm_start=warm_start,
                        accept=lambda x: clear(x) and approach(x))


@functools.cache
def hand() -> HandCollision:
    """The MICO hand's collision geometry, built once for the module."""
    return HandCollision()


# ---------------------------------------------------------------------------------- messages
def ns(stamp: Time) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


def v_msg(values: Any, label: str | None = LABELS_7) -> Float64MultiArray:
    """V as the interpreter sends it (labelled), or raw data as ``ros2 topic pub`` does (label None).

    Any values, NaN included: the layout of :func:`array_to_msg` (which refuses to write a NaN) is filled
    with them.
    """
    data = [float(x) for x in values]
    if label is None:
        return Float64MultiArray(data=data)
    msg = array_to_msg(np.zeros(len(data)), [label])
    msg.data = data
    return msg


def pose_msg(position: Any, xyzw: Any, frame_id: str = BASE_FRAME) -> PoseStamped:
    msg = matrix_to_pose_msg(np.eye(4), frame_id=frame_id, stamp=Time())
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(c) for c in position)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = (float(c) for c in xyzw)
    return msg


@dataclass
class Plan:
    """The six outputs of one plan."""

    stamp: int
    pose: PoseStamped
    joints: JointState
    trajectory: JointTrajectory
    posterior: Any  # GraspPosterior
    features: Float64MultiArray
    markers: MarkerArray

    @property
    def x(self) -> np.ndarray:
        return stamped_array_from_msg(self.features)[2]

    @property
    def q_arm(self) -> np.ndarray:
        return np.array(self.joints.position[:6])


class Grasps:
    """Every grasp/* output received by the probe, paired by stamp."""

    def __init__(self, ros: Any) -> None:
        types = (PoseStamped, JointState, JointTrajectory, Float64MultiArray, Float64MultiArray, MarkerArray)
        topics = ('pose', 'joint_targets', 'trajectory', 'posterior', 'features', 'markers')
        self.received = {key: ros.subscribe(t, f'grasp/{topic}') for key, t, topic in zip(TOPICS, types, topics)}

    @staticmethod
    def _stamp(key: str, msg: Any) -> int:
        if key == 'posterior':
            return ns(posterior_from_msg(msg).stamp)
        if key == 'features':
            return ns(stamped_array_from_msg(msg)[0])
        if key == 'markers':
            return ns(msg.markers[0].header.stamp)
        return ns(msg.header.stamp)

    def count(self) -> int:
        return sum(len(msgs) for msgs in self.received.values())

    def _stamps(self, key: str) -> list[int]:
        """The plan stamp of each message received on one output.

        The trajectory's own stamp is zero
        ("start now"): it is published right after the joint targets of its plan, so the i-th trajectory
        belongs to the plan of the i-th joint targets.
        """
        if key == 'trajectory':
            assert all(ns(m.header.stamp) == 0 for m in self.received[key]), 'trajectory stamp is not zero'
            return [self._stamp('joints', m) for m in self.received['joints'][:len(self.received[key])]]
        return [self._stamp(key, m) for m in self.received[key]]

    def plans(self, after: int = -1) -> list[Plan]:
        """Complete plans (all six outputs) with a stamp > ``after``, oldest first."""
        by_stamp: dict[int, dict[str, Any]] = {}
        for key, msgs in self.received.items():
            for stamp, msg in zip(self._stamps(key), msgs):
                by_stamp.setdefault(stamp, {})[key] = msg
        return [Plan(stamp, **{k: (posterior_from_msg(v) if k == 'posterior' else v) for k, v in out.items()})
                for stamp, out in sorted(by_stamp.items()) if stamp > after and len(out) == len(TOPICS)]

    def stamps_after(self, after: int) -> list[int]:
        return [s for key in self.received for s in self._stamps(key) if s > after]


@dataclass
class Rig:
    ros: Any
    node: GraspPlanner
    grasps: Grasps
    statuses: list[Any]
    v_pub: Any
    model_pub: Any
    pose_pub: Any
    joints_pub: Any

    def now(self) -> int:
        return ns(self.ros.node.get_clock().now().to_msg())

    def request(self, msg: Float64MultiArray, publisher: Any = None, timeout: float = ANSWER) -> Plan:
        """Publish ``msg`` (default on intent/v) until a plan newer than now arrives; return it."""
        start = self.now()
        assert self.ros.publish_until(publisher or self.v_pub, msg, lambda: self.grasps.plans(start),
                                      timeout=timeout, period=0.5), 'no complete plan received'
        return self.grasps.plans(start)[0]

    def plans_at(self, base_T_obj: Any, after: int) -> list[Plan]:
        """Complete plans stamped after ``after`` whose grasp is at the object pose ``base_T_obj``.

        A v that :meth:`request` re-sent may still be planned after ``after`` with the object where it was.
        """
        return [p for p in self.grasps.plans(after) if np.allclose(
            pose_msg_to_matrix(p.pose, frame_id=BASE_FRAME), base_T_obj @ features_to_obj_T_ee(p.x), atol=1e-9)]

    def warn(self, reason: str) -> Callable[[], list[Any]]:
        return lambda: [s for s in self.statuses if s.level == DiagnosticStatus.WARN and reason in s.message]


@pytest.fixture
def make_rig(ros: Any) -> Callable[..., Rig]:
    def make(model: GraspModel | None, **node_kwargs: Any) -> Rig:
        # markers with every plan, so that every plan is complete (test_markers_period checks the period)
        node_kwargs.setdefault('parameter_overrides', [Parameter('markers_period', value=0.0)])
        statuses = ros.diagnostics()
        node = ros.add(GraspPlanner(context=ros.context, **node_kwargs))
        rig = Rig(ros, node, Grasps(ros), statuses, ros.publisher(Float64MultiArray, 'intent/v'),
                  ros.publisher(String, 'model/active', latched_qos()), ros.publisher(PoseStamped, 'object/pose'),
                  ros.publisher(JointState, 'joint_states'))
        if model is not None:
            rig.model_pub.publish(model_to_msg(model, name=model.name or 'model', version=1))
        return rig
    return make


@pytest.fixture
def rig(make_rig: Callable[..., Rig], model: GraspModel) -> Rig:
    return make_rig(model)


def assert_fk_reproduces_pose(kin: MicoKinematics, plan: Plan) -> None:
    base_T_ee = pose_msg_to_matrix(plan.pose, frame_id=BASE_FRAME)
    fk = kin.fk(plan.q_arm)
    assert np.linalg.norm(fk[:3, 3] - base_T_ee[:3, 3]) < 1e-3
    assert rotation_angle(fk[:3, :3], base_T_ee[:3, :3]) < 0.01


def values_of(status: Any) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


# ---------------------------------------------------------------------------------- tests
def test_v_in_grasp_out_equals_core(rig: Rig, model: GraspModel, kin: MicoKinematics) -> None:
    v = interpret(W_GOOD).v
    plan = rig.request(v_msg(v))
    assert plan.stamp == rig.grasps.plans()[0].stamp, 'the first plan (no warm start) is the one compared'
    expected = core_plan(kin, model, v)
    assert expected.status != 'rejected'
    # posterior: P over the model's zones, then w; labelled "<zones>|<tasks>"
    assert plan.posterior.zone_labels == model.zone_labels and plan.posterior.task_names == TASKS
    assert_allclose(plan.posterior.p, expected.posterior, rtol=0, atol=1e-6)
    assert_allclose(plan.posterior.w, expected.w, rtol=0, atol=1e-6)
    assert plan.features.layout.dim[1].label == ','.join(MICO_3F.names)
    assert_allclose(plan.x, expected.x, rtol=0, atol=1e-6)
    # pose = object pose composed with the feature transform; FK of the joint targets reproduces it
    assert plan.pose.header.frame_id == BASE_FRAME
    assert_allclose(pose_msg_to_matrix(plan.pose, frame_id=BASE_FRAME),
                    DEFAULT_POSE @ features_to_obj_T_ee(plan.x), atol=1e-9)
    assert list(plan.joints.name) == list(ARM_JOINTS + FINGER_JOINTS)
    assert_fk_reproduces_pose(kin, plan)
    assert_allclose(plan.joints.position[6:], plan.x[FINGERS], atol=1e-12)
    # trajectory: one point, same joints, time from the velocity limits (from Home: no joint state yet);
    # its stamp is zero ("start now"), the other outputs carry the plan stamp
    assert ns(plan.trajectory.header.stamp) == 0 < plan.stamp == ns(plan.joints.header.stamp)
    assert list(plan.trajectory.joint_names) == list(plan.joints.name)
    (point,) = plan.trajectory.points
    assert_allclose(point.positions, plan.joints.position, atol=1e-12)
    duration = point.time_from_start.sec + 1e-9 * point.time_from_start.nanosec
    expected_duration = max(MIN_TRAJECTORY_TIME, float(np.max(np.abs(plan.q_arm - HOME_Q) / kin.velocity_limits)))
    assert duration == pytest.approx(expected_duration, abs=1e-6)
    # markers: object cylinder at the object, arrow ending at the palm, three finger lines, top zones
    cylinder, arrow, fingers, text = plan.markers.markers
    assert [m.type for m in plan.markers.markers] == [Marker.CYLINDER, Marker.ARROW, Marker.LINE_LIST,
                                                      Marker.TEXT_VIEW_FACING]
    assert all(m.header.frame_id == BASE_FRAME for m in plan.markers.markers)
    assert (cylinder.pose.position.x, cylinder.pose.position.y) == pytest.approx(DEFAULT_POSE[:2, 3])
    palm = DEFAULT_POSE[:3, :3] @ plan.x[:3] + DEFAULT_POSE[:3, 3]
    assert [arrow.points[1].x, arrow.points[1].y, arrow.points[1].z] == pytest.approx(palm)
    assert len(fingers.points) == 6
    top = model.zone_labels[int(np.argmax(expected.posterior))]
    assert f'{top}  {np.max(expected.posterior):.2f}' in text.text


def test_object_pose_change_moves_the_grasp(rig: Rig, kin: MicoKinematics) -> None:
    before = rig.request(v_msg(interpret(W_GOOD).v))
    moved = pose_to_matrix((0.3, -0.25, 0.02), (0.0, 0.0, 1.0, 0.0))
    start = rig.now()
    assert rig.ros.publish_until(rig.pose_pub, pose_msg((0.3, -0.25, 0.02), (0.0, 0.0, 1.0, 0.0)),
                                 lambda: rig.plans_at(moved, start), timeout=10.0, period=0.5), \
        'no plan for the moved object'
    after = rig.plans_at(moved, start)[0]
    shift = pose_msg_to_matrix(after.pose, frame_id=BASE_FRAME)[:3, 3] - pose_msg_to_matrix(
        before.pose, frame_id=BASE_FRAME)[:3, 3]
    assert np.linalg.norm(shift) > 0.04
    assert_fk_reproduces_pose(kin, after)


def test_unreachable_object_publishes_no_targets_and_says_why(rig: Rig) -> None:
    clarifications = rig.ros.subscribe(String, 'intent/clarification')
    rig.request(v_msg(interpret(W_GOOD).v))
    start = rig.now()
    assert rig.ros.publish_until(rig.pose_pub, pose_msg((1.2, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)),
                                 rig.warn('no reachable grasp'), timeout=10.0, period=1.0)
    status = rig.warn('no reachable grasp')()[-1]
    assert status.name.endswith('grasp_planner: planning')
    assert status.message.startswith('clarification requested: no reachable grasp')
    assert 'IK failed for all' in status.message and '1.20 m from the base' in status.message
    values = {kv.key: kv.value for kv in status.values}
    assert values['last plan status'].startswith('clarification requested: no reachable grasp')
    assert rig.ros.wait_for(lambda: clarifications)
    # one clarification for the intent, however often the (unreachable) object pose is re-sent
    assert rig.ros.publish_until(rig.pose_pub, pose_msg((1.2, 0.01, 0.0), (0.0, 0.0, 1.0, 0.0)),
                                 lambda: int(values_of(rig.warn('no reachable grasp')()[-1])['plans']) >= 3, ANSWER,
                                 period=0.5)
    assert [m.data.split(':')[0] for m in clarifications] == ['no reachable grasp']
    assert 'IK failed for all' in clarifications[0].data
    assert rig.grasps.stamps_after(start) == []
    # back within reach: served again
    rig.request(pose_msg((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0)), rig.pose_pub)


def test_joint_states_seed_ik_in_any_order_nearest_branch(rig: Rig, kin: MicoKinematics) -> None:
    first = rig.request(v_msg(interpret(W_GOOD).v))
    seed = first.q_arm + np.array([2 * math.pi, 0.0, 0.0, 0.0, 0.0, -2 * math.pi])  # same pose, other branch
    assert np.all(seed >= kin.lower) and np.all(seed <= kin.upper)
    names = list(ARM_JOINTS + FINGER_JOINTS)[::-1]
    values = dict(zip(ARM_JOINTS + FINGER_JOINTS, [*seed, 0.3, 0.3, 0.3]))
    joint_state = JointState(name=names, position=[float(values[n]) for n in names])
    fingers_only = JointState(name=list(FINGER_JOINTS), position=[0.1, 0.1, 0.1])  # ignored
    start = rig.now()

    def seeded() -> list[Plan]:
        return [p for p in rig.grasps.plans(start) if np.allclose(p.q_arm, seed, atol=1e-3)]

    deadline = time.monotonic() + 10.0
    while not seeded() and time.monotonic() < deadline:
        rig.joints_pub.publish(joint_state)
        rig.joints_pub.publish(fingers_only)
        rig.v_pub.publish(v_msg(interpret(W_GOOD).v))
        rig.ros.wait_for(seeded, timeout=0.4)
    plan = seeded()[0]
    assert_fk_reproduces_pose(kin, plan)
    duration = plan.trajectory.points[0].time_from_start
    assert duration.sec + 1e-9 * duration.nanosec == pytest.approx(MIN_TRAJECTORY_TIME)
    assert not [s for s in rig.statuses if s.level != DiagnosticStatus.OK], 'a finger-only joint state is no error'


def test_joint_states_split_over_publishers_seed_ik_with_each_joints_latest_position(rig: Rig,
                                                                                      kin: MicoKinematics) -> None:
    """A real arm's driver: the arm's joints in two messages, the fingers in a third; the seed is the latest of each.

    The halves in other orders, one with a joint the suite does not know, no velocities. Until both halves have
    come, a half is noted (WARN: the joints never named), and the node keeps serving.
    """
    first = rig.request(v_msg(interpret(W_GOOD).v))
    seed = first.q_arm + np.array([2 * math.pi, 0.0, 0.0, 0.0, 0.0, -2 * math.pi])  # same pose, other branch
    halves = [JointState(name=['m1n6s300_joint_extra', ARM_JOINTS[2], ARM_JOINTS[0], ARM_JOINTS[1]],
                         position=[5.0, *seed[[2, 0, 1]].tolist()]),
              JointState(name=list(ARM_JOINTS[5:2:-1]), position=seed[5:2:-1].tolist())]
    fingers_only = JointState(name=list(FINGER_JOINTS), position=[0.1, 0.1, 0.1])
    start = rig.now()

    def seeded() -> list[Plan]:
        return [p for p in rig.grasps.plans(start) if np.allclose(p.q_arm, seed, atol=1e-3)]

    deadline = time.monotonic() + 10.0
    while not seeded() and time.monotonic() < deadline:
        for msg in (halves[0], fingers_only, halves[1]):
            rig.joints_pub.publish(msg)
        rig.v_pub.publish(v_msg(interpret(W_GOOD).v))
        rig.ros.wait_for(seeded, timeout=0.4)
    plan = seeded()[0]
    assert_fk_reproduces_pose(kin, plan)
    assert rig.warn('joint state not used: never named: ')(), 'the first half alone is noted'


def test_latest_only_burst(rig: Rig, model: GraspModel, kin: MicoKinematics) -> None:
    rig.request(v_msg(interpret(W_GOOD).v))
    before = len(rig.grasps.plans())
    burst = [interpret((0.9, t, 0.1)).v for t in np.linspace(0.05, 0.95, 100)]
    for v in burst:
        last_sent = rig.now()  # a plan stamped after it answers the last v (a grasp may answer many v alike)
        rig.v_pub.publish(v_msg(v))
        rig.ros.executor.spin_once(timeout_sec=0.0)
    checked: dict[int, bool] = {}

    def last_answers_last_v() -> bool:
        plans = rig.grasps.plans()
        if len(plans) <= before or not rig.grasps.plans(last_sent):
            return False
        if len(plans) not in checked:  # the node warm-starts from its previous plan
            expected = core_plan(kin, model, burst[-1], warm_start=plans[-2].x)
            checked[len(plans)] = (np.allclose(plans[-1].x, expected.x, atol=1e-6)
                                   and np.allclose(plans[-1].posterior.p, expected.posterior, atol=1e-6))
        return checked[len(plans)]

    assert rig.ros.wait_for(last_answers_last_v, timeout=15.0), 'the last plan does not answer the last v'
    settled = len(rig.grasps.plans())
    start = rig.now()
    rig.v_pub.publish(v_msg(interpret(W_GOOD).v))  # a marker: its plan comes after any backlog of the burst
    assert rig.ros.wait_for(lambda: rig.grasps.plans(start), timeout=10.0), 'no plan for the marker v'
    assert len(rig.grasps.plans()) == settled + 1, 'backlog: plans kept coming'
    made = settled - before
    assert 1 <= made <= 20, f'{made} plans for 100 messages'

    def superseded() -> list[Any]:  # the node itself dropped inputs that a newer one replaced
        return [s for s in rig.statuses if s.name.endswith('planning') and
                int({kv.key: kv.value for kv in s.values}.get('inputs superseded', '0')) > 0]
    assert rig.ros.wait_for(superseded, timeout=3.0)


def _corrupted(model: GraspModel) -> String:
    text = model_to_msg(model, name='cup_7zone', version=2).data
    return String(data=text.replace('prior: 0.', 'prior: 1.', 1))


BAD_INPUTS: dict[str, tuple[str, Callable[[GraspModel], Any], str]] = {
    'v wrong length': ('v', lambda m: v_msg([0.2] * 5, None), 'must have 7 entries'),
    'v NaN': ('v', lambda m: v_msg([math.nan] + [1 / 6] * 6), 'NaN or infinity'),
    'v Inf': ('v', lambda m: v_msg([math.inf] + [0.0] * 6), 'NaN or infinity'),
    'v negative': ('v', lambda m: v_msg([-0.1, 0.6, 0.5, 0.0, 0.0, 0.0, 0.0]), 'non-negative'),
    'v not summing to 1': ('v', lambda m: v_msg([0.5] * 7), 'sum to 1'),
    'v empty': ('v', lambda m: v_msg([], None), 'v is empty'),
    'v oversized': ('v', lambda m: v_msg([1 / 2000] * 2000, None), 'oversized'),
    'v unknown zone label': ('v', lambda m: v_msg(interpret(W_GOOD).v, 'U,T,H,UT,UH,TH,XYZ'),
                             "do not match the model's 3 tasks"),
    'v labels of two tasks': ('v', lambda m: v_msg([0.5, 0.3, 0.2], 'U,T,UT'), 'must name each of the 7 zones'),
    'v label count': ('v', lambda m: v_msg(interpret(W_GOOD).v, 'U,T,H,UT,UH,TH'), 'label names 6 zones'),
    'model not a document': ('model', lambda m: String(data='zones: [U, T]'), 'lacks the header lines'),
    'model corrupted': ('model', _corrupted, 'corrupted'),
    'pose quaternion': ('pose', lambda m: pose_msg((0.3, -0.3, 0.0), (0.0, 0.0, 0.0, 2.0)), 'unit norm'),
    'pose NaN': ('pose', lambda m: pose_msg((math.nan, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0)), 'must be finite'),
    'pose frame': ('pose', lambda m: pose_msg((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0), 'world'),
                   "frame 'm1n6s300_link_base'"),
    'joint_states NaN': ('joints', lambda m: JointState(name=list(ARM_JOINTS), position=[math.nan] + [1.0] * 5),
                         'NaN or infinity for'),
    'joint_states length': ('joints', lambda m: JointState(name=list(ARM_JOINTS), position=[1.0] * 5),
                            'names but 5 positions'),
    'v oversized message': ('v', lambda m: v_msg([1e-4] * 10_000, None), 'intent/v: oversized message'),
    'pose far away': ('pose', lambda m: pose_msg((1e6, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)),
                      'outside the workspace radius 1.5 m'),
    'pose 1e308': ('pose', lambda m: pose_msg((0.3, -1e308, 0.0), (0.0, 0.0, 1.0, 0.0)), 'outside the workspace'),
    'pose oversized frame id': ('pose', lambda m: pose_msg((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0), 'f' * 5000),
                                'object/pose: oversized message'),
    'joint_states absurd positions': ('joints', lambda m: JointState(
        name=list(ARM_JOINTS), position=[float(q) for q in HOME_Q + (1e6, 0.0, 0.0, 0.0, 0.0, 0.0)]),
        'joint state outside the joint limits (margin 0.1 rad): m1n6s300_joint_1 = 1e+06 rad'),
    'joint_states long names': ('joints', lambda m: JointState(name=['j' * 5000] * 10, position=[0.0] * 10),
                                'name 0 has 5000 characters'),
    'joint_states oversized': ('joints', lambda m: JointState(name=['j' * 5000] * 100, position=[0.0] * 100),
                               'joint_states: oversized message'),
}


@pytest.mark.parametrize('kind', list(BAD_INPUTS))
def test_bad_input_warns_and_node_keeps_serving(rig: Rig, model: GraspModel, kind: str) -> None:
    topic, make_msg, reason = BAD_INPUTS[kind]
    assert_rejected_and_serving(rig, model, topic, make_msg(model), reason)


@pytest.mark.parametrize('kind', ['alias bomb', 'nested too deeply', 'oversized'])
def test_weaponised_model_document_is_rejected_and_the_model_kept(
        rig: Rig, model: GraspModel, kind: str, weaponised_model_documents: Callable[..., Any]) -> None:
    text, reason = weaponised_model_documents(model)[kind]
    assert_rejected_and_serving(rig, model, 'model', String(data=text), reason)


def assert_rejected_and_serving(rig: Rig, model: GraspModel, topic: str, msg: Any, reason: str) -> None:
    """``msg`` on ``topic`` is rejected (a WARN naming ``reason``, counted) and the node plans with ``model``."""
    if topic == 'model':  # the node must hold the good model before the bad one replaces it on the latched topic
        rig.request(v_msg(interpret(W_GOOD).v))
    publisher = {'v': rig.v_pub, 'model': rig.model_pub, 'pose': rig.pose_pub, 'joints': rig.joints_pub}[topic]
    start = rig.now()
    assert rig.ros.publish_until(publisher, msg, rig.warn(reason), timeout=5.0, period=0.5), \
        f'no WARN diagnostic naming {reason!r}'
    status = rig.warn(reason)()[-1]
    values = {kv.key: kv.value for kv in status.values}
    assert reason in values['last error'] and int(values['messages rejected']) >= 1
    assert rig.grasps.stamps_after(start) == [], 'something was published for a bad input'
    plan = rig.request(v_msg(interpret((0.2, 0.9, 0.9)).v))
    assert plan.posterior.zone_labels == model.zone_labels


def test_a_plan_failing_its_checks_publishes_nothing_and_asks(rig: Rig, kin: MicoKinematics,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from grasp_intent_ros.nodes import grasp_planner

    rig.request(v_msg(interpret(W_GOOD).v))
    clarifications = rig.ros.subscribe(String, 'intent/clarification')
    real_plan_grasp = grasp_planner.plan_grasp

    def beyond_the_limits(*args: Any, **kwargs: Any) -> Any:  # an IK seed of Home + 1e14, at the output
        grasp = real_plan_grasp(*args, **kwargs)
        positions = grasp.positions.copy()
        positions[0] += 1e14
        return dataclasses.replace(grasp, positions=positions)

    monkeypatch.setattr(grasp_planner, 'plan_grasp', beyond_the_limits)
    start = rig.now()
    reason = 'no grasp published: arm joint targets outside the joint limits'
    assert rig.ros.publish_until(rig.v_pub, v_msg(interpret((0.2, 0.9, 0.9)).v), lambda: clarifications,
                                 timeout=10.0, period=1.0)
    assert [m.data.split(' (')[0] for m in clarifications] == [reason]
    assert rig.ros.wait_for(rig.warn(f'clarification requested: {reason}'))
    assert rig.grasps.stamps_after(start) == [], 'part of a failed plan was published'
    monkeypatch.setattr(grasp_planner, 'plan_grasp', real_plan_grasp)
    assert_fk_reproduces_pose(kin, rig.request(v_msg(interpret(W_GOOD).v)))  # all six outputs again


def test_clarification_needed_and_model_switch(make_rig: Callable[..., Rig], tiny: dict[str, GraspModel],
                                               kin: MicoKinematics) -> None:
    five, seven = tiny['cup_5zone'], tiny['cup_7zone']
    rig = make_rig(five, parameter_overrides=UNCHECKED)
    clarifications = rig.ros.subscribe(String, 'intent/clarification')
    h_only = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0])  # no zone of the 5-zone model is possible
    assert rig.ros.publish_until(rig.v_pub, v_msg(h_only), rig.warn('clarification requested'), period=0.5)
    status = rig.warn('clarification requested')()[-1]
    assert 'U,T,UT,TH,UTH' in status.message
    assert values_of(status)['last plan status'] == status.message
    assert rig.ros.wait_for(lambda: clarifications)
    assert all('no probability to the zones U,T,UT,TH,UTH' in m.data for m in clarifications)
    v = interpret(W_GOOD).v
    plan = rig.request(v_msg(v))
    assert plan.posterior.zone_labels == ('U', 'T', 'UT', 'TH', 'UTH')
    assert_allclose(plan.posterior.p, core_plan(kin, five, v, checked=False).posterior, atol=1e-6)
    # a new model re-plans the current v without a warm start from the other model
    switched = rig.request(model_to_msg(seven, name='cup_7zone', version=2), rig.model_pub)
    assert switched.posterior.zone_labels == tuple(LABELS_7.split(','))
    assert_allclose(switched.x, core_plan(kin, seven, v, checked=False).x, atol=1e-6)


def test_a_model_the_suite_cannot_serve_is_refused_and_every_v_clarified_until_one_is_served(
        make_rig: Callable[..., Rig], model: GraspModel) -> None:
    doc = model.to_document()
    doc['task_names'] = ['use', 'throw', 'hold']  # the same zone labels, other tasks
    other = GraspModel.from_document(doc)
    rig = make_rig(None)
    clarifications = rig.ros.subscribe(String, 'intent/clarification')
    rig.model_pub.publish(model_to_msg(other, name='other_tasks', version=1))
    refused = ("model/active: model 'other_tasks' refused: its tasks [use, throw, hold] are not the task_names "
               '[usage, transfer, handover]')
    error = lambda text: lambda: [s for s in rig.statuses if s.level == DiagnosticStatus.ERROR  # noqa: E731
                                  and s.message == f'cannot serve: {text}']
    assert rig.ros.wait_for(error(refused), 10.0), [s.message for s in rig.statuses]
    start = rig.now()
    for n in (1, 2):  # each v: one clarification with the reason, no plan
        assert rig.ros.publish_until(rig.v_pub, v_msg(interpret(W_GOOD).v), lambda n=n: len(clarifications) >= n,
                                     timeout=10.0)
    assert [m.data for m in clarifications[:2]] == [f'cannot serve: {refused}'] * 2
    assert rig.grasps.stamps_after(start) == []
    # a served model: the last v is planned, the ERROR clears
    plan = rig.request(model_to_msg(model, name='cup', version=2), rig.model_pub)
    assert plan.posterior.zone_labels == model.zone_labels
    assert rig.ros.wait_for(lambda: rig.node._inputs_diag.status().level != DiagnosticStatus.ERROR)
    # task_names the served model does not have: refused by the set itself, with the reason; planning goes on
    result = rig.node.set_parameters([Parameter('task_names', value=['use', 'throw', 'hold'])])[0]
    assert not result.successful
    assert result.reason == ("the suite could not serve its active model 'cup': its tasks [usage, transfer, "
                             'handover] are not the task_names [use, throw, hold]')
    assert tuple(rig.node.get_parameter('task_names').value) == ('usage', 'transfer', 'handover')
    assert rig.request(v_msg(interpret(W_GOOD).v)).posterior.zone_labels == model.zone_labels
    # while the newest document is refused, task_names that serve it are accepted: it is read again and used
    rig.model_pub.publish(model_to_msg(other, name='other_tasks', version=3))
    assert rig.ros.wait_for(lambda: rig.node._models.refused, 10.0)
    assert rig.node.set_parameters([Parameter('task_names', value=['use', 'throw', 'hold'])])[0].successful
    assert rig.ros.wait_for(lambda: rig.node._models.current is not None
                            and rig.node._models.current.name == 'other_tasks', 10.0)


def test_planning_goes_on_with_the_current_model_while_a_new_one_is_read(
        make_rig: Callable[..., Rig], tiny: dict[str, GraspModel], monkeypatch: pytest.MonkeyPatch) -> None:
    five, seven = tiny['cup_5zone'], tiny['cup_7zone']
    rig = make_rig(five, parameter_overrides=UNCHECKED)
    v = interpret(W_GOOD).v
    assert rig.request(v_msg(v)).posterior.zone_labels == five.zone_labels
    reading, release = threading.Event(), threading.Event()
    during: list[tuple[bool, float]] = []
    before = (gc.isenabled(), sys.getswitchinterval())

    def held(text: str, **kwargs: Any) -> Any:  # the real reader, held until the test releases it
        during.append((gc.isenabled(), sys.getswitchinterval()))
        reading.set()
        release.wait(timeout=30.0)
        return read_model_document(text, **kwargs)

    monkeypatch.setattr(model_follower, 'read_model_document', held)
    rig.model_pub.publish(model_to_msg(seven, name='cup_7zone', version=2))
    assert rig.ros.wait_for(reading.is_set), 'the new model document never reached the reader'
    # while the 7-zone model is being read, new intents are planned with the 5-zone model
    for w in ((0.2, 0.9, 0.9), (0.9, 0.9, 0.9)):
        assert rig.request(v_msg(interpret(w).v)).posterior.zone_labels == five.zone_labels
    start = rig.now()
    release.set()  # swapped in whole: the current v is planned again with the new model
    assert rig.ros.wait_for(lambda: rig.grasps.plans(start), timeout=10.0)
    assert all(p.posterior.zone_labels == seven.zone_labels for p in rig.grasps.plans(start))
    # while reading: no cyclic garbage collection, a short GIL switch interval; restored afterwards
    assert during == [(False, model_follower.READ_SWITCH_INTERVAL)]
    assert (gc.isenabled(), sys.getswitchinterval()) == before
    assert rig.ros.wait_for(lambda: [s for s in rig.statuses if float(values_of(s).get('last model read time [ms]',
                                                                                       '0')) > 0.0])


def test_unreachable_best_grasp_falls_back_to_reachable_candidate(make_rig: Callable[..., Rig],
                                                                   tiny: dict[str, GraspModel],
                                                                   kin: MicoKinematics) -> None:
    model = tiny['cup_5zone']
    rng = np.random.default_rng(0)
    # a v and an object pose whose best candidate the arm cannot reach (found with the core planner);
    # the best candidate is the match nearest to a demonstration, so the object sits near the arm's reach
    for base_T_obj in (DEFAULT_POSE, *(pose_to_matrix((x, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
                                       for x in (0.45, 0.55, 0.6))):
        for _ in range(20):
            v = interpret(rng.uniform(0.0, 1.0, 3)).v
            if v is not None and (expected := core_plan(kin, model, v, base_T_obj, checked=False)).rejected \
                    and expected.status != 'rejected':
                break
        else:
            continue
        break
    else:
        pytest.fail('no v with an unreachable best grasp found')
    rig = make_rig(model, parameter_overrides=[
        *UNCHECKED, Parameter('object_position', value=[float(c) for c in base_T_obj[:3, 3]])])
    plan = rig.request(v_msg(v))
    assert_allclose(plan.x, expected.x, atol=1e-6)
    assert expected.rejected >= 1 and not np.allclose(expected.x, expected.candidates[0].x)

    def fallback_reported() -> list[dict[str, str]]:  # every plan so far fell back (rig.request may send v twice)
        values = [{kv.key: kv.value for kv in s.values} for s in rig.statuses if s.name.endswith('planning')]
        return [v for v in values if int(v.get('fallback to a reachable candidate', '0')) >= 1
                and v.get('fallback to a reachable candidate') == v.get('plans')]
    assert rig.ros.wait_for(fallback_reported, timeout=3.0)
    assert fallback_reported()[-1]['last plan reachability'].startswith(
        f'best grasp unreachable: published candidate {expected.rejected + 1} of {len(expected.candidates)}')


def test_parameters_are_validated_and_object_pose_parameters_replan(rig: Rig) -> None:
    node = rig.node
    for name, value, reason in (('method', 'newton', 'must be one of'),
                                ('object_orientation', [0.0, 0.0, 0.0, 2.0], 'unit norm'),
                                ('object_position', [0.3, 0.0], '3 finite numbers'),
                                ('object_marker_size', [0.08, -0.1], 'positive'),
                                ('object_position', [1e6, 0.0, 0.0], 'outside the workspace radius 1.5 m'),
                                ('workspace_radius', 0.2, 'outside the workspace radius 0.2 m'),
                                ('urdf_path', '/tmp/x.urdf', 'read-only')):
        result = node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful and reason in result.reason, (name, result.reason)
    for name, value in (('n_starts', 0), ('ik_restarts', 101), ('min_replan_period', -1.0)):
        assert not node.set_parameters([Parameter(name, value=value)])[0].successful
    rig.request(v_msg(interpret(W_GOOD).v))
    moved = pose_to_matrix((0.28, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
    start = rig.now()
    assert node.set_parameters([Parameter('object_position', value=[0.28, -0.3, 0.0])])[0].successful
    assert rig.ros.wait_for(lambda: rig.plans_at(moved, start), timeout=10.0), 'no plan at the new object_position'


def test_plan_for_the_most_likely_task_plans_its_zone_alone_and_a_change_replans(
        make_rig: Callable[..., Rig], model: GraspModel, kin: MicoKinematics) -> None:
    """``plan_for: most_likely_task``: the core's plan for v on the zone of argmax w alone, whatever else v holds.

    An exact tie of w goes to the first task (v's sums put handover an ulp ahead of usage here); back to ``v``, the
    newest v is planned again as received, with no new v and not warm-started from the other target's plan; a value
    outside the two is refused.
    """
    rig = make_rig(model, parameter_overrides=[Parameter('markers_period', value=0.0),
                                               Parameter('plan_for', value='most_likely_task')])
    tie = interpret((0.67, 0.4, 0.67)).v
    assert tie is not None
    single = rig.request(v_msg(tie))
    usage, handover = (core_plan(kin, model, np.eye(7)[all_zones(3).index(zone)]) for zone in (0b001, 0b100))
    assert not np.allclose(usage.x, handover.x, atol=1e-3), 'the tie must decide between different grasps'
    assert_allclose(single.x, usage.x, rtol=0, atol=1e-6)
    start = rig.now()
    assert rig.node.set_parameters([Parameter('plan_for', value='v')])[0].successful
    assert rig.ros.wait_for(lambda: rig.grasps.plans(start), timeout=ANSWER), 'no plan after the change'
    as_received = core_plan(kin, model, tie)  # no warm start: the plans so far were for another target
    assert not np.allclose(as_received.x, usage.x, atol=1e-3), 'the intent-aware grasp differs here'
    assert_allclose(rig.grasps.plans(start)[0].x, as_received.x, rtol=0, atol=1e-6)
    result = rig.node.set_parameters([Parameter('plan_for', value='argmax')])[0]
    assert not result.successful and 'must be one of' in result.reason


def test_params_file_and_invalid_initial_parameters(ros: Any) -> None:
    node = ros.add(GraspPlanner(context=ros.context, cli_args=[
        '--ros-args', '--params-file', str(REPO / 'config' / 'grasp_planner.yaml')]))
    assert node.get_parameter('method').value == 'task'
    assert tuple(node.get_parameter('object_orientation').value) == (0.0, 0.0, 1.0, 0.0)
    with pytest.raises(ParameterError, match='unit norm'):
        GraspPlanner(context=ros.context, parameter_overrides=[
            Parameter('object_orientation', value=[0.0, 0.0, 0.5, 0.5])])
    with pytest.raises(ParameterError, match='urdf_path'):
        GraspPlanner(context=ros.context, parameter_overrides=[Parameter('urdf_path', value='/nonexistent.urdf')])


def test_send_intent_prints_the_chain_answer(rig: Rig, model: GraspModel, kin: MicoKinematics) -> None:
    from grasp_intent_ros.cli.send_intent import IntentSender, NoGrasp, format_grasp
    from grasp_intent_ros.nodes.intent_interpreter import IntentInterpreter

    rig.ros.add(IntentInterpreter(context=rig.ros.context))
    sender = rig.ros.add(IntentSender(context=rig.ros.context))
    answer = sender.send(W_GOOD, rig.ros.executor, timeout=10.0)
    assert_allclose(answer.v, interpret(W_GOOD).v, atol=1e-12)
    assert answer.v_labels == tuple(LABELS_7.split(','))
    assert_allclose(answer.posterior.p, core_plan(kin, model, interpret(W_GOOD).v).posterior, atol=1e-6)
    assert ns(answer.pose.header.stamp) == ns(answer.joints.header.stamp) == ns(answer.posterior.stamp)
    text = format_grasp(answer)
    for heading in ('w (sent)', 'v (intent/v)', 'P (grasp)', 'w (reconstructed)', 'end effector', 'joint targets'):
        assert heading in text
    assert all(name in text for name in ARM_JOINTS + FINGER_JOINTS)
    with pytest.raises(NoGrasp, match='clarification'):
        sender.send((0.1, 0.1, 0.1), rig.ros.executor, timeout=10.0)


def test_outputs_carry_no_event_handlers_and_the_inputs_one(rig: Rig) -> None:
    """The executor walks every event handler at every wake-up: none on the outputs (ros.qos.output_publisher)."""
    outputs = {pub.topic_name: pub for pub in rig.node.publishers if pub.topic_name != '/parameter_events'}
    assert {'/grasp/pose', '/grasp/joint_targets', '/grasp/markers', '/intent/clarification', '/diagnostics'} \
        <= set(outputs)
    assert all(not pub.event_handlers for pub in outputs.values())
    assert all(len(sub.event_handlers) == 1 for sub in rig.node.subscriptions), 'the incompatible-QoS warning'
    assert len(list(rig.node.waitables)) == len(list(rig.node.subscriptions)) + 2  # + /parameter_events' two


def test_markers_period(make_rig: Callable[..., Rig], model: GraspModel) -> None:
    rig = make_rig(model, parameter_overrides=[Parameter('markers_period', value=5.0)])
    first = rig.request(v_msg(interpret(W_GOOD).v))  # the first plan draws its markers
    assert len(first.markers.markers) == 4
    start = rig.now()
    rig.v_pub.publish(v_msg(interpret((0.9, 0.2, 0.1)).v))
    joints = rig.grasps.received['joints']
    assert rig.ros.wait_for(lambda: [m for m in joints if ns(m.header.stamp) > start], timeout=10.0)
    assert len(joints) >= 2
    assert len(rig.grasps.received['markers']) == 1, 'markers again within markers_period'


def test_every_compiled_kernel_loads_before_the_first_plan_and_none_after(make_rig: Callable[..., Rig],
                                                                          model: GraspModel) -> None:
    """The planning thread loads every kernel while the node waits for its first inputs, and none later.

    Loading ends a node process's start (:mod:`grasp_intent_ros.ros.startup`), which leaves the garbage
    collector of a process that did not begin one (this test's) as it was. Plans of both methods and of a
    second model then compile and load nothing (the count of kernel signatures loaded after ready).
    """
    frozen, collecting = gc.get_freeze_count(), gc.isenabled()
    rig = make_rig(None)

    def loaded(key: str) -> list[Any]:
        return [s for s in rig.statuses if key in values_of(s)]
    assert rig.ros.wait_for(lambda: loaded(KEY_KERNELS_LOAD_TIME), timeout=30.0), 'no kernel load time'
    assert float(values_of(loaded(KEY_KERNELS_LOAD_TIME)[0])[KEY_KERNELS_LOAD_TIME]) >= 0.0
    assert not rig.grasps.count(), 'nothing planned: no model and no v were sent'
    assert (gc.get_freeze_count(), gc.isenabled()) == (frozen, collecting)
    rig.model_pub.publish(model_to_msg(model, name=model.name or 'model', version=1))
    for method, w in (('task', W_GOOD), ('task', (0.2, 0.9, 0.9)), ('lm', W_GOOD)):
        assert rig.node.set_parameters([Parameter('method', value=method)])[0].successful
        rig.request(v_msg(interpret(w).v))
        assert rig.ros.wait_for(lambda: loaded(KEY_KERNELS_LOADED_LATE), timeout=10.0)
        assert values_of(loaded(KEY_KERNELS_LOADED_LATE)[-1])[KEY_KERNELS_LOADED_LATE] == '0'


def test_collision_check_turns_down_grasps_into_the_table_and_reports_the_clearance(
        make_rig: Callable[..., Rig], model: GraspModel) -> None:
    """With collision_check on (the default), a grasp whose open hand goes below the table is not published.

    One clear of it is. The table is raised 4 cm above the object's plane: every usage demonstration opens its hand
    lower than that (at most 3.3 cm above the object's plane), many transfer ones from above do not.
    """
    rig = make_rig(model, parameter_overrides=[Parameter('markers_period', value=0.0),
                                               Parameter('table_plane', value=[0.0, 0.0, 1.0, 0.04])])
    assert rig.node.get_parameter('collision_check').value is True
    clarifications = rig.ros.subscribe(String, 'intent/clarification')
    start = rig.now()
    assert rig.ros.publish_until(rig.v_pub, v_msg(interpret((0.9, 0.1, 0.1)).v),
                                 rig.warn('no grasp clear of the table and the object'), timeout=20.0, period=2.0)
    assert rig.ros.wait_for(lambda: clarifications)
    assert 'below the table' in clarifications[0].data
    assert rig.grasps.stamps_after(start) == []
    plan = rig.request(v_msg(interpret((0.1, 0.9, 0.1)).v))  # transfer, from above: clear
    assert rig.ros.wait_for(lambda: any('last grasp clearance' in values_of(s) for s in rig.statuses))
    status = next(s for s in reversed(rig.statuses) if 'last grasp clearance' in values_of(s))
    assert values_of(status)['last grasp clearance'].startswith('table ') and plan.x is not None
    # a table plane that is not one is refused with the reason, and the node keeps its own
    result = rig.node.set_parameters([Parameter('table_plane', value=[0.0, 0.0, 0.0, 1.0])])[0]
    assert not result.successful and 'non-zero normal' in result.reason
