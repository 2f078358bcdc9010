"""What the process benchmarks share: the network rule, a probe node, w, the planner primed, the teardown.

Not a benchmark itself. Its submodules :mod:`_bench.cdp` (a headless Chromium driven over the DevTools protocol)
and :mod:`_bench.fuzz_inputs` (malformed inputs for every input topic) are shared with the tests (setup.cfg puts
benchmarks/ on pytest's path); :mod:`_bench.closed_loop` (the live closed loop's probe side and judge) and
:mod:`_bench.closed_loop_record` (that loop recorded as a session bag) are ``bench_shared_control.py``'s.

The probe is an rclpy node in a private Context, spun by an executor in a thread of its own; callbacks
record the middleware's receive time of each message (``received_timestamp`` of the message info),
so the probe's own Python overhead does not enter the figures.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def loopback_domain(name: str) -> int:
    """The ROS domain id of the run; exits unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set."""
    if os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') != 'LOCALHOST' or not os.environ.get('ROS_DOMAIN_ID'):
        sys.exit(f'{name}: set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of your own: DDS '
                 'discovery must stay on the loopback interface')
    return int(os.environ['ROS_DOMAIN_ID'])


def walk(n: int, m: int = 3, *, seed: int = 0, step: float = 0.01) -> Iterator[np.ndarray]:
    """``n`` intents w: a random walk of m task probabilities (each entry N(0, step) per message)."""
    rng = np.random.default_rng(seed)
    w = np.full(m, 0.5)
    for _ in range(n):
        w = np.clip(w + rng.normal(0.0, step, m), 0.02, 0.98)
        yield w


def uptime() -> str:
    """The load averages (1, 5, 15 min), as ``uptime`` prints them."""
    return 'load average %.2f, %.2f, %.2f' % os.getloadavg()


def bootstrap_ci(values: Sequence[float], rng: np.random.Generator, n: int = 10_000) -> tuple[float, float, float]:
    """(mean, 2.5th, 97.5th percentile of the bootstrap means) of ``values``: ``n`` resamples with replacement."""
    arr = np.asarray(values, dtype=np.float64)
    means = arr[rng.integers(0, arr.size, (n, arr.size))].mean(axis=1)
    return float(arr.mean()), float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def percentiles(values_ms: list[float] | np.ndarray, *, digits: int = 1) -> str:
    """``median X ms, p99 Y ms, max Z ms`` with ``digits`` decimals (or 'no samples')."""
    a = np.asarray(values_ms, dtype=np.float64)
    if not a.size:
        return 'no samples'
    return (f'median {np.median(a):.{digits}f} ms, p99 {np.percentile(a, 99):.{digits}f} ms, '
            f'max {a.max():.{digits}f} ms')


def cpu_seconds(pid: int) -> float:
    """CPU time (user + system, s) process ``pid`` has used so far, from /proc."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')  # utime, stime (fields 14, 15)


def rss_mb(pid: int) -> float:
    """Resident set size of process ``pid`` (MB), from /proc."""
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmRSS:'):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError(f'no VmRSS for pid {pid}')


class Probe:
    """An rclpy node in a private Context on ``domain_id``, spun in a thread until :meth:`close`."""

    def __init__(self, domain_id: int, name: str = 'bench_probe') -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self._rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node(name, context=self.context)
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def now_ns(self) -> int:
        """System time (ns): the clock of the nodes' stamps and of the middleware's receive times."""
        return time.time_ns()

    def record(self, msg_type: Any, topic: str, qos: Any,
               convert: Callable[[Any], Any] = lambda msg: msg) -> list[tuple[int, Any]]:
        """Subscribe; the returned list fills with (middleware receive time ns, ``convert(msg)``)."""
        received: list[tuple[int, Any]] = []
        self.node.create_subscription(msg_type, topic, lambda msg, info: received.append(
            (info['received_timestamp'], convert(msg))), qos)
        return received

    def wait_for(self, condition: Callable[[], object], timeout: float, *, poll: float = 0.01) -> bool:
        """Poll ``condition`` until it is true or ``timeout`` s pass; whether it became true."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                return False
            time.sleep(poll)
        return True

    def close(self) -> None:
        """Stop spinning and shut the context down."""
        self._executor.shutdown()
        self._thread.join()
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)


@contextmanager
def stopped_after(suite: Any, probe: Probe) -> Iterator[None]:
    """The body, then the probe closed, the suite stopped and its logs removed, also after an error.

    After a body that ended normally, the problems the stop found (a node that did not exit cleanly) go to
    stderr.
    """
    try:
        yield
    finally:
        probe.close()
        problems = suite.stop()
        suite.remove_logs()
    if problems:
        print('\n'.join(problems), file=sys.stderr)


def prime_planner(name: str, probe: Probe, suite: Any, model: Any, model_name: str, messages: Sequence[Any],
                  answers: Sequence[object]) -> Any:
    """Publish ``model`` on model/active and v until the planner answers (into ``answers``); the v publisher.

    Exits (naming ``name``, the benchmark) when the planner has not answered within 60 s; then waits one more
    second, while the planner loads the kernels its first plan did not use.
    """
    from std_msgs.msg import Float64MultiArray, String

    from grasp_intent_ros.ros.conversions import model_to_msg
    from grasp_intent_ros.ros.qos import latched_qos, output_qos

    model_pub = probe.node.create_publisher(String, 'model/active', latched_qos())
    v_pub = probe.node.create_publisher(Float64MultiArray, 'intent/v', output_qos())
    model_pub.publish(model_to_msg(model, name=model_name, version=1))
    if not probe.wait_for(lambda: answers or v_pub.publish(messages[-1]), 60.0, poll=0.2):
        sys.exit(f'{name}: the planner did not answer within 60 s\n{suite.died()}')
    probe.wait_for(lambda: False, 1.0)  # the kernels the first plan did not use load after it
    return v_pub


def paced(n: int, period: float, send: Callable[[int], None]) -> float:
    """Call ``send(i)`` for i < n at ``period`` s intervals (no drift); the seconds it took."""
    start = time.monotonic()
    for i in range(n):
        delay = start + i * period - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
        send(i)
    return time.monotonic() - start
