r"""Restart after SIGKILL: how soon a restarted node serves again. Prints figures, asserts nothing.

The three suite nodes run as ``python -m`` processes; a probe publishes a random walk of w on
``intent/w`` at 100 Hz throughout. Each node in turn is SIGKILLed (by its PID) and started again with the
same arguments, ``--trials`` times (default 5), ``--gap`` s apart. Measured from the restart (the new
process's start):

- intent_interpreter: the first v on ``intent/v`` answering a w published after the restart (each v is
  mapped back to its w by content);
- grasp_planner: the first ``grasp/pose`` stamped after the restart (its stamp is the new planner's
  arrival time of the v it answers);
- model_server: ``model/active`` received again (the probe's subscription is latched, so the new server's
  publication arrives as a new message), and whether grasps kept coming meanwhile.

Also printed: the CPU time (user + system) the new process had used when it served again, which the load
on a shared machine changes much less than the wall time; each node module's import time (a fresh
``python -c 'import ...'``, median of 3) and the load average.

``--compare DIR`` measures a before/after pair in one run: the restarts alternate between the nodes of this
tree (or ``--code``'s) and those of ``DIR`` (e.g. a clone of main with its venv.sh run), trial by trial, so
that both see the same load and the machine's drift (its speed varied by more than half between sittings
minutes apart) falls on both; each is printed with the per-pair differences of its wall and CPU times.

The probe stands for the suite's clients (the source of w, a recorder). A restarted node learns of a running
participant from that participant's periodic announcement whenever the first exchange is missed
(config/fastdds_loopback.xml says why), so the clients' own Fast DDS timing enters the figures: the probe
uses the nodes' profile (``--client suite``, as the project's tools do) or Fast DDS's defaults
(``--client fastdds-defaults``: an announcement every 3 s).

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=99 \
        .venv/bin/python benchmarks/bench_restart.py [--trials 5] [--gap 3] [--nodes grasp_planner ...] \
        [--code DIR] [--compare DIR]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
from _bench import REPO, Probe, cpu_seconds, loopback_domain, paced, uptime, walk


def import_seconds(module: str, code: Path | None = None, repeats: int = 3) -> float:
    """Median wall time of ``python -c 'import grasp_intent_ros.nodes.<module>'`` in a fresh interpreter (s)."""
    times = []
    env = {**os.environ, 'PYTHONPATH': str(code)} if code else None
    for _ in range(repeats):
        start = time.monotonic()
        subprocess.run([sys.executable, '-c', f'import grasp_intent_ros.nodes.{module}'], check=True, cwd=code or REPO,
                       env=env)
        times.append(time.monotonic() - start)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--trials', type=int, default=5, help='restarts per node')
    parser.add_argument('--gap', type=float, default=3.0, help='seconds between an answer and the next kill')
    parser.add_argument('--timeout', type=float, default=30.0, help='seconds to wait for an answer')
    parser.add_argument('--nodes', nargs='+', default=['intent_interpreter', 'grasp_planner', 'model_server'])
    parser.add_argument('--client', choices=('suite', 'fastdds-defaults'), default='suite',
                        help="the probe's Fast DDS discovery timing: the nodes' profile or Fast DDS's defaults")
    parser.add_argument('--code', type=Path, default=None,
                        help='run the nodes from this source tree instead (e.g. an export of main, its kernels '
                             'compiled there first; byte-compile it too, as scripts/venv.sh does, or its nodes '
                             'compile their modules at every start under PYTHONDONTWRITEBYTECODE=1), to compare '
                             'before/after in one sitting')
    parser.add_argument('--compare', type=Path, default=None,
                        help='restart the nodes alternately from this source tree (prepared as for --code) and '
                             'from this one (or --code): --trials restarts of each, interleaved')
    args = parser.parse_args()
    domain_id = loopback_domain('bench_restart')

    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import Float64MultiArray, String

    from grasp_intent_ros.launch.process import NodeProcess
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.method import intent
    from grasp_intent_ros.ros.qos import input_qos, latched_qos, output_qos

    code = args.code.resolve() if args.code else None
    trees: list[Path | None] = [code] if args.compare is None else [code, args.compare.resolve()]
    imports = {(module, tree): import_seconds(module, tree) for module in args.nodes for tree in trees}
    n = 10**6  # more w than any run sends
    ws = walk(n, seed=0)
    v_index: dict[tuple[float, ...], int] = {}
    sent: list[int] = []

    suite = NodeSuite(domain_id, cwd=code or REPO, numbered_logs=True,
                      env={'PYTHONPATH': str(code)} if code else None)
    suite.start_nodes()
    profile = suite.env.get('FASTRTPS_DEFAULT_PROFILES_FILE') if args.client == 'suite' else None
    if profile:  # before this process's first participant
        os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = profile
    else:
        os.environ.pop('FASTRTPS_DEFAULT_PROFILES_FILE', None)
    probe = Probe(domain_id)
    stop = threading.Event()
    pub = probe.node.create_publisher(Float64MultiArray, 'intent/w', output_qos())

    def send(_: int) -> None:
        if stop.is_set():
            raise StopIteration
        w = next(ws)
        v = intent.interpret(w).v
        if v is not None:
            v_index.setdefault(tuple(np.round(v, 9)), len(sent))
        sent.append(time.time_ns())
        pub.publish(Float64MultiArray(data=[float(x) for x in w]))

    def sender() -> None:
        try:
            paced(n, 0.01, send)
        except StopIteration:
            pass
    results: dict[tuple[str, Path | None], list[float]] = {}
    cpu: dict[tuple[str, Path | None], list[float]] = {}
    gaps: list[float] = []
    try:
        vs = probe.record(Float64MultiArray, 'intent/v', input_qos(100_000),
                          lambda m: v_index.get(tuple(np.round(np.asarray(m.data), 9)), -1))
        poses = probe.record(PoseStamped, 'grasp/pose', input_qos(100_000),
                             lambda m: int(m.header.stamp.sec) * 10**9 + int(m.header.stamp.nanosec))
        models = probe.record(String, 'model/active', latched_qos())
        thread = threading.Thread(target=sender, daemon=True)
        thread.start()
        if not probe.wait_for(lambda: poses, 60.0):
            sys.exit(f'bench_restart: the suite did not answer within 60 s\n{suite.died()}')
        load_before = uptime()
        for module in args.nodes:
            for tree in trees:
                results[module, tree], cpu[module, tree] = [], []
            for trial in range(args.trials * len(trees)):
                tree = trees[trial % len(trees)]
                time.sleep(args.gap)
                proc = suite.node(module)
                proc.send_signal(signal.SIGKILL)
                proc.wait(10.0)
                counts = len(vs), len(poses), len(models)
                t0 = time.time_ns()
                if tree == code:
                    new = suite.start(module, *suite.node_args(module))
                else:  # as suite.start does, from the other tree
                    new = NodeProcess.start(module, suite.node_args(module), env={**suite.env, 'PYTHONPATH': str(tree)},
                                            log_dir=suite.log_dir, prefix=f'{len(suite.processes):02d}_', cwd=tree)
                    suite.processes.append(new)

                def answered() -> int | None:
                    if module == 'intent_interpreter':
                        return next((t for t, i in vs[counts[0]:] if i >= 0 and sent[i] > t0), None)
                    if module == 'grasp_planner':
                        return next((t for t, stamp in poses[counts[1]:] if stamp > t0), None)
                    return next((t for t, _ in models[counts[2]:]), None)
                probe.wait_for(lambda: answered() is not None, args.timeout)
                t = answered()
                results[module, tree].append(np.inf if t is None else (t - t0) * 1e-9)
                cpu[module, tree].append(cpu_seconds(new.pid))
                if module == 'model_server':  # did grasps keep coming while the server was away?
                    times = [t0] + [t for t, _ in poses[counts[1]:] if t > t0] + [time.time_ns()]
                    gaps.append(max(np.diff(times)) * 1e-9)
        load_after = uptime()
    finally:
        stop.set()
        probe.close()
        problems = suite.stop(include_exited=False)
        suite.remove_logs()
    print(f'restart after SIGKILL -> serving again, {args.trials} trials per node, w at 100 Hz throughout; '
          f'domain {domain_id}; nodes from {code or REPO}'
          f'{f" and, alternately, {trees[1]}" if len(trees) > 1 else ""}; Fast DDS profile '
          f'{suite.env.get("FASTRTPS_DEFAULT_PROFILES_FILE", "none")}, the probe\'s '
          f'{os.environ.get("FASTRTPS_DEFAULT_PROFILES_FILE") or "Fast DDS defaults"} [{load_before} -> {load_after}]')
    what = {'intent_interpreter': 'v for a fresh w', 'grasp_planner': 'grasp/pose for a fresh v',
            'model_server': 'model/active re-latched'}
    for (module, tree), times in results.items():
        source = f' [{tree or REPO}]' if len(trees) > 1 else ''
        print(f'  {module:19s} {what[module]:24s} median {np.median(times):.2f} s (target <= 2 s); '
              f'trials {", ".join(f"{t:.2f}" for t in times)} s; CPU used by then: median '
              f'{np.median(cpu[module, tree]):.2f} s; import {imports[module, tree]:.2f} s{source}')
        if tree != trees[0]:  # the pairs: this tree's trial minus the compared tree's trial just after it
            walls = np.subtract(results[module, trees[0]], times)
            cpus = np.subtract(cpu[module, trees[0]], cpu[module, tree])
            print(f'  {"":19s} {"pairs, first - second":24s} wall median {np.median(walls):+.2f} s '
                  f'({", ".join(f"{d:+.2f}" for d in walls)}); CPU median {np.median(cpus):+.2f} s '
                  f'({", ".join(f"{d:+.2f}" for d in cpus)}); first faster in {int(np.sum(walls < 0))} of '
                  f'{walls.size}, less CPU in {int(np.sum(cpus < 0))}')
    if gaps:
        print(f'  while the model server restarted, the longest gap between grasps was {max(gaps):.2f} s')
    if problems:
        print('\n'.join(problems), file=sys.stderr)


if __name__ == '__main__':
    main()
