r"""The viewer's cost to the planner, and 100 browser connections: prints figures, asserts nothing.

Part 1, in one run: the grasp planner runs as deployed (``python -m grasp_intent_ros.nodes.grasp_planner`` with its
config file, a process of its own); the probe (:class:`_bench.Probe`) publishes the cup 7-zone model and then
a v every ``--period`` s (seeded random w over all zones, as bench_planner_node.py) for ``--duration`` s per
phase. Phases cycle through ``alone``, ``viewer`` and ``browser`` (``--rounds`` of each, interleaved so that a
change of the machine's load falls on all three): in a ``viewer`` phase the viewer node runs
(``python -m grasp_intent_ros.nodes.viewer``, a process, subscribed to everything the planner publishes) and draws,
with no browser; in a ``browser`` phase a headless Chromium page is open on it too, so the viewer sends its
frames and the browser renders them (software WebGL) on the same machine. Printed per phase and pooled per
condition: the latency from publishing a v to the probe's receipt of the grasp/joint_targets that answers it
(the answer is the output whose stamp lies between the publication of v_i and of v_{i+1}), plans made, the
planner's and the viewer's CPU, the viewer's frames drawn; and the load average.

Part 2: a Chromium page opens the viewer, waits until the page shows it (the panel's text), and closes, 100
times. Printed: seconds per cycle, the viewer's RSS and thread count before and after (and its RSS every 25
pages), its
``browsers connected`` after the last close, and whether a last page still shows the newest plan's P.

Needs Debian's chromium (``apt-get install -y chromium``). Network rule: refuses to run unless
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set; every process gets both, and the page is
served on 127.0.0.1.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=92 \\
        python benchmarks/bench_viewer.py [--period 0.01] [--duration 10] [--rounds 2] [--connections 100]
"""

from __future__ import annotations

import argparse
import bisect
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _bench import (
    REPO,
    Probe,
    cpu_seconds,
    loopback_domain,
    paced,
    percentiles,
    prime_planner,
    rss_mb,
    stopped_after,
    uptime,
)
from _bench.cdp import INSTALL, Chromium, chromium_path  # the tests' DevTools client

CONDITIONS = ('alone', 'viewer', 'browser')
"""Part 1's conditions: the planner alone; with the viewer node; with the viewer node and a browser page on it."""


def threads(pid: int) -> int:
    """Threads of process ``pid``, from /proc."""
    return len(list(Path(f'/proc/{pid}/task').iterdir()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--period', type=float, default=0.01, help='seconds between two v messages')
    parser.add_argument('--duration', type=float, default=10.0, help='seconds of publishing per phase')
    parser.add_argument('--rounds', type=int, default=2, help='phases of each condition, interleaved (0: part 2 only)')
    parser.add_argument('--connections', type=int, default=100, help='browser connections of part 2')
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    domain_id = loopback_domain('bench_viewer')
    browser_path = chromium_path()
    if browser_path is None:
        sys.exit(f'bench_viewer: Debian chromium is not installed ({INSTALL})')

    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import JointState

    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.method import intent
    from grasp_intent_ros.method.model import GraspModel
    from grasp_intent_ros.resources import config_dir
    from grasp_intent_ros.ros.conversions import array_to_msg
    from grasp_intent_ros.ros.qos import input_qos
    from grasp_intent_ros.wire.diagnostics import status_values

    path = config_dir() / 'models' / 'cup_7zone.yaml'
    model = GraspModel.load(path)
    labels = intent.zone_labels(intent.all_zones(3), model.task_names)
    rng = np.random.default_rng(args.seed)
    n = int(round(args.duration / args.period))
    messages = []
    while len(messages) < n:
        result = intent.interpret(rng.uniform(0.0, 1.0, 3))
        if result.v is not None and intent.restrict(result.v, intent.all_zones(3), model.zones) is not None:
            messages.append(array_to_msg(result.v, [labels]))

    suite = NodeSuite(domain_id, cwd=REPO)
    planner = suite.start('grasp_planner', *NodeSuite.node_args('grasp_planner'))
    probe = Probe(domain_id)
    phases: list[tuple[str, list[float], int, float, float, int]] = []
    with stopped_after(suite, probe):
        answers: list[tuple[int, int]] = []  # (received ns, stamp ns)
        probe.node.create_subscription(JointState, 'grasp/joint_targets', lambda msg, info: answers.append(
            (info['received_timestamp'], msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)),
            input_qos(100_000))
        viewer_status: dict[str, str] = {}
        probe.node.create_subscription(DiagnosticArray, '/diagnostics', lambda msg: viewer_status.update(
            *(status_values(s) for s in msg.status if s.name.endswith('viewer: viewer'))), 100)
        v_pub = prime_planner('bench_viewer', probe, suite, model, path.stem, messages, answers)
        load_before = uptime()
        for phase in [c for _ in range(args.rounds) for c in CONDITIONS]:
            viewer = browser = None
            if phase != 'alone':
                viewer_status.clear()
                viewer = suite.start('viewer', '-p', 'port:=0')
                if not probe.wait_for(lambda: viewer_status.get('url'), 60.0):
                    sys.exit(f'bench_viewer: the viewer reported no URL\n{suite.died()}')
                if phase == 'browser':
                    browser = Chromium(browser_path)
                    page = browser.open(viewer_status['url'])
                    probe.wait_for(lambda: 'grasp_intent_ros' in page.text(), 60.0, poll=0.1)
                probe.wait_for(lambda: False, 2.0)  # the planner's new subscriber matched, the page loaded
                frames_before, viewer_cpu = int(viewer_status.get('frames drawn', '0')), cpu_seconds(viewer.pid)
            answers.clear()
            sent = [0] * n

            def send(i: int) -> None:
                sent[i] = probe.now_ns()
                v_pub.publish(messages[i])
            cpu = cpu_seconds(planner.pid)
            took = paced(n, args.period, send)
            probe.wait_for(lambda: answers and answers[-1][1] >= sent[-1], 10.0)
            cpu = cpu_seconds(planner.pid) - cpu
            burst = [(received, bisect.bisect_right(sent, stamp) - 1) for received, stamp in answers
                     if stamp >= sent[0]]
            latency = [(received - sent[i]) * 1e-6 for received, i in burst]
            frames, vcpu = 0, 0.0
            if viewer is not None:
                probe.wait_for(lambda: False, 1.2)  # one more diagnostics period of the viewer
                frames = int(viewer_status.get('frames drawn', '0')) - frames_before
                vcpu = cpu_seconds(viewer.pid) - viewer_cpu
                if browser is not None:
                    browser.close()
                viewer.stop()
            phases.append((phase, latency, len(burst), 100.0 * cpu / took, 100.0 * vcpu / took, frames))
            print(f'{phase:7s}: {len(burst)} plans for {n} v in {took:.1f} s; latency {percentiles(latency)}; '
                  f'planner CPU {phases[-1][3]:.0f}%' + (f'; viewer CPU {phases[-1][4]:.0f}%, {frames} frames '
                                                         f'drawn ({frames / took:.1f}/s)' if frames else ''),
                  flush=True)
        load_after = uptime()
        for condition in CONDITIONS if phases else ():
            pooled = [ms for c, latency, *_ in phases if c == condition for ms in latency]
            plans = sum(p for c, _, p, *_ in phases if c == condition)
            print(f'pooled {condition:7s}: {plans} plans; latency {percentiles(pooled)}')
        if phases:
            print(f'[{load_before} -> {load_after}]')
        connections(args.connections, suite, probe, viewer_status, browser_path, v_pub, messages[0], answers)


def connections(count: int, suite: Any, probe: Probe, viewer_status: dict[str, str], browser_path: str,
                v_pub: Any, v_msg: Any, answers: list[tuple[int, int]]) -> None:
    """Part 2: ``count`` pages open the viewer and close; then one more shows the newest plan."""
    viewer_status.clear()
    viewer = suite.start('viewer', '-p', 'port:=0')
    if not probe.wait_for(lambda: viewer_status.get('url'), 60.0):
        sys.exit(f'bench_viewer: the viewer reported no URL\n{suite.died()}')
    url = viewer_status['url']
    load_before = uptime()
    with Chromium(browser_path) as browser:
        first = browser.open(url)
        probe.wait_for(lambda: 'grasp_intent_ros' in first.text(), 60.0, poll=0.1)
        first.close()
        probe.wait_for(lambda: viewer_status.get('browsers connected') == '0', 10.0)
        rss, nthreads = rss_mb(viewer.pid), threads(viewer.pid)
        start = time.monotonic()
        shown = 0
        series = [f'{rss:.0f}']
        for k in range(count):
            page = browser.open(url)
            shown += probe.wait_for(lambda: 'grasp_intent_ros' in page.text(), 30.0, poll=0.05)
            page.close()
            if (k + 1) % 25 == 0:
                series.append(f'{rss_mb(viewer.pid):.0f}')
        took = time.monotonic() - start
        probe.wait_for(lambda: viewer_status.get('browsers connected') == '0', 10.0)
        connected = viewer_status.get('browsers connected')
        after_rss, after_threads = rss_mb(viewer.pid), threads(viewer.pid)
        answers.clear()
        v_pub.publish(v_msg)
        probe.wait_for(lambda: answers, 10.0)
        page = browser.open(url)
        served = probe.wait_for(lambda: 'P(zone | x)' in page.text(), 60.0, poll=0.1)
    print(f'{count} pages opened and closed in {took:.1f} s ({took / count:.2f} s each), {shown} showed the viewer; '
          f'viewer RSS {rss:.0f} -> {after_rss:.0f} MB, threads {nthreads} -> {after_threads}; browsers connected '
          f'after the last close: {connected}; a last page shows the next plan: '
          f'{"yes" if served else "no"}; viewer running: {"yes" if viewer.poll() is None else "no"}')
    print(f'viewer RSS every 25 pages (MB): {" ".join(series)}')
    print(f'[{load_before} -> {uptime()}]')


if __name__ == '__main__':
    main()
