r"""Latest-only benchmark of the grasp planner node as deployed: prints figures, asserts nothing.

The planner runs as it is deployed, ``python -m grasp_intent_ros.nodes.grasp_planner`` with its config file, in a
process of its own (:class:`grasp_intent_ros.launch.suite.NodeSuite`); the probe (:class:`_bench.Probe`, the
helpers bench_latency.py uses) runs in this process. The probe publishes the cup 7-zone model on
``model/active`` and then a new target vector v every 10 ms for 10 s (seeded random w, interpreted over
all zones; ``--stream walk``: a random walk of w, as from a smooth intent estimate during
teleoperation), faster than the node can plan at times. Printed: how many plans it made for how many
messages, the latency from publishing a v to the middleware's receipt of the grasp/joint_targets that
answer it (median, p99, max) and its three parts (v's hop to the node, the node's own time from its receipt
of v to the publication of the answer, the answer's hop back), the in-node planning and IK times (sampled
from its diagnostics), the largest backlog, the planner process's CPU time during the burst, and the load
average. The target (the README's planner-node row): v -> joint targets within 3 ms median and 10 ms p99.

Why a process, not an in-process node (the method up to this revision, which is in git's history): the
in-process node shared its process, executor and GIL with the probe, so the probe's own publishing and its
callback's wake-up entered every figure (about 1.3 ms of the walk's median), the v never crossed a process
boundary as the interpreter's v does, and the process never ran the node's start-up
(:mod:`grasp_intent_ros.ros.startup`: OpenBLAS single-threaded, the start-up objects frozen out of the
garbage collector's reach), so collections of the start-up's objects inflated its p99. The latency is now
the middleware's receive time at the probe (``received_timestamp``), not the probe's callback time. The
two methods were measured in one sitting when this changed (the README's planner-node row).

Pairing: every output of a plan is stamped with the time the planner received the newest input (the
system clock, as the probe's), so the answer to v_i is the output whose stamp lies between the
publication of v_i and of v_{i+1}. Backlog: after answer k goes out the node starts plan k + 1 with the
newest input it holds, so every later answer (k + 2, ...) must answer an input that arrived after answer
k was published. The backlog of answer k is the number of later answers whose input (stamp) is older
than answer k's publication (its DDS source timestamp): 0 for a latest-only node, the queue length for a
node working through a queue.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
the planner process gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=96 \\
        python benchmarks/bench_planner_node.py [--stream walk] [--period 0.01] [--duration 10] [--code DIR]
"""

from __future__ import annotations

import argparse
import bisect
import sys
from pathlib import Path

import numpy as np
from _bench import REPO, Probe, cpu_seconds, loopback_domain, paced, percentiles, prime_planner, stopped_after, uptime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--model', default=None, help='model YAML (default: config/models/cup_7zone.yaml)')
    parser.add_argument('--period', type=float, default=0.01, help='seconds between two v messages')
    parser.add_argument('--duration', type=float, default=10.0, help='seconds of publishing')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--stream', choices=('random', 'walk'), default='random',
                        help='independent random w (default) or a teleoperation-like random walk of w '
                             '(each entry moves by N(0, 0.01) per message)')
    parser.add_argument('--method', default=None, help="the node's method parameter (default: its config file's)")
    parser.add_argument('--param', action='append', default=[], metavar='NAME:=VALUE',
                        help="another of the node's parameters (repeatable), e.g. planning_threads:=1")
    parser.add_argument('--code', type=Path, default=None,
                        help='run the planner node from this source tree instead (before/after in one sitting; '
                             'its kernels compiled there first)')
    args = parser.parse_args()
    domain_id = loopback_domain('bench_planner_node')

    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import JointState

    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.method import intent
    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.resources import config_dir
    from grasp_intent_ros.ros.conversions import array_to_msg
    from grasp_intent_ros.ros.qos import input_qos
    from grasp_intent_ros.wire.diagnostics import KEY_PLANS, status_values

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

    code = args.code.resolve() if args.code else None
    suite = NodeSuite(domain_id, cwd=code or REPO, env={'PYTHONPATH': str(code)} if code else None)
    params = ([] if args.method is None else [f'method:={args.method}']) + args.param
    ros_args = NodeSuite.node_args('grasp_planner') + [arg for param in params for arg in ('-p', param)]
    planner = suite.start('grasp_planner', *ros_args)
    probe = Probe(domain_id)
    with stopped_after(suite, probe):
        answers: list[tuple[int, int, int]] = []  # (received ns, stamp ns, published ns)
        probe.node.create_subscription(JointState, 'grasp/joint_targets', lambda msg, info: answers.append(
            (info['received_timestamp'], msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
             info['source_timestamp'])), input_qos(100_000))
        samples: list[dict[str, str]] = []
        probe.node.create_subscription(DiagnosticArray, '/diagnostics', lambda msg: samples.extend(
            status_values(s) for s in msg.status if s.name.endswith('planning')), 100)
        v_pub = prime_planner('bench_planner_node', probe, suite, model, path.stem, messages, answers)
        answers.clear()
        sent = [0] * n

        def send(i: int) -> None:
            sent[i] = probe.now_ns()
            v_pub.publish(messages[i])
        load_before, cpu_before = uptime(), cpu_seconds(planner.pid)
        took = paced(n, args.period, send)
        probe.wait_for(lambda: answers and answers[-1][1] >= sent[-1], 10.0)
        cpu = cpu_seconds(planner.pid) - cpu_before
        load_after = uptime()
        probe.wait_for(lambda: False, 1.5)  # late answers would be a backlog; one more diagnostics period

    burst = [answer for answer in answers if answer[1] >= sent[0]]
    pairs = [(received, bisect.bisect_right(sent, stamp) - 1) for received, stamp, _ in burst]
    latency_ms = [(received - sent[i]) * 1e-6 for received, i in pairs]
    # the same answers in three parts: v's hop in (to the planner's receipt, the answer's stamp), the node
    # (to the middleware's publication of grasp/joint_targets), the hop out (to the probe's receipt)
    parts = {'hop in': [(stamp - sent[i]) * 1e-6 for (_, i), (_, stamp, _) in zip(pairs, burst)],
             'node': [(published - stamp) * 1e-6 for _, stamp, published in burst],
             'hop out': [(received - published) * 1e-6 for received, _, published in burst]}
    stamps = np.array([stamp for _, stamp, _ in burst])
    # inputs the node already held when answer k went out, yet answered after the next plan (k + 1)
    backlog = [int(np.sum(stamps[k + 2:] < published)) for k, (_, _, published) in enumerate(burst)]
    answered = len({i for _, i in pairs})
    last = samples[-1] if samples else {}

    def sampled(key: str) -> str:
        values = np.array([float(s[key]) for s in samples if s.get(key)])
        return f'median {np.median(values):.1f} ms over {values.size} samples' if values.size else 'n/a'

    print(f'planner process from {code or REPO}; model {path} ({len(model.zones)} zones); {n} v messages, one '
          f'every {1e3 * args.period:.0f} ms for {took:.1f} s ({args.stream} w stream); domain {domain_id}'
          + (f'; parameters {" ".join(params)}' if params else ''))
    print(f'plans answering the burst: {len(pairs)} ({answered} distinct v); '
          f'node: {last.get(KEY_PLANS, "?")} plans in all, {last.get("inputs superseded", "?")} inputs superseded')
    print(f'latency v -> grasp/joint_targets: {percentiles(latency_ms)}')
    print('  of which ' + '; '.join(f'{part} {percentiles(ms)}' for part, ms in parts.items()))
    print(f'in-node planning time (incl. IK): {sampled("last planning time [ms]")}; '
          f'IK time: {sampled("last IK time [ms]")}')
    print(f'answer to the last v: {"yes" if pairs and pairs[-1][1] == n - 1 else "no"}; '
          f'max backlog: {max(backlog, default=0)}; planner CPU during the burst {cpu:.2f} s '
          f'({100.0 * cpu / took:.0f}%)')
    print(f'[{load_before} -> {load_after}]')


if __name__ == '__main__':
    main()
