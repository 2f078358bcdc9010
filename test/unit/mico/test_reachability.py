"""grasp_intent_ros.mico.reachability (no rclpy): the planner's IK constraint and the answers it keeps."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from grasp_intent_ros.mico.frames import features_to_obj_T_ee, obj_T_ee_to_features
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.mico.reachability import Reachability


def test_reachability_constraint_caches_ik_answers(kin: MicoKinematics) -> None:
    base_T_obj = np.eye(4)
    base_T_ee = kin.fk(HOME_Q)  # reachable: the home pose, as a grasp of an object at the base origin
    x = obj_T_ee_to_features(base_T_ee, np.zeros(3))
    reach = Reachability(kin, base_T_obj)
    assert reach(x)
    first = reach.answer(x)
    assert reach.answer(x) is first and len(reach.answers) == 1 and reach.seconds > 0.0
    target = reach.target(x)  # the pose IK solved, kept for the grasp's pose (plan_grasp)
    assert reach.target(x.copy()) is target and not target.flags.writeable
    assert_allclose(target, base_T_obj @ features_to_obj_T_ee(x), atol=1e-15)
    assert_allclose(kin.fk(first.q), target, atol=1e-4)
    far = base_T_obj.copy()
    far[:3, 3] = (2.0, 0.0, 0.0)
    assert not Reachability(kin, far)(x)
