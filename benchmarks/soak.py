r"""Memory soak of the node suite: RSS per node per minute under 100 Hz w and model switches.

The three suite nodes run as ``python -m`` processes. A probe publishes a random walk of w on
``intent/w`` at ``--rate`` Hz (default 100) for ``--minutes`` minutes (default 30), moves the object on
``object/pose`` every 5 s, and switches the model server's ``model`` parameter every minute
(cup_7zone -> cup_5zone -> cup_4zone -> flashlight_7zone -> ...). At the end of every minute it prints
each node's resident set size (from /proc), the grasps received in that minute, and the load average;
at the end, each node's growth after the first minute (target <= 2%) and, to tell one-off steps (the
first use of each model) from steady growth, after the first round of models.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=100 \
        .venv/bin/python benchmarks/soak.py [--minutes 30] [--rate 100]
"""

from __future__ import annotations

import argparse
import sys
import threading
import time

from _bench import REPO, Probe, loopback_domain, paced, rss_mb, uptime, walk

MODELS = ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')


def growth(history: dict[str, list[float]], minute: int) -> str:
    """Each node's RSS growth from the end of ``minute`` (1-based) to the last minute."""
    return ', '.join(f'{m} {100.0 * (h[-1] - h[minute - 1]) / h[minute - 1]:+.1f}% ({h[minute - 1]:.1f} -> '
                     f'{h[-1]:.1f} MB, peak {max(h[minute - 1:]):.1f})' for m, h in history.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--minutes', type=int, default=30)
    parser.add_argument('--rate', type=float, default=100.0, help='w per second')
    args = parser.parse_args()
    domain_id = loopback_domain('soak')

    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.launch.suite import SUITE_NODES, NodeSuite
    from grasp_intent_ros.mico.kinematics import BASE_FRAME
    from grasp_intent_ros.ros.qos import input_qos, output_qos

    suite = NodeSuite(domain_id, cwd=REPO)
    suite.start_nodes()
    probe = Probe(domain_id, 'soak_probe')
    stop = threading.Event()
    try:
        poses = probe.record(PoseStamped, 'grasp/pose', input_qos(100), lambda m: None)
        w_pub = probe.node.create_publisher(Float64MultiArray, 'intent/w', output_qos())
        pose_pub = probe.node.create_publisher(PoseStamped, 'object/pose', output_qos())
        params = AsyncParameterClient(probe.node, 'model_server')
        n = int(args.minutes * 60 * args.rate)
        ws = walk(n + 1000, seed=0)
        if not probe.wait_for(lambda: poses or w_pub.publish(Float64MultiArray(data=[float(x) for x in next(ws)])),
                              60.0, poll=0.2):
            sys.exit(f'soak: the suite did not answer within 60 s\n{suite.died()}')

        def object_pose(i: int) -> PoseStamped:
            msg = PoseStamped()
            msg.header.frame_id = BASE_FRAME
            msg.pose.position.x, msg.pose.position.y = 0.3 + 0.02 * (i % 3), -0.3
            msg.pose.orientation.z, msg.pose.orientation.w = 1.0, 0.0
            return msg

        def send(i: int) -> None:
            if stop.is_set():
                raise StopIteration
            w_pub.publish(Float64MultiArray(data=[float(x) for x in next(ws)]))
            if i % int(5 * args.rate) == 0:
                pose_pub.publish(object_pose(i // int(5 * args.rate)))

        def sender() -> None:
            try:
                paced(n, 1.0 / args.rate, send)
            except StopIteration:
                pass
        thread = threading.Thread(target=sender, daemon=True)
        start = time.monotonic()
        thread.start()
        pids = {module: suite.node(module).pid for module in SUITE_NODES}
        print(f'soak: {args.minutes} min, w at {args.rate:g} Hz, object moved every 5 s, model switched every '
              f'minute; domain {domain_id}; pids {pids}', flush=True)
        print('minute  ' + '  '.join(f'{m + " [MB]":>24s}' for m in SUITE_NODES) + '  grasps  load', flush=True)
        history: dict[str, list[float]] = {m: [] for m in SUITE_NODES}
        counted = len(poses)
        for minute in range(1, args.minutes + 1):
            time.sleep(max(0.0, start + 60.0 * minute - time.monotonic()))
            if problem := suite.died():
                sys.exit(f'soak: {problem}')
            for module in SUITE_NODES:
                history[module].append(rss_mb(pids[module]))
            grasps, counted = len(poses) - counted, len(poses)
            print(f'{minute:6d}  ' + '  '.join(f'{history[m][-1]:24.1f}' for m in SUITE_NODES)
                  + f'  {grasps:6d}  {uptime()}', flush=True)
            if minute < args.minutes:
                params.set_parameters([Parameter('model', value=MODELS[minute % len(MODELS)])])
    finally:
        stop.set()
        probe.close()
        problems = suite.stop()
        suite.remove_logs()
    if args.minutes >= 2:
        print('growth after the first minute (target <= 2%): ' + growth(history, 1))
    if args.minutes > len(MODELS):  # one-off steps (a model's first use) against steady growth
        print(f'growth after minute {len(MODELS)} (every model used once): ' + growth(history, len(MODELS)))
    if problems:
        print('\n'.join(problems), file=sys.stderr)


if __name__ == '__main__':
    main()
