"""The recorded bags do not depend on the machine that recorded them.

Every plan in every session of bags/ is planned again through the core alone, the way the planner node
plans it (the recorded v over the model's zones, the previous plan of the same model as the warm start,
IK reachability seeded from the latest joint state), with v perturbed at the last bits (1e-12
relative). The grasp must match the recording within the replay's tolerances. The object pose is read
off the recording itself (base_T_obj = base_T_ee @ inv(obj_T_ee(x))), so the test needs no ROS.
Closed-loop sessions are left out: their joint states are the arm's, and test/system/test_replay.py replays
them with the inputs perturbed at the last bits instead.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from grasp_intent_ros.method.intent import parse_zones, restrict
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pose_to_matrix, rotation_angle
from grasp_intent_ros.mico.grasp import ApproachReach
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, MicoKinematics
from grasp_intent_ros.mico.reachability import Reachability
from grasp_intent_ros.planning import planner
from grasp_intent_ros.planning.options import node_options
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.sessions.closed_loop import is_closed_loop
from grasp_intent_ros.sessions.compare import Tolerances
from grasp_intent_ros.sessions.outputs import Pose, Vector, decode
from grasp_intent_ros.sessions.pairing import load_paired_session

REPO = Path(__file__).resolve().parents[3]
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').is_file() and not is_closed_loop(p))
PARAMS = yaml.safe_load((config_dir() / 'grasp_planner.yaml').read_text())['/**/grasp_planner']['ros__parameters']
TOL = Tolerances()


def _output(step: Any, topic: str) -> Any:
    values = [o.value for o in step.expected if o.topic == topic]
    return values[-1] if values else None


@pytest.mark.parametrize('bag', BAGS, ids=[p.name for p in BAGS])
def test_every_recorded_plan_is_planned_again_with_v_perturbed_at_the_last_bits(bag: Path,
                                                                                  kin: MicoKinematics) -> None:
    session = load_paired_session(bag)
    assert session.initial_model is not None
    models = {name: GraspModel.load(config_dir() / 'models' / f'{name}.yaml')
              for name in ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')}
    model = models[session.initial_model.name]
    warm: dict[str, np.ndarray] = {}
    q_arm: np.ndarray | None = None
    v_rec: Vector | None = None
    rng = np.random.default_rng(0)
    checked = 0
    for step in session.steps:
        if step.model is not None:
            model = models[step.model]
        if step.topic == 'joint_states':
            msg = decode(step.msgtype, step.cdr)
            named = dict(zip(msg.name, msg.position))
            q = np.array([named.get(j, np.nan) for j in ARM_JOINTS], dtype=np.float64)
            if np.all(np.isfinite(q)) and not any(o.topic == '/diagnostics' for o in step.expected):
                q_arm = q  # the node keeps a joint state it did not reject
        v_rec = _output(step, 'intent/v') or v_rec
        features, pose = _output(step, 'grasp/features'), _output(step, 'grasp/pose')
        if not isinstance(features, Vector) or not isinstance(pose, Pose):
            continue
        assert v_rec is not None
        x_rec = features.data
        base_T_ee = pose_to_matrix(pose.position, pose.orientation)
        base_T_obj = base_T_ee @ np.linalg.inv(features_to_obj_T_ee(x_rec))
        zones = parse_zones(v_rec.labels[0].split(','), model.task_names) if v_rec.labels else None
        v = restrict(v_rec.data, zones, model.zones)
        assert v is not None
        v_perturbed = v * (1.0 + 1e-12 * rng.standard_normal(v.size))
        v_perturbed /= v_perturbed.sum()
        reachable = ApproachReach(Reachability(kin, base_T_obj, q_arm, restarts=PARAMS['ik_restarts']))
        result = planner.plan(model, v_perturbed, method=PARAMS['method'],
                              options=node_options(PARAMS['method'], PARAMS['n_starts'], PARAMS['execution_noise']),
                              warm_start=warm.get(model.name), accept=reachable)
        again = base_T_obj @ features_to_obj_T_ee(result.x)
        where = f'{bag.name} input #{step.index} ({step.description})'
        assert np.linalg.norm(again[:3, 3] - base_T_ee[:3, 3]) <= TOL.position_m, where
        assert rotation_angle(again[:3, :3], base_T_ee[:3, :3]) <= TOL.angle_rad, where
        posterior = _output(step, 'grasp/posterior')
        if isinstance(posterior, Vector):
            assert_allclose(result.posterior, posterior.data[:len(model.zones)], atol=TOL.posterior,
                            err_msg=where)
        warm[model.name] = result.x
        checked += 1
    plans = sum(isinstance(_output(s, 'grasp/features'), Vector) for s in session.steps)
    assert checked == plans
