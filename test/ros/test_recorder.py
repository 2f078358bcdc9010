"""In-process tests of the session recorder (private Context per test: the ``ros`` fixture of test/conftest.py).

"Nothing lost": 2000 Float64MultiArray at 1 kHz, each carrying its sequence number, are all found in
the bag, in order, by the rosbags reader and by the independent mcap reader; topics, types and offered
QoS (transient local for a latched String published before the recorder existed) match what was sent.
The package's topics are subscribed at start: a one-shot publisher's message is recorded without any look
at the graph after the start; other topics wait for discovery.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest
import rosbags.rosbag2
import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from mcap_check import read_messages_mcap
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from grasp_intent_ros.nodes.recorder import Recorder
from grasp_intent_ros.ros.qos import latched_qos, output_qos
from grasp_intent_ros.ros.recording import DEFAULT_TOPICS, TopicSelection
from grasp_intent_ros.sessions.bag import BagWriteError, QosSpec, read_messages, topics_info
from grasp_intent_ros.wire.topics import JOINT_STATES, OBJECT_POSE, OPERATOR_GRASP_TASKS

N = 2000
PERIOD = 1e-3  # s: 1 kHz
NS = '/robot1'
W, MODEL, POSE = f'{NS}/intent/w', f'{NS}/model/active', f'{NS}/object/pose'
DIAG = '/diagnostics'
F64MA, STRING, POSE_T = 'std_msgs/msg/Float64MultiArray', 'std_msgs/msg/String', 'geometry_msgs/msg/PoseStamped'
MODEL_DOC = '# model_name: cup_7zone\n# model_version: 1\nname: cup_7zone\n'
DEEP_RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=N, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE)
BEST_EFFORT = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def w_msg(seq: int) -> Float64MultiArray:
    """Message ``seq``: data = (seq, 0.25, 1 - seq / N), one labelled dimension."""
    msg = Float64MultiArray(data=[float(seq), 0.25, 1.0 - seq / N])
    msg.layout.dim.append(MultiArrayDimension(label='seq,a,b', size=3, stride=3))
    return msg


def publish_at_rate(ros, publisher, count: int, period: float) -> list[int]:
    """Publish w_msg(0..count-1) from a timer every ``period`` s; returns the live list of sent seqs."""
    sent: list[int] = []

    def tick() -> None:
        if len(sent) < count:
            publisher.publish(w_msg(len(sent)))
            sent.append(len(sent))
        else:
            timer.cancel()

    timer = ros.node.create_timer(period, tick)
    return sent


def test_nothing_lost_at_1khz_and_latched_model_recorded(ros, tmp_path: Path) -> None:
    model_pub = ros.publisher(String, MODEL, latched_qos())
    model_pub.publish(String(data=MODEL_DOC))  # before the recorder exists: only transient local gets it
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    pose_pub = ros.publisher(PoseStamped, POSE, BEST_EFFORT)
    ros.publisher(Float64MultiArray, f'{NS}/other/w', DEEP_RELIABLE)  # not selected
    ros.publisher(Float64MultiArray, '/intent/w', DEEP_RELIABLE)  # outside the namespace

    bag = tmp_path / 'session'
    recorder = ros.add(Recorder(bag, context=ros.context, namespace=NS, discovery_period=0.1))
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1 and pose_pub.get_subscription_count() >= 1
                        and recorder.counts.get(MODEL) == 1, timeout=10.0), recorder.summary()

    sent = publish_at_rate(ros, w_pub, N, PERIOD)
    assert ros.wait_for(lambda: recorder.counts[W] == N, timeout=20.0), recorder.summary()
    assert len(sent) == N
    assert set(recorder.recorded_topics) == {W, MODEL, POSE, DIAG}  # /diagnostics: the recorder's own
    ros.remove(recorder)  # destroy_node closes the bag

    assert (bag / 'metadata.yaml').is_file()
    assert recorder.error is None
    assert f'{W} {N}, {MODEL} 1, {POSE} 0)' in recorder.summary()

    # topics, types, counts and offered QoS as sent (depth 0: history is not visible through discovery)
    info = topics_info(bag)
    n_diag = info.pop(DIAG).count
    assert {t: (i.msgtype, i.count) for t, i in info.items()} == {
        W: (F64MA, N), MODEL: (STRING, 1), POSE: (POSE_T, 0)}
    assert info[W].qos == (QosSpec('reliable', 'volatile', 0),)
    assert info[MODEL].qos == (QosSpec('reliable', 'transient_local', 0),)
    assert info[POSE].qos == (QosSpec('best_effort', 'volatile', 0),)
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert (meta['version'], meta['storage_identifier'], meta['message_count']) == (9, 'mcap', N + 1 + n_diag)

    # every message, in order, with its values, by rosbags ...
    messages = list(read_messages(bag, topics=[W]))
    assert [int(m.decode().data[0]) for m in messages] == list(range(N))
    stamps = [m.timestamp_ns for m in messages]
    assert stamps == sorted(stamps)
    # each with the publisher's send time (one clock here): sent in order, each before it was received
    assert [m.publish_ns for m in messages] == sorted(m.publish_ns for m in messages)
    assert all(0 < m.timestamp_ns - m.publish_ns for m in messages)
    for m in messages[:: N // 20]:
        msg = m.decode()
        seq = int(msg.data[0])
        assert list(msg.data) == [seq, 0.25, 1.0 - seq / N]
        assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [('seq,a,b', 3, 3)]
    (model,) = [m.decode() for m in read_messages(bag, topics=[MODEL])]
    assert model.data == MODEL_DOC

    # ... and by the independent mcap reader
    mcap = list(read_messages_mcap(bag))
    assert [int(m.decoded.data[0]) for m in mcap if m.topic == W] == list(range(N))
    assert [m.log_time_ns for m in mcap if m.topic == W] == stamps
    assert [(m.schema_name, m.decoded.data) for m in mcap if m.topic == MODEL] == [(STRING, MODEL_DOC)]
    assert len(mcap) == N + 1 + n_diag


def test_write_error_stops_recording_reports_and_calls_on_failure(ros, tmp_path: Path, monkeypatch) -> None:
    """A disk-full error from the storage: ERROR status and log, no more writes, on_failure called once."""
    writes = {'n': 0}
    original = rosbags.rosbag2.Writer.write

    def write_until_disk_full(self, *args, **kwargs):
        writes['n'] += 1
        if writes['n'] > 5:
            raise OSError(errno.ENOSPC, 'No space left on device')
        return original(self, *args, **kwargs)

    monkeypatch.setattr(rosbags.rosbag2.Writer, 'write', write_until_disk_full)
    statuses = ros.diagnostics()
    failures: list[BagWriteError] = []
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    recorder = ros.add(Recorder(tmp_path / 'full', context=ros.context, namespace=NS, discovery_period=0.1,
                                on_failure=failures.append))
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1, timeout=10.0)
    sent = publish_at_rate(ros, w_pub, 50, PERIOD)
    assert ros.wait_for(lambda: failures and len(sent) == 50, timeout=10.0)

    assert len(failures) == 1
    error = recorder.error
    assert error is failures[0] and error.path == tmp_path / 'full' and error.messages_written == 5
    assert os.strerror(errno.ENOSPC) in str(error) and '5 messages had been written' in str(error)
    assert recorder.counts[W] == 5
    assert 'FAILED' in recorder.summary()
    assert ros.wait_for(lambda: [s for s in statuses if s.name == f'{NS}/recorder: recorder'
                                 and s.level == DiagnosticStatus.ERROR and 'No space left' in s.message])
    assert w_pub.get_subscription_count() == 0 or ros.wait_for(lambda: w_pub.get_subscription_count() == 0)
    ros.remove(recorder)  # closing again is harmless
    assert writes['n'] == 6  # nothing was written after the failure


def test_existing_bag_is_never_overwritten(ros, tmp_path: Path) -> None:
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagWriteError, match='exists already'):
        Recorder(tmp_path / 'taken', context=ros.context)


def test_recorded_qos_and_type_hashes_are_what_publishers_offer(ros, tmp_path: Path) -> None:
    """As ``ros2 bag record`` (Jazzy): one offered profile per publisher, as discovery shows it.

    History
    unknown, depth 0, the publisher's deadline, lifespan, liveliness and lease; infinite when it sets none),
    and each MCAP channel's topic_type_hash is the hash rclpy reports for the live publishers.
    """
    from mcap.reader import make_reader
    from rclpy.duration import Duration
    from rclpy.qos import LivelinessPolicy
    timed = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=3, reliability=ReliabilityPolicy.RELIABLE,
                       deadline=Duration(seconds=0.5), lifespan=Duration(seconds=2.0),
                       liveliness=LivelinessPolicy.MANUAL_BY_TOPIC, liveliness_lease_duration=Duration(seconds=1.5))
    timed_pub = ros.publisher(String, f'{NS}/object/label', timed)
    plain_pubs = [ros.publisher(Float64MultiArray, W, DEEP_RELIABLE), ros.publisher(Float64MultiArray, W, BEST_EFFORT)]
    recorder = ros.add(Recorder(tmp_path / 'q', context=ros.context, namespace=NS, discovery_period=0.1,
                                topics=['object/', 'intent/']))
    assert ros.wait_for(lambda: {f'{NS}/object/label', W} <= set(recorder.recorded_topics), timeout=10.0)
    # a package topic stays subscribed reliable (what the suite offers) beside a best-effort publisher, which is
    # warned about; both offers are recorded
    assert recorder.recorded_topics[W][1] == QosSpec('reliable', 'volatile', 0)
    assert ros.publish_until(timed_pub, String(data='cup'), lambda: recorder.counts[f'{NS}/object/label'] >= 1)
    hashes = {t: str(ros.node.get_publishers_info_by_topic(t)[0].topic_type_hash) for t in (f'{NS}/object/label', W)}
    ros.remove(recorder)
    info = topics_info(tmp_path / 'q')
    assert info[f'{NS}/object/label'].qos == (QosSpec('reliable', 'volatile', 0, 'manual_by_topic', 500_000_000,
                                                      2_000_000_000, 1_500_000_000),)
    assert sorted(info[W].qos, key=lambda q: q.reliability) == [QosSpec('best_effort', 'volatile', 0),
                                                                QosSpec('reliable', 'volatile', 0)]
    meta = yaml.safe_load((tmp_path / 'q' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['ros_distro'] == 'jazzy'
    (label,) = [t['topic_metadata'] for t in meta['topics_with_message_count']
                if t['topic_metadata']['name'] == f'{NS}/object/label']
    (profile,) = label['offered_qos_profiles']
    assert (profile['history'], profile['depth'], profile['liveliness']) == ('unknown', 0, 'manual_by_topic')
    assert profile['deadline'] == {'sec': 0, 'nsec': 500_000_000}
    assert profile['lifespan'] == {'sec': 2, 'nsec': 0}
    assert profile['liveliness_lease_duration'] == {'sec': 1, 'nsec': 500_000_000}
    (mcap_file,) = (tmp_path / 'q').glob('*.mcap')
    with mcap_file.open('rb') as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert {c.topic: c.metadata['topic_type_hash'] for c in summary.channels.values() if c.topic in hashes} == hashes
    assert all(h.startswith('RIHS01_') for h in hashes.values())
    del plain_pubs


def test_qos_override_and_explicit_topics(ros, tmp_path: Path) -> None:
    pub = ros.publisher(Float64MultiArray, f'{NS}/grasp/posterior', DEEP_RELIABLE)
    ros.publisher(Float64MultiArray, f'{NS}/intent/v', DEEP_RELIABLE)
    recorder = ros.add(Recorder(tmp_path / 'b', context=ros.context, namespace=NS, discovery_period=0.1,
                                topics=['grasp/'], qos_overrides={'grasp/posterior': QosSpec('best_effort')}))
    assert ros.wait_for(lambda: pub.get_subscription_count() >= 1, timeout=10.0)
    assert ros.publish_until(pub, w_msg(7), lambda: recorder.counts.get(f'{NS}/grasp/posterior', 0) >= 1)
    assert set(recorder.recorded_topics) == {f'{NS}/grasp/posterior'}
    ros.remove(recorder)
    assert topics_info(tmp_path / 'b')[f'{NS}/grasp/posterior'].qos == (QosSpec('best_effort', 'volatile', 10),)


def test_late_publisher_with_weaker_qos_is_reported(ros, tmp_path: Path) -> None:
    """A volatile publisher joining a latched topic cannot reach the transient-local subscription: WARN."""
    statuses = ros.diagnostics()
    ros.publisher(String, MODEL, latched_qos()).publish(String(data=MODEL_DOC))
    recorder = ros.add(Recorder(tmp_path / 'b', context=ros.context, namespace=NS, discovery_period=0.1))
    assert ros.wait_for(lambda: recorder.counts.get(MODEL) == 1, timeout=10.0)
    ros.publisher(String, MODEL, DEEP_RELIABLE)
    assert ros.wait_for(lambda: [s for s in statuses if s.name == f'{NS}/recorder: recorder'
                                 and s.level == DiagnosticStatus.WARN and 'NOT recorded' in s.message],
                        timeout=10.0)


def test_the_default_topics_hold_what_the_demonstrations_command_reads(ros) -> None:
    """joint_states, object/pose and operator/grasp_tasks (grasp_intent_ros.sessions.demonstrations)."""
    selection = TopicSelection.resolve(ros.node, DEFAULT_TOPICS)
    assert all(selection.matches(f'/{topic}') for topic in (JOINT_STATES, OBJECT_POSE, OPERATOR_GRASP_TASKS))
    assert not selection.matches('/grasp_tasks')


NO_LOOK = 3600.0
"""A discovery period (s) no test lasts: the recorder looks at the graph once, when it starts."""


def recorder_qos(ros, topic: str) -> list[tuple[ReliabilityPolicy, DurabilityPolicy]]:
    """The reliability and durability of the recorder's subscriptions of ``topic``, as the graph shows them."""
    return [(i.qos_profile.reliability, i.qos_profile.durability)
            for i in ros.node.get_subscriptions_info_by_topic(topic) if i.node_name == 'recorder']


def test_one_shot_publish_on_a_package_topic_right_after_ready_is_recorded(ros, tmp_path: Path) -> None:
    """A publisher that appears after the recorder is ready, sends once after matching it and leaves."""
    bag = tmp_path / 'one_shot'
    recorder = ros.add(Recorder(bag, context=ros.context, namespace=NS, discovery_period=NO_LOOK))
    pub = ros.publisher(Float64MultiArray, W, output_qos())  # what send_intent and ros2 topic pub offer
    # what `ros2 topic pub --once -w 1` waits for before it publishes
    assert ros.wait_for(lambda: pub.get_subscription_count() >= 1, timeout=10.0), 'the recorder never subscribed'
    pub.publish(w_msg(3))
    ros.node.destroy_publisher(pub)
    assert ros.wait_for(lambda: recorder.counts.get(W) == 1, timeout=10.0), recorder.summary()
    ros.remove(recorder)
    assert [list(m.decode().data) for m in read_messages(bag, topics=[W])] == [list(w_msg(3).data)]
    # the offer of the publisher seen at the first message, or the suite's if it was gone by then: the same here
    assert topics_info(bag)[W].qos == (QosSpec('reliable', 'volatile', 0),)


SCENE_TOPICS = ('cup/', 'flashlight/', 'joint_states', '/diagnostics')
"""A scene's recording at the root (docs/several_objects.md): each chain's namespace, the arm's joint states."""


def test_the_namespaces_a_selection_names_are_its_chains_not_the_folders_of_the_package_topics(ros) -> None:
    def namespaces(*patterns: str) -> tuple[str, ...]:
        return TopicSelection.resolve(ros.node, patterns).namespaces()

    assert namespaces(*DEFAULT_TOPICS) == ('',)
    assert namespaces(*SCENE_TOPICS) == ('', '/cup', '/flashlight')  # '': the arm's joint_states
    assert namespaces('/robot1/cup/', '/robot1/model/ambiguity/', 'cup/intent/w', 'other') == ('/cup', '/robot1',
                                                                                             '/robot1/cup')


def test_a_one_shot_w_in_a_chain_of_a_scene_right_after_ready_is_recorded(ros, tmp_path: Path) -> None:
    """A recorder at the root selecting each chain by its prefix hears the chains' topics before any publisher."""
    bag = tmp_path / 'scene'
    cup_w, flashlight_model = '/cup/intent/w', '/flashlight/model/active'
    recorder = ros.add(Recorder(bag, context=ros.context, topics=SCENE_TOPICS, discovery_period=NO_LOOK))
    assert recorder_qos(ros, flashlight_model) == [(ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL)]
    assert recorder_qos(ros, '/intent/w') == [] and recorder_qos(ros, '/cup/cup/intent/w') == []
    pub = ros.publisher(Float64MultiArray, cup_w, output_qos())
    assert ros.wait_for(lambda: pub.get_subscription_count() >= 1, timeout=10.0), 'the recorder never subscribed'
    pub.publish(w_msg(5))
    ros.node.destroy_publisher(pub)
    model_pub = ros.publisher(String, flashlight_model, latched_qos())
    model_pub.publish(String(data=MODEL_DOC))
    assert ros.wait_for(lambda: recorder.counts.get(cup_w) == 1 and recorder.counts.get(flashlight_model) == 1,
                        timeout=10.0), recorder.summary()
    ros.remove(recorder)
    assert [list(m.decode().data) for m in read_messages(bag, topics=[cup_w])] == [list(w_msg(5).data)]
    assert set(topics_info(bag)) - {DIAG} == {cup_w, flashlight_model}  # /diagnostics: the recorder's own


def test_a_scenes_closed_loop_records_the_object_the_assistance_follows_sent_before_the_recorder(
        ros, tmp_path: Path) -> None:
    """``assistance/object`` is latched: a recorder of a scene's loop started after its last change still has it."""
    followed = '/assistance/object'
    pub = ros.publisher(String, followed, latched_qos())
    pub.publish(String(data='flashlight'))
    pub.publish(String(data='cup'))  # keep-last 1: only this one is left for a late subscriber
    bag = tmp_path / 'scene_loop'
    recorder = ros.add(Recorder(bag, context=ros.context, topics=(*SCENE_TOPICS, 'operator/', 'assistance/'),
                                discovery_period=NO_LOOK))
    assert recorder_qos(ros, followed) == [(ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL)]
    assert ros.wait_for(lambda: recorder.counts.get(followed) == 1, timeout=10.0), recorder.summary()
    ros.remove(recorder)
    assert [m.decode().data for m in read_messages(bag, topics=[followed])] == ['cup']
    assert topics_info(bag)[followed].qos == (QosSpec('reliable', 'transient_local', 0),)


def test_latched_topic_gets_its_last_message_and_best_effort_only_publisher_matches(ros, tmp_path: Path) -> None:
    """The package's latched topic is subscribed transient local.

    A package topic with best-effort publishers only is subscribed again best effort.
    """
    model_pub = ros.publisher(String, MODEL, latched_qos())
    model_pub.publish(String(data='# first'))
    model_pub.publish(String(data=MODEL_DOC))  # keep-last 1: only this one is left for a late subscriber
    bag = tmp_path / 'latched'
    recorder = ros.add(Recorder(bag, context=ros.context, namespace=NS, discovery_period=0.1))
    assert ros.wait_for(lambda: recorder_qos(ros, MODEL) == [(ReliabilityPolicy.RELIABLE,
                                                              DurabilityPolicy.TRANSIENT_LOCAL)])
    assert recorder_qos(ros, POSE) == [(ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE)]
    pose_pub = ros.publisher(PoseStamped, POSE, BEST_EFFORT)
    assert ros.wait_for(lambda: recorder_qos(ros, POSE) == [(ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE)],
                        timeout=10.0)
    assert ros.publish_until(pose_pub, PoseStamped(), lambda: recorder.counts.get(POSE, 0) >= 1, timeout=10.0)
    assert ros.wait_for(lambda: recorder.counts.get(MODEL) == 1, timeout=10.0), recorder.summary()
    ros.remove(recorder)
    assert [m.decode().data for m in read_messages(bag, topics=[MODEL])] == [MODEL_DOC]
    info = topics_info(bag)
    assert info[MODEL].qos == (QosSpec('reliable', 'transient_local', 0),)
    assert info[POSE].qos == (QosSpec('best_effort', 'volatile', 0),)


def test_topic_outside_the_package_is_recorded_once_discovered(ros, tmp_path: Path) -> None:
    label = f'{NS}/object/label'
    recorder = ros.add(Recorder(tmp_path / 'other', context=ros.context, namespace=NS, discovery_period=0.1,
                                topics=['object/']))
    # the package's topic under object/ is subscribed before any publisher, the other one is not
    assert ros.wait_for(lambda: recorder_qos(ros, POSE) == [(ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE)])
    assert recorder_qos(ros, label) == []
    assert recorder.recorded_topics == {}  # a topic enters the bag with its first publisher or message
    pub = ros.publisher(String, label, output_qos())
    assert ros.publish_until(pub, String(data='cup'), lambda: recorder.counts.get(label, 0) >= 1, timeout=10.0)
    assert recorder.recorded_topics[label] == (STRING, QosSpec('reliable', 'volatile', 0))
    assert set(recorder.recorded_topics) == {label}


def test_send_intent_waits_for_the_subscriptions_it_is_told_of(ros, tmp_path: Path) -> None:
    """``send_intent -w 2``: no w before two subscriptions (the interpreter's, the recorder's) have matched."""
    from grasp_intent_ros.cli.send_intent import IntentSender, NoGrasp

    heard: list[Float64MultiArray] = []
    ros.node.create_subscription(Float64MultiArray, W, heard.append, 10)  # stands in for the interpreter
    sender = ros.add(IntentSender(context=ros.context, namespace=NS))
    with pytest.raises(NoGrasp, match='no w was sent: 1 of the 2 subscriptions'):
        sender.send((0.9, 0.1), ros.executor, timeout=1.0, subscribers=2)
    assert heard == []
    recorder = ros.add(Recorder(tmp_path / 'sent', context=ros.context, namespace=NS, discovery_period=NO_LOOK))
    with pytest.raises(NoGrasp, match='no intent/v came back'):  # nobody answers: w is sent until the timeout
        sender.send((0.9, 0.1), ros.executor, timeout=2.0, subscribers=2)
    assert ros.wait_for(lambda: heard and recorder.counts.get(W) == len(heard)), (len(heard), recorder.summary())
