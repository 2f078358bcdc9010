r"""Model switches under a stream of intents: prints figures, asserts nothing.

A grasp planner process gets a new target vector v every 10 ms (a random walk of w, as from a smooth
intent estimate) while ``model/active`` switches between two models every second, for 20 s. A model
switch must not stall planning: the new model is read off the planning path and swapped in whole.

Printed, with the load average before and after:
- the time to read one model document (:func:`grasp_intent_ros.wire.model_document.read_model_document`: hash,
  YAML, model) beside PyYAML's pure-Python ``safe_load`` of the same document plus the model's
  construction (how a document was read before ``read_model_document``), medians in this process;
- the gaps between consecutive answers (``grasp/posterior`` received by the probe): the largest within
  half a switch period after each switch (largest and median over the switches), how many switches
  saw a gap over 50 ms (the target: none), and the gaps in the other half of the periods (the same
  machine without a switch, for comparison);
- the time from publishing a switch to the first answer with the new model's zones.

- in this process, without ROS: the largest gap between warm-started plans of a planning thread while
  another thread reads documents, plainly and inside the follower's
  :func:`~grasp_intent_ros.ros.model_follower.yielding_reader` (no garbage collection, 0.5 ms GIL switch
  interval), beside the same thread with no reading.

``--source DIR`` runs the planner from another source tree (e.g. ``git archive <commit> | tar -x -C
DIR``) for a before/after comparison in one sitting.

Network rule: it sets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST for itself and the planner; the domain is
ROS_DOMAIN_ID (default 93).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=93 \\
        python benchmarks/bench_model_switch.py [--duration 20] [--period 0.01] [--switch-period 1.0]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import threading
import time
from pathlib import Path

import numpy as np


def median_seconds(func: object, repeat: int) -> float:
    """Median wall time of ``repeat`` calls of ``func()``."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()  # type: ignore[operator]
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def plan_gaps_while(read: object, model: object, seconds: float = 0.6) -> float:
    """Largest gap (ms) between warm-started plans in a thread while ``read()`` runs (None: sleep ``seconds``)."""
    from grasp_intent_ros.method import intent
    from grasp_intent_ros.planning import planner

    v = intent.interpret([0.9, 0.9, 0.1]).v
    x0 = planner.plan(model, v).x  # type: ignore[arg-type]
    stop, stamps = threading.Event(), [time.perf_counter()]

    def plan_loop() -> None:
        while not stop.is_set():
            planner.plan(model, v, warm_start=x0)  # type: ignore[arg-type]
            stamps.append(time.perf_counter())

    thread = threading.Thread(target=plan_loop)
    thread.start()
    time.sleep(0.1)
    first = len(stamps)
    if read is None:
        time.sleep(seconds)
    else:
        read()  # type: ignore[operator]
    stop.set()
    thread.join()
    return float(1e3 * np.diff(stamps[first - 1:]).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--models', nargs=2, default=('cup_7zone', 'cup_5zone'),
                        help='the two models switched between (stems in config/models)')
    parser.add_argument('--period', type=float, default=0.01, help='seconds between two v messages')
    parser.add_argument('--switch-period', type=float, default=1.0, help='seconds between two model switches')
    parser.add_argument('--duration', type=float, default=20.0, help='seconds of publishing')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--source', default=None, help='run the planner from this source tree (PYTHONPATH)')
    args = parser.parse_args()
    from grasp_intent_ros.launch.suite import NodeSuite, domain_id_from_environment, use_loopback_discovery

    use_loopback_discovery()  # this process's participant too, before rclpy is imported
    domain_id = domain_id_from_environment(unset=93)

    import rclpy
    import yaml
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64MultiArray, String

    from grasp_intent_ros.method import intent
    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.resources import config_dir
    from grasp_intent_ros.ros.conversions import array_to_msg, model_to_msg
    from grasp_intent_ros.ros.model_follower import yielding_reader
    from grasp_intent_ros.ros.qos import input_qos, latched_qos
    from grasp_intent_ros.wire.arrays import read_posterior
    from grasp_intent_ros.wire.model_document import parse_model_document, read_model_document

    load_before = os.getloadavg()
    models = {name: GraspModel.load(config_dir() / 'models' / f'{name}.yaml') for name in args.models}
    documents = {name: model_to_msg(model, name=name, version=1).data for name, model in models.items()}
    for name, text in documents.items():
        body = parse_model_document(text)[1]
        new = median_seconds(lambda: read_model_document(text), 7)
        old = median_seconds(lambda: GraspModel.from_document(yaml.safe_load(body)), 3)
        print(f'read {name} ({len(text) / 1e3:.0f} kB): {1e3 * new:.0f} ms (pure-Python safe_load: '
              f'{1e3 * old:.0f} ms, {old / new:.1f}x)')

    text = documents[args.models[0]]
    model = models[args.models[0]]

    def read_twice() -> None:
        for _ in range(2):
            read_model_document(text)

    def read_twice_yielding() -> None:
        for _ in range(2):
            with yielding_reader():
                read_model_document(text)

    for _ in range(3):
        print(f'in-process, largest gap between warm-started plans: no reading {plan_gaps_while(None, model):.1f} ms, '
              f'reading {args.models[0]} twice: plainly {plan_gaps_while(read_twice, model):.1f} ms, '
              f'as the follower does {plan_gaps_while(read_twice_yielding, model):.1f} ms')

    rng = np.random.default_rng(args.seed)
    m = 3
    labels = intent.zone_labels(intent.all_zones(m), intent.DEFAULT_TASKS)
    w = np.full(m, 0.5)
    n = int(round(args.duration / args.period))
    messages = []
    for _ in range(n + 1):
        w = np.clip(w + rng.normal(0.0, 0.01, m), 0.02, 0.98)
        messages.append(array_to_msg(intent.interpret(w).v, [labels]))

    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    executor = SingleThreadedExecutor(context=context)
    probe = rclpy.create_node('bench_model_switch_probe', context=context)
    clock = probe.get_clock()
    answers: list[tuple[int, tuple[str, ...]]] = []  # (received ns, zone labels)
    probe.create_subscription(Float64MultiArray, 'grasp/posterior', lambda msg: answers.append(
        (clock.now().nanoseconds, read_posterior(msg).zone_labels)), input_qos(1000))
    model_pub = probe.create_publisher(String, 'model/active', latched_qos())
    v_pub = probe.create_publisher(Float64MultiArray, 'intent/v', 10)
    executor.add_node(probe)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    env = {'PYTHONPATH': str(Path(args.source).resolve())} if args.source else {}
    switches: list[tuple[int, tuple[str, ...]]] = []  # (published ns, zones of the new model)
    try:
        with NodeSuite(domain_id, env=env, cwd=args.source) as suite:
            planner = suite.start('grasp_planner')
            names = list(args.models)
            model_pub.publish(String(data=documents[names[0]]))
            deadline = time.monotonic() + 30.0
            while not answers and time.monotonic() < deadline:  # start-up, discovery and the first plan
                v_pub.publish(messages[-1])
                time.sleep(0.2)
                if planner.poll() is not None:
                    sys.exit(f'bench_model_switch: the planner exited:\n{planner.stderr_tail()}')
            if not answers:
                sys.exit('bench_model_switch: the planner did not answer within 30 s')
            answers.clear()
            start = time.monotonic()
            next_switch, version = start + args.switch_period, 1
            for i in range(n):
                now = time.monotonic()
                if now >= next_switch:
                    version += 1
                    name = names[version % 2 == 0]
                    # the version line is outside the hashed body: no YAML is written here
                    text = documents[name].replace('# model_version: 1\n', f'# model_version: {version}\n', 1)
                    switches.append((clock.now().nanoseconds, models[name].zone_labels))
                    model_pub.publish(String(data=text))
                    next_switch += args.switch_period
                delay = start + i * args.period - time.monotonic()
                if delay > 0.0:
                    time.sleep(delay)
                v_pub.publish(messages[i])
            time.sleep(1.0)  # the last answers
    finally:
        executor.shutdown()
        spinner.join()
        probe.destroy_node()
        rclpy.try_shutdown(context=context)
    load_after = os.getloadavg()

    received = np.array([t for t, _ in answers], dtype=np.int64)
    gaps_ms = np.diff(received) * 1e-6
    near = np.zeros(gaps_ms.size, dtype=bool)
    around, swap_ms = [], []
    for published, zones in switches:
        # gaps that end after the switch and start within half a switch period after it
        window = (received[1:] > published) & (received[:-1] < published + int(0.5e9 * args.switch_period))
        near |= window
        if window.any():
            around.append(float(gaps_ms[window].max()))
        first = next((t for t, z in answers if t > published and z == zones), None)
        if first is not None:
            swap_ms.append((first - published) * 1e-6)
    print(f'planner from {args.source or "this tree"}; {n} v messages, one every {1e3 * args.period:.0f} ms, '
          f'{len(switches)} switches {" <-> ".join(args.models)} every {args.switch_period:.1f} s; '
          f'load average before {load_before[0]:.2f}, after {load_after[0]:.2f} (1 min)')
    print(f'answers: {len(answers)}; gap between answers: median {np.median(gaps_ms):.1f} ms')
    if around:
        print(f'largest gap within {0.5 * args.switch_period:.1f} s after a switch: max {max(around):.1f} ms, '
              f'median over switches {statistics.median(around):.1f} ms; switches with a gap > 50 ms: '
              f'{sum(g > 50.0 for g in around)} of {len(around)}')
    if (~near).any():
        print(f'gaps elsewhere (the other half of each period): p99 {np.percentile(gaps_ms[~near], 99):.1f} ms, '
              f'max {gaps_ms[~near].max():.1f} ms')
    if swap_ms:
        print(f'switch published -> first answer with the new model: median {statistics.median(swap_ms):.0f} ms, '
              f'max {max(swap_ms):.0f} ms ({len(swap_ms)} of {len(switches)} switches seen)')


if __name__ == '__main__':
    main()
