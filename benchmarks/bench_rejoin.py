r"""How soon a subscriber SIGKILLed and restarted beside a running publisher receives data again.

The bare form of a node restart, without the suite: one publisher process (100 Hz, the nodes' output QoS)
runs throughout; a subscriber process (the nodes' input QoS) is started ``--trials`` times, each time
``--gap`` s after the previous one was SIGKILLed (``--graceful``: after it exited cleanly). Printed per
trial, in seconds: the subscriber's node created (from its process start), its subscription matched
(from the node created) and the first message published after its start received (from the match).
Prints figures, asserts nothing.

Both processes get the environment of the suite's nodes (``launch.suite.node_environment``), so the Fast DDS
profile ``config/fastdds_loopback.xml`` unless FASTRTPS_DEFAULT_PROFILES_FILE is set: set it to another
profile to compare (the profile's comment gives the findings).

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=99 \
        .venv/bin/python benchmarks/bench_rejoin.py [--trials 8] [--gap 0.5] [--graceful]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
from _bench import REPO, loopback_domain, uptime

from grasp_intent_ros.launch.suite import node_environment

TOPIC = 'bench_rejoin/w'


def since_process_start() -> float:
    """Seconds since this process started (its start time from /proc, 10 ms resolution)."""
    with open('/proc/self/stat') as f:
        ticks = int(f.read().rsplit(')', 1)[1].split()[19])
    return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf('SC_CLK_TCK')


def publisher() -> None:
    """Publish [index, wall time] at 100 Hz until SIGTERM."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import output_qos

    rclpy.init()
    node = rclpy.create_node('bench_rejoin_publisher')
    pub = node.create_publisher(Float64MultiArray, TOPIC, output_qos())
    count = iter(range(10**9))
    node.create_timer(0.01, lambda: pub.publish(Float64MultiArray(data=[float(next(count)), time.time()])))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):  # SIGTERM from the benchmark
        pass


def subscriber(graceful: bool) -> None:
    """Print the timeline (JSON, s from the process start) at the first fresh message, then exit or wait."""
    started = time.time() - since_process_start()
    import rclpy
    from rclpy.event_handler import SubscriptionEventCallbacks
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import input_qos

    rclpy.init()
    node = rclpy.create_node('bench_rejoin_subscriber')
    marks = {'created': since_process_start()}

    def on_message(msg: Float64MultiArray) -> None:
        if msg.data[1] > started and 'first' not in marks:
            marks['first'] = since_process_start()

    def on_matched(_: object) -> None:
        marks.setdefault('matched', since_process_start())

    node.create_subscription(Float64MultiArray, TOPIC, on_message, input_qos(),
                             event_callbacks=SubscriptionEventCallbacks(matched=on_matched))
    deadline = time.monotonic() + 15.0
    while 'first' not in marks and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print(json.dumps(marks), flush=True)
    if graceful:
        node.destroy_node()
        rclpy.try_shutdown()
    else:
        signal.pause()  # until the benchmark's SIGKILL


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--trials', type=int, default=8, help='subscriber starts')
    parser.add_argument('--gap', type=float, default=0.5, help='seconds between a subscriber gone and the next')
    parser.add_argument('--graceful', action='store_true', help='the subscriber exits cleanly instead')
    parser.add_argument('--role', choices=('publisher', 'subscriber'), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role == 'publisher':
        return publisher()
    if args.role == 'subscriber':
        return subscriber(args.graceful)
    env = node_environment(loopback_domain('bench_rejoin'))
    command = [sys.executable, __file__]
    pub = subprocess.Popen([*command, '--role', 'publisher'], env=env, cwd=REPO)
    rows: list[dict[str, float]] = []
    load_before = uptime()
    try:
        time.sleep(2.0)  # the publisher up before the first subscriber, as a running peer is
        for _ in range(args.trials):
            sub = subprocess.Popen([*command, '--role', 'subscriber', *(['--graceful'] if args.graceful else [])],
                                   env=env, cwd=REPO, stdout=subprocess.PIPE, text=True)
            assert sub.stdout is not None
            rows.append(json.loads(sub.stdout.readline() or '{}'))
            if not args.graceful:
                sub.send_signal(signal.SIGKILL)
            sub.wait(10.0)
            time.sleep(args.gap)
    finally:
        pub.send_signal(signal.SIGTERM)
        pub.wait(10.0)
    print(f'subscriber restarted {args.trials} times beside a 100 Hz publisher ('
          f'{"clean exits" if args.graceful else "SIGKILLed"}); Fast DDS profile '
          f'{env.get("FASTRTPS_DEFAULT_PROFILES_FILE", "none")} [{load_before} -> {uptime()}]')
    late = []
    for i, row in enumerate(rows):
        created, matched, first = (row.get(k, np.nan) for k in ('created', 'matched', 'first'))
        late.append(first - matched)
        print(f'  trial {i}: node created {created:.3f} s, matched +{matched - created:.3f} s, '
              f'first message +{first - matched:.3f} s after the match')
    print(f'  first message after the match: median {np.nanmedian(late):.3f} s, max {np.nanmax(late):.3f} s '
          f'(trial 0 has no killed predecessor); no message within 15 s: {int(np.isnan(late).sum())}')


if __name__ == '__main__':
    main()
