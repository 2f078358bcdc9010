"""Fuzz: the three nodes as processes get a few thousand malformed messages on every input topic.

Hypothesis draws the cases (benchmarks/_bench/fuzz_inputs.py: NaN/Inf, 1e308, -0.0, empty and 5,000-element arrays,
bogus layouts and offsets, bad quaternions and frames, length mismatches, oversized strings and name
lists, absurd joint positions and object poses, undecodable bytes) with a fixed seed (derandomize), so
every run sends the same messages. Each one is sent once its predecessor's verdict is in, and each verdict
is attributed to its case exactly (``Fuzzer``: a stale answer never stands for a later case, nothing a case set
off is on its way when the next is sent), so a case's outcome does not depend on timing: every rejection
must be counted on /diagnostics by the node that reads the topic, every accepted edge case answered.
Afterwards the same processes (same PIDs) answer a valid w with a grasp.
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Any

from _bench.fuzz_inputs import COMPONENTS, FAMILIES, Case, Fuzzer, cases, valid_w
from geometry_msgs.msg import PoseStamped
from hypothesis import HealthCheck, Phase, given, settings

from grasp_intent_ros.launch.suite import SUITE_NODES
from grasp_intent_ros.wire import topics

STARTUP = 60.0
"""Seconds the suite gets to start and plan the first w on a loaded 2-core machine."""
EXAMPLES = 2000


def test_fuzzed_inputs_are_all_rejected_and_counted_and_the_nodes_keep_serving(ros: Any, launch: Any) -> None:
    launch.start_nodes()
    pids = {module: launch.node(module).pid for module in SUITE_NODES}
    fuzzer = Fuzzer(ros.node, ros.wait_for)
    grasps = ros.subscribe(PoseStamped, topics.GRASP_POSE)
    w_pub = ros.publisher(type(valid_w()), topics.INTENT_W)
    ready = lambda: grasps and all(fuzzer.component(t) in fuzzer.latest for t in COMPONENTS)  # noqa: E731
    assert ros.publish_until(w_pub, valid_w(), ready, timeout=STARTUP, period=1.0), launch.died() or 'no grasp'
    fuzzer.settle()  # the w published until then and their answers are all in

    @settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None,
              phases=(Phase.explicit, Phase.generate),  # no shrinking: the nodes' counters are state
              suppress_health_check=list(HealthCheck))
    @given(case=cases())
    def send(case: Case) -> None:
        fuzzer.send(case)
        assert not launch.died(), launch.died()

    start = time.monotonic()
    send()
    tally = ', '.join(f'{t} {f} {n}/{fuzzer.rejected[(t, f)]}' for (t, f), n in sorted(fuzzer.sent.items()))
    print(f'{sum(fuzzer.sent.values())} messages in {time.monotonic() - start:.1f} s; sent/rejected: {tally}')

    assert {family for _, family in fuzzer.sent} == set(FAMILIES)
    rejected_by = Counter()  # each node's own counter holds exactly the rejections of this run
    for (topic, _), n in fuzzer.rejected.items():
        rejected_by[fuzzer.component(topic)] += n
    assert {fuzzer.component(t): fuzzer.count(t) for t in COMPONENTS} == rejected_by
    n = len(grasps)
    assert ros.publish_until(w_pub, valid_w(), lambda: len(grasps) > n, timeout=10.0), 'no grasp after the fuzz'
    assert {module: launch.node(module).pid for module in SUITE_NODES} == pids and not launch.died()
