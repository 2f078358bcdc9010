"""grasp_intent_ros.mico.grasp: the planner node's policy without ROS."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import InvalidIntentError, KinematicsError, ModelError, PlanningError
from grasp_intent_ros.method import intent
from grasp_intent_ros.method.features import FINGERS
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import (
    PRE_GRASP_STANDOFF,
    features_to_obj_T_ee,
    obj_T_ee_to_features,
    pose_to_matrix,
    pre_grasp,
)
from grasp_intent_ros.mico.grasp import (
    MIN_TRAJECTORY_TIME,
    OUTCOMES,
    ApproachReach,
    Grasp,
    NoModelZone,
    NoReachableGrasp,
    check_grasp,
    check_mico_model,
    check_workspace,
    plan_grasp,
    trajectory_duration,
)
from grasp_intent_ros.mico.kinematics import HOME_Q, JOINT_LIMIT_MARGIN
from grasp_intent_ros.mico.reachability import Reachability
from grasp_intent_ros.planning import planner
from grasp_intent_ros.resources import config_dir

W = (0.9, 0.9, 0.1)
BASE_T_OBJ = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))


@pytest.fixture(scope='module')
def cup() -> GraspModel:
    return GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')


def test_reachable_grasp_is_the_core_plan_with_its_pose_joints_and_timing(cup, kin) -> None:
    v = intent.interpret(W).v
    grasp = plan_grasp(cup, v, intent.all_zones(3), BASE_T_OBJ, kin, name='cup_7zone')
    approach = ApproachReach(Reachability(kin, BASE_T_OBJ))
    expected = planner.plan(cup, intent.restrict(v, intent.all_zones(3), cup.zones), accept=approach)
    assert isinstance(grasp, Grasp) and grasp.fallback == bool(expected.rejected)
    assert grasp.outcome == OUTCOMES[1 if expected.rejected else 0]
    assert_allclose(grasp.result.x, expected.x, atol=1e-9)
    assert_allclose(grasp.positions[:6], approach.joints(expected.x), atol=1e-12)
    assert_allclose(grasp.base_T_ee, BASE_T_OBJ @ features_to_obj_T_ee(grasp.result.x), atol=1e-12)
    assert_allclose(kin.fk(grasp.positions[:6]), grasp.base_T_ee, atol=1e-4)
    assert_allclose(grasp.positions[6:], grasp.result.x[FINGERS])
    assert grasp.duration_s == pytest.approx(
        max(MIN_TRAJECTORY_TIME, trajectory_duration(HOME_Q, grasp.positions[:6], kin.velocity_limits)))
    if not expected.rejected:
        assert grasp.note == f'best of {len(grasp.result.candidates)} candidates reachable'
    else:  # each candidate before it turned down with the reason (IK or the approach)
        assert grasp.note.startswith(f'best grasp unreachable: published candidate {expected.rejected + 1} of ')
        for x in (c.x for c in expected.candidates[:expected.rejected]):
            assert x.tobytes() in approach.faults or not approach.reachable(x)


def test_a_grasp_whose_approach_pins_a_joint_at_its_limit_is_turned_down_with_the_reason(kin) -> None:
    # hand-built: the elbow (joint 3) 0.1 rad from its lower limit, the hand's approach axis pointing away from
    # the base and down, so backing out toward the pre-grasp folds the elbow further: the grasp is reachable,
    # its approach is not (on no branch: IK of the pre-grasp from Home with 50 restarts fails too)
    q = np.array([4.37, 4.31, kin.lower[2] + 0.1, 3.01, 1.59, 3.05])
    base_T_ee = kin.fk(q)
    assert float(np.linalg.norm(base_T_ee[:3, 3])) < 0.4 and base_T_ee[:3, 3] @ base_T_ee[:3, 2] > 0.0
    x = obj_T_ee_to_features(np.linalg.inv(BASE_T_OBJ) @ base_T_ee, np.zeros(3))
    reachable = Reachability(kin, BASE_T_OBJ)
    approach = ApproachReach(reachable)
    assert reachable(x) and not kin.ik(pre_grasp(base_T_ee, PRE_GRASP_STANDOFF), HOME_Q, restarts=50).success
    assert not approach(x) and approach.joints(x) is None
    fault = approach.faults[x.tobytes()]
    assert "the approach leaves the arm's reach" in fault and 'at its limit: m1n6s300_joint_3' in fault
    # the same arm with the elbow mid-range: grasp and approach reachable, the joint targets the grasp's IK
    q[2] = 2.0
    mid = obj_T_ee_to_features(np.linalg.inv(BASE_T_OBJ) @ kin.fk(q), np.zeros(3))
    assert approach(mid) and np.array_equal(approach.joints(mid), reachable.answer(mid).q)
    with pytest.raises(KinematicsError, match='standoff'):
        ApproachReach(reachable, standoff=-0.01)


def test_unreachable_object_gives_no_grasp_and_says_why(cup, kin) -> None:
    far = BASE_T_OBJ.copy()
    far[:3, 3] = (2.0, 0.0, 0.0)
    grasp = plan_grasp(cup, intent.interpret(W).v, intent.all_zones(3), far, kin, ik_restarts=0)
    assert isinstance(grasp, NoReachableGrasp) and grasp.outcome == OUTCOMES[2]
    assert grasp.reason.startswith('no reachable grasp: IK failed for all') and '[2.0, 0.0, 0.0] m' in grasp.reason


def test_v_without_probability_on_the_model_zones_is_no_plan(kin) -> None:
    cup4 = GraspModel.load(config_dir() / 'models' / 'cup_4zone.yaml')
    only_h = np.zeros(7)
    only_h[2] = 1.0  # 'H' is no zone of the 4-zone model
    outcome = plan_grasp(cup4, only_h, intent.all_zones(3), BASE_T_OBJ, kin, name='cup_4zone')
    assert outcome == NoModelZone("v gives no probability to the zones T,UT,TH,UTH of model 'cup_4zone'")
    with pytest.raises(InvalidIntentError, match='v must be a finite, non-negative vector with 7 entries'):
        plan_grasp(cup4, only_h[:3], intent.all_zones(3), BASE_T_OBJ, kin)


def test_timing_and_model_checks(cup) -> None:
    assert trajectory_duration([0.0, 0.0], [1.0, -3.0], [2.0, 1.0]) == 3.0
    assert trajectory_duration([0.0], [0.01], [1.0], min_duration=0.1) == 0.1
    with pytest.raises(ValueError, match='positive velocity limits'):
        trajectory_duration([0.0], [1.0], [0.0])
    check_mico_model(cup, 'cup_7zone')
    document = cup.to_document()
    document['features'] = [{**f, 'name': f'f{i}'} for i, f in enumerate(document['features'])]
    del document['body']  # a body needs the palm's features (test_model)
    other = GraspModel.from_document(document)
    with pytest.raises(ModelError, match="model 'other' has features"):
        check_mico_model(other, 'other')


def test_check_grasp_passes_a_plan_and_names_what_is_wrong_with_a_corrupted_one(cup, kin) -> None:
    grasp = plan_grasp(cup, intent.interpret(W).v, intent.all_zones(3), BASE_T_OBJ, kin, name='cup_7zone')
    assert isinstance(grasp, Grasp)
    check_grasp(grasp, kin)
    q = grasp.positions.copy()
    far = q.copy()
    far[0] += 1e14  # an IK seed of Home + 1e14: joint targets beyond the limits
    branch = q.copy()
    branch[1] = kin.lower[1] + 0.01  # within the limits, but another pose
    nan_w = dataclasses.replace(grasp.result, w=np.full_like(grasp.result.w, np.nan))
    for corrupted, reason in ((dataclasses.replace(grasp, positions=far), 'outside the joint limits'),
                              (dataclasses.replace(grasp, positions=branch), 'miss the planned end-effector pose'),
                              (dataclasses.replace(grasp, duration_s=1_591_546.0), 'trajectory time'),
                              (dataclasses.replace(grasp, duration_s=-5.0), 'trajectory time'),
                              (dataclasses.replace(grasp, result=nan_w), "reconstructed w are not finite")):
        with pytest.raises(PlanningError, match=reason):
            check_grasp(corrupted, kin)


def test_check_grasp_measures_the_pose_error_within_its_tolerances(cup, kin) -> None:
    """The FK check's errors: position (m) and rotation angle (rad) of the pose against the targets' FK."""
    grasp = plan_grasp(cup, intent.interpret(W).v, intent.all_zones(3), BASE_T_OBJ, kin, name='cup_7zone')
    assert isinstance(grasp, Grasp)

    def moved(angle: float, shift: float) -> Grasp:  # the pose turned about its own z axis, shifted along x
        ee_T_moved = pose_to_matrix((shift, 0.0, 0.0), (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)))
        return dataclasses.replace(grasp, base_T_ee=grasp.base_T_ee @ ee_T_moved)
    for angle, shift in ((0.009, 0.0), (0.0, 0.0009), (-0.009, 0.0009)):  # within 1e-2 rad and 1 mm
        check_grasp(moved(angle, shift), kin)
    for angle, shift, error in ((0.011, 0.0, '0.011 rad'), (0.0, 0.0011, '1.1 mm'), (math.pi, 0.0, '3.14 rad')):
        with pytest.raises(PlanningError, match=f'miss the planned end-effector pose by .*{error}'):
            check_grasp(moved(angle, shift), kin)


def test_joint_limits_with_a_margin_and_the_workspace_radius(kin) -> None:
    assert_allclose(kin.check_limits(HOME_Q), HOME_Q)
    edge = kin.upper.copy()
    edge[1] += 0.5 * JOINT_LIMIT_MARGIN
    kin.check_limits(edge, margin=JOINT_LIMIT_MARGIN)
    with pytest.raises(KinematicsError, match='m1n6s300_joint_2'):
        kin.check_limits(edge)
    for x in (1e6, 2e9, 1e10, 1e14, 1e308):
        with pytest.raises(KinematicsError, match=r'joint state outside the joint limits .*m1n6s300_joint_1 = '):
            kin.check_limits(HOME_Q + np.array([x, 0, 0, 0, 0, 0]), margin=JOINT_LIMIT_MARGIN, what='joint state')
    assert_allclose(check_workspace([0.3, -0.3, -0.0], 1.5), [0.3, -0.3, 0.0])
    for position in ([1e6, 0.0, 0.0], [0.0, 0.0, -1e308], [1.1, 1.1, 0.0]):
        with pytest.raises(KinematicsError, match='outside the workspace radius 1.5 m'):
            check_workspace(position, 1.5)
    with pytest.raises(KinematicsError, match='3 finite numbers'):
        check_workspace([np.inf, 0.0, 0.0], 1.5)
