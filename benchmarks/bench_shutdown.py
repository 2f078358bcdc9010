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

``--code DIR`` runs the nodes from another checkout (e.g. an older commit, for a before/after pair in one
sitting): started in DIR with DIR on PYTHONPATH.

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set;
every process it starts gets both.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=99 \
        .venv/bin/python benchmarks/bench_shutdown.py [--cycles 50] [--nodes quiet model_server ...] [--code DIR]
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

from grasp_intent_ros.tools.suite import SUITE_NODES, NodeProcess, NodeSuite, node_environment

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--nodes', nargs='+', default=list(SUITE_NODES), choices=[*SUITE_NODES, 'quiet'])
    parser.add_argument('--cycles', type=int, default=50)
    parser.add_argument('--signal', choices=['TERM', 'INT'], default='TERM')
    parser.add_argument('--hang', type=float, default=12.0, help='seconds after which a node counts as hung')
    parser.add_argument('--code', type=Path, help='checkout to run the nodes from (default this one)')
    args = parser.parse_args()
    code = (args.code or REPO).resolve()
    extra_env = {'PYTHONPATH': str(code)} if args.code else {}
    domain_id = loopback_domain('bench_shutdown')
    sig = signal.SIGTERM if args.signal == 'TERM' else signal.SIGINT
    probe = Probe(domain_id, 'bench_shutdown_probe')
    from diagnostic_msgs.msg import DiagnosticArray

    statuses = probe.record(DiagnosticArray, '/diagnostics', 50, lambda msg: [s.name for s in msg.status])
    print(f'bench_shutdown: SIG{args.signal}, {args.cycles} cycles per node, code in {code}; {uptime()}', flush=True)
    try:
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
