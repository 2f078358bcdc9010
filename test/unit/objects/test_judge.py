"""The objects' judge (objects/judge.py): a grasp as a hand pose and closures, judged by its object's rules."""

from __future__ import annotations

import dataclasses

import numpy as np

from grasp_intent_ros.method.features import FINGERS
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import default_base_T_obj, features_to_obj_T_ee, obj_T_ee_to_features
from grasp_intent_ros.objects.demos import CUP_RULES
from grasp_intent_ros.objects.judge import judge, operator_verdict
from grasp_intent_ros.resources import config_dir

U, T, H, UT = 0b001, 0b010, 0b100, 0b011
MODEL = ModelFiles(config_dir() / 'models').load('cup_7zone')
BASE_T_OBJ = default_base_T_obj()
WANTED = ('usage', 'transfer')


def test_a_grasp_is_judged_from_its_pose_and_closures_by_the_models_objects_rules() -> None:
    x = MODEL.demo_x[int(np.flatnonzero(MODEL.demo_sets == UT)[0])]
    assert CUP_RULES.label(x) == UT
    base_T_ee, closures = BASE_T_OBJ @ features_to_obj_T_ee(x), x[FINGERS]
    verdict = judge(MODEL, BASE_T_OBJ, base_T_ee, closures)
    assert (verdict.label, verdict.text) == (UT, 'usage, transfer (UT)')
    assert verdict.serves(U) and verdict.serves(UT) and not verdict.serves(T | H)
    assert verdict.failed['usage'] == () and verdict.failed['transfer'] == () and verdict.failed['handover']
    assert operator_verdict(verdict, WANTED, MODEL.task_names) == "the operator's tasks served"
    opened = judge(MODEL, BASE_T_OBJ, base_T_ee, np.zeros(3))  # no finger closed: neither usage nor transfer
    assert opened.label == 0 and not opened.serves(U)
    judged = obj_T_ee_to_features(np.linalg.inv(BASE_T_OBJ) @ base_T_ee, np.zeros(3))  # the features judged
    assert opened.failed == {task: tuple(name for name, ok in checks.items() if not ok)
                             for task, checks in CUP_RULES.explain(judged).items()}
    assert all(opened.failed.values())
    assert opened.text == 'no task (failed: ' + '; '.join(f'{task}: {", ".join(names)}'
                                                          for task, names in opened.failed.items()) + ')'
    assert operator_verdict(opened, WANTED, MODEL.task_names) == "not the operator's usage, transfer"


def test_a_model_of_an_object_without_rules_is_judged_unknown() -> None:
    verdict = judge(dataclasses.replace(MODEL, object_name='teapot'), BASE_T_OBJ, BASE_T_OBJ, np.zeros(3))
    assert verdict.label is None and verdict.failed == {} and not verdict.serves(U)
    assert verdict.text.startswith("unknown (model 'cup_7zone' names no object of cup, flashlight")
    assert operator_verdict(verdict, WANTED, MODEL.task_names) == 'unknown'
