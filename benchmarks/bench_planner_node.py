r"""Latest-only benchmark of the grasp planner node (issue 3): prints figures, asserts nothing.

An in-process GraspPlanner (its own rclpy Context) gets the cup 7-zone model and then a new target
vector v every 10 ms for 10 s (seeded random w, interpreted over all zones; ``--stream walk``: a random
walk of w, as from a smooth intent estimate during teleoperation), faster than it can plan.
Printed: how many plans it made for how many messages, the end-to-end latency from publishing a v to
receiving the grasp/joint_targets that answer it (median, p99, max), the in-node planning and IK times
(sampled from its diagnostics), and the largest backlog.

Pairing: every output of a plan is stamped with the time the planner received the newest input, so
the answer to v_i is the output whose stamp lies between the publication of v_i and of v_{i+1}.
Backlog: after answer k goes out the node starts plan k + 1 with the newest input it holds, so every
later answer (k + 2, ...) must answer an input that arrived after answer k was published. The backlog
of answer k is the number of later answers whose input (stamp) is older than answer k's publication
(its DDS source timestamp): 0 for a latest-only node, the queue length for a node working through a
queue.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the domain is
ROS_DOMAIN_ID (default 88).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=80 \\
        python benchmarks/bench_planner_node.py [--model config/models/cup_7zone.yaml] [--period 0.01] [--duration 10]
"""

from __future__ import annotations

import argparse
import bisect
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--model', default=None, help='model YAML (default: config/models/cup_7zone.yaml)')
    parser.add_argument('--period', type=float, default=0.01, help='seconds between two v messages')
    parser.add_argument('--duration', type=float, default=10.0, help='seconds of publishing')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--stream', choices=('random', 'walk'), default='random',
                        help='independent random w (default) or a teleoperation-like random walk of w '
                             '(each entry moves by N(0, 0.01) per message)')
    parser.add_argument('--method', default=None, help="the node's method parameter (default: its default)")
    args = parser.parse_args()
    if os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') != 'LOCALHOST':
        sys.exit('bench_planner_node: set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (and a ROS_DOMAIN_ID of '
                 'your own): DDS discovery must stay on the loopback interface')
    domain_id = int(os.environ.get('ROS_DOMAIN_ID', '88'))

    import rclpy  # after the network check
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, String

    from grasp_intent_ros.core import intent
    from grasp_intent_ros.core.model import GraspModel
    from grasp_intent_ros.core.resources import config_dir
    from grasp_intent_ros.grasp_planner import GraspPlanner
    from grasp_intent_ros.ros.conversions import array_to_msg, model_to_msg
    from grasp_intent_ros.ros.qos import input_qos, latched_qos

    path = Path(args.model) if args.model else config_dir() / 'models' / 'cup_7zone.yaml'
    if not path.is_file():
        sys.exit(f'bench_planner_node: no model at {path}; pass --model <model YAML>')
    model = GraspModel.load(path)
    m = len(model.task_names)
    labels = intent.zone_labels(intent.all_zones(m), model.task_names)
    rng = np.random.default_rng(args.seed)
    n = int(round(args.duration / args.period))
    messages = []
    w = np.full(m, 0.5)
    while len(messages) < n + 1:
        w = rng.uniform(0.0, 1.0, m) if args.stream == 'random' else np.clip(
            w + rng.normal(0.0, 0.01, m), 0.02, 0.98)
        result = intent.interpret(w)
        if result.v is not None and intent.restrict(result.v, intent.all_zones(m), model.zones) is not None:
            messages.append(array_to_msg(result.v, [labels]))

    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    executor = SingleThreadedExecutor(context=context)
    planner_node = GraspPlanner(context=context, parameter_overrides=[] if args.method is None else [
        Parameter('method', value=args.method)])
    method = planner_node.get_parameter('method').value
    probe = rclpy.create_node('bench_probe', context=context)
    clock = probe.get_clock()
    answers: list[tuple[int, int, int]] = []  # (received ns, stamp ns, published ns)
    samples: list[dict[str, str]] = []
    probe.create_subscription(JointState, 'grasp/joint_targets', lambda msg, info: answers.append(
        (clock.now().nanoseconds, msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
         info['source_timestamp'])), input_qos(1000))
    probe.create_subscription(DiagnosticArray, '/diagnostics', lambda msg: samples.extend(
        {kv.key: kv.value for kv in s.values} for s in msg.status if s.name.endswith('planning')), 100)
    model_pub = probe.create_publisher(String, 'model/active', latched_qos())
    v_pub = probe.create_publisher(Float64MultiArray, 'intent/v', 10)
    for node in (planner_node, probe):
        executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        model_pub.publish(model_to_msg(model, name=path.stem, version=1))
        deadline = time.monotonic() + 15.0
        while not answers and time.monotonic() < deadline:  # discovery and the first plan
            v_pub.publish(messages[-1])
            time.sleep(0.2)
        if not answers:
            sys.exit('bench_planner_node: the planner did not answer within 15 s')
        answers.clear()
        sent: list[int] = []
        start = time.monotonic()
        for i in range(n):
            delay = start + i * args.period - time.monotonic()
            if delay > 0.0:
                time.sleep(delay)
            sent.append(clock.now().nanoseconds)
            v_pub.publish(messages[i])
        end = time.monotonic()
        deadline = end + 10.0
        while time.monotonic() < deadline and not (answers and answers[-1][1] >= sent[-1]):
            time.sleep(0.01)
        time.sleep(1.5)  # late answers would be a backlog; one more diagnostics period
    finally:
        executor.shutdown()
        spinner.join()
        planner_node.destroy_node()
        probe.destroy_node()
        rclpy.try_shutdown(context=context)

    burst = [answer for answer in answers if answer[1] >= sent[0]]
    pairs = [(received, bisect.bisect_right(sent, stamp) - 1) for received, stamp, _ in burst]
    latency_ms = np.array([(received - sent[i]) * 1e-6 for received, i in pairs])
    stamps = np.array([stamp for _, stamp, _ in burst])
    # inputs the node already held when answer k went out, yet answered after the next plan (k + 1)
    backlog = [int(np.sum(stamps[k + 2:] < published)) for k, (_, _, published) in enumerate(burst)]
    answered = len({i for _, i in pairs})
    last = samples[-1] if samples else {}

    def sampled(key: str) -> str:
        values = np.array([float(s[key]) for s in samples if s.get(key)])
        return f'median {np.median(values):.1f} ms over {values.size} samples' if values.size else 'n/a'

    print(f'method {method}, model {path} ({len(model.zones)} zones); {n} v messages, one every '
          f'{1e3 * args.period:.0f} ms for {end - start:.1f} s ({args.stream} w stream)')
    print(f'plans answering the burst: {len(pairs)} ({answered} distinct v); '
          f'node: {last.get("plans", "?")} plans in all, {last.get("inputs superseded", "?")} inputs superseded')
    if latency_ms.size:
        print(f'end-to-end latency v -> grasp/joint_targets: median {np.median(latency_ms):.1f} ms, '
              f'p99 {np.percentile(latency_ms, 99):.1f} ms, max {latency_ms.max():.1f} ms')
    print(f'in-node planning time (incl. IK): {sampled("last planning time [ms]")}; '
          f'IK time: {sampled("last IK time [ms]")}')
    print(f'answer to the last v: {"yes" if pairs and pairs[-1][1] == n - 1 else "no"}; '
          f'max backlog: {max(backlog, default=0)}')


if __name__ == '__main__':
    main()
