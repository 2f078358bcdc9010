"""The judge's sweep of the open hand's path through the object (shared_control/sweep.py)."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from grasp_intent_ros.mico.collision import LIMITS, HandCollision
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pre_grasp
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.objects.demos import CUP
from grasp_intent_ros.shared_control.sweep import HAND_REACH, PathSweep, default_hand

CUP_BODY = CUP.body()
SIDE = np.array([0.075, 0.0, 0.05, -1.0, 0.0, 0.0, math.pi / 2, 1.2, 1.2, 1.2])
"""A side grasp of the cup from +x, fingers sideways, the palm 5 mm clear of the handle's outer bar."""
ANCHOR_Q = HOME_Q + np.array([0.0, 0.3, 0.0, 0.0, 0.0, 0.0])
"""The arm's joints at that grasp (the object is placed so): every path below has an IK near them."""


def _joints(kin: MicoKinematics, base_T_ees: list[np.ndarray]) -> list[np.ndarray]:
    """The arm's joints along hand poses (IK, each seeded with the previous; the first with ANCHOR_Q)."""
    q, out = ANCHOR_Q.copy(), []
    for T in base_T_ees:
        ik = kin.ik(T, q, restarts=0)
        assert ik.success
        q = ik.q
        out.append(q)
    return out


def _path(kin: MicoKinematics, obj_T_start: np.ndarray, obj_T_end: np.ndarray, base_T_obj: np.ndarray,
          steps: int = 40) -> list[np.ndarray]:
    """Joints along a straight line (same orientation) between two hand poses of the object frame."""
    poses = []
    for s in np.linspace(0.0, 1.0, steps):
        T = obj_T_start.copy()
        T[:3, 3] = (1.0 - s) * obj_T_start[:3, 3] + s * obj_T_end[:3, 3]
        poses.append(base_T_obj @ T)
    return _joints(kin, poses)


def test_a_path_through_the_object_sweeps_and_the_approach_along_the_axis_does_not(kin: MicoKinematics) -> None:
    """The object placed so that the side grasp is ANCHOR_Q's hand pose; every path is checked pose by pose."""
    obj_T_grasp = features_to_obj_T_ee(SIDE)
    base_T_obj = kin.fk(ANCHOR_Q) @ np.linalg.inv(obj_T_grasp)
    assert HandCollision().clearance(SIDE, CUP_BODY).fault() is None  # its approach corridor is clear

    along = PathSweep(kin, CUP_BODY, base_T_obj)
    for q in _path(kin, pre_grasp(obj_T_grasp, 0.08), obj_T_grasp, base_T_obj):
        along.check(q)
    assert not along.swept()
    assert along.palm == pytest.approx(-0.005, abs=1e-4)  # deepest at the grasp, 5 mm clear
    assert along.finger <= LIMITS.finger

    # the same hand slid sideways (along the object's y) through the cup's cylinder at its centre height
    start, end = obj_T_grasp.copy(), obj_T_grasp.copy()
    start[:3, 3] = (-0.02, 0.15, 0.05)
    end[:3, 3] = (-0.02, -0.15, 0.05)
    through = PathSweep(kin, CUP_BODY, base_T_obj)
    for q in _path(kin, start, end, base_T_obj):
        through.check(q)
    assert through.swept()
    assert through.palm > 0.03  # the palm's box goes centimetres deep
    # only the path's ends, both clear of the cup: nothing swept (the figure is the path's, not its end's)
    ends = PathSweep(kin, CUP_BODY, base_T_obj)
    for q in _path(kin, start, end, base_T_obj, steps=2):
        ends.check(q)
    assert not ends.swept()


def test_the_closing_pose_is_told_from_the_way(kin: MicoKinematics) -> None:
    """A path through the cup that closes clear of it: swept on the way only; closing inside it: in at the closing."""
    obj_T_grasp = features_to_obj_T_ee(SIDE)
    base_T_obj = kin.fk(ANCHOR_Q) @ np.linalg.inv(obj_T_grasp)
    start, middle, end = obj_T_grasp.copy(), obj_T_grasp.copy(), obj_T_grasp.copy()
    start[:3, 3] = (-0.02, 0.15, 0.05)
    middle[:3, 3] = (-0.02, 0.0, 0.05)
    end[:3, 3] = (-0.02, -0.15, 0.05)
    way = PathSweep(kin, CUP_BODY, base_T_obj)
    *path, last = _path(kin, start, end, base_T_obj)
    for q in path:
        way.check(q)
    way.close(last)
    assert way.swept() and not way.in_at_closing()
    assert way.closing_palm < 0.0 < way.palm  # the deepest was on the way; the closing pose is clear
    inside = PathSweep(kin, CUP_BODY, base_T_obj)
    *path, last = _path(kin, start, middle, base_T_obj)
    for q in path:
        inside.check(q)
    inside.close(last)
    assert inside.swept() and inside.in_at_closing()
    assert inside.closing_palm > LIMITS.palm and inside.palm >= inside.closing_palm


def test_without_a_body_nothing_sweeps(kin: MicoKinematics) -> None:
    sweep = PathSweep(kin, None, np.eye(4))
    sweep.close(HOME_Q)
    assert (sweep.palm, sweep.finger, sweep.swept(), sweep.in_at_closing()) == (-math.inf, -math.inf, False, False)


def test_the_hand_reach_bounds_the_hand_s_collision_primitives() -> None:
    """HAND_REACH (the checks' spacing rests on it) bounds every primitive's farthest point from the end effector."""
    hand = default_hand()
    reach = max(float(np.linalg.norm(T[:3, 3])) + shape.radius
                for T, shape in zip(hand.parts(np.eye(4), np.zeros(3)), hand.shapes))
    assert reach <= HAND_REACH


def test_only_the_simulator_s_judge_side_imports_the_sweep() -> None:
    """The planner, the assistance, the operators and the estimator never read the judge's figure."""
    package = Path(__file__).resolve().parents[3] / 'grasp_intent_ros'
    importers = set()
    for path in package.rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [node.module or ''] + [a.name for a in node.names] if isinstance(node, ast.ImportFrom) else \
                [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if any(name == 'sweep' or name.endswith('.sweep') for name in names):
                importers.add(path.relative_to(package).as_posix())
    # the loops' judge side: the two loops and their shared steps (loop_steps.swept_into records the figures)
    assert importers == {'shared_control/simulator.py', 'shared_control/scene_simulator.py',
                         'shared_control/loop_steps.py'}
