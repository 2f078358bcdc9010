r"""Recorder under load: suite + recorder as processes, w at 1 kHz; prints figures, asserts nothing.

Starts the three suite nodes (:meth:`~grasp_intent_ros.launch.suite.NodeSuite.start_nodes`) and
``python -m grasp_intent_ros recorder BAG`` as processes, then publishes ``intent/w`` from this process
at ``--rate`` Hz for ``--duration`` s (each w carries its sequence number in ``data[0]``; a paced
publishing thread, reliable keep-last ``--pub-depth``, the profile of the suite's own publishers). The
interpreter answers every w and the planner plans, so the recorder records the suite's outputs as well.
After the last w, it waits until the recorder's ``/diagnostics`` count of ``intent/w`` stops growing,
stops the recorder with SIGINT and reads the bag back.

Printed: w sent, recorded, lost (sent - distinct sequence numbers in the bag), out of order, messages
recorded on all topics, the messages the recorder itself reports lost (its diagnostics' 'messages lost': the
middleware's message-lost events and what its keep-last queue dropped), the recorder's CPU over the publishing
window (% of one core, from /proc/<pid>/stat), the largest writer queue it reported, and the load average before
and after.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the domain is
ROS_DOMAIN_ID (default 91).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=91 \\
        python benchmarks/bench_recorder.py [--rate 1000] [--duration 20] [--no-suite]
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

from _bench import cpu_seconds

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--rate', type=float, default=1000.0, help='w messages per second (default 1000)')
    parser.add_argument('--duration', type=float, default=20.0, help='seconds of publishing (default 20)')
    parser.add_argument('--pub-depth', type=int, default=10, help='keep-last depth of the w publisher (default 10)')
    parser.add_argument('--no-suite', action='store_true', help='the recorder alone, without the three nodes')
    parser.add_argument('--keep', action='store_true', help='keep the bag and the logs (their directory is printed)')
    parser.add_argument('--recorder-source', type=Path, default=REPO,
                        help='run the recorder of this source tree (e.g. `git archive` of an older commit '
                             'unpacked somewhere) for a before/after figure; default this checkout')
    args = parser.parse_args()
    if os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') != 'LOCALHOST':
        sys.exit('bench_recorder: set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (and a ROS_DOMAIN_ID of your own): '
                 'DDS discovery must stay on the loopback interface')
    domain_id = int(os.environ.get('ROS_DOMAIN_ID', '91'))

    import rclpy  # after the network check
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.launch.process import NodeProcess
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.ros.qos import output_qos
    from grasp_intent_ros.sessions.bag import read_messages
    from grasp_intent_ros.wire.topics import INTENT_W

    work = Path(tempfile.mkdtemp(prefix='bench_recorder_'))
    bag = work / 'session'
    suite = NodeSuite(domain_id, log_dir=work / 'logs', cwd=REPO)
    if not args.no_suite:
        suite.start_nodes()
    recorder = NodeProcess([sys.executable, '-m', 'grasp_intent_ros', 'recorder', str(bag)], module='recorder',
                           env=suite.env, log_dir=suite.log_dir, cwd=args.recorder_source.resolve())
    suite.processes.append(recorder)

    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = rclpy.create_node('bench_recorder', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    w_topic = f'/{INTENT_W}'
    w_pub = node.create_publisher(Float64MultiArray, w_topic, output_qos(args.pub_depth))
    written = {'w': -1, 'queue peak': 0, 'lost': 0}

    def on_diagnostics(msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.endswith('recorder: recorder'):
                values = {kv.key: kv.value for kv in status.values}
                written['w'] = int(values.get(f'topic {w_topic}', written['w']))
                written['queue peak'] = int(values.get('writer queue peak', written['queue peak']))
                written['lost'] = int(values.get('messages lost', written['lost']))

    node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 100)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()

    def wait(condition, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            problem = suite.died() or (f'timed out waiting for {what}' if time.monotonic() > deadline else '')
            if problem:
                suite.stop()
                executor.shutdown()
                sys.exit(f'bench_recorder: {problem}')
            time.sleep(0.05)

    subscribers = 1 if args.no_suite else 2  # the recorder (and the interpreter)
    wait(lambda: w_pub.get_subscription_count() >= subscribers and written['w'] >= 0, 60.0,
         f'{subscribers} subscriber(s) of {w_topic} and the recorder\'s diagnostics')
    count = int(round(args.rate * args.duration))
    period = 1.0 / args.rate
    load_before = os.getloadavg()
    cpu0, t0 = cpu_seconds(recorder.pid), time.monotonic()
    for seq in range(count):  # paced against an absolute schedule: no drift
        delay = t0 + seq * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        w_pub.publish(Float64MultiArray(data=[seq / count, 0.5, 0.5]))  # a valid w: the interpreter answers
    publish_s = time.monotonic() - t0
    cpu_pct = 100.0 * (cpu_seconds(recorder.pid) - cpu0) / publish_s
    # settle: until the recorder's count has not moved for 3 s (it reports at 1 Hz)
    last, still_since = written['w'], time.monotonic()
    while time.monotonic() - still_since < 3.0:
        time.sleep(0.2)
        if written['w'] != last:
            last, still_since = written['w'], time.monotonic()
    load_after = os.getloadavg()
    recorder.stop(signal.SIGINT)
    problems = suite.stop()
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)

    seqs = [round(m.decode().data[0] * count) for m in read_messages(bag, topics=[w_topic])]  # type: ignore[attr-defined]
    total = sum(1 for _ in read_messages(bag))
    out_of_order = sum(1 for a, b in zip(seqs, seqs[1:]) if b < a)
    print(f'bench_recorder: {"recorder alone" if args.no_suite else "suite + recorder"}, w at {args.rate:g} Hz '
          f'for {args.duration:g} s (published in {publish_s:.2f} s), publisher depth {args.pub_depth}, '
          f'recorder from {args.recorder_source}')
    print(f'  w sent {count}, recorded {len(seqs)} ({len(set(seqs))} distinct), lost {count - len(set(seqs))}, '
          f'out of order {out_of_order}')
    print(f'  all topics recorded: {total} messages; writer queue peak {written["queue peak"]}; '
          f'messages the recorder reports lost (middleware events, its queue\'s drops): {written["lost"]}')
    print(f'  recorder CPU while publishing: {cpu_pct:.0f}% of one core')
    print(f'  load average before {load_before[0]:.2f}, after {load_after[0]:.2f}')
    for problem in problems:
        print(f'  problem: {problem}')
    if args.keep:
        print(f'  bag and logs kept in {work}')
    else:
        import shutil
        shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    main()
