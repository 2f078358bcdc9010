r"""Memory under huge messages on every input: each node's RSS before and after. Prints figures, asserts nothing.

The three suite nodes run as ``python -m`` processes (config/<node>.yaml, the environment of
:func:`grasp_intent_ros.launch.suite.node_environment`, so the Fast DDS profile config/fastdds_loopback.xml). A
probe publishes ``--count`` messages of ``--mbytes`` MB (default 100 of 64 MB), serialized, on each input topic
in turn: intent/w, intent/v, model/active (read by the interpreter and the planner), object/pose,
joint_states, model/query. Each is far over its topic's cap and rejected by its size; the next is sent once
the reading node's diagnostics count the one before (or after ``--wait`` s: bounded). Printed per node: RSS
(VmRSS) before, after (once the nodes have counted every message, or 120 s, and ``--settle`` s more) and its
peak (VmHWM), with the load average;
then whether every smaller valid input is still answered: a w (a grasp), a feature vector on model/query (a
posterior), an object pose (a new grasp), a model document on model/active (a grasp on that model).

``--env KEY=VALUE`` (repeatable) changes the nodes' environment, e.g. to measure without this revision's
profile: ``--env FASTRTPS_DEFAULT_PROFILES_FILE=/tmp/old_profile.xml --env RMW_FASTRTPS_USE_QOS_FROM_XML=0``.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=93 \
        .venv/bin/python benchmarks/bench_big_messages.py [--count 100] [--mbytes 64] [--env KEY=VALUE]
"""

from __future__ import annotations

import argparse
import array
import time
from pathlib import Path
from typing import Any

from _bench import REPO, Probe, loopback_domain, rss_mb, uptime


def peak_mb(pid: int) -> float:
    """Peak resident set size of process ``pid`` so far (VmHWM, MB), from /proc."""
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError(f'no VmHWM for pid {pid}')


def huge_messages(n_bytes: int) -> dict[str, bytes]:
    """One serialized message of about ``n_bytes`` per input topic, of the topic's type."""
    from geometry_msgs.msg import PoseStamped
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, String

    from grasp_intent_ros.wire import topics

    values = Float64MultiArray()
    values.data = array.array('d', bytes(n_bytes))  # n_bytes / 8 zeros
    text = 'x' * n_bytes
    pose = PoseStamped()
    pose.header.frame_id = text
    return {topics.INTENT_W: serialize_message(values), topics.INTENT_V: serialize_message(values),
            topics.MODEL_ACTIVE: serialize_message(String(data=text)),
            topics.OBJECT_POSE: serialize_message(pose),
            topics.JOINT_STATES: serialize_message(JointState(name=[text])),
            topics.MODEL_QUERY: serialize_message(values)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--count', type=int, default=100, help='messages per input topic')
    parser.add_argument('--mbytes', type=float, default=64.0, help='size of each message, MB (2^20 bytes)')
    parser.add_argument('--wait', type=float, default=10.0, help='longest wait for a message to be counted, s')
    parser.add_argument('--settle', type=float, default=3.0, help='seconds between the last message and "after"')
    parser.add_argument('--env', action='append', default=[], metavar='KEY=VALUE', help="the nodes' environment")
    args = parser.parse_args()
    domain_id = loopback_domain('bench_big_messages')
    env = dict(item.split('=', 1) for item in args.env)

    from grasp_intent_ros.launch.suite import SUITE_NODES, NodeSuite, use_loopback_discovery

    use_loopback_discovery()  # the probe too: loopback only, the suite's profile
    suite = NodeSuite(domain_id, cwd=REPO, env=env)
    probe = Probe(domain_id, 'big_message_probe')
    try:
        suite.start_nodes()
        run(args, suite, probe, {m: suite.node(m).pid for m in SUITE_NODES})
    finally:
        problems = suite.stop(tail_lines=10)
        print('exit on SIGTERM: ' + ('clean (code 0, no traceback) for all three' if not problems
                                     else '\n'.join(problems)))
        suite.remove_logs()
        probe.close()


def run(args: argparse.Namespace, suite: Any, probe: Probe, pids: dict[str, int]) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.mico.frames import pose_to_matrix
    from grasp_intent_ros.mico.kinematics import BASE_FRAME
    from grasp_intent_ros.ros.conversions import message_class, model_to_msg
    from grasp_intent_ros.ros.qos import input_qos, latched_qos
    from grasp_intent_ros.ros.robot import matrix_to_pose_msg
    from grasp_intent_ros.wire import topics
    from grasp_intent_ros.wire.diagnostics import KEY_RECEIVED, status_values

    readers = {topics.INTENT_W: 'intent_interpreter: intent', topics.INTENT_V: 'grasp_planner: inputs',
               topics.MODEL_ACTIVE: 'grasp_planner: inputs', topics.OBJECT_POSE: 'grasp_planner: inputs',
               topics.JOINT_STATES: 'grasp_planner: inputs', topics.MODEL_QUERY: 'model_server: model'}
    counts: dict[str, int] = {}

    def on_diagnostics(msg: DiagnosticArray) -> None:
        for status in msg.status:
            counts[status.name.lstrip('/')] = int(status_values(status).get(KEY_RECEIVED, 0))

    probe.node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, on_diagnostics, 50)
    grasps = probe.record(PoseStamped, topics.GRASP_POSE, input_qos())
    posteriors = probe.record(Float64MultiArray, topics.MODEL_POSTERIOR, input_qos())
    pubs = {topic: probe.node.create_publisher(message_class(topic), topic, latched_qos()
                                               if topic == topics.MODEL_ACTIVE else input_qos())
            for topic in readers}

    def answered(what: str, topic: str, msg: Any, replies: list[Any], check: Any = lambda _: True) -> None:
        n, start = len(replies), time.monotonic()
        pubs[topic].publish(msg)
        while not probe.wait_for(lambda: len(replies) > n and check(replies[-1][1]), 1.0):
            pubs[topic].publish(msg)  # the first message after matching may be lost
            if time.monotonic() - start > 30.0:
                print(f'  {what}: NOT answered within 30 s ({suite.died() or "all nodes running"})')
                return
        print(f'  {what}: answered after {time.monotonic() - start:.2f} s')

    def valid_inputs(when: str) -> None:
        print(f'valid inputs {when}:')
        answered('w (0.9, 0.9, 0.1) -> grasp/pose', topics.INTENT_W, Float64MultiArray(data=[0.9, 0.9, 0.1]),
                 grasps)
        answered('x on model/query -> model/posterior', topics.MODEL_QUERY,
                 Float64MultiArray(data=[0.0, 0.0, 0.1, 0.0, 0.0, -1.0, 0.0, 0.5, 0.5, 0.5]), posteriors)
        moved = pose_to_matrix((0.32, -0.28, 0.0), (0.0, 0.0, 1.0, 0.0))
        answered('object/pose -> grasp/pose', topics.OBJECT_POSE, matrix_to_pose_msg(
            moved, frame_id=BASE_FRAME, stamp=probe.node.get_clock().now().to_msg()),
                 grasps)

    valid_inputs('at start')
    model5 = GraspModel.load(REPO / 'config' / 'models' / 'cup_5zone.yaml')
    messages = huge_messages(int(args.mbytes * (1 << 20)))
    print(f'{uptime()}; {args.count} messages of {args.mbytes:g} MB on each of {len(readers)} inputs')
    before = {m: rss_mb(pid) for m, pid in pids.items()}
    start, late = time.monotonic(), 0
    expected = {component: counts.get(component, 0) for component in readers.values()}
    for topic, component in readers.items():
        expected[component] += args.count
        for _ in range(args.count):
            n = counts.get(component, 0)
            pubs[topic].publish(messages[topic])
            late += not probe.wait_for(lambda n=n, c=component: counts.get(c, 0) > n, args.wait)
    elapsed = time.monotonic() - start
    # every message taken (a node may still be working through its queue), then a quiet interval
    drained = probe.wait_for(lambda: all(counts.get(c, 0) >= n for c, n in expected.items()), 120.0)
    probe.wait_for(lambda: False, args.settle)
    after = {m: rss_mb(pid) for m, pid in pids.items()}
    print(f'sent in {elapsed:.0f} s ({late} not counted within {args.wait:g} s); every message counted: {drained}; '
          f'{uptime()}')
    for m, pid in pids.items():
        print(f'RSS {m}: {before[m]:.1f} -> {after[m]:.1f} MB ({100 * (after[m] / before[m] - 1):+.1f}%), '
              f'peak {peak_mb(pid):.1f} MB')
    valid_inputs('after')
    answered('a model document on model/active (cup_5zone) -> a grasp on it', topics.MODEL_ACTIVE,
             model_to_msg(model5, name='cup_5zone', version=99), grasps)
    print(f'same PIDs: {all(suite.node(m).pid == pid and suite.node(m).poll() is None for m, pid in pids.items())}')


if __name__ == '__main__':
    main()
