"""grasp_intent_ros.sessions.pairing: a recorded session paired into inputs and their outputs; compaction."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap_check import read_messages_mcap

from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter, read_messages, topics_info
from grasp_intent_ros.sessions.outputs import Joints, Pose, Rejection, SessionError, Trajectory, Vector, decode
from grasp_intent_ros.sessions.pairing import compact_session, detect_namespace, load_paired_session, pair_messages
from grasp_intent_ros.sessions.scenes import Scene, detect_scene, load_paired_scene
from grasp_intent_ros.wire.model_document import ModelHeader
from grasp_intent_ros.wire.topics import DIAGNOSTICS, PLAN_TOPICS

from ..session_bags import (
    ARM,
    MS,
    SHA_A,
    SHA_B,
    STORE,
    T0,
    TASKS,
    ZONES,
    P,
    Q,
    diagnostics,
    f64,
    joint_msg,
    model_doc,
    plan,
    pose_msg,
    session_messages,
    text,
    twist_msg,
    v_msg,
    write_bag,
)


# ---------------------------------------------------------------- pairing
def test_each_input_is_paired_with_the_outputs_that_follow_it(session_bag: Path) -> None:
    session = load_paired_session(session_bag)

    assert session.namespace == ''
    assert session.initial_model == ModelHeader('cup_7zone', 1, SHA_A)
    assert [s.topic for s in session.steps] == ['joint_states', 'intent/w', 'intent/w', 'intent/w',
                                                'model/active', 'object/pose']
    assert [s.index for s in session.steps] == [1, 2, 3, 4, 5, 6]
    assert [sorted(o.topic for o in s.expected) for s in session.steps] == [
        [],
        sorted(['intent/v', *PLAN_TOPICS]),
        [DIAGNOSTICS],
        ['intent/clarification'],
        sorted(['model/active', *PLAN_TOPICS]),
        sorted(PLAN_TOPICS),
    ]
    assert [o.topic for o in session.unpaired] == ['intent/v']
    assert session.n_outputs == 6 + 1 + 1 + 6 + 5
    rejection = session.steps[2].expected[0].value
    assert rejection == Rejection('/intent_interpreter: intent', 1, 'w contains NaN')
    assert session.steps[4].model == 'cup_5zone' and session.steps[1].model is None
    assert session.steps[1].description == 'intent/w [0.9, 0.9, 0.1]'
    assert session.steps[2].description == 'intent/w [0.5, nan, 0.5]'
    assert session.steps[4].description == 'model switch to cup_5zone'
    assert session.steps[5].description.startswith('object/pose (0.350, -0.200, 0.000) m')
    assert session.duration_s == pytest.approx((session.steps[-1].t_ns - session.steps[0].t_ns) * 1e-9)
    # the recorded bytes are kept for publishing again
    w = decode('std_msgs/msg/Float64MultiArray', session.steps[1].cdr)
    assert list(w.data) == [0.9, 0.9, 0.1]


def test_an_input_received_after_the_outputs_it_caused_is_paired_by_the_send_times(tmp_path: Path) -> None:
    """A w its publisher delivered to the chain first: received after its v and plan, sent before them.

    By receive times the v and the plan are outputs before any input (unpaired, never compared) and the w answers
    nothing; by send times (the bag's publish times) the w comes first and they are its. Equal send times keep the
    receive order; a bag without send times of its own (publish time = receive time) pairs by receipts as before.
    """
    messages = [('model/active', model_doc('cup_7zone')), ('intent/v', v_msg(P)), *plan(),
                ('intent/w', f64([0.9, 0.9, 0.1]))]
    bag, late = tmp_path / 'late_w', T0 + 20 * MS
    with SessionWriter(bag) as writer:
        for k, (topic, msg) in enumerate(messages):
            writer.add_topic(f'/{topic}', msg.__msgtype__, qos=QosSpec())
            received = late if topic == 'intent/w' else T0 + k * MS
            sent = T0 + MS // 2 if topic == 'intent/w' else received - MS // 10
            writer.write(f'/{topic}', received, STORE.serialize_cdr(msg, msg.__msgtype__), sent)
    read = list(read_messages(bag))
    assert [m.topic for m in read][-1] == '/intent/w' and read[-1].publish_ns == T0 + MS // 2  # receive order
    assert [(m.topic, m.publish_time_ns) for m in read_messages_mcap(bag, topics=['/intent/w'])] == [
        ('/intent/w', T0 + MS // 2)]
    session = load_paired_session(bag)
    assert [s.topic for s in session.steps] == ['intent/w'] and session.unpaired == ()
    assert sorted(o.topic for o in session.steps[0].expected) == sorted(['intent/v', *PLAN_TOPICS])
    assert session.steps[0].t_ns == late  # the step keeps its receive time
    def shape(steps: tuple) -> list:
        return [(step.topic, step.t_ns, [(o.topic, o.t_ns) for o in step.expected]) for step in steps]

    compact_session(bag, tmp_path / 'compact')  # the send times are copied
    assert shape(load_paired_session(tmp_path / 'compact').steps) == shape(session.steps)

    by_receipts = write_bag(tmp_path / 'receipts', messages)
    assert [len(s.expected) for s in load_paired_session(by_receipts).steps] == [0]
    assert len(load_paired_session(by_receipts).unpaired) == 1 + len(PLAN_TOPICS)


def test_the_reduced_outputs_carry_what_is_compared(session_bag: Path) -> None:
    step = load_paired_session(session_bag).steps[1]
    values = {o.topic: o.value for o in step.expected}
    assert isinstance(values['intent/v'], Vector) and values['intent/v'].labels == (ZONES,)
    np.testing.assert_array_equal(values['intent/v'].data, P)
    posterior = values['grasp/posterior']
    assert isinstance(posterior, Vector) and posterior.labels == ('stamp=1.000000005', f'{ZONES}|{TASKS}')
    pose = values['grasp/pose']
    assert isinstance(pose, Pose) and pose.frame_id == 'm1n6s300_link_base'
    np.testing.assert_array_equal(pose.position, [0.3, -0.25, 0.1])
    joints = values['grasp/joint_targets']
    assert isinstance(joints, Joints) and joints.names == ARM
    trajectory = values['grasp/trajectory']
    assert isinstance(trajectory, Trajectory) and trajectory.positions.shape == (1, 9)
    np.testing.assert_allclose(trajectory.times_s, [1.5], rtol=0, atol=1e-9)


def test_namespace_is_detected_and_other_namespaces_are_rejected(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'ns', session_messages(), namespace='/robot1')
    session = load_paired_session(bag)
    assert session.namespace == '/robot1' and len(session.steps) == 6
    assert detect_namespace(['/rosout', '/a/b/intent/w', '/a/b/grasp/pose']) == '/a/b'
    with pytest.raises(SessionError, match='several namespaces'):
        detect_namespace(['/r1/intent/w', '/r2/intent/v'])
    with pytest.raises(SessionError, match='no session topic'):
        detect_namespace(['/rosout'])


def test_a_bag_without_inputs_is_not_a_session(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'outputs_only', [('model/active', model_doc('cup_7zone')), ('intent/v', v_msg(P))])
    with pytest.raises(SessionError, match='no inputs'):
        load_paired_session(bag)


def test_a_malformed_model_document_is_a_session_error(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'bad_model', [('model/active', text('name: cup_7zone\n')),
                                             ('intent/w', f64([0.9, 0.9, 0.1]))])
    with pytest.raises(SessionError, match='header lines'):
        load_paired_session(bag)


def test_pair_messages_accepts_any_message_stream() -> None:
    class Raw:
        def __init__(self, topic: str, t: int, msg: Any) -> None:
            self.topic, self.msgtype, self.timestamp_ns = topic, msg.__msgtype__, t
            self.cdr = bytes(STORE.serialize_cdr(msg, msg.__msgtype__))

    stream = [Raw('/intent/w', 1, f64([0.9, 0.1, 0.1])), Raw('/intent/v', 2, v_msg(P))]
    initial, steps, unpaired = pair_messages(stream)
    assert initial is None and unpaired == () and [len(s.expected) for s in steps] == [1]




# ---------------------------------------------------------------- scenes
def test_a_scene_is_the_arms_joint_states_and_one_chain_per_namespace_directly_below() -> None:
    assert detect_scene(['/joint_states', '/cup/intent/w', '/cup/intent/v', '/flashlight/model/active', DIAGNOSTICS,
                         '/rosout']) == Scene('', ('/cup', '/flashlight'))
    assert detect_scene(['/robot1/joint_states', '/robot1/cup/grasp/pose']) == Scene('/robot1', ('/robot1/cup',))
    one = detect_scene(['/robot1/intent/w', '/robot1/joint_states'])
    assert one == Scene('/robot1', ('/robot1',)) and one.one_chain
    assert not Scene('', ('/cup',)).one_chain


@pytest.mark.parametrize(('topics', 'reason'), [
    (['/r1/intent/w', '/r2/intent/v'], r"several namespaces \['/r1', '/r2'\], 0 of them with joint_states"),
    (['/r1/joint_states', '/r1/intent/w', '/r2/joint_states', '/r2/intent/w'], '2 of them with joint_states'),
    (['/joint_states', '/intent/w', '/cup/intent/w'], 'belong to no chain of the scene in /.*: /intent/w$'),
    (['/joint_states', '/cup/intent/w', '/cup/x/grasp/pose'], 'belong to no chain.*: /cup/x/grasp/pose$'),
    (['/rosout'], 'no session topic'),
])
def test_topics_of_no_chain_are_refused_naming_them(topics: list[str], reason: str) -> None:
    with pytest.raises(SessionError, match=reason):
        detect_scene(topics)


def scene_messages() -> list[tuple[str, Any]]:
    """A scene at the root: the arm's joint states, a cup and a flashlight chain answering out of turn."""
    cup, flashlight = '/cup/grasp_planner: planning', '/flashlight/grasp_planner: planning'
    return [
        ('/cup/model/active', model_doc('cup_7zone')),
        ('/flashlight/model/active', model_doc('flashlight_7zone', SHA_B)),
        ('/joint_states', joint_msg(Q)),                                   # 1: both chains, no answer
        ('/cup/intent/w', f64([0.9, 0.9, 0.1])),                           # 2: cup
        ('/flashlight/intent/w', f64([0.1, 0.9, 0.1])),                    # 3: flashlight, sent before cup answered
        *[(f'/cup/{topic}', msg) for topic, msg in [('intent/v', v_msg(P)), *plan()]],
        *[(f'/flashlight/{topic}', msg) for topic, msg in [('intent/v', v_msg(P)), *plan((0.3, 0.3, 0.1))]],
        ('/joint_states', joint_msg([float('nan')] * 9)),                  # 4: both planners reject it
        (DIAGNOSTICS, diagnostics(cup, received=2, rejected=1, reason='joint_states: NaN')),
        (DIAGNOSTICS, diagnostics(flashlight, received=2, rejected=1, reason='joint_states: NaN')),
        ('/flashlight/object/pose', pose_msg((0.3, 0.3, 0.0))),           # 5: flashlight
        *[(f'/flashlight/{topic}', msg) for topic, msg in plan((0.3, 0.31, 0.1))],
    ]


def test_each_chain_of_a_scene_is_paired_by_its_namespace_with_the_arms_joint_states(tmp_path: Path) -> None:
    scene = load_paired_scene(write_bag(tmp_path / 'scene', scene_messages()))

    assert scene.scene == Scene('', ('/cup', '/flashlight'))
    cup, flashlight = scene.chains
    assert (cup.namespace, cup.name, cup.arm_namespace, cup.joint_states) == ('/cup', 'cup', '', '/joint_states')
    assert cup.initial_model == ModelHeader('cup_7zone', 1, SHA_A)
    assert flashlight.initial_model == ModelHeader('flashlight_7zone', 1, SHA_B)
    # each chain's inputs are its own and the arm's; its outputs are its own, after its own input
    assert [s.topic for s in cup.steps] == ['joint_states', 'intent/w', 'joint_states']
    assert [s.topic for s in flashlight.steps] == ['joint_states', 'intent/w', 'joint_states', 'object/pose']
    # the cup's answer, received after the flashlight's w, is the answer to the cup's w
    assert [sorted(o.topic for o in s.expected) for s in cup.steps] == [
        [], sorted(['intent/v', *PLAN_TOPICS]), [DIAGNOSTICS]]
    assert [len(s.expected) for s in flashlight.steps] == [0, 6, 1, 5]
    # the rejections of a chain are those of its own nodes
    assert [o.value.status for s in flashlight.steps for o in s.expected if o.topic == DIAGNOSTICS] == [
        '/flashlight/grasp_planner: planning']
    assert [s.description.partition(' ')[0] for s in flashlight.steps] == [
        'joint_states', 'flashlight:', 'joint_states', 'flashlight:']
    # every input once, in receive order; the arm's joint states feed both chains
    assert [(i.index, [(k, s.index) for k, s in i.steps]) for i in scene.inputs] == [
        (1, [(0, 1), (1, 1)]), (2, [(0, 2)]), (3, [(1, 2)]), (4, [(0, 3), (1, 3)]), (5, [(1, 4)])]
    assert scene.n_outputs == cup.n_outputs + flashlight.n_outputs


def test_a_scenes_closed_loop_pairs_its_chains_as_without_the_loop_and_ignores_the_object_followed(
        tmp_path: Path) -> None:
    """The loop's topics at the arm's namespace are neither a chain's inputs nor its outputs.

    The operator's and the assistance's twists, the object followed: a replay compares the chains' answers alone.
    """
    loop = [('/operator/twist', twist_msg()), ('/assistance/twist', twist_msg()), ('/assistance/object', text('cup'))]
    messages = scene_messages()
    bare = load_paired_scene(write_bag(tmp_path / 'scene', messages))
    with_loop = load_paired_scene(write_bag(tmp_path / 'scene_loop', [*messages[:3], *loop, *messages[3:], *loop]))
    assert with_loop.scene == bare.scene == Scene('', ('/cup', '/flashlight'))
    for chain, bare_chain in zip(with_loop.chains, bare.chains, strict=True):
        assert [(s.topic, sorted(o.topic for o in s.expected)) for s in chain.steps] == [
            (s.topic, sorted(o.topic for o in s.expected)) for s in bare_chain.steps]
    assert [i.index for i in with_loop.inputs] == [i.index for i in bare.inputs]


def test_a_one_chain_session_is_a_scene_of_one_chain_paired_as_before(session_bag: Path, tmp_path: Path) -> None:
    for bag in (session_bag, write_bag(tmp_path / 'ns', session_messages(), namespace='/robot1')):
        session, scene = load_paired_session(bag), load_paired_scene(bag)
        assert scene.scene.one_chain and scene.chains[0].namespace == session.namespace
        assert scene.chains[0].name == '' and scene.chains[0].joint_states == 'joint_states'
        assert [(s.index, s.topic, s.t_ns, s.cdr, s.description, [(o.topic, o.t_ns) for o in s.expected])
                for s in scene.chains[0].steps] == [
            (s.index, s.topic, s.t_ns, s.cdr, s.description, [(o.topic, o.t_ns) for o in s.expected])
            for s in session.steps]
        assert [[(k, s.index) for k, s in i.steps] for i in scene.inputs] == [[(0, s.index)] for s in session.steps]


# ---------------------------------------------------------------- compaction
def test_compaction_keeps_only_rejections_of_the_diagnostics(session_bag: Path, tmp_path: Path) -> None:
    counts = compact_session(session_bag, tmp_path / 'compact', drop_topics=['/grasp/markers'])

    original = [m for m in read_messages(session_bag) if m.topic != '/grasp/markers']
    kept = list(read_messages(tmp_path / 'compact'))
    assert counts[DIAGNOSTICS] == 1 and '/grasp/markers' not in counts
    assert sum(counts.values()) == len(kept) == len(original) - 3  # 2 periodic statuses and 1 repeat dropped
    others = [(m.topic, m.timestamp_ns, m.cdr) for m in original if m.topic != DIAGNOSTICS]
    assert [(m.topic, m.timestamp_ns, m.cdr) for m in kept if m.topic != DIAGNOSTICS] == others
    assert topics_info(tmp_path / 'compact')['/model/active'].qos == (QosSpec('reliable', 'transient_local', 0),)
    before, after = load_paired_session(session_bag), load_paired_session(tmp_path / 'compact')
    assert [[(o.topic, o.t_ns) for o in s.expected] for s in before.steps] == \
        [[(o.topic, o.t_ns) for o in s.expected] for s in after.steps]
