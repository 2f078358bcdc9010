"""grasp_intent_ros.sessions.bag: write session bags in tmp_path and read them back with rosbags and with mcap.

Decoded values are compared, never raw bytes. No rclpy.
"""

from __future__ import annotations

import errno
import math
import os
import pathlib
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_check import read_messages_mcap
from numpy.testing import assert_array_equal
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.sessions.bag import (
    BROKEN_SUFFIX,
    BagError,
    BagMessage,
    BagReadError,
    BagWriteError,
    QosSpec,
    QueuedWriter,
    ReindexResult,
    SessionWriter,
    TopicInfo,
    decode_qos,
    encode_qos,
    read_messages,
    reindex,
    topics_info,
)

T0_NS = 1_700_000_000_000_000_000  # a realistic epoch time, ns
INTENT, POSE, STATUS = '/grasp_intent/intent', '/grasp_intent/target_pose', '/grasp_intent/status'
F64MA, POSE_T = 'std_msgs/msg/Float64MultiArray', 'geometry_msgs/msg/PoseStamped'
STRING = 'std_msgs/msg/String'
STRING_RIHS01 = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'
"""std_msgs/msg/String's type hash in ROS 2 Jazzy, as rclpy reports it for a live publisher."""
QOS = {
    INTENT: QosSpec('best_effort', 'volatile', 5),
    POSE: QosSpec('reliable', 'volatile', 10),
    STATUS: QosSpec('reliable', 'transient_local', 1),
}


Session = tuple[Path, list[tuple[str, int, int]]]  # bag path, (topic, timestamp_ns, seq) in write order


@pytest.fixture(scope='module')
def store() -> Typestore:
    return get_typestore(Stores.ROS2_JAZZY)


# -- message builders (rosbags objects) and their expected decoded values --------------------------------

def intent_msg(store: Typestore, seq: int) -> Any:
    """Float64MultiArray, shape (2, 3) row-major; data[0] carries the sequence number."""
    t = store.types
    dims = [
        t['std_msgs/msg/MultiArrayDimension'](label='zone', size=2, stride=6),
        t['std_msgs/msg/MultiArrayDimension'](label='task', size=3, stride=3),
    ]
    data = np.array([seq, 0.1, -0.2, 1e-9, math.pi, -1e300], dtype=np.float64)
    return t[F64MA](layout=t['std_msgs/msg/MultiArrayLayout'](dim=dims, data_offset=0), data=data)


def pose_msg(store: Typestore, seq: int) -> Any:
    t = store.types
    header = t['std_msgs/msg/Header'](
        stamp=t['builtin_interfaces/msg/Time'](sec=1_700_000_000 + seq, nanosec=123_456_789),
        frame_id='mico_link_base',
    )
    pose = t['geometry_msgs/msg/Pose'](
        position=t['geometry_msgs/msg/Point'](x=0.1 * seq, y=-0.25, z=0.4),
        orientation=t['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(0.3), w=math.cos(0.3)),
    )
    return t[POSE_T](header=header, pose=pose)


def status_msg(store: Typestore, seq: int) -> Any:
    return store.types[STRING](data=f'seq {seq}: grasp zone → top ✓')


BUILDERS = {INTENT: (F64MA, intent_msg), POSE: (POSE_T, pose_msg), STATUS: (STRING, status_msg)}


def check_decoded(topic: str, msg: Any, seq: int) -> None:
    """Compare a decoded message (rosbags object or mcap_ros2 object: same attribute names) with `seq`'s."""
    if topic == INTENT:
        assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [('zone', 2, 6), ('task', 3, 3)]
        assert msg.layout.data_offset == 0
        assert_array_equal(np.asarray(msg.data), [seq, 0.1, -0.2, 1e-9, math.pi, -1e300])
    elif topic == POSE:
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_700_000_000 + seq, 123_456_789)
        assert msg.header.frame_id == 'mico_link_base'
        p, q = msg.pose.position, msg.pose.orientation
        assert (p.x, p.y, p.z) == (0.1 * seq, -0.25, 0.4)
        assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, math.sin(0.3), math.cos(0.3))
    else:
        assert msg.data == f'seq {seq}: grasp zone → top ✓'


def decoded(m: BagMessage) -> Any:
    """The rosbags message object, typed loosely for attribute access."""
    return m.decode()


def seq_of(topic: str, msg: Any) -> int:
    if topic == INTENT:
        return int(msg.data[0])
    if topic == POSE:
        return int(msg.header.stamp.sec) - 1_700_000_000
    return int(msg.data.split(':')[0].removeprefix('seq '))


def write_session(store: Typestore, path: Path, n_per_topic: int) -> list[tuple[str, int, int]]:
    """Write interleaved messages on three topics; return (topic, timestamp_ns, seq) in write order."""
    written = []
    with SessionWriter(path, typestore=store) as bag:
        for topic, (msgtype, _) in BUILDERS.items():
            bag.add_topic(topic, msgtype, qos=QOS[topic])
        stamp = T0_NS
        for seq in range(n_per_topic):
            for topic, (_, build) in BUILDERS.items():
                stamp += 1_000_000  # 1 ms
                if topic == POSE:  # pose via pre-serialized CDR, as the recorder gets it from rclpy
                    bag.write(topic, stamp, bytes(store.serialize_cdr(build(store, seq), POSE_T)))
                else:
                    bag.write_message(topic, stamp, build(store, seq))
                written.append((topic, stamp, seq))
        assert bag.message_count == len(written)
    assert bag.closed
    return written


@pytest.fixture(scope='module')
def session(tmp_path_factory: pytest.TempPathFactory, store: Typestore) -> Session:
    path = tmp_path_factory.mktemp('bags') / 'session'
    return path, write_session(store, path, n_per_topic=40)


# -- round trip ---------------------------------------------------------------------------------------------

def test_rosbags_reader_round_trip(session: Session) -> None:
    path, written = session
    msgs = list(read_messages(path))
    assert len(msgs) == len(written) == 120
    assert [(m.topic, m.timestamp_ns) for m in msgs] == [(t, s) for t, s, _ in written]
    stamps = [m.timestamp_ns for m in msgs]
    assert stamps == sorted(stamps)
    for m, (topic, _, seq) in zip(msgs, written):
        assert m.msgtype == BUILDERS[topic][0]
        decoded = m.decode()
        check_decoded(topic, decoded, seq)
        assert seq_of(topic, decoded) == seq


def test_mcap_reader_round_trip(session: Session) -> None:
    path, written = session
    msgs = list(read_messages_mcap(path))
    assert [(m.topic, m.log_time_ns) for m in msgs] == [(t, s) for t, s, _ in written]
    for m, (topic, _, seq) in zip(msgs, written):
        assert m.schema_name == BUILDERS[topic][0]
        check_decoded(topic, m.decoded, seq)
        assert seq_of(topic, m.decoded) == seq


def test_topic_filter_in_both_readers(session: Session) -> None:
    path, written = session
    want = [(s, q) for t, s, q in written if t == STATUS]
    got = [(m.timestamp_ns, seq_of(STATUS, m.decode())) for m in read_messages(path, topics=[STATUS])]
    got_mcap = [(m.log_time_ns, seq_of(STATUS, m.decoded)) for m in read_messages_mcap(path, topics=[STATUS])]
    assert got == got_mcap == want


def test_topics_info_round_trips_types_counts_qos(session: Session) -> None:
    path, _ = session
    expect = {topic: TopicInfo(BUILDERS[topic][0], 40, (QOS[topic],)) for topic in BUILDERS}
    assert topics_info(path) == expect


def test_mcap_channels_carry_v9_qos_and_ros2msg_schemas(session: Session) -> None:
    """Read the channel metadata with the mcap library alone, as rosbag2_storage_mcap does."""
    path, _ = session
    (mcap_file,) = path.glob('*.mcap')
    with mcap_file.open('rb') as f:
        reader = make_reader(f)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
    assert summary is not None
    channels = {c.topic: c for c in summary.channels.values()}
    assert set(channels) == set(BUILDERS)
    for topic, channel in channels.items():
        schema = summary.schemas[channel.schema_id]
        assert (schema.name, schema.encoding) == (BUILDERS[topic][0], 'ros2msg')
        assert channel.message_encoding == 'cdr'
        # rosbag2_storage_mcap (jazzy) create_topic: exactly these two entries per channel
        assert set(channel.metadata) == {'offered_qos_profiles', 'topic_type_hash'}
        assert re.fullmatch(r'RIHS01_[0-9a-f]{64}', channel.metadata['topic_type_hash'])
        (profile,) = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        assert_rosbag2_profile(profile, QOS[topic])
        assert summary.statistics is not None
        assert summary.statistics.channel_message_counts[channel.id] == 40


def assert_rosbag2_profile(profile: dict[str, Any], spec: QosSpec) -> None:
    """One offered QoS profile as rosbag2_storage's qos.cpp (jazzy) encodes it for metadata version 9.

    rmw policy names, rmw_time_t durations with RMW_DURATION_INFINITE = {9223372036 s, 854775807 ns}.
    """
    assert set(profile) == {'history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
                            'liveliness_lease_duration', 'avoid_ros_namespace_conventions'}
    assert (profile['history'], profile['depth']) == (('keep_last', spec.depth) if spec.depth else ('unknown', 0))
    assert (profile['reliability'], profile['durability']) == (spec.reliability, spec.durability)
    assert profile['liveliness'] == 'automatic'
    infinite = {'sec': 9223372036, 'nsec': 854775807}
    assert profile['deadline'] == profile['lifespan'] == profile['liveliness_lease_duration'] == infinite
    assert profile['avoid_ros_namespace_conventions'] is False


def test_metadata_yaml_is_rosbag2_v9_mcap(session: Session) -> None:
    path, written = session
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9
    assert info['ros_distro'] == 'jazzy'  # what rosbag2 writes on Jazzy ($ROS_DISTRO), not 'rosbags'
    # the MCAP file carries the same metadata (record 'rosbag2', as rosbag2_storage_mcap reads it)
    (mcap_file,) = path.glob('*.mcap')
    with mcap_file.open('rb') as f:
        records = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    embedded = yaml.safe_load(records['rosbag2']['serialized_metadata'])
    assert embedded['ros_distro'] == 'jazzy' and embedded['version'] == 9
    assert embedded['topics_with_message_count'] == info['topics_with_message_count']
    assert info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == ['session.mcap']
    assert (path / 'session.mcap').is_file()
    assert info['message_count'] == len(written)
    assert info['starting_time']['nanoseconds_since_epoch'] == written[0][1]
    assert info['duration']['nanoseconds'] == written[-1][1] - written[0][1]
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == set(BUILDERS)
    for topic, entry in topics.items():
        meta = entry['topic_metadata']
        assert entry['message_count'] == 40
        assert (meta['type'], meta['serialization_format']) == (BUILDERS[topic][0], 'cdr')
        assert re.fullmatch(r'RIHS01_[0-9a-f]{64}', meta['type_description_hash'])
        (profile,) = meta['offered_qos_profiles']  # v9: a list of mappings with string enums
        assert_rosbag2_profile(profile, QOS[topic])
    # the channel hash equals the metadata's, and the one rosidl gives std_msgs/String (as rclpy reports it)
    with mcap_file.open('rb') as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    hashes = {c.topic: c.metadata['topic_type_hash'] for c in summary.channels.values()}
    assert hashes == {t: e['topic_metadata']['type_description_hash'] for t, e in topics.items()}
    assert hashes[STATUS] == STRING_RIHS01


def test_5000_messages_all_found_in_order_by_both_readers(tmp_path: Path, store: Typestore) -> None:
    path = tmp_path / 'big'
    n = 5000
    with SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/a', STRING, qos=QosSpec())
        bag.add_topic('/b', STRING, qos=QosSpec('best_effort'))
        for i in range(n):
            bag.write_message('/a' if i % 3 else '/b', T0_NS + 1000 * i, store.types[STRING](data=str(i)))
    expect = [('/a' if i % 3 else '/b', T0_NS + 1000 * i, str(i)) for i in range(n)]
    assert [(m.topic, m.timestamp_ns, decoded(m).data) for m in read_messages(path)] == expect
    assert [(m.topic, m.log_time_ns, m.decoded.data) for m in read_messages_mcap(path)] == expect
    info = topics_info(path)
    assert (info['/a'].count, info['/b'].count) == (n - (n + 2) // 3, (n + 2) // 3)


def test_equal_timestamps_keep_write_order(tmp_path: Path, store: Typestore) -> None:
    path = tmp_path / 'ties'
    with SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/a', STRING, qos=QosSpec())
        bag.add_topic('/b', STRING, qos=QosSpec())
        for i in range(50):
            stamp = T0_NS + 1000 * (i // 10)  # ten messages per timestamp
            bag.write_message('/a' if i % 2 else '/b', stamp, store.types[STRING](data=str(i)))
    assert [decoded(m).data for m in read_messages(path)] == [str(i) for i in range(50)]
    assert [m.decoded.data for m in read_messages_mcap(path)] == [str(i) for i in range(50)]


def test_each_message_keeps_its_send_time_as_the_mcap_publish_time(tmp_path: Path, store: Typestore) -> None:
    """Receive time in log_time, send time in publish_time (the receive time when none is given), as rosbag2 does."""
    path = tmp_path / 'times'
    with SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/a', STRING, qos=QosSpec())
        cdr = store.serialize_cdr(store.types[STRING](data='x'), STRING)
        bag.write('/a', T0_NS + 10, cdr, T0_NS + 3)
        bag.write('/a', T0_NS + 20, cdr)
        for bad in (-1, 2**63, 1.5):
            with pytest.raises(BagWriteError, match='publish_ns'):
                bag.write('/a', T0_NS + 30, cdr, bad)  # type: ignore[arg-type]
    assert [(m.timestamp_ns, m.publish_ns) for m in read_messages(path)] == [(T0_NS + 10, T0_NS + 3),
                                                                           (T0_NS + 20, T0_NS + 20)]
    assert [(m.log_time_ns, m.publish_time_ns) for m in read_messages_mcap(path)] == [(T0_NS + 10, T0_NS + 3),
                                                                                      (T0_NS + 20, T0_NS + 20)]


def test_a_bag_of_another_storage_is_read_with_receive_times_as_send_times(tmp_path: Path, store: Typestore) -> None:
    """A rosbag2 sqlite3 bag (rosbags writes it) holds no send times: read by rosbags, the receive time in both."""
    path = tmp_path / 'sqlite'
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        connection = writer.add_connection('/a', STRING, typestore=store)
        for k in range(3):
            writer.write(connection, T0_NS + k, store.serialize_cdr(store.types[STRING](data=str(k)), STRING))
    read = list(read_messages(path))
    assert [(m.topic, m.timestamp_ns, m.publish_ns, decoded(m).data) for m in read] == [
        ('/a', T0_NS + k, T0_NS + k, str(k)) for k in range(3)]


def two_file_bag(tmp_path: Path, store: Typestore) -> Path:
    """A bag directory of two MCAP files, as a split recording leaves it.

    /a's messages at receive times 0, 2, 4 (x 10 ns) in ``part_1.mcap`` and 1, 3, 5 in ``part_0.mcap``, each sent
    1 ns before; metadata.yaml lists both, part_1 first; a stray ``old.mcap`` beside them that it does not list.
    """
    path = tmp_path / 'split'
    path.mkdir()
    cdr = {k: store.serialize_cdr(store.types[STRING](data=str(k)), STRING) for k in range(6)}
    for name, ks in (('part_1', (0, 2, 4)), ('part_0', (1, 3, 5)), ('old', (9,))):
        with SessionWriter(tmp_path / name, typestore=store) as bag:
            bag.add_topic('/a', STRING, qos=QosSpec())
            for k in ks:
                bag.write('/a', T0_NS + 10 * k, cdr.get(k, cdr[0]), T0_NS + 10 * k - 1)
        (tmp_path / name / f'{name}.mcap').rename(path / f'{name}.mcap')
    metadata = yaml.safe_load((tmp_path / 'part_1' / 'metadata.yaml').read_text())
    info = metadata['rosbag2_bagfile_information']
    info['relative_file_paths'] = ['part_1.mcap', 'part_0.mcap']
    info['files'] = []
    info['message_count'] = info['topics_with_message_count'][0]['message_count'] = 6
    (path / 'metadata.yaml').write_text(yaml.safe_dump(metadata))
    return path


def test_a_bag_of_two_files_is_read_from_the_files_its_metadata_lists(tmp_path: Path, store: Typestore) -> None:
    """Both listed files' messages, merged by receive time, each with its send time; the unlisted file is not read."""
    read = list(read_messages(two_file_bag(tmp_path, store)))
    assert [(m.timestamp_ns, m.publish_ns, decoded(m).data) for m in read] == [
        (T0_NS + 10 * k, T0_NS + 10 * k - 1, str(k)) for k in range(6)]


def test_a_metadata_listing_a_missing_file_is_a_read_error(tmp_path: Path, store: Typestore) -> None:
    path = two_file_bag(tmp_path, store)
    (path / 'part_0.mcap').unlink()
    with pytest.raises(BagReadError, match='part_0.mcap'):
        next(read_messages(path))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), max_size=20),
    text=st.text(st.characters(blacklist_categories=['Cs'], blacklist_characters='\x00'), max_size=40),
)
def test_arbitrary_values_round_trip(
    tmp_path_factory: pytest.TempPathFactory, store: Typestore, values: list[float], text: str
) -> None:
    path = tmp_path_factory.mktemp('prop') / 'bag'
    t = store.types
    layout = t['std_msgs/msg/MultiArrayLayout'](
        dim=[t['std_msgs/msg/MultiArrayDimension'](label=text, size=len(values), stride=len(values))],
        data_offset=0,
    )
    with SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/x', F64MA, qos=QosSpec())
        bag.write_message('/x', T0_NS, t[F64MA](layout=layout, data=np.array(values, dtype=np.float64)))
    (msg,) = read_messages(path)
    (mmsg,) = read_messages_mcap(path)
    both: list[Any] = [msg.decode(), mmsg.decoded]
    for decoded in both:
        assert_array_equal(np.asarray(decoded.data, dtype=np.float64), values)  # equal_nan by default
        assert decoded.layout.dim[0].label == text


# -- writer errors ------------------------------------------------------------------------------------

def test_existing_directory_is_refused(tmp_path: Path) -> None:
    (tmp_path / 'old').mkdir()
    with pytest.raises(BagWriteError, match='exists already') as err:
        SessionWriter(tmp_path / 'old')
    assert err.value.path == tmp_path / 'old'
    assert err.value.messages_written == 0
    assert isinstance(err.value, BagError) and not isinstance(err.value, ValueError), 'not a bad-argument error'
    assert list((tmp_path / 'old').iterdir()) == []


class _DiskFull:
    """A file object that accepts `budget` bytes, then fails like a full disk."""

    def __init__(self, raw: Any, budget: int) -> None:
        self._raw, self._budget = raw, budget

    def write(self, data: bytes | memoryview) -> int:
        size = memoryview(data).nbytes
        if size > self._budget:
            raise OSError(errno.ENOSPC, 'No space left on device')
        self._budget -= size
        return int(self._raw.write(data))

    def tell(self) -> int:
        return int(self._raw.tell())

    def flush(self) -> None:
        self._raw.flush()

    def close(self) -> None:
        self._raw.close()


def _fill_disk_after(monkeypatch: pytest.MonkeyPatch, budget: int) -> None:
    """Make the storage file (opened 'xb' by rosbags' MCAP writer) hit ENOSPC after `budget` bytes."""
    real_open = pathlib.Path.open

    def fake_open(self: Path, mode: str = 'r', *args: Any, **kwargs: Any) -> Any:
        f = real_open(self, mode, *args, **kwargs)
        return _DiskFull(f, budget) if mode == 'xb' else f

    monkeypatch.setattr(pathlib.Path, 'open', fake_open)


def test_enospc_during_write_reports_path_and_count(
    tmp_path: Path, store: Typestore, monkeypatch: pytest.MonkeyPatch
) -> None:
    _fill_disk_after(monkeypatch, budget=4096)  # fails at the first chunk flush (> 1 MiB buffered)
    path = tmp_path / 'full'
    layout = store.types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
    big = store.types[F64MA](layout=layout, data=np.zeros(10_000))  # 80 kB
    accepted = 0
    with pytest.raises(BagWriteError) as err, SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/big', F64MA, qos=QosSpec())
        for i in range(1000):
            bag.write_message('/big', T0_NS + i, big)
            accepted += 1
    assert 0 < accepted < 1000
    assert err.value.messages_written == accepted
    assert err.value.path == path
    assert str(path) in str(err.value) and f'{accepted} messages' in str(err.value)
    assert os.strerror(errno.ENOSPC) in str(err.value)  # the cause, in this machine's C library's words
    assert isinstance(err.value.__cause__, OSError) and err.value.__cause__.errno == errno.ENOSPC
    assert bag.closed
    with pytest.raises(BagWriteError, match='closed'):
        bag.write_message('/big', T0_NS, big)
    bag.close()  # idempotent, also after a failure


def test_enospc_during_close_reports_count(
    tmp_path: Path, store: Typestore, monkeypatch: pytest.MonkeyPatch
) -> None:
    _fill_disk_after(monkeypatch, budget=64)  # header fits; the buffered chunk does not
    path = tmp_path / 'full'
    with pytest.raises(BagWriteError, match='7 messages') as err, SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/s', STRING, qos=QosSpec())
        for i in range(7):
            bag.write_message('/s', T0_NS + i, store.types[STRING](data='x'))
    assert err.value.messages_written == 7
    assert not (path / 'metadata.yaml').exists()


def test_exception_in_body_still_closes_and_keeps_data(tmp_path: Path, store: Typestore) -> None:
    path = tmp_path / 'crash'
    with pytest.raises(RuntimeError, match='node died'), SessionWriter(path, typestore=store) as bag:
        bag.add_topic('/s', STRING, qos=QosSpec())
        bag.write_message('/s', T0_NS, store.types[STRING](data='before'))
        raise RuntimeError('node died')
    assert bag.closed
    assert [decoded(m).data for m in read_messages(path)] == ['before']


def test_writer_misuse_is_reported(tmp_path: Path, store: Typestore) -> None:
    with SessionWriter(tmp_path / 'b', typestore=store) as bag:
        bag.add_topic('/s', STRING, qos=QosSpec())
        cdr = bytes(store.serialize_cdr(store.types[STRING](data='ok'), STRING))
        cases: list[tuple[Callable[[], object], str]] = [
            (lambda: bag.add_topic('/s', STRING, qos=QosSpec()), 'already added'),
            (lambda: bag.add_topic('no_slash', STRING, qos=QosSpec()), 'fully qualified'),
            (lambda: bag.add_topic('/u', 'nope_msgs/msg/Nope', qos=QosSpec()), 'not in the typestore'),
            (lambda: bag.write('/unknown', T0_NS, cdr), 'not added'),
            (lambda: bag.write('/s', -1, cdr), r'\[0, 2\*\*63\)'),
            (lambda: bag.write('/s', 1.5, cdr), 'integer'),  # type: ignore[arg-type]
            (lambda: bag.write('/s', T0_NS, b''), 'encapsulation'),
            (lambda: bag.write_message('/s', T0_NS, store.types['std_msgs/msg/Bool'](data=True)), 'carries'),
            (lambda: bag.write_message('/s', T0_NS, store.types[STRING](data=3)), 'cannot serialize'),
        ]
        for call, match in cases:
            with pytest.raises(BagWriteError, match=match):
                call()
        bag.write('/s', np.int64(T0_NS), cdr)  # type: ignore[arg-type]  # numpy integers are integers
    assert bag.message_count == 1
    bag.close()
    with pytest.raises(BagWriteError, match='closed'):
        bag.write('/s', T0_NS, cdr)


# -- QoS and reader errors ----------------------------------------------------------------------------

def test_qos_spec_validates_and_round_trips() -> None:
    for bad in ({'reliability': 'sometimes'}, {'durability': 'persistent'}, {'depth': -1}, {'depth': 2.0}):
        with pytest.raises(BagError):
            QosSpec(**bad)
    for bad in ({'liveliness': 'manual_by_node'}, {'deadline_ns': 0}, {'lifespan_ns': -1},
                {'liveliness_lease_ns': 2**63 - 1}, {'deadline_ns': 1.5}):
        with pytest.raises(BagError):
            QosSpec(**bad)
    for spec in (QosSpec(), QosSpec('best_effort', 'transient_local', 1), QosSpec(depth=0),
                 QosSpec(liveliness='manual_by_topic', deadline_ns=100_000_000, lifespan_ns=2_500_000_000,
                         liveliness_lease_ns=10**18)):
        assert decode_qos(encode_qos(spec)) == spec
    assert encode_qos(QosSpec(depth=0)).history == QosHistory.UNKNOWN  # as `ros2 bag record` stores it
    # a publisher without deadline, lifespan or lease offers them infinite, with automatic liveliness
    qos = encode_qos(QosSpec())
    assert qos.deadline == qos.lifespan == qos.liveliness_lease_duration == QosTime(9223372036, 854775807)
    assert qos.liveliness == QosLiveliness.AUTOMATIC
    assert encode_qos(QosSpec(deadline_ns=2_500_000_000)).deadline == QosTime(2, 500_000_000)


def test_decode_qos_of_foreign_profiles() -> None:
    inf = QosTime(9223372036, 854775807)
    keep_all = Qos(QosHistory.KEEP_ALL, 0, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, inf, inf,
                   QosLiveliness.AUTOMATIC, inf, False)
    assert decode_qos(keep_all) == QosSpec('reliable', 'transient_local', 0)
    # unspecified (0, the rmw default) and Foxy's infinities read as infinite, as rosbag2's qos.cpp does
    for legacy in (QosTime(0, 0), QosTime(0x7FFFFFFF, 0xFFFFFFFF), QosTime(0x7FFFFFFF, 0x7FFFFFFF)):
        assert decode_qos(keep_all._replace(deadline=legacy, liveliness=QosLiveliness.SYSTEM_DEFAULT)) == QosSpec(
            'reliable', 'transient_local', 0, 'system_default')
    with pytest.raises(BagReadError, match='system_default'):
        decode_qos(keep_all._replace(reliability=QosReliability.SYSTEM_DEFAULT))


def test_reader_errors(tmp_path: Path, session: Session) -> None:
    path, _ = session
    with pytest.raises(GraspIntentError, match='no topic') as err:  # bad input, like the core's
        next(read_messages(path, topics=['/typo']))
    assert isinstance(err.value, BagReadError)
    with pytest.raises(BagReadError):
        next(read_messages(tmp_path / 'missing'))
    with pytest.raises(BagReadError):
        topics_info(tmp_path / 'missing')
    with pytest.raises(BagReadError, match='no .mcap'):
        next(read_messages_mcap(tmp_path))


# -- crash safety: flushing, the writer thread, reindex -------------------------------------------------------

def wait_until(condition: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Poll ``condition`` until it holds or ``timeout`` s pass (a condition wait, not a sleep)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
    return True


def mcap_file(bag: Path) -> Path:
    (path,) = bag.glob('*.mcap')
    return path


def test_header_is_on_disk_at_once_and_flush_writes_the_open_chunk(tmp_path: Path, store: Typestore) -> None:
    bag = SessionWriter(tmp_path / 'b', typestore=store, flush_period=None)
    assert mcap_file(tmp_path / 'b').read_bytes().startswith(b'\x89MCAP0\r\n\x01')
    bag.add_topic('/s', STRING, qos=QosSpec())
    size = mcap_file(tmp_path / 'b').stat().st_size
    bag.write_message('/s', T0_NS, status_msg(store, 0))
    assert bag.seconds_to_flush is None  # no period: chunks close by size only
    assert mcap_file(tmp_path / 'b').stat().st_size == size  # buffered in the open chunk
    bag.flush()
    assert mcap_file(tmp_path / 'b').stat().st_size > size
    bag.close()
    with pytest.raises(BagWriteError, match='closed'):
        bag.flush()
    with pytest.raises(ValueError, match='flush_period'):
        SessionWriter(tmp_path / 'c', flush_period=0.0)


def test_a_chunk_is_flushed_once_its_first_message_is_flush_period_old(tmp_path: Path, store: Typestore) -> None:
    bag = SessionWriter(tmp_path / 'b', typestore=store, flush_period=0.05)
    bag.add_topic('/s', STRING, qos=QosSpec())
    assert bag.seconds_to_flush is None and not bag.flush_if_due()  # nothing to flush
    size = mcap_file(tmp_path / 'b').stat().st_size
    bag.write_message('/s', T0_NS, status_msg(store, 0))
    due = bag.seconds_to_flush
    assert due is not None and 0.0 < due <= 0.05
    assert wait_until(bag.flush_if_due, timeout=5.0)
    assert bag.seconds_to_flush is None and mcap_file(tmp_path / 'b').stat().st_size > size
    # write() itself flushes a chunk that is due
    bag.write_message('/s', T0_NS + 1, status_msg(store, 1))
    size = mcap_file(tmp_path / 'b').stat().st_size
    assert wait_until(lambda: (bag.seconds_to_flush or 0.0) <= 0.0, timeout=5.0)
    bag.write_message('/s', T0_NS + 2, status_msg(store, 2))
    assert bag.seconds_to_flush is None and mcap_file(tmp_path / 'b').stat().st_size > size
    bag.close()
    assert [m.decode().data for m in read_messages(tmp_path / 'b')] == [  # type: ignore[attr-defined]
        status_msg(store, i).data for i in range(3)]


def test_queued_writer_writes_in_order_and_flushes_when_idle(tmp_path: Path, store: Typestore) -> None:
    bag = SessionWriter(tmp_path / 'b', typestore=store, flush_period=0.05)
    bag.add_topic('/s', STRING, qos=QosSpec())
    bag.add_topic(INTENT, F64MA, qos=QosSpec())
    writer = QueuedWriter(bag)
    cdr = [bytes(store.serialize_cdr(status_msg(store, i), STRING)) for i in range(300)]
    for i, data in enumerate(cdr):
        writer.put('/s', T0_NS + i, data)
    writer.put(INTENT, T0_NS + 300, bytes(store.serialize_cdr(intent_msg(store, 7), F64MA)))
    assert 1 <= writer.peak <= 301
    size_before = mcap_file(tmp_path / 'b').stat().st_size
    # no further message: the writer thread flushes the open chunk on its own
    assert wait_until(lambda: writer.counts == {'/s': 300, INTENT: 1}
                      and mcap_file(tmp_path / 'b').stat().st_size > size_before and bag.seconds_to_flush is None)
    assert writer.queued == 0 and writer.error is None and writer.dropped == 0
    writer.close()
    writer.close()  # idempotent
    writer.put('/s', T0_NS, cdr[0])
    assert writer.dropped == 1 and bag.closed
    got = list(read_messages(tmp_path / 'b'))
    assert [seq_of(m.topic, decoded(m)) for m in got] == [*range(300), 7]


def test_queued_writer_stops_at_a_write_error_and_reports_it_once(
    tmp_path: Path, store: Typestore, monkeypatch: pytest.MonkeyPatch
) -> None:
    _fill_disk_after(monkeypatch, budget=4096)
    bag = SessionWriter(tmp_path / 'full', typestore=store, flush_period=None)
    bag.add_topic('/big', F64MA, qos=QosSpec())
    layout = store.types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
    noise = np.random.default_rng(0).random(10_000)  # 80 kB that zstd cannot shrink
    big = bytes(store.serialize_cdr(store.types[F64MA](layout=layout, data=noise), F64MA))
    errors: list[BagWriteError] = []
    writer = QueuedWriter(bag, on_error=errors.append)
    for i in range(40):  # the first 1 MiB chunk cannot be written
        writer.put('/big', T0_NS + i, big)
    assert wait_until(lambda: writer.error is not None and writer.counts.get('/big', 0) + writer.dropped == 40)
    assert errors == [writer.error] and 'No space left on device' in str(writer.error)
    assert 0 < writer.counts['/big'] < 40
    writer.close()  # the writer is closed already: no second error


def truncated_copy(source: Path, tmp_path: Path, name: str, size: int) -> Path:
    """A bag directory ``name`` holding the first ``size`` bytes of ``source``'s .mcap and no metadata.yaml."""
    bag = tmp_path / name
    bag.mkdir()
    (bag / f'{name}.mcap').write_bytes(mcap_file(source).read_bytes()[:size])
    return bag


@pytest.fixture(scope='module')
def chunked(tmp_path_factory: pytest.TempPathFactory, store: Typestore) -> tuple[Path, list[tuple[int, int]]]:
    """A complete bag of 5 explicitly flushed chunks, 30 messages each; its (chunk end offset, messages before)."""
    path = tmp_path_factory.mktemp('chunked') / 'chunked'
    with SessionWriter(path, typestore=store, flush_period=None) as bag:
        for topic, (msgtype, _) in BUILDERS.items():
            bag.add_topic(topic, msgtype, qos=QOS[topic])
        for seq in range(50):
            for k, (topic, (msgtype, build)) in enumerate(BUILDERS.items()):  # sent 1 ns before received
                stamp = T0_NS + 3 * seq + k
                bag.write(topic, stamp, store.serialize_cdr(build(store, seq), msgtype), stamp - 1)
            if seq % 10 == 9:
                bag.flush()
    with mcap_file(path).open('rb') as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.chunk_indexes) == 5
    ends = [(c.chunk_start_offset + c.chunk_length, 30 * (i + 1)) for i, c in enumerate(summary.chunk_indexes)]
    return path, ends


def test_reindex_of_a_truncated_file_recovers_every_complete_chunk(
    tmp_path: Path, store: Typestore, chunked: tuple[Path, list[tuple[int, int]]]
) -> None:
    """Cut at ~30 offsets (at and just before every chunk's end, in the header, a spread): never a crash.

    (~0.3 s each: rosbags' YAML dump of the metadata dominates.)
    """
    source, ends = chunked
    size = mcap_file(source).stat().st_size
    offsets = sorted({*range(0, size + 1, max(1, size // 12)), *(e + d for e, _ in ends for d in (-1, 0)),
                      8, 9, 60, size - 1})
    everything = [(m.topic, m.timestamp_ns, seq_of(m.topic, decoded(m)), m.publish_ns) for m in read_messages(source)]
    assert all(publish == stamp - 1 for _, stamp, _, publish in everything)  # the send times are kept too
    for offset in offsets:
        bag = truncated_copy(source, tmp_path, f'cut{offset}', offset)
        expected = max((n for end, n in ends if end <= offset), default=0)
        try:
            result = reindex(bag, typestore=store)
        except BagReadError as exc:  # only a file without a complete header cannot be repaired
            assert offset < 60 and ('MCAP magic' in str(exc) or 'header' in str(exc)), (offset, exc)
            assert (bag / f'cut{offset}.mcap').stat().st_size == offset  # untouched
            continue
        assert result.repaired and result.messages == expected, (offset, result)
        got = [(m.topic, m.timestamp_ns, seq_of(m.topic, decoded(m)), m.publish_ns)
               for m in read_messages(bag, typestore=store)]
        assert got == everything[:expected], offset
        assert (bag / f'cut{offset}.mcap{BROKEN_SUFFIX}').read_bytes() == mcap_file(source).read_bytes()[:offset]
        if expected:
            assert [(m.topic, m.log_time_ns) for m in read_messages_mcap(bag)] == [t[:2] for t in got]
            info = topics_info(bag)
            assert {t: (i.msgtype, i.count, i.qos) for t, i in info.items()} == {
                t: (BUILDERS[t][0], expected // 3, (QOS[t],)) for t in BUILDERS}
            meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
            assert meta['message_count'] == expected
            assert meta['starting_time']['nanoseconds_since_epoch'] == T0_NS
            assert meta['duration']['nanoseconds'] == got[-1][1] - T0_NS


def test_reindex_leaves_a_complete_bag_alone_and_rebuilds_a_missing_metadata(
    tmp_path: Path, chunked: tuple[Path, list[tuple[int, int]]]
) -> None:
    source, ends = chunked
    assert reindex(source) == ReindexResult(source, repaired=False)
    assert 'nothing to do' in reindex(source).summary()
    whole = truncated_copy(source, tmp_path, 'whole', mcap_file(source).stat().st_size)  # no metadata.yaml
    result = reindex(whole)
    assert (result.messages, result.chunks, result.discarded_bytes, result.stopped) == (150, 5, 0, 'end of data')
    assert topics_info(whole)[INTENT].count == 50
    assert not reindex(whole).repaired  # complete now


def test_reindex_errors_are_clear_and_change_nothing(
    tmp_path: Path, chunked: tuple[Path, list[tuple[int, int]]]
) -> None:
    source, ends = chunked
    with pytest.raises(BagReadError, match='not a directory'):
        reindex(tmp_path / 'missing')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagReadError, match='expected one .mcap file, found none'):
        reindex(tmp_path / 'empty')
    junk = tmp_path / 'junk'
    junk.mkdir()
    (junk / 'junk.mcap').write_bytes(b'not an mcap file at all')
    with pytest.raises(BagReadError, match='MCAP magic'):
        reindex(junk)
    assert sorted(p.name for p in junk.iterdir()) == ['junk.mcap']
    bag = truncated_copy(source, tmp_path, 'twice', ends[2][0] + 5)
    (bag / 'twice.mcap.broken').write_bytes(b'an earlier original')
    with pytest.raises(BagReadError, match='exists'):
        reindex(bag)
    assert (bag / 'twice.mcap').stat().st_size == ends[2][0] + 5
    (bag / 'twice.mcap').unlink()  # as if a repair had been killed between its two renames
    with pytest.raises(BagReadError, match='found none .twice.mcap.broken: the original of an interrupted'):
        reindex(bag)


def test_reindex_stops_at_a_corrupt_chunk_and_keeps_what_precedes_it(
    tmp_path: Path, chunked: tuple[Path, list[tuple[int, int]]]
) -> None:
    source, ends = chunked
    data = bytearray(mcap_file(source).read_bytes())
    data[ends[3][0] - 20] ^= 0xFF  # inside the compressed data of chunk 4
    bag = tmp_path / 'flipped'
    bag.mkdir()
    (bag / 'flipped.mcap').write_bytes(bytes(data[:ends[4][0]]))
    result = reindex(bag)
    assert result.messages == ends[2][1] and 'corrupt' in result.stopped, result
    assert len(list(read_messages(bag))) == ends[2][1]
