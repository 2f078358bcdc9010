r"""Stop on SIGTERM: how long each node takes to exit, and whether any hangs. Prints figures.

Each node in turn (``--nodes``, default the three suite nodes) is started ``--cycles`` times as a
``python -m`` process with its config file, one process at a time; once it serves (its status on
``/diagnostics`` has reached the probe) it gets SIGTERM (``--signal INT``: SIGINT) by its PID, and the
time to its exit is measured. A node that has not exited ``--hang`` s later (default 12: beyond the
watchdog's 5 s and faulthandler's 7 s) counts as hung: its log directory is kept and its stderr's end
printed, and it is SIGKILLed. Printed per node: the exit time's median, 90th percentile and maximum, how
many exits took over 1 s, the hangs, the watchdog's firings (``shutdown not finished`` in stderr), other
exit codes, and the load average.

``quiet`` is a node with no timer and no subscription, spun by ``ros.run.run_node`` without a watchdog, that
serves once its executor waits in rcl_wait: nothing but the stop can end its spin, so it shows rclpy's
signal race (``ros.run``'s module docstring) as hangs on code that does not close it.

``--suite`` stops the three suite nodes together instead, as Ctrl-C stops the suite: each cycle starts them
(:meth:`NodeSuite.start_nodes`), sends w until a grasp posterior comes back, then stops them all with SIGINT
the way the suite command does (:meth:`NodeSuite.stop`: one at a time, the last started first) or, with
``--together``, with SIGINT to every node at once (a launch that signals a process group). Printed: the time
from the first signal to the last exit (median, 90th percentile, maximum), the nodes that did not exit
within ``--hang`` s, exits with a code other than 0, and faulthandler's timeouts (``Timeout (``: a hang
that held the GIL, the middleware's shutdown livelock of docs/nodes.md) and the watchdog's firings.

``--code DIR`` runs the nodes from another checkout (e.g. an older commit, for a before/after pair in one
sitting): started in DIR with DIR on PYTHONPATH.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=99 \
        .venv/bin/python benchmarks/bench_shutdown.py [--cycles 50] [--nodes quiet model_server ...] [--code DIR]
        .venv/bin/python benchmarks/bench_shutdown.py --suite [--together] [--cycles 200]
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _bench import REPO, Probe, loopback_domain, uptime

from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import SUITE_NODES, NodeSuite, node_environment

QUIET = '''
import linecache, sys, threading, time
from rclpy.node import Node
from grasp_intent_ros.ros.run import run_node
def announce(spinner):  # "up" once the spinning thread's innermost frame is the executor's rcl_wait call
    while True:
        frame = sys._current_frames().get(spinner.ident)
        line = '' if frame is None else linecache.getline(frame.f_code.co_filename, frame.f_lineno)
        if line.strip().startswith('wait_set.wait('):
            print('up', flush=True)
            return
        time.sleep(0.005)
class Quiet(Node):
    def __init__(self):
        super().__init__('quiet')
        threading.Thread(target=announce, args=(threading.current_thread(),), daemon=True).start()
run_node(Quiet, shutdown_grace=None)
'''


def suite_cycles(probe: Probe, domain_id: int, args: argparse.Namespace, code: Path,
                 extra_env: dict[str, str]) -> None:
    """``--suite``: the three nodes started, answering, and stopped with SIGINT ``args.cycles`` times."""
    from std_msgs.msg import Float64MultiArray

    from grasp_intent_ros.ros.qos import input_qos, output_qos
    from grasp_intent_ros.wire.topics import GRASP_POSTERIOR, INTENT_W

    answers = probe.record(Float64MultiArray, GRASP_POSTERIOR, input_qos())
    w_pub = probe.node.create_publisher(Float64MultiArray, INTENT_W, output_qos())
    w = Float64MultiArray(data=[0.9, 0.9, 0.1])
    how = 'SIGINT to every node at once' if args.together else 'stopped one at a time (NodeSuite.stop)'
    stops: list[float] = []
    hung, codes, timeouts, watchdog, silent = 0, [], 0, 0, 0
    for cycle in range(args.cycles):
        log_dir = Path(tempfile.mkdtemp(prefix='bench_shutdown_'))
        suite = NodeSuite(domain_id, log_dir=log_dir, cwd=code, env=extra_env)
        suite.start_nodes()
        seen = len(answers)
        deadline = time.monotonic() + 60.0
        while len(answers) == seen and time.monotonic() < deadline and not suite.died():
            w_pub.publish(w)
            probe.wait_for(lambda: len(answers) > seen, 0.5)
        silent += len(answers) == seen
        start = time.monotonic()
        if args.together:
            for proc in suite.processes:
                proc.send_signal(signal.SIGINT)
            probe.wait_for(lambda: all(p.poll() is not None for p in suite.processes), args.hang, poll=0.002)
        else:
            suite.stop(signal.SIGINT, timeout=args.hang, tail_lines=0)
        stops.append(time.monotonic() - start)
        for proc in suite.processes:
            proc.wait(0.0)  # SIGKILL for one still running (--together)
        killed = [p for p in suite.processes if 'was killed' in p.problem()]
        hung += len(killed)
        for proc in suite.processes:
            err = proc.stderr()
            timeouts += 'Timeout (' in err
            watchdog += 'shutdown not finished' in err
            if proc not in killed and proc.poll() != 0:
                codes.append(f'{proc.module} {proc.poll()}')
        if problems := [p.problem() for p in suite.processes if p.problem()]:
            print(f'  cycle {cycle}: {"; ".join(problems)}; logs kept in {log_dir}', flush=True)
        else:
            shutil.rmtree(log_dir, ignore_errors=True)
    e = np.array(stops)
    print(f'suite, {how}: {args.cycles} cycles ({silent} without an answer first): last exit after median '
          f'{np.median(e):.2f} s, p90 {np.percentile(e, 90):.2f} s, max {e.max():.2f} s; nodes hung {hung}, '
          f"faulthandler timeouts {timeouts}, watchdog {watchdog}, other exit codes {codes or 'none'}; "
          f'{uptime()}', flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--nodes', nargs='+', default=list(SUITE_NODES), choices=[*SUITE_NODES, 'quiet'])
    parser.add_argument('--cycles', type=int, default=50)
    parser.add_argument('--signal', choices=['TERM', 'INT'], default='TERM')
    parser.add_argument('--hang', type=float, default=12.0, help='seconds after which a node counts as hung')
    parser.add_argument('--code', type=Path, help='checkout to run the nodes from (default this one)')
    parser.add_argument('--suite', action='store_true', help='stop the three suite nodes together (module docstring)')
    parser.add_argument('--together', action='store_true', help='with --suite: SIGINT to every node at once')
    args = parser.parse_args()
    code = (args.code or REPO).resolve()
    extra_env = {'PYTHONPATH': str(code)} if args.code else {}
    domain_id = loopback_domain('bench_shutdown')
    sig = signal.SIGTERM if args.signal == 'TERM' else signal.SIGINT
    probe = Probe(domain_id, 'bench_shutdown_probe')
    from diagnostic_msgs.msg import DiagnosticArray

    statuses = probe.record(DiagnosticArray, '/diagnostics', 50, lambda msg: [s.name for s in msg.status])
    what = 'the suite stopped with SIGINT' if args.suite else f'SIG{args.signal}'
    print(f'bench_shutdown: {what}, {args.cycles} cycles{"" if args.suite else " per node"}, code in {code}; '
          f'{uptime()}', flush=True)
    try:
        if args.suite:
            suite_cycles(probe, domain_id, args, code, extra_env)
            return
        for module in args.nodes:
            exits: list[float] = []
            hung, watchdog, other_codes = 0, 0, []
            for _ in range(args.cycles):
                log_dir = Path(tempfile.mkdtemp(prefix='bench_shutdown_'))
                if module == 'quiet':
                    proc = NodeProcess([sys.executable, '-c', QUIET], module=module, log_dir=log_dir, cwd=code,
                                       env=node_environment(domain_id, {**os.environ, **extra_env}))
                    serving = lambda: 'up' in proc.stdout_path.read_text()  # noqa: E731
                else:
                    suite = NodeSuite(domain_id, log_dir=log_dir, cwd=code, env=extra_env)
                    proc = suite.start(module, *NodeSuite.node_args(module))
                    seen = len(statuses)
                    serving = lambda: any(name.startswith(f'/{module}:')  # noqa: E731
                                          for _, names in statuses[seen:] for name in names)
                if not probe.wait_for(lambda: serving() or proc.poll() is not None, 60.0):
                    print(f'  {module}: not serving 60 s after its start', flush=True)
                stop = time.monotonic()
                proc.send_signal(sig)
                probe.wait_for(lambda: proc.poll() is not None, args.hang, poll=0.002)
                if proc.poll() is None:
                    hung += 1
                    proc.wait(0.0)  # SIGKILL
                    print(f'  {module} (pid {proc.pid}) did not exit {args.hang:g} s after SIG{args.signal}; '
                          f'logs kept in {log_dir}; stderr ends:\n{proc.stderr_tail()}', flush=True)
                    continue
                exits.append(time.monotonic() - stop)
                watchdog += 'shutdown not finished' in proc.stderr()
                if proc.poll() != 0:
                    other_codes.append(proc.poll())
                shutil.rmtree(log_dir, ignore_errors=True)
            e = np.array(exits)
            figures = (f'exit median {np.median(e):.3f} s, p90 {np.percentile(e, 90):.3f} s, max {e.max():.3f} s, '
                       f'{int((e > 1.0).sum())} over 1 s' if e.size else 'no exits')
            print(f'{module}: {args.cycles} cycles: {figures}; hung {hung}, watchdog {watchdog}, '
                  f'other exit codes {other_codes or "none"}; {uptime()}', flush=True)
    finally:
        probe.close()


if __name__ == '__main__':
    main()
