r"""End-to-end latency and throughput of the node chain beside the middleware floor, in one run.

Three phases, one after the other on the same domain (prints figures, asserts nothing):

1. **floor**: two trivial rclpy relay processes (this file with ``--relay``), run by the nodes' own run
   idiom (:func:`grasp_intent_ros.ros.run.run_node`) over the same QoS and the same hops as
   interpreter -> planner: ``floor/w`` -> relay 1 -> ``floor/v`` (subscribed keep-last 1, as the
   planner does) -> relay 2 -> ``floor/pose`` (PoseStamped). A w message goes out every ``1/--rate`` s
   for ``--duration`` s; each carries its index, so the answers pair exactly.
2. **chain**: the three suite nodes (``python -m`` processes with their config files): a random walk
   of w on ``intent/w`` at the same rate and duration; ``grasp/pose`` answers. Pairing: the planner
   stamps its outputs with its arrival time of v; the probe also receives ``intent/v`` (every v is
   mapped back to its w by content) and an answer belongs to the newest v the probe had received by
   its stamp (+1 ms: both receive the same publication).
3. **interpreter at --fast-rate** (suite still running): random w at 1 kHz for ``--fast-duration``
   s; the share of w answered with a v, and the w -> v latency.

Latency = the middleware's receive time of the answer at the probe minus the time the probe published
the w (both the system clock). Printed per phase: median / p99 / max, the share of w answered,
"stale" answers (planned from a v while a newer v had been received >= 10 ms before the answer was
published), and the nodes' diagnostics counters (received, lost, superseded) at the end. The load
average is printed before and after each phase: the machine is shared.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=98 \
        .venv/bin/python benchmarks/bench_latency.py [--duration 60] [--rate 100] [--fast-rate 1000]
"""

from __future__ import annotations

import argparse
import bisect
import sys
from pathlib import Path
from typing import Any

import numpy as np
from _bench import REPO, Probe, loopback_domain, paced, percentiles, stopped_after, uptime, walk

FLOOR_W, FLOOR_V, FLOOR_POSE = 'floor/w', 'floor/v', 'floor/pose'


def relay(which: str) -> None:
    """A relay process: ``first`` forwards floor/w to floor/v, ``second`` answers floor/v on floor/pose."""
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import input_qos, output_qos
    from grasp_intent_ros.ros.run import run_node

    class Relay(Node):
        def __init__(self) -> None:
            super().__init__(f'relay_{which}')
            if which == 'first':
                pub = self.create_publisher(Float64MultiArray, FLOOR_V, output_qos())
                self.create_subscription(Float64MultiArray, FLOOR_W, pub.publish, input_qos())
            else:
                pose = self.create_publisher(PoseStamped, FLOOR_POSE, output_qos())
                clock = self.get_clock()

                def answer(msg: Float64MultiArray) -> None:
                    out = PoseStamped()
                    out.header.stamp = clock.now().to_msg()
                    out.pose.position.x = msg.data[0]
                    pose.publish(out)
                self.create_subscription(Float64MultiArray, FLOOR_V, answer, input_qos(depth=1))

    run_node(Relay, [sys.argv[0]])


def _stamp_ns(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)


def floor_phase(domain_id: int, n: int, period: float) -> dict[str, Any]:
    """The relay chain's latencies (ms) and share of w answered."""
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.launch.process import NodeProcess
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.ros.qos import input_qos, output_qos

    suite = NodeSuite(domain_id)
    for which in ('first', 'second'):
        suite.processes.append(NodeProcess([sys.executable, __file__, '--relay', which], module=f'relay_{which}',
                                           env=suite.env, log_dir=suite.log_dir, cwd=REPO))
    probe = Probe(domain_id)
    try:
        answers = probe.record(PoseStamped, FLOOR_POSE, input_qos(100_000), lambda m: int(m.pose.position.x))
        pub = probe.node.create_publisher(Float64MultiArray, FLOOR_W, output_qos())
        if not probe.wait_for(lambda: answers or pub.publish(Float64MultiArray(data=[-1.0, 0.5, 0.5])), 20.0,
                              poll=0.1):
            sys.exit(f'bench_latency: the relays did not answer within 20 s\n{suite.died()}')
        answers.clear()
        sent = [0] * n

        def send(i: int) -> None:
            sent[i] = probe.now_ns()
            pub.publish(Float64MultiArray(data=[float(i), 0.5, 0.5]))
        load_before = uptime()
        paced(n, period, send)
        probe.wait_for(lambda: answers and answers[-1][1] == n - 1, 5.0)
        load_after = uptime()
    finally:
        probe.close()
        suite.stop()
        suite.remove_logs()
    got = [(received, i) for received, i in answers if 0 <= i < n]
    return {'latency': [(received - sent[i]) * 1e-6 for received, i in got], 'answered': len({i for _, i in got}),
            'n': n, 'load': (load_before, load_after)}


def chain_phase(domain_id: int, n: int, period: float, fast_n: int, fast_period: float, seed: int,
                code: Path | None = None) -> tuple[dict[str, Any], dict[str, Any], dict[str, dict[str, str]]]:
    """The suite's w -> grasp/pose figures at ``period``, then the interpreter's w -> v at ``fast_period``."""
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.method import intent
    from grasp_intent_ros.ros.qos import input_qos, output_qos
    from grasp_intent_ros.wire.diagnostics import status_values

    def key(v: Any) -> tuple[float, ...]:
        return tuple(np.round(np.asarray(v, dtype=np.float64), 9))

    ws = list(walk(n, seed=seed))
    rng = np.random.default_rng(seed + 1)
    fast_ws = [rng.uniform(0.3, 0.98, 3) for _ in range(fast_n)]  # P(no task) < 0.35: always a v
    v_index: dict[tuple[float, ...], int] = {}
    for i, w in enumerate(ws + fast_ws):
        result = intent.interpret(w)
        assert result.v is not None
        v_index.setdefault(key(result.v), i)
    msgs = [Float64MultiArray(data=[float(x) for x in w]) for w in ws + fast_ws]

    suite = NodeSuite(domain_id, cwd=code or REPO, env={'PYTHONPATH': str(code)} if code else None)
    suite.start_nodes()
    probe = Probe(domain_id)
    with stopped_after(suite, probe):
        statuses: dict[str, dict[str, str]] = {}
        probe.node.create_subscription(DiagnosticArray, '/diagnostics', lambda m: statuses.update(
            (s.name, status_values(s)) for s in m.status), 100)
        vs = probe.record(Float64MultiArray, 'intent/v', input_qos(100_000),
                          lambda m: v_index.get(key(m.data), -1))
        poses: list[tuple[int, int, int]] = []  # (received, stamp, source timestamp)
        probe.node.create_subscription(PoseStamped, 'grasp/pose', lambda m, info: poses.append(
            (info['received_timestamp'], _stamp_ns(m), info['source_timestamp'])), input_qos(100_000))
        pub = probe.node.create_publisher(Float64MultiArray, 'intent/w', output_qos())
        warmup = Float64MultiArray(data=[0.9, 0.9, 0.1])
        if not probe.wait_for(lambda: poses or pub.publish(warmup), 60.0, poll=0.2):
            sys.exit(f'bench_latency: the suite did not answer within 60 s\n{suite.died()}')
        poses.clear()
        vs.clear()
        sent = [0] * (n + fast_n)

        def send(i: int) -> None:
            sent[i] = probe.now_ns()
            pub.publish(msgs[i])
        load_before = uptime()
        paced(n, period, send)
        probe.wait_for(lambda: poses and poses[-1][1] >= sent[n - 1], 5.0)
        load_after = uptime()
        chain = _chain_figures(list(poses), [(t, i) for t, i in vs if 0 <= i < n], sent, n)
        chain['load'] = (load_before, load_after)

        load_before = uptime()
        took = paced(fast_n, fast_period, lambda i: send(n + i))
        probe.wait_for(lambda: vs and vs[-1][1] == n + fast_n - 1, 5.0)
        probe.wait_for(lambda: False, 1.5)  # one more diagnostics period
        fast_got = [(t, i) for t, i in vs if i >= n]
        fast = {'latency': [(t - sent[i]) * 1e-6 for t, i in fast_got], 'answered': len({i for _, i in fast_got}),
                'n': fast_n, 'took': took, 'load': (load_before, uptime())}
    return chain, fast, statuses


def _chain_figures(poses: list[tuple[int, int, int]], vs: list[tuple[int, int]], sent: list[int],
                   n: int) -> dict[str, Any]:
    v_times = [t for t, _ in vs]
    latency, answered, stale = [], set(), 0
    for received, stamp, published in poses:
        k = bisect.bisect_right(v_times, stamp + 1_000_000) - 1
        if k < 0:
            continue
        i = vs[k][1]
        latency.append((received - sent[i]) * 1e-6)
        answered.add(i)
        if k + 1 < len(vs) and v_times[k + 1] <= published - 10_000_000:
            stale += 1
    return {'latency': latency, 'answered': len(answered), 'n': n, 'stale': stale, 'answers': len(poses),
            'v_received': len({i for _, i in vs})}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--duration', type=float, default=60.0, help='seconds of w per phase (floor, chain)')
    parser.add_argument('--rate', type=float, default=100.0, help='w per second (floor, chain)')
    parser.add_argument('--fast-rate', type=float, default=1000.0, help='w per second (interpreter phase)')
    parser.add_argument('--fast-duration', type=float, default=10.0, help='seconds (interpreter phase)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--code', type=Path, default=None,
                        help='run the suite nodes from this source tree instead (e.g. an export of main, to '
                             'compare before/after in one sitting; its kernels compiled there first)')
    parser.add_argument('--relay', choices=('first', 'second'), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.relay:
        return relay(args.relay)
    from grasp_intent_ros.wire.diagnostics import KEY_DROPPED, KEY_PLANS, KEY_RECEIVED
    domain_id = loopback_domain('bench_latency')
    n, fast_n = int(round(args.duration * args.rate)), int(round(args.fast_duration * args.fast_rate))
    floor = floor_phase(domain_id, n, 1.0 / args.rate)
    chain, fast, statuses = chain_phase(domain_id, n, 1.0 / args.rate, fast_n, 1.0 / args.fast_rate, args.seed,
                                        args.code.resolve() if args.code else None)

    def share(r: dict[str, Any]) -> str:
        return f'{r["answered"]:,} of {r["n"]:,} w answered ({100.0 * r["answered"] / r["n"]:.1f}%)'

    fl, ch = np.asarray(floor['latency']), np.asarray(chain['latency'])
    print(f'{n:,} w at {args.rate:g} Hz per phase; domain {domain_id}; nodes from {args.code or REPO}')
    print(f'floor (2 relays) w -> pose: {percentiles(fl)}; {share(floor)} [{floor["load"][0]} -> '
          f'{floor["load"][1]}]')
    print(f'chain w -> grasp/pose:      {percentiles(ch)}; {share(chain)} [{chain["load"][0]} -> '
          f'{chain["load"][1]}]')
    print(f'  {chain["answers"]:,} answers; v received by the probe for {chain["v_received"]:,} w; '
          f'stale answers (a newer v waited >= 10 ms): {chain["stale"]:,} '
          f'({100.0 * chain["stale"] / max(1, chain["answers"]):.1f}%)')
    if fl.size and ch.size:
        print(f'  chain - floor: median {np.median(ch) - np.median(fl):+.1f} ms (target <= +2), p99 '
              f'{np.percentile(ch, 99) - np.percentile(fl, 99):+.1f} ms (target <= +6); planned '
              f'{100.0 * chain["answered"] / n:.1f}% (target >= 95%)')
    print(f'interpreter at {args.fast_rate:g} Hz ({fast["n"]:,} w sent in {fast["took"]:.1f} s): w -> v '
          f'{percentiles(fast["latency"])}; {share(fast)} (target >= 99%) [{fast["load"][0]} -> '
          f'{fast["load"][1]}]')
    for name, values in sorted(statuses.items()):
        shown = {k: v for k, v in values.items() if k in (KEY_RECEIVED, KEY_DROPPED, 'inputs superseded', KEY_PLANS)}
        if shown:
            print(f'  diagnostics {name}: ' + ', '.join(f'{k} {v}' for k, v in shown.items()))


if __name__ == '__main__':
    main()
