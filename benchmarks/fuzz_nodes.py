r"""Fuzz the three nodes as processes and measure their memory under oversized messages: prints figures.

1. Starts the suite (``python -m`` processes, config/<node>.yaml) and waits for a grasp for a valid w.
2. Fuzz: ``--cases`` hypothesis-drawn malformed messages (benchmarks/_bench/fuzz_inputs.py, fixed seed) on intent/w,
   intent/v, object/pose, joint_states and model/query, each sent once its predecessor's verdict is in.
   Prints sent / rejected per family and topic (every case must be rejected but the accepted edge cases),
   each node's RSS before and after, and the answer to a valid w afterwards.
3. Oversized: ``--oversized`` messages of ``--oversized-bytes`` each to each node (joint_states with
   duplicated 5,000-character names for the planner, a w and a feature vector with a huge dimension
   label for the interpreter and the model server), published serialized.
   They go out to the three nodes together, in windows smaller than the nodes' input queues, each once
   every node has counted the previous window's messages (or after ``--window-wait`` s: under load DDS
   repairs a lost fragment only at its next heartbeat, seconds later; a message lost stalls only its own
   window), so few are dropped by a keep-last queue. Prints per node the
   messages its diagnostics count as received and rejected and its RSS before / after; then the answer
   to a valid w, and whether every node still has its PID.

``--nodes-from DIR`` runs the nodes from another checkout of the package (e.g. ``git archive`` of main
unpacked in /tmp) for a before/after comparison; the probe and the messages stay this checkout's.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=95 \
        .venv/bin/python benchmarks/fuzz_nodes.py [--cases 12000] [--oversized 100000] [--oversized-bytes 500000]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _bench import REPO, loopback_domain, rss_mb


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--cases', type=int, default=12_000, help='fuzz cases (0: skip the fuzz)')
    parser.add_argument('--oversized', type=int, default=100_000, help='oversized messages per node (0: skip)')
    parser.add_argument('--oversized-bytes', type=int, default=500_000, help='size of each oversized message')
    parser.add_argument('--window-wait', type=float, default=0.5,
                        help='seconds to wait for a window of oversized messages to be counted (0: do not wait, '
                             'publish as fast as possible and let the keep-last queues drop what they must)')
    parser.add_argument('--nodes-from', type=Path, default=None, help='run the nodes from this checkout')
    args = parser.parse_args()
    domain_id = loopback_domain('fuzz_nodes')

    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    from grasp_intent_ros.launch.suite import SUITE_NODES, NodeSuite, use_loopback_discovery

    use_loopback_discovery()
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    executor = SingleThreadedExecutor(context=context)
    probe = rclpy.create_node('fuzz_probe', context=context)
    executor.add_node(probe)

    def wait_for(predicate: Callable[[], object], timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() >= deadline:
                return bool(predicate())
            executor.spin_once(timeout_sec=0.05)
        return True

    suite = NodeSuite(domain_id, cwd=args.nodes_from or REPO)
    try:
        suite.start_nodes()
        run(args, suite, probe, wait_for, {m: suite.node(m).pid for m in SUITE_NODES})
    finally:
        problems = suite.stop(tail_lines=10)
        print('\nexit on SIGTERM: ' + ('clean (code 0, no traceback) for all three' if not problems
                                        else '\n'.join(problems)))
        suite.remove_logs()
        executor.shutdown()
        probe.destroy_node()
        rclpy.try_shutdown(context=context)


def run(args: argparse.Namespace, suite: Any, probe: Any, wait_for: Callable[[Callable[[], object], float], bool],
        pids: dict[str, int]) -> None:
    from _bench.fuzz_inputs import COMPONENTS, Fuzzer, array_msg, cases, joint_msg, serialized, valid_w
    from geometry_msgs.msg import PoseStamped
    from hypothesis import HealthCheck, Phase, given, settings
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import DEFAULT_DEPTH, input_qos
    from grasp_intent_ros.wire import topics
    from grasp_intent_ros.wire.diagnostics import KEY_RECEIVED

    fuzzer = Fuzzer(probe, wait_for)
    grasps: list[Any] = []
    probe.create_subscription(PoseStamped, topics.GRASP_POSE, grasps.append, input_qos())
    w_pub = probe.create_publisher(Float64MultiArray, topics.INTENT_W, input_qos())

    def answer(what: str) -> None:
        n, start = len(grasps), time.monotonic()
        while not wait_for(lambda: len(grasps) > n, 1.0):
            w_pub.publish(valid_w())
            if time.monotonic() - start > 30.0:
                sys.exit(f'no grasp for a valid w {what}: {suite.died() or "all nodes running"}')
        p = grasps[-1].pose.position
        print(f'valid w (0.9, 0.9, 0.1) {what}: grasp/pose at ({p.x:.4f}, {p.y:.4f}, {p.z:.4f}) m after '
              f'{time.monotonic() - start:.2f} s; same PIDs: '
              f'{all(suite.node(m).pid == pid and suite.node(m).poll() is None for m, pid in pids.items())}')

    def rss() -> dict[str, float]:
        return {m: rss_mb(pid) for m, pid in pids.items()}

    w_pub.publish(valid_w())
    answer('at start')
    wait_for(lambda: all(fuzzer.component(t) in fuzzer.latest for t in COMPONENTS), 5.0)
    fuzzer.settle()  # the w published until then and their answers are all in
    print(f'load average at start: {os.getloadavg()}')

    if args.cases:
        before, start = rss(), time.monotonic()

        @settings(max_examples=args.cases, derandomize=True, database=None, deadline=None,
                  phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck))
        @given(case=cases())
        def send(case: Any) -> None:
            fuzzer.send(case)

        send()
        elapsed, after = time.monotonic() - start, rss()
        print(f'\nfuzz: {sum(fuzzer.sent.values())} messages in {elapsed:.1f} s (load average '
              f'{os.getloadavg()[0]:.2f})\n{"family":24} {"topic":14} {"sent":>6} {"rejected":>8}')
        for (topic, family), n in sorted(fuzzer.sent.items(), key=lambda kv: (kv[0][1], kv[0][0])):
            print(f'{family:24} {topic:14} {n:6d} {fuzzer.rejected[(topic, family)]:8d}')
        print(f'{"all":24} {"":14} {sum(fuzzer.sent.values()):6d} {sum(fuzzer.rejected.values()):8d}')
        readers = {fuzzer.component(t): t for t in COMPONENTS}
        print('messages rejected on each node\'s /diagnostics: ' + ', '.join(
            f'{component} {fuzzer.count(topic)}' for component, topic in readers.items()))
        for m in pids:
            print(f'RSS {m}: {before[m]:.1f} -> {after[m]:.1f} MB ({100 * (after[m] / before[m] - 1):+.1f}%)')
        answer('after the fuzz')

    if args.oversized:
        WINDOW = DEFAULT_DEPTH - 1  # noqa: N806 - messages in flight: fewer than the nodes' input queue holds
        k = args.oversized_bytes
        names = max(1, k // 5000)
        oversized = {  # topic -> (node, serialized message)
            topics.JOINT_STATES: ('grasp_planner', serialized(joint_msg(['m1n6s300_joint_1' + 'x' * 4984] * names,
                                                                          [0.0] * names))),
            topics.INTENT_W: ('intent_interpreter', serialized(array_msg([0.5] * 3, (('x' * k, 3, 3),)))),
            topics.MODEL_QUERY: ('model_server', serialized(array_msg([0.1] * 10, (('x' * k, 10, 10),)))),
        }
        print(f'\noversized: {args.oversized} messages of {k} bytes to each node at once, published serialized')
        wait_for(lambda: False, 1.5)  # a periodic status with the counts before
        received0 = {t: fuzzer.count(t, KEY_RECEIVED) for t in oversized}
        rejected0 = {t: fuzzer.count(t) for t in oversized}
        before, start, stalls, sent = rss(), time.monotonic(), 0, 0
        while sent < args.oversized:  # a window fits each node's queue
            window = min(WINDOW, args.oversized - sent)
            sent += window
            counted = {t: fuzzer.count(t) for t in oversized}
            for topic, (_, data) in oversized.items():
                for _ in range(window):
                    fuzzer.publish(topic, data)
            # under load DDS repairs a lost fragment at the next heartbeat (seconds): go on after a while. Each
            # window waits for its own messages only, so a message lost before stalls no later window
            stalls += not wait_for(lambda: all(fuzzer.count(t) >= counted[t] + window for t in oversized),
                                   args.window_wait)
        elapsed = time.monotonic() - start
        wait_for(lambda: False, 2.5)  # the nodes catch up; then a periodic status with the final counts
        after = rss()
        print(f'{3 * args.oversized} messages ({3 * args.oversized * k / 1e9:.1f} GB) in {elapsed:.1f} s; '
              f'{stalls} of {-(-args.oversized // WINDOW)} windows not counted within {args.window_wait} s; '
              f'load average '
              f'{os.getloadavg()[0]:.2f}')
        for topic, (module, _) in oversized.items():
            print(f'{module:18} {topic:14} sent {args.oversized}; {fuzzer.component(topic)}: received '
                  f'{fuzzer.count(topic, KEY_RECEIVED) - received0[topic]}, rejected '
                  f'{fuzzer.count(topic) - rejected0[topic]}; RSS {before[module]:.1f} -> {after[module]:.1f} MB '
                  f'({100 * (after[module] / before[module] - 1):+.1f}%)')
        answer('after the oversized messages')


if __name__ == '__main__':
    main()
