"""The recorder as a real ``python -m grasp_intent_ros recorder`` process.

Fed over loopback DDS by the in-process probe (``ros`` fixture of test/conftest.py, whose domain id the process shares).

Only the recorder processes started here are ever signalled, by PID.
"""

from __future__ import annotations

import re
import resource
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap_check import read_messages_mcap
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray, String

from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.sessions.bag import QosSpec, read_messages, topics_info

REPO = Path(__file__).resolve().parents[2]
STARTUP = 20.0
"""Seconds the process gets to start (imports, DDS discovery) on a loaded machine."""
N = 2000
NS = '/robot1'
W, MODEL, DIAG = f'{NS}/intent/w', f'{NS}/model/active', '/diagnostics'
MODEL_DOC = '# model_name: cup_7zone\nname: cup_7zone\n'
DEEP_RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=N, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE)


class RecorderProcess(NodeProcess):
    """``python -m grasp_intent_ros recorder BAG --ros-args -r __ns:=/robot1``; output to files."""

    def __init__(self, bag: Path, domain_id: int, log_dir: Path,
                 preexec_fn: Callable[[], None] | None = None, flush_period: float = 1.0,
                 depth: int | None = None) -> None:
        command = [sys.executable, '-m', 'grasp_intent_ros', 'recorder', str(bag), '--discovery-period', '0.2',
                   '--flush-period', str(flush_period), *(['--depth', str(depth)] if depth else []),
                   '--ros-args', '-r', f'__ns:={NS}']
        super().__init__(command, module='recorder', env=node_environment(domain_id), log_dir=log_dir,
                         cwd=REPO, preexec_fn=preexec_fn)

    def stop(self, sig: signal.Signals = signal.SIGTERM, timeout: float = 10.0) -> int:
        """Send ``sig`` to this PID (unless it exited) and wait; SIGKILL after ``timeout`` s fails the test."""
        code = super().stop(sig, timeout)
        if self._killed:
            pytest.fail(f'recorder (pid {self.pid}) did not exit within {timeout} s of signal {sig}')
        return code

    def output(self) -> tuple[str, str]:
        return self.stdout_path.read_text(errors='replace'), self.stderr()


@pytest.fixture
def start_recorder(ros, tmp_path: Path) -> Iterator[Callable[..., RecorderProcess]]:
    started: list[RecorderProcess] = []

    def start(bag: Path, **kwargs) -> RecorderProcess:
        started.append(RecorderProcess(bag, ros.domain_id, tmp_path, **kwargs))
        return started[-1]

    yield start
    for proc in started:
        if proc.popen.poll() is None:
            proc.popen.kill()  # only after a failed test; by PID
            proc.popen.wait()


def recorder_count(statuses: list, key: str) -> int:
    """The recorder's last reported count for ``key`` (e.g. 'topic /robot1/intent/w'), -1 if none yet."""
    for status in reversed(statuses):
        if status.name == f'{NS}/recorder: recorder':
            values = {kv.key: kv.value for kv in status.values}
            if key in values:
                return int(values[key])
    return -1


def publish_w(ros, publisher, seqs: range) -> list[int]:
    """Publish w = (seq, 0.5, 0.5) for each of ``seqs`` from a 1 kHz timer; returns the live list of those sent."""
    sent: list[int] = []

    def tick() -> None:
        if len(sent) < len(seqs):
            publisher.publish(Float64MultiArray(data=[float(seqs[len(sent)]), 0.5, 0.5]))
            sent.append(seqs[len(sent)])
        else:
            timer.cancel()

    timer = ros.node.create_timer(1e-3, tick)
    return sent


def test_process_records_2000_messages_at_1khz_and_closes_on_sigint(ros, start_recorder, tmp_path) -> None:
    model_pub = ros.publisher(String, MODEL, latched_qos())
    model_pub.publish(String(data=MODEL_DOC))  # latched, published before the recorder starts
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    statuses = ros.diagnostics()
    bag = tmp_path / 'session'
    # its queue holds the whole burst: a recorder that a loaded machine leaves 1 s behind (the default depth at
    # 1 kHz, 1461 of 2000 written at load ~8 on 2 cores) catches up; bench_recorder measures the rate it keeps
    proc = start_recorder(bag, depth=N)
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1 and recorder_count(statuses, f'topic {MODEL}') == 1,
                        timeout=STARTUP), proc.output()

    sent = publish_w(ros, w_pub, range(N))
    assert ros.wait_for(lambda: len(sent) == N, timeout=20.0)
    # the recorder reports what it wrote on /diagnostics (1 Hz): wait until it has all, then SIGINT
    assert ros.wait_for(lambda: recorder_count(statuses, f'topic {W}') == N, timeout=STARTUP), \
        (recorder_count(statuses, f'topic {W}'), proc.output())
    assert proc.stop(signal.SIGINT) == 0, proc.output()
    stdout, stderr = proc.output()
    assert 'Traceback' not in stderr
    summary = stdout.strip().splitlines()[-1]
    assert f'{W} {N},' in summary and f'{MODEL} 1)' in summary, summary

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert (meta['version'], meta['storage_identifier']) == (9, 'mcap')
    info = topics_info(bag)
    assert (info[W].msgtype, info[W].count, info[W].qos) == (
        'std_msgs/msg/Float64MultiArray', N, (QosSpec('reliable', 'volatile', 0),))
    assert (info[MODEL].msgtype, info[MODEL].count, info[MODEL].qos) == (
        'std_msgs/msg/String', 1, (QosSpec('reliable', 'transient_local', 0),))
    assert set(info) == {W, MODEL, DIAG}
    assert [int(m.decode().data[0]) for m in read_messages(bag, topics=[W])] == list(range(N))
    assert [int(m.decoded.data[0]) for m in read_messages_mcap(bag, topics=[W])] == list(range(N))
    assert [m.decoded.data for m in read_messages_mcap(bag, topics=[MODEL])] == [MODEL_DOC]


def test_process_closes_the_bag_on_sigterm(ros, start_recorder, tmp_path) -> None:
    ros.publisher(String, MODEL, latched_qos()).publish(String(data=MODEL_DOC))
    statuses = ros.diagnostics()
    bag = tmp_path / 'session'
    proc = start_recorder(bag)
    assert ros.wait_for(lambda: recorder_count(statuses, f'topic {MODEL}') == 1, timeout=STARTUP), proc.output()
    assert proc.stop(signal.SIGTERM) == 0, proc.output()
    assert 'Traceback' not in proc.output()[1]
    assert topics_info(bag)[MODEL].count == 1


def _limit_file_size() -> None:
    """In the child: files may not grow beyond 200 kB; writing more fails with EFBIG (not SIGXFSZ)."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))


def test_process_exits_nonzero_with_an_error_when_the_bag_cannot_be_written(ros, start_recorder, tmp_path) -> None:
    """File size limit as a stand-in for a full disk: the first 1 MiB MCAP chunk cannot be written."""
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    bag = tmp_path / 'session'
    proc = start_recorder(bag, preexec_fn=_limit_file_size)
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1, timeout=STARTUP), proc.output()
    rng = np.random.default_rng(0)

    def publish_until_exit() -> bool:
        for _ in range(10):  # 16 kB of random doubles each, incompressible: a chunk fills after ~65
            w_pub.publish(Float64MultiArray(data=rng.random(2000).tolist()))
        return proc.popen.poll() is not None

    assert ros.wait_for(publish_until_exit, timeout=20.0), proc.output()
    code = proc.stop(signal.SIGTERM)  # it has exited on its own; no signal is sent
    stdout, stderr = proc.output()
    assert code == 1, (stdout, stderr)
    assert 'Traceback' not in stderr
    error_lines = [line for line in stderr.splitlines() if '[ERROR]' in line and 'recording stopped' in line]
    assert error_lines, stderr
    assert str(bag) in error_lines[0] and 'File too large' in error_lines[0]
    assert 'messages had been written' in error_lines[0]
    assert 'FAILED' in stdout.strip().splitlines()[-1]


def test_an_existing_bag_directory_exits_1_with_the_reason(ros, start_recorder, tmp_path) -> None:
    bag = tmp_path / 'session'
    bag.mkdir()
    proc = start_recorder(bag)
    assert proc.popen.wait(STARTUP) == 1, proc.output()
    stderr = proc.output()[1]
    assert 'exists already' in stderr and 'Traceback' not in stderr, stderr


def test_sigkill_then_reindex_recovers_every_message_flushed_before_the_kill(ros, start_recorder, tmp_path) -> None:
    """The recorder is SIGKILLed while w arrives at 1 kHz; reindex gives back every w flushed before.

    Batch A (500 w) is published, the recorder reports it written, and the .mcap grows after that
    (a chunk holding all of A was closed and flushed: --flush-period 0.5). Batch B follows and the
    recorder is killed in its middle. The repaired bag holds w 0..k-1 for some k >= 500, exact and in
    order, in both readers; the original file is kept as .mcap.broken.
    """
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    statuses = ros.diagnostics()
    bag = tmp_path / 'killed'
    proc = start_recorder(bag, flush_period=0.5)
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1, timeout=STARTUP), proc.output()
    mcap = bag / 'killed.mcap'
    batch = 500
    sent = publish_w(ros, w_pub, range(batch))
    assert ros.wait_for(lambda: len(sent) == batch and recorder_count(statuses, f'topic {W}') == batch,
                        timeout=20.0), (recorder_count(statuses, f'topic {W}'), proc.output())
    size = mcap.stat().st_size
    assert ros.wait_for(lambda: mcap.stat().st_size > size, timeout=10.0), 'no chunk was flushed'
    more = publish_w(ros, w_pub, range(batch, 2 * batch))
    assert ros.wait_for(lambda: len(more) >= batch // 2, timeout=10.0)
    assert proc.stop(signal.SIGKILL) == -signal.SIGKILL
    assert not (bag / 'metadata.yaml').exists()

    repair = subprocess.run([sys.executable, '-m', 'grasp_intent_ros', 'reindex', str(bag)], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert repair.returncode == 0, repair.stdout + repair.stderr
    assert 'recovered' in repair.stdout and 'killed.mcap.broken' in repair.stdout, repair.stdout
    assert (bag / 'killed.mcap.broken').is_file()
    recovered = [m.decode() for m in read_messages(bag, topics=[W])]
    k = len(recovered)
    assert batch <= k <= batch + len(more)
    assert [list(m.data) for m in recovered] == [[float(seq), 0.5, 0.5] for seq in range(k)]
    assert [list(m.decoded.data) for m in read_messages_mcap(bag, topics=[W])] == [
        [float(seq), 0.5, 0.5] for seq in range(k)]
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['message_count'] == sum(i.count for i in topics_info(bag).values()) >= k


def recorder_status(statuses: list) -> tuple[int, str, dict[str, str]]:
    """The recorder's last status: (level, message, values); (-1, '', {}) before any."""
    for status in reversed(statuses):
        if status.name == f'{NS}/recorder: recorder':
            return int.from_bytes(status.level, 'little'), status.message, {kv.key: kv.value for kv in status.values}
    return -1, '', {}


@pytest.mark.parametrize('publishers', [1, 2])
def test_a_recorder_left_behind_reports_the_messages_its_queue_dropped_per_topic(ros, start_recorder, tmp_path,
                                                                                   publishers: int) -> None:
    """A recorder stopped (SIGSTOP) during 200 messages, its queue 20 deep: it keeps the newest 20 (or more), says so.

    The queue (keep-last) drops the oldest without a middleware event; the recorder counts the publisher's sequence
    numbers it never took: a WARN naming the topic, its diagnostics (per topic) and its exit summary. How many more
    than the newest 20 it takes as it resumes is the middleware's (the reliable writer still holds them): every one
    not in the bag is counted. With a second publisher of the topic (silent here) the numbers cannot be told apart:
    the full queue is reported, uncounted.
    """
    burst, depth = 200, 20
    w_pub = ros.publisher(Float64MultiArray, W, DEEP_RELIABLE)
    others = [ros.publisher(Float64MultiArray, W, DEEP_RELIABLE) for _ in range(publishers - 1)]
    statuses = ros.diagnostics()
    bag = tmp_path / 'session'
    proc = start_recorder(bag, depth=depth)
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1 and recorder_count(statuses, f'topic {W}') == 0,
                        timeout=STARTUP), proc.output()
    w_pub.publish(Float64MultiArray(data=[-1.0, 0.5, 0.5]))  # taken before the stall: the sequence's start
    assert ros.wait_for(lambda: recorder_count(statuses, f'topic {W}') == 1, timeout=STARTUP), proc.output()
    proc.popen.send_signal(signal.SIGSTOP)  # our own process, by PID
    try:
        sent = publish_w(ros, w_pub, range(burst))
        assert ros.wait_for(lambda: len(sent) == burst, timeout=20.0)
    finally:
        proc.popen.send_signal(signal.SIGCONT)
    key = f'lost {W}' if not others else f'queue full {W}'
    assert ros.wait_for(lambda: int(recorder_status(statuses)[2].get(key, '0')) > 0,
                        timeout=STARTUP), (recorder_status(statuses), proc.output())
    level, message, values = recorder_status(statuses)
    assert level == 1 and W in message, (level, message)
    assert others or int(values['messages lost']) > 0, values
    assert not others or values['messages lost'] == '0', values
    assert proc.stop(signal.SIGINT) == 0, proc.output()
    stdout, stderr = proc.output()
    summary = stdout.strip().splitlines()[-1]
    recorded = [int(m.decode().data[0]) for m in read_messages(bag, topics=[W])]
    kept = recorded[1:]  # after the one taken before the stall
    assert recorded[0] == -1 and kept[-depth:] == list(range(burst - depth, burst)), recorded
    assert kept == sorted(set(kept)) and set(kept) <= set(range(burst)), recorded
    assert f'{W} {len(recorded)})' in summary, summary
    if others:
        assert re.search(rf'queue full, losses not counted: {re.escape(W)} \d+ times?', summary), summary
    else:
        lost = burst - len(kept)
        assert f'LOST {lost}: {W} {lost}' in summary, summary
    assert W in stderr and 'lost' in stderr, stderr
