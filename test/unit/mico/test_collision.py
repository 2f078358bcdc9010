"""The hand's clearance from the table and the object (mico/collision.py) and the planner turning grasps down."""

from __future__ import annotations

import math
import subprocess
import sys

import coal
import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import KinematicsError
from grasp_intent_ros.method import intent
from grasp_intent_ros.method.body import ObjectBody
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.collision import (
    HAND_PARTS,
    LIMITS,
    CollisionFree,
    HandCollision,
    Limits,
)
from grasp_intent_ros.mico.frames import default_base_T_obj, features_to_obj_T_ee
from grasp_intent_ros.mico.grasp import Grasp, NoReachableGrasp, plan_grasp
from grasp_intent_ros.mico.grasp_clearance import Table
from grasp_intent_ros.mico.kinematics import EE_FRAME, MicoKinematics, default_urdf_path
from grasp_intent_ros.objects.demos import CUP, FLASHLIGHT, grasp_features
from grasp_intent_ros.resources import config_dir

CUP_BODY = CUP.body()
CYLINDER_ONLY = ObjectBody(CUP_BODY.primitives[:1])
BASE_T_OBJ = default_base_T_obj()
SIDE_THUMB_SIDEWAYS = math.pi / 2
"""Roll of a horizontal approach from +x with the thumb along +y: the fingers close in the horizontal plane."""


HISTORY_THEN_PROBE = """
import sys
import coal
import numpy as np
import pinocchio as pin
import grasp_intent_ros.mico.collision

def distance(a, a_R, a_t, b, b_R, b_t):
    return coal.distance(a, coal.Transform3s(a_R, np.array(a_t, dtype=float)), b,
                         coal.Transform3s(b_R, np.array(b_t, dtype=float)), coal.DistanceRequest(),
                         coal.DistanceResult())

turned, box, rod = pin.exp3(np.array([0.3, -0.5, 0.7])), coal.Box(0.01, 0.02, 0.03), coal.Cylinder(0.01, 0.02)
if sys.argv[1] == 'box first':
    distance(box, np.eye(3), (0, 0, 0), rod, np.eye(3), (0, 0, 0.5))
elif sys.argv[1] == 'box second':
    distance(rod, np.eye(3), (0, 0, 0.5), box, turned, (0, 0, 0))
palm_R = np.array([[-0.1376543286683126, -0.7079285619128521, -0.692739804707999],
                   [-0.9904802835695544, 0.0981699296833075, 0.09649597279653077],
                   [-0.00030603733521738136, 0.6994282065615991, -0.7147027985164]])
print(distance(coal.Cylinder(0.04, 0.16), palm_R, (0.11298218437660074, -0.02612667782358058, 0.14792122388138707),
               coal.Box(0.008, 0.012, 0.05), np.eye(3), (0.066, 0.0, 0.05)).hex())
"""
"""The palm's cylinder against a cup handle's bar (a pose of a closed-loop run), after a history in a fresh process:
none, a box query whose first support direction is an axis of the box's frame, one whose is not."""


def test_a_distance_does_not_depend_on_the_queries_its_process_ran_before() -> None:
    """The same coal query, after each history, in fresh processes that imported mico.collision: equal bit for bit.

    Without the import's pin, coal's box support function keeps the inflation its first direction set, and the
    query after the axis-aligned history differs from the others in its last digits.
    """
    runs = [subprocess.Popen([sys.executable, '-c', HISTORY_THEN_PROBE, history], stdout=subprocess.PIPE, text=True)
            for history in ('none', 'box first', 'box second')]
    outputs = [run.communicate(timeout=120)[0].strip() for run in runs]
    assert [run.returncode for run in runs] == [0, 0, 0]
    assert len(set(outputs)) == 1, outputs


@pytest.fixture(scope='module')
def hand() -> HandCollision:
    return HandCollision()


def test_the_hand_parts_are_where_pinocchio_puts_the_urdf_s_collision_geometry(hand: HandCollision) -> None:
    """Every part's pose from the end effector's pose and the closures = forward kinematics of the whole URDF."""
    path = str(default_urdf_path())
    model = pin.buildModelFromUrdf(path)
    geom = pin.buildGeomFromUrdf(model, path, pin.COLLISION)
    data, gdata = model.createData(), geom.createData()
    names = [f'm1n6s300_link_{p if p != "palm" else "6"}_0' for p in HAND_PARTS]
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = pin.randomConfiguration(model)
        closures = rng.uniform(0.0, 1.51, 3)
        q[-3:] = closures
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        pin.updateGeometryPlacements(model, data, geom, gdata)
        world_T_ee = np.array(data.oMf[model.getFrameId(EE_FRAME)].homogeneous)
        expected = np.array([gdata.oMg[geom.getGeometryId(n)].homogeneous for n in names])
        assert_allclose(hand.parts(world_T_ee, closures), expected, atol=1e-12)


def test_the_table_depth_is_coal_s_distance_to_a_half_space(hand: HandCollision) -> None:
    """The support function of each primitive against the plane agrees with coal's signed distance (1e-9 m)."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        normal = rng.normal(size=3)
        table = Table(tuple(normal.tolist()), float(rng.uniform(-0.1, 0.1)))
        half_space = coal.Halfspace(np.array(table.normal), table.offset)
        x = grasp_features(rng.uniform(-0.05, 0.05, 3), rng.uniform(-math.pi, math.pi), rng.uniform(-0.5, 1.5),
                           0.03, rng.uniform(0.0, 2 * math.pi), (0.0, 0.0, 0.0))
        obj_T_ee = features_to_obj_T_ee(x)
        depths = []
        for shape, pose in zip(hand.shapes, hand.parts(obj_T_ee, np.zeros(3))):
            distance = coal.distance(shape.geometry, coal.Transform3s(pose[:3, :3], pose[:3, 3]), half_space,
                                     coal.Transform3s(), coal.DistanceRequest(), coal.DistanceResult())
            depths.append(-distance)
        pre = obj_T_ee.copy()
        pre[:3, 3] -= hand.standoff * obj_T_ee[:3, 2]
        for shape, pose in zip(hand.shapes, hand.parts(pre, np.zeros(3))):
            depths.append(-coal.distance(shape.geometry, coal.Transform3s(pose[:3, :3], pose[:3, 3]), half_space,
                                         coal.Transform3s(), coal.DistanceRequest(), coal.DistanceResult()))
        assert hand.clearance(x, None, table).table_depth == pytest.approx(max(depths), abs=1e-9)


def test_a_low_side_grasp_of_the_handle_with_the_thumb_up_is_turned_down_for_the_table(hand: HandCollision) -> None:
    """The usage grasp of the demonstrations: palm 5 cm high, nearly horizontal, fingers open below the table."""
    x = grasp_features((0.055, 0.0, 0.040), 0.0, math.radians(22.0), 0.030, 0.0, (1.2, 1.2, 1.05))
    clearance = hand.clearance(x, CUP_BODY)
    assert clearance.table_depth > 0.05  # a finger tip more than 5 cm below the table
    assert 'below the table' in (clearance.fault() or '')
    # the same hand 10 cm above a lower table is clear of it
    lowered = hand.clearance(x, CUP_BODY, Table(offset=-0.10))
    assert lowered.table_depth < 0.0 and 'table' not in (lowered.fault() or '')


def test_a_palm_pressed_into_the_handle_is_turned_down_and_clear_of_the_cylinder_alone(hand: HandCollision) -> None:
    """From +x, horizontal, fingers sideways: the palm 4 mm into the handle's outer bar (its face at x = 0.070 m)."""
    into = np.array([0.066, 0.0, 0.05, -1.0, 0.0, 0.0, SIDE_THUMB_SIDEWAYS, 1.2, 1.2, 1.2])
    clearance = hand.clearance(into, CUP_BODY)
    assert clearance.palm_depth == pytest.approx(0.004, abs=1e-6)
    assert clearance.fault() == 'palm 4.0 mm into the object'
    assert hand.clearance(into, CYLINDER_ONLY).fault() is None  # the handle, not the cup, is in the way
    clear = into.copy()
    clear[0] = 0.075
    assert hand.clearance(clear, CUP_BODY).palm_depth == pytest.approx(-0.005, abs=1e-6)
    assert hand.clearance(clear, CUP_BODY).fault() is None


def test_closing_fingers_stop_on_what_they_touch(hand: HandCollision) -> None:
    """Round the handle the fingers stop on it short of their plan; low over the table on the table."""
    x = np.array([0.075, 0.0, 0.05, -1.0, 0.0, 0.0, SIDE_THUMB_SIDEWAYS, 1.4, 1.4, 1.4])
    stops = hand.clearance(x, CUP_BODY).stops
    assert all(stop.on == 'object' and 0.0 < stop.closure < 1.4 for stop in stops)
    assert hand.clearance(x, CYLINDER_ONLY).stops != stops  # the handle stops them
    # far from the object, palm down 7 cm above the table: the open fingers clear it, closing they meet it
    low = np.array([0.0, 0.3, 0.07, 0.0, 0.0, -1.0, 0.0, 1.4, 1.4, 1.4])
    clearance = hand.clearance(low, CUP_BODY)
    assert clearance.fault() is None
    assert clearance.fingers_on_table >= 1
    assert all(stop.on in ('table', '') for stop in clearance.stops)


def test_the_flashlight_s_switch_is_part_of_its_body() -> None:
    switch = FLASHLIGHT.body().primitives[1]
    sd = FLASHLIGHT.body().distance(np.array([[FLASHLIGHT.switch_x, FLASHLIGHT.radius + 0.003, FLASHLIGHT.radius]]))[0]
    assert sd[0] < 0.0 and switch.centre[0] == FLASHLIGHT.switch_x


def test_the_planner_turns_down_grasps_in_collision_and_says_so(hand: HandCollision) -> None:
    """A table 4 cm above the object's plane: every usage demonstration of the shipped cup puts the open hand below it.

    The demonstrations are clear of the object's own plane, with the usage ones' lowest part at most 3.3 cm above it.
    """
    cup = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    kin = MicoKinematics()
    raised = (0.0, 0.0, 1.0, 0.04)  # the base frame's z = 0 is the object's plane at BASE_T_OBJ
    v_usage, v_transfer = intent.interpret((0.9, 0.1, 0.1)).v, intent.interpret((0.1, 0.9, 0.1)).v
    usage = plan_grasp(cup, v_usage, intent.all_zones(3), BASE_T_OBJ, kin, hand=hand, table_plane=raised)
    assert isinstance(usage, NoReachableGrasp)
    asked = len(usage.result.candidates)  # the first 32, then the rest of the usage-only tier
    assert asked > 32
    assert usage.reason.startswith(f'no grasp clear of the table and the object: all {asked} candidates in collision')
    assert 'below the table' in usage.reason
    transfer = plan_grasp(cup, v_transfer, intent.all_zones(3), BASE_T_OBJ, kin, hand=hand, table_plane=raised)
    assert isinstance(transfer, Grasp) and transfer.clearance is not None
    assert transfer.clearance.fault() is None
    table = Table.in_object_frame(raised, BASE_T_OBJ)
    turned_down = CollisionFree(hand, cup.body, table)
    for candidate in transfer.result.candidates[:transfer.result.rejected]:
        assert not turned_down(candidate.x)
    unchecked = plan_grasp(cup, v_usage, intent.all_zones(3), BASE_T_OBJ, kin, table_plane=raised)
    assert isinstance(unchecked, Grasp) and unchecked.clearance is None
    assert CollisionFree(hand, cup.body, table).clearance(unchecked.result.x).fault(LIMITS) is not None
    # on the object's own table, the shipped demonstrations are clear: usage gets its grasp
    assert isinstance(plan_grasp(cup, v_usage, intent.all_zones(3), BASE_T_OBJ, kin, hand=hand), Grasp)


def test_the_hand_s_verdicts_follow_the_object_and_the_table(hand: HandCollision) -> None:
    """The same usage plan with one hand (its caches filled by the plans before) and with a new hand, bit for bit.

    A table 4 cm up with the object on the base's plane (no usage grasp is clear), then the object's own table,
    then the object raised onto that table (the same table in the object's frame as its own): a verdict kept
    for another table, or for the object where it was, would give another answer than the new hand's.
    """
    cup = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    kin = MicoKinematics()
    v_usage = intent.interpret((0.9, 0.1, 0.1)).v
    raised_object = BASE_T_OBJ.copy()
    raised_object[2, 3] = 0.04
    outcomes = []
    for base_T_obj, plane in ((BASE_T_OBJ, (0.0, 0.0, 1.0, 0.04)), (BASE_T_OBJ, None),
                              (raised_object, (0.0, 0.0, 1.0, 0.04))):
        shared, new = (plan_grasp(cup, v_usage, intent.all_zones(3), base_T_obj, kin, hand=h, table_plane=plane)
                       for h in (hand, HandCollision()))
        assert type(shared) is type(new) and shared.result.x.tobytes() == new.result.x.tobytes()
        if isinstance(shared, Grasp) and isinstance(new, Grasp):
            assert shared.positions.tobytes() == new.positions.tobytes() and shared.clearance == new.clearance
        outcomes.append(type(shared))
    assert outcomes == [NoReachableGrasp, Grasp, Grasp]


def test_the_open_hand_s_depth_at_one_pose_is_the_clearance_s_without_a_corridor() -> None:
    """With no standoff the corridor is the grasp's pose alone: the same palm and open-finger depths (1e-12 m)."""
    at_pose = HandCollision(standoff=0.0)
    into = np.array([0.066, 0.0, 0.05, -1.0, 0.0, 0.0, SIDE_THUMB_SIDEWAYS, 1.2, 1.2, 1.2])
    for x in (into, into + np.r_[0.009, np.zeros(9)], into + np.r_[-0.03, 0.0, 0.01, np.zeros(7)]):
        clearance = at_pose.clearance(x, CUP_BODY)
        palm, finger = at_pose.open_hand_depth(features_to_obj_T_ee(x), CUP_BODY)
        assert (palm, finger) == pytest.approx((clearance.palm_depth, clearance.finger_depth), abs=1e-12)
    assert at_pose.open_hand_depth(features_to_obj_T_ee(into), CUP_BODY)[0] == pytest.approx(0.004, abs=1e-6)
    far = features_to_obj_T_ee(into)
    far[:3, 3] += (1.0, 0.0, 0.0)
    assert at_pose.open_hand_depth(far, CUP_BODY) == (-math.inf, -math.inf)
    with pytest.raises(KinematicsError):
        at_pose.open_hand_depth(np.eye(3), CUP_BODY)


def test_a_grasp_at_the_limits_is_taken_without_a_margin_and_turned_down_with_one(hand: HandCollision) -> None:
    """A grasp exactly at the limits is taken with no margin and turned down with 0.1 mm.

    The shipped cup's demonstration whose palm goes deepest, limits set at its depths (a fault is deeper than a
    limit): less 0.1 mm turns it down for the palm and the fingers, not the table (its limit is kept); a negative
    or non-finite margin is an error.
    """
    cup = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    palm = [hand.clearance(x, cup.body).palm_depth for x in cup.demo_x]
    x = cup.demo_x[int(np.argmax(palm))]
    clearance = hand.clearance(x, cup.body)
    assert -0.001 < clearance.palm_depth <= LIMITS.palm and -0.005 < clearance.finger_depth <= LIMITS.finger
    at = Limits(table=max(clearance.table_depth, 0.0), palm=clearance.palm_depth, finger=clearance.finger_depth)
    assert at.less(0.0) == at
    assert CollisionFree(hand, cup.body, limits=at.less(0.0))(x)
    turned_down = CollisionFree(hand, cup.body, limits=at.less(1e-4))
    assert not turned_down(x)
    fault = turned_down.faults[x.tobytes()]
    assert 'palm' in fault and 'open finger' in fault and 'table' not in fault
    assert at.less(0.003) == Limits(at.table, at.palm - 0.003, at.finger - 0.003)
    for bad in (-1e-3, math.nan, math.inf):
        with pytest.raises(KinematicsError):
            LIMITS.less(bad)


def test_the_planner_prefers_the_margin_and_plans_at_the_limits_when_no_grasp_keeps_it(hand: HandCollision) -> None:
    """The planner's grasp keeps a 3 mm object margin where one does; where none does, the limits alone decide.

    Transfer on the cup (the palm against the body): the plan without a margin is not 3 mm shallower than LIMITS
    allow, is the margin plan's first candidate, and is turned down for the margin alone; the margin plan is.
    Usage-transfer-handover (all its demonstrations put the palm within 2 mm of its limit): with a 4.5 mm margin
    the plan is the one without it, and its note says so.
    """
    cup = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    kin = MicoKinematics()
    zones = intent.all_zones(3)
    v = intent.interpret((0.1, 0.9, 0.1)).v
    plain = plan_grasp(cup, v, zones, BASE_T_OBJ, kin, hand=hand)
    kept = plan_grasp(cup, v, zones, BASE_T_OBJ, kin, hand=hand, margin=0.003)
    assert isinstance(plain, Grasp) and isinstance(kept, Grasp)
    assert plain.clearance is not None and kept.clearance is not None
    assert kept.clearance.palm_depth <= LIMITS.palm - 0.003 and kept.clearance.finger_depth <= LIMITS.finger - 0.003
    assert plain.clearance.fault() is None and plain.clearance.fault(LIMITS.less(0.003)) is not None
    assert kept.result.candidates[0].x.tobytes() == plain.result.x.tobytes()
    assert 'within the object margin' in kept.note
    held = plan_grasp(cup, v, zones, BASE_T_OBJ, kin, hand=hand, margin=0.003, warm_start=plain.result.x)
    assert isinstance(held, Grasp) and held.result.x.tobytes() == plain.result.x.tobytes()
    v_all = intent.interpret((0.9, 0.9, 0.9)).v
    plain = plan_grasp(cup, v_all, zones, BASE_T_OBJ, kin, hand=hand)
    fallback = plan_grasp(cup, v_all, zones, BASE_T_OBJ, kin, hand=hand, margin=0.0045)
    assert isinstance(plain, Grasp) and isinstance(fallback, Grasp)
    assert fallback.result.x.tobytes() == plain.result.x.tobytes()
    assert fallback.note.endswith('none with the object margin: planned at the limits')
    assert not plain.note.endswith('planned at the limits')
