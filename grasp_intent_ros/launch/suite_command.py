"""The suite command: ``python -m grasp_intent_ros suite``, ``ros2 run grasp_intent_ros suite``.

:func:`main` starts the nodes (:class:`~grasp_intent_ros.launch.suite.NodeSuite`), copies their output
to stdout with each line prefixed by ``[node]``, prints ``suite: up`` once every node has logged that it is
ready (:func:`~grasp_intent_ros.ros.startup.is_ready_line`; the scripted operator is started only once the
others are, :data:`_HELD_BACK`), and stops them all on Ctrl-C (SIGINT), SIGTERM
or SIGHUP (its terminal closed). With ``--object NAME=MODEL`` (repeatable) it starts one planning chain per
object under ``<namespace>/<NAME>/`` instead (:mod:`grasp_intent_ros.launch.objects`), each process's lines
prefixed ``[NAME/node]``, and ``suite: up`` waits for every chain; the optional nodes then serve the scene, the
scripted operator reaching for ``--operator-object NAME`` (default: the first object). Its last line says
whether every node stopped cleanly, else names each that did not (died, killed, or ended by its watchdog); exit
code 0 when every node stopped cleanly, 1 when one died or did not stop cleanly, 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from ..errors import GraspIntentError
from ..ros.startup import is_ready_line
from .objects import operator_object, parse_objects
from .suite import (
    MAX_DOMAIN_ID,
    OPTIONAL_NODES,
    SHARED_CONTROL_NODES,
    NodeSuite,
    SuiteError,
    domain_id_from_environment,
    optional_nodes,
)

__all__ = ['main']

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""The signals on which the suite command stops its nodes (they, in sessions of their own, get none of them)."""
_HELD_BACK = ('scripted_operator',)
"""Optional nodes started only once every other node is ready: the scripted operator drives the loop, and started
with the others it would begin its first episode (its twists, its time to grasp) before the assistance could move
the arm, so that a session recorded from the start would not replay."""


class _Echo:
    """Copies the lines the processes wrote to their log files to stdout, each prefixed with ``[module]``."""

    def __init__(self, suite: NodeSuite) -> None:
        self._suite = suite
        self._done: dict[Path, int] = {}  # bytes of each log file already copied (or held as a partial line)
        self._partial: dict[Path, bytes] = {}
        self.ready: set[int] = set()
        """The pids of the processes that logged that they are ready (``startup.is_ready_line``)."""

    def copy(self, *, final: bool = False) -> None:
        """Copy every complete new line; with ``final``, also each file's last line without a newline."""
        for proc in self._suite.processes:
            for path in (proc.stdout_path, proc.stderr_path):
                try:
                    with path.open('rb') as log:
                        log.seek(self._done.get(path, 0))
                        data = log.read()
                except OSError:
                    continue
                self._done[path] = self._done.get(path, 0) + len(data)
                lines = (self._partial.pop(path, b'') + data).split(b'\n')
                last = lines.pop()
                if final and last:
                    lines.append(last)
                elif last:
                    self._partial[path] = last
                for line in lines:
                    text = line.decode(errors='replace')
                    print(f'[{proc.module}] {text}')
                    if is_ready_line(text):
                        self.ready.add(proc.pid)
        sys.stdout.flush()


def main(argv: Sequence[str] | None = None) -> int:
    """The suite command (see the module docstring); returns the exit code."""
    parser = argparse.ArgumentParser(
        description='Start the node suite (intent_interpreter, model_server, grasp_planner) as processes on '
                    'loopback-only discovery, each with its config/<node>.yaml; Ctrl-C stops them all.')
    parser.add_argument('--namespace', default='', metavar='NS', help='every node in this namespace, e.g. /robot1')
    parser.add_argument('--domain-id', type=int, metavar='ID',
                        help=f'ROS_DOMAIN_ID of the nodes, 0..{MAX_DOMAIN_ID} (default: $ROS_DOMAIN_ID, else 0)')
    parser.add_argument('--params-file', action='append', default=[], type=Path, metavar='FILE',
                        help='a ROS parameters file for every node, after its config/<node>.yaml (its node-name '
                             'keys pick what each reads); repeatable, a later file wins')
    parser.add_argument('--with', dest='extra', action='append', default=[], metavar='NAME',
                        help=f'also start this node (optional nodes: {", ".join(OPTIONAL_NODES) or "none"})')
    parser.add_argument('--shared-control', action='store_true',
                        help=f'also start the shared-control loop: {" and ".join(SHARED_CONTROL_NODES)}')
    parser.add_argument('--object', dest='objects', action='append', default=[], metavar='NAME=MODEL',
                        help='instead of one planning chain, one per object of the scene under <namespace>/NAME/ '
                             'with its own model (a stem in config/models) and object/pose, all reading the arm\'s '
                             'joint_states; repeatable (docs/several_objects.md)')
    parser.add_argument('--operator-object', default='', metavar='NAME',
                        help='with --object and --with scripted_operator: the object the scripted operator reaches '
                             'for (default: the first --object)')
    parser.add_argument('--log-dir', type=Path, metavar='DIR',
                        help="keep each node's stdout and stderr in DIR (default: a temporary directory, deleted)")
    args = parser.parse_args(argv)
    if args.namespace and not args.namespace.startswith('/'):
        parser.error(f'--namespace must be absolute, e.g. /{args.namespace}')
    if missing := [str(path) for path in args.params_file if not path.is_file()]:
        parser.error(f'no parameters file {", ".join(missing)}')
    try:
        extra = optional_nodes(args.extra)
        objects = parse_objects(args.objects)
        if args.operator_object and not (objects and 'scripted_operator' in extra):
            raise GraspIntentError('--operator-object names the object of a scene (--object) that the scripted '
                                   'operator (--with scripted_operator) reaches for: give both')
        if objects:
            operator_object(objects, args.operator_object)
        domain_id = args.domain_id if args.domain_id is not None else domain_id_from_environment(unset=0)
        suite = NodeSuite(domain_id, log_dir=args.log_dir)
    except (SuiteError, GraspIntentError) as exc:
        parser.error(str(exc))
    stop_requested: list[int] = []
    for sig in _STOP_SIGNALS:
        signal.signal(sig, lambda signum, _frame: stop_requested.append(signum))
    echo = _Echo(suite)
    died = ''
    try:
        held = [module for module in extra if module in _HELD_BACK]
        suite.start_nodes(namespace=args.namespace, params_files=args.params_file,
                          extra=[module for module in extra if module not in held], shared_control=args.shared_control,
                          objects=objects, operator=args.operator_object)
        scene = ''.join(f'; object {o.name} ({o.model}) in {o.namespace(args.namespace)}' for o in objects)
        print(f'suite: ROS_DOMAIN_ID={domain_id}, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, namespace '
              f'{args.namespace or "/"}{scene}; started '
              + ', '.join(f'{p.module} (pid {p.pid})' for p in suite.processes)
              + ''.join(f'; {module} once they are ready' for module in held) + '; Ctrl-C stops them', flush=True)
        start, up = time.monotonic(), False
        while not stop_requested and not died:
            time.sleep(0.1)  # a signal handler only appends: the loop looks 10 times a second
            echo.copy()
            if not up and {p.pid for p in suite.processes} <= echo.ready:
                if held:  # the others are ready: now the held-back ones, then up once they are too
                    later = [suite.start(module, *suite.node_args(
                        module, namespace=args.namespace, params_files=args.params_file, objects=objects,
                        operator=args.operator_object, estimated='intent_estimator' in extra)) for module in held]
                    print('suite: started ' + ', '.join(f'{p.module} (pid {p.pid})' for p in later), flush=True)
                    held = []
                else:
                    up = True
                    print(f'suite: up after {time.monotonic() - start:.1f} s: every node is ready', flush=True)
            if died := suite.died().split(';', 1)[0]:
                print(f'suite: {died}; stopping the others', file=sys.stderr, flush=True)
    finally:
        for sig in _STOP_SIGNALS:
            signal.signal(sig, signal.SIG_IGN)  # the nodes are stopped once, completely
        problems = suite.stop(signal.SIGTERM, tail_lines=0)  # SIGINT would print a node's imports' traceback
        echo.copy(final=True)
        if args.log_dir is None:
            suite.remove_logs()
    for problem in problems:
        print(f'suite: {problem}', file=sys.stderr)
    sys.stderr.flush()
    print('suite: stopped ' + (f'not cleanly: {"; ".join(p.split(":", 1)[0] for p in problems)}' if problems
                               else 'cleanly'), flush=True)
    return 1 if problems or died else 0


if __name__ == '__main__':
    sys.exit(main())
