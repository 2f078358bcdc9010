"""The viewer's playback of a session bag: a scene of several objects shown as the live viewer shows it.

Bags written in ``tmp_path`` with rosbags messages; the page is not served.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.scene.state import ObjectsState, SceneState
from grasp_intent_ros.sessions.outputs import SessionError
from grasp_intent_ros.sessions.playback import load_timeline, main
from grasp_intent_ros.wire.model_document import model_document
from grasp_intent_ros.wire.topics import DIAGNOSTICS

from ..session_bags import Q, T, X, f64, header, joint_msg, pose_msg, posterior_msg, text, v_msg, write_bag

REPO = Path(__file__).resolve().parents[3]
P = [0.05, 0.05, 0.05, 0.6, 0.05, 0.05, 0.15]


def document(name: str) -> Any:
    model = GraspModel.load(REPO / 'config' / 'models' / f'{name}.yaml')
    return text(model_document(model, name=name, version=1))


def plan(chain: str, position: tuple[float, float, float], sec: int) -> list[tuple[str, Any]]:
    """The viewer's outputs of one plan of ``chain`` (stamp ``sec`` s + 5 ns): grasp at ``position``."""
    stamp = f'stamp={sec}.000000005'
    pose = pose_msg(position)
    pose.header.stamp = T['builtin_interfaces/msg/Time'](sec=sec, nanosec=5)
    joints = joint_msg(Q)
    joints.header.stamp = pose.header.stamp
    features = f64(X, (stamp, 1), ('palm_x,palm_y,palm_z,approach_x,approach_y,approach_z,roll,finger_1,finger_2,'
                                   'finger_3', 10))
    return [(f'{chain}/grasp/posterior', posterior_msg(P, [0.85, 0.8, 0.3], stamp)),
            (f'{chain}/grasp/features', features), (f'{chain}/grasp/pose', pose),
            (f'{chain}/grasp/joint_targets', joints)]


def plan_status(node: str, status: str) -> Any:
    """A DiagnosticArray of ``node``'s planner status (``<node>: planning``) with its ``last plan status``."""
    value = T['diagnostic_msgs/msg/KeyValue'](key='last plan status', value=status)
    status = T['diagnostic_msgs/msg/DiagnosticStatus'](level=0, name=f'{node}: planning', message='ok', hardware_id='',
                                                       values=[value])
    return T['diagnostic_msgs/msg/DiagnosticArray'](header=header(''), status=[status])


def scene_messages() -> list[tuple[str, Any]]:
    """A scene at /robot1: a cup and a flashlight chain and the arm's joint states.

    A pose of the flashlight in another frame (unreadable), the flashlight's planner status.
    """
    ns = '/robot1'
    return [
        (f'{ns}/cup/model/active', document('cup_7zone')),
        (f'{ns}/flashlight/model/active', document('flashlight_7zone')),
        (f'{ns}/joint_states', joint_msg(Q)),
        (f'{ns}/cup/object/pose', pose_msg((0.3, -0.3, 0.0))),
        (f'{ns}/flashlight/object/pose', pose_msg((0.3, 0.3, 0.0))),
        (f'{ns}/cup/intent/v', v_msg(P)),
        *plan(f'{ns}/cup', (0.3, -0.25, 0.1), 1),
        (f'{ns}/flashlight/object/pose', pose_msg((9.0, 9.0, 9.0), frame='world')),
        *plan(f'{ns}/flashlight', (0.3, 0.31, 0.1), 2),
        (DIAGNOSTICS, plan_status(f'{ns}/flashlight/grasp_planner', 'ok')),
        *plan(f'{ns}/flashlight', (0.3, 0.32, 0.1), 3),
        (f'{ns}/intent/objects', f64([0.25, 0.75], ('cup,flashlight', 2))),  # the intent estimator's P(o)
        (f'{ns}/assistance/object', text('flashlight')),  # the object the assistance follows
    ]


def test_a_scene_bag_is_played_back_chain_by_chain_with_the_arm_once(tmp_path: Path) -> None:
    messages = scene_messages()
    timeline = load_timeline(write_bag(tmp_path / 'scene', messages))
    assert isinstance(timeline.empty, ObjectsState) and timeline.at(-1.0) is timeline.empty
    assert list(timeline.empty.chains) == ['cup', 'flashlight'] and timeline.empty.namespace == '/robot1'
    assert dict(timeline.unreadable) == {'/robot1/flashlight/object/pose (KinematicsError)': 1}
    assert len(timeline.times) == len(messages) - 1
    # a plan of each chain counts, each when its last output arrived
    ends = [k for k, (topic, _) in enumerate(messages) if topic.endswith('grasp/joint_targets')]
    assert [round((t - timeline.start) / 1e6) for t in timeline.plans] == [ends[0], ends[1], ends[2]]
    final = timeline.states[-1]
    assert isinstance(final, ObjectsState)
    cup, flashlight = final.chains['cup'], final.chains['flashlight']
    assert (cup.model.name, flashlight.model.name) == ('cup_7zone', 'flashlight_7zone')
    assert_allclose(cup.base_T_obj, pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 0.0, 1.0)))
    assert_allclose(flashlight.base_T_obj, pose_to_matrix((0.3, 0.3, 0.0), (0.0, 0.0, 0.0, 1.0)))
    assert_allclose(cup.base_T_ee[:3, 3], (0.3, -0.25, 0.1)) and cup.plan_stamp == (1, 5)
    assert_allclose(flashlight.base_T_ee[:3, 3], (0.3, 0.32, 0.1)) and flashlight.plan_stamp == (3, 5)
    assert cup.v is not None and flashlight.v is None
    assert (cup.plan_status, flashlight.plan_status) == ('', 'ok')
    assert_allclose(final.arm.q_live, Q[:6]) and cup.q_live is None
    assert final.object_probabilities == {'cup': 0.25, 'flashlight': 0.75} and final.followed == 'flashlight'
    # at the cup's plan the flashlight has no plan yet
    at_cup_plan = timeline.at((timeline.plans[0] - timeline.start) * 1e-9)
    assert at_cup_plan.chains['cup'].plan_stamp == (1, 5) and at_cup_plan.chains['flashlight'].base_T_ee is None


def test_a_one_chain_bag_is_played_back_as_before(tmp_path: Path) -> None:
    timeline = load_timeline(write_bag(tmp_path / 'one', [('model/active', document('cup_7zone')),
                                                          *plan('/robot1', (0.3, -0.25, 0.1), 1)],
                                       namespace='/robot1'))
    assert timeline.empty == SceneState() and len(timeline.plans) == 1
    assert isinstance(timeline.states[-1], SceneState) and timeline.states[-1].plan_stamp == (1, 5)


def test_a_bag_of_several_namespaces_that_is_no_scene_is_refused_naming_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = write_bag(tmp_path / 'two_arms', [('/cup/intent/v', v_msg(P)), ('/flashlight/intent/v', v_msg(P))])
    with pytest.raises(SessionError, match=r"\['/cup', '/flashlight'\], 0 of them with joint_states"):
        load_timeline(bag)
    assert main([str(bag), '--port', '0']) == 2
    assert "['/cup', '/flashlight']" in capsys.readouterr().err
