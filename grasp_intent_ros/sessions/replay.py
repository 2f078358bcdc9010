"""Replay a recorded session into a live node suite and, with ``--check``, compare its answers.

Run: ``python -m grasp_intent_ros replay BAG [--rate R | --fast] [--check] [--start-suite]``
     ``[--timeout S] [--models-dir DIR] [--max-diffs N]``

What is replayed
    The recorded inputs ``intent/w``, ``object/pose`` and ``joint_states``, published again byte for byte
    (bad inputs included), and the model switches: a recorded ``model/active`` with another name (or
    content) is reproduced by setting the model server's ``model`` parameter through its parameter
    service at that point. Before the first input the live model is set to the session's initial one.
Scenes of several objects
    A bag of one planning chain per object (``/cup``, ``/flashlight``) and the arm's ``joint_states`` above
    them (:func:`~grasp_intent_ros.sessions.scenes.detect_scene`): each chain is paired by its namespace, and
    replayed and checked through a client in it (its model server's parameter, its outputs, its nodes'
    rejections); every input is sent once in the recorded order (a joint state for every chain), and the answer
    of each chain it feeds is awaited. A difference names the chain's topic (``flashlight/grasp/pose``).
Closed-loop sessions
    A session with operator twists is replayed as a closed loop (:mod:`grasp_intent_ros.sessions.closed_loop`):
    w, object poses, model switches and operator twists at the recorded pace (``--fast`` and ``--rate`` are
    refused), never the arm's joint states; ``--start-suite`` adds the assistance and the mock arm; ``--check``
    compares the outcome (start, last grasp, where the hand ends, last w), not each message. A session recorded
    with the intent estimator (its status in the bag) is replayed on the recorded hand: its operator twists
    and joint states, no w, into the estimator (``--start-suite`` starts it with the three nodes, no assistance
    or arm); the live estimator's last w and the last grasp are compared.
Pace
    Default: the recorded pace (``--rate R`` scales it: 2 = twice as fast). ``--fast``: each input as soon
    as the system has answered the previous one. ``--check`` always waits for the answer to an input
    (or ``--timeout`` seconds) before sending the next, so inputs and outputs pair one to one.
Check (``--check``)
    The live answer to each input is compared with the recorded one
    (:func:`grasp_intent_ros.sessions.compare.compare_step`): v within 1e-9, P and reconstructed w within 1e-4,
    end-effector pose within 1 mm and 0.01 rad, joint targets within 1e-3 rad, clarifications and
    rejections (WARN diagnostics: node, level, reason) identical, nothing missing, nothing extra.
    Differences are printed one per line (input #, its description, topic, field, recorded vs live), for
    the first ``--max-diffs`` differing messages; exit code 1. All equal: one summary line, exit code 0.
Suite (``--start-suite``)
    Starts ``intent_interpreter``, ``model_server`` (with the session's initial model and ``--models-dir``)
    and ``grasp_planner`` (for a closed-loop session also ``mock_arm`` and ``assistance``, or for one recorded
    with the intent estimator ``intent_estimator``) as ``python -m``
    processes with the package's config files, in the session's
    namespace (:class:`~grasp_intent_ros.launch.suite.NodeSuite`; for a scene, one chain per object as
    ``suite --object`` starts them, each with its recorded initial model), with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
    and this process's ROS_DOMAIN_ID (else one derived from the process id); they are
    stopped by PID (SIGTERM, then SIGKILL) at the end. The planner warm-starts from its previous plan and
    keeps the last object pose and joint state, so exact answers need a suite whose history is the
    recording's: a fresh one.
Network
    ROS_AUTOMATIC_DISCOVERY_RANGE defaults to LOCALHOST when unset (always with ``--start-suite``).
Exit codes
    0 replayed (and, with --check, everything matched); 1 a check difference; 2 the bag cannot be used (e.g.
    topics that belong to no chain of a scene),
    the system did not come up, or a suite process died; 130 interrupted (SIGINT/SIGTERM; a started suite
    is stopped all the same).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from ..launch.objects import SceneObject
from ..launch.suite import NodeSuite, SuiteError, domain_id_from_environment, use_loopback_discovery
from ..mico.kinematics import MicoKinematics
from .bag.errors import BagError
from .bag.reader import topics_info
from .closed_loop import (
    ESTIMATOR_REMAPPING,
    ClosedLoopSession,
    Trace,
    compare_outcomes,
    describe,
    is_closed_loop,
    load_closed_loop,
    outcome,
)
from .compare import Difference
from .outputs import SessionError
from .replay_client import SUITE_SETTLE_S, SessionClient
from .replayers import ClosedLoopReplayer, Replayer, ReplayError, ReplayOptions, ReplayResult, SceneReplayer
from .scenes import PairedScene, detect_scene, load_paired_scene

__all__ = ['main']

def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=__doc__.split('\n\n')[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, help='session bag directory (rosbag2, MCAP)')
    pace = parser.add_mutually_exclusive_group()
    pace.add_argument('--rate', type=float, default=1.0, help='recorded pace multiplier (default 1)')
    pace.add_argument('--fast', action='store_true', help='send each input once the previous one was answered')
    parser.add_argument('--check', action='store_true', help='compare the live answers with the recorded ones')
    parser.add_argument('--start-suite', action='store_true',
                        help='start the three nodes (a closed-loop session: five, with the assistance and the mock '
                             'arm; one recorded with the intent estimator: four, with it) as processes (LOCALHOST, '
                             'this ROS_DOMAIN_ID) and stop them at the end')
    parser.add_argument('--timeout', type=float, default=10.0, metavar='S',
                        help='longest wait for one answer, s (default 10)')
    parser.add_argument('--startup-timeout', type=float, default=60.0, metavar='S',
                        help='longest wait for the live system to be ready, s (default 60)')
    parser.add_argument('--models-dir', type=Path, default=None, metavar='DIR',
                        help="with --start-suite: the model server's models_dir (default config/models)")
    parser.add_argument('--model-server', default='model_server', metavar='NAME',
                        help='model server node name, relative to the session namespace (default model_server)')
    parser.add_argument('--max-diffs', type=int, default=10, metavar='N',
                        help='differing messages printed, up to 2 fields each (default 10)')
    parser.add_argument('--max-failed-inputs', type=int, default=5, metavar='N',
                        help='stop after N inputs with differences; 0: never (default 5)')
    return parser


def _report(session: PairedScene, options: ReplayOptions, result: ReplayResult, max_diffs: int) -> int:
    name = session.path
    notes = [d for d in result.differences if not d.fatal]
    for note in notes[:max_diffs]:
        print(str(note))
    if not options.check:
        print(f'replay: {name}: {result.inputs_sent} inputs published in {result.replay_s:.2f} s '
              f'({"as fast as answered" if options.fast else f"recorded pace x {options.rate:g}"}); '
              f'{result.outputs_received} outputs received')
        return 0
    failures = result.failures
    scene = session.scene
    chains = '' if scene.one_chain else (f' to the chains {", ".join(c.name for c in session.chains)} of the scene '
                                         f'in {scene.namespace or "/"}')
    if not failures:
        print(f'replay --check OK: {name}: {result.inputs_sent} inputs{chains}, {session.n_outputs} recorded outputs '
              f'matched live (v, P, w, pose, joints, clarifications, rejections) in {result.replay_s:.2f} s '
              f'(system ready after {result.ready_s:.2f} s)')
        return 0
    failed_inputs = sorted({d.step for d in failures})
    first = failures[0]
    print(f'replay --check FAILED: {name}: {len(failures)} difference(s) in {len(failed_inputs)} of '
          f'{result.inputs_sent} inputs replayed{chains} ({len(session.inputs)} recorded)'
          f'{", stopped early" if result.stopped_early else ""}; first differing message: input '
          f'#{first.step}, {first.topic}')
    for line in _diff_lines(failures, max_diffs):
        print(f'  {line}')
    return 1


def scene_objects(session: PairedScene) -> tuple[SceneObject, ...]:
    """The objects ``suite --object`` starts for a scene's chains: each chain's name and its initial model.

    Raises
    ------
    SessionError
        A chain without a model document (its model is unknown).
    """
    lacking = [chain.namespace for chain in session.chains if chain.initial_model is None]
    if lacking:
        raise SessionError(f'no model/active of the chain(s) {", ".join(lacking)} in {session.path}: --start-suite '
                           'does not know their models')
    return tuple(SceneObject(chain.name, chain.initial_model.name) for chain in session.chains
                 if chain.initial_model is not None)


def _report_closed_loop(session: ClosedLoopSession, options: ReplayOptions, result: ReplayResult,
                        live: Trace) -> int:
    kin = MicoKinematics()
    recorded_outcome, live_outcome = outcome(session.trace, kin), outcome(live, kin)
    for note in result.differences:
        print(str(note))
    print(f'  recorded: {describe(recorded_outcome)}')
    print(f'  live:     {describe(live_outcome)}')
    stopped = '' if not result.timed_out else f'; the arm still moved {options.timeout_s:g} s after the last input'
    head = (f'{session.path}: closed loop, {result.inputs_sent} inputs at the recorded pace in {result.replay_s:.2f} s '
            f'(system ready after {result.ready_s:.2f} s){stopped}')
    if not options.check:
        print(f'replay: {head}')
        return 0
    problems = compare_outcomes(recorded_outcome, live_outcome, grasp=not session.estimated)
    if not problems:
        print(f'replay --check OK: {head}; ' + (
            'the live intent estimator ended on the recorded w (the last grasp not compared: module '
            'closed_loop)' if session.estimated else
            'the live loop planned the recorded last grasp and ended where the recorded one did'))
        return 0
    print(f'replay --check FAILED: {head}')
    for problem in problems:
        print(f'  {problem}')
    return 1


def _diff_lines(failures: Sequence[Difference], max_messages: int, fields_per_message: int = 2) -> list[str]:
    """One line per difference, for the first ``max_messages`` differing messages (input, topic).

    At most ``fields_per_message`` fields each; the last line of a message says how many more fields differ.
    """
    groups: dict[tuple[int, str], list[Difference]] = {}
    for diff in failures:
        groups.setdefault((diff.step, diff.topic), []).append(diff)
    lines = []
    for diffs in list(groups.values())[:max_messages]:
        shown = [str(d) for d in diffs[:fields_per_message]]
        if len(diffs) > fields_per_message:
            shown[-1] += f' (and {len(diffs) - fields_per_message} more field(s) of this message)'
        lines += shown
    if len(groups) > max_messages:
        lines.append(f'... and {len(groups) - max_messages} more differing message(s)')
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (see the module docstring)."""
    args = _parser().parse_args(argv)
    if not args.rate > 0.0 or not args.timeout > 0.0:
        _parser().error('--rate and --timeout must be > 0')
    if args.models_dir is not None and not args.start_suite:
        _parser().error('--models-dir needs --start-suite')
    try:
        scene = detect_scene(topics_info(args.bag))
        closed_loop = scene.one_chain and is_closed_loop(args.bag, namespace=scene.namespace)
        session: PairedScene | ClosedLoopSession = (load_closed_loop(args.bag) if closed_loop
                                                    else load_paired_scene(args.bag))
        objects = (scene_objects(session) if isinstance(session, PairedScene) and not scene.one_chain
                   and args.start_suite else ())
    except BagError as exc:
        print(f'replay: error: {exc}', file=sys.stderr)
        return 2
    if closed_loop and (args.fast or args.rate != 1.0):
        print(f'replay: error: {args.bag} is a closed-loop session (it holds operator twists): it is replayed at '
              'the recorded pace only, because the operator\'s twists answered the arm\'s motion at that pace; '
              'drop --fast and --rate', file=sys.stderr)
        return 2
    options = ReplayOptions(rate=args.rate, fast=args.fast, check=args.check, timeout_s=args.timeout,
                            startup_timeout_s=args.startup_timeout, max_failed_inputs=args.max_failed_inputs,
                            settle_s=SUITE_SETTLE_S if args.start_suite else 0.0)
    if args.start_suite or not os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE'):
        use_loopback_discovery()
    try:
        domain_id = domain_id_from_environment(unset=None if args.start_suite else 0)
    except SuiteError as exc:
        print(f'replay: error: {exc}', file=sys.stderr)
        return 2

    suite: NodeSuite | None = None
    context = Context()  # rclpy's SIGINT/SIGTERM handlers shut it down: exit code 130, suite stopped
    rclpy.init(context=context, domain_id=domain_id, args=[])
    executor = SingleThreadedExecutor(context=context)
    clients: list[SessionClient] = []
    code = 2
    estimated = isinstance(session, ClosedLoopSession) and session.estimated
    try:
        if args.start_suite:
            suite = NodeSuite(domain_id)
            if objects:
                suite.start_nodes(models_dir=args.models_dir, namespace=scene.namespace, objects=objects)
            else:
                model = (session.initial_model if isinstance(session, ClosedLoopSession)
                         else session.chains[0].initial_model)
                suite.start_nodes(model=model.name if model is not None else None, models_dir=args.models_dir,
                                  namespace=scene.namespace, shared_control=closed_loop and not estimated,
                                  extra=('intent_estimator',) if estimated else (),
                                  remappings={'intent_estimator': (ESTIMATOR_REMAPPING,)} if estimated else None)
        alive = suite.died if suite else lambda: ''
        if isinstance(session, ClosedLoopSession):
            client = SessionClient(model_server=args.model_server, context=context, closed_loop=closed_loop,
                                   estimated=estimated, namespace=session.namespace or '/')
            clients.append(client)
            executor.add_node(client)
            result = ClosedLoopReplayer(session, client, executor, options, alive=alive).run()
            code = _report_closed_loop(session, options, result, client.tracer.trace())
        else:
            chains = []
            for chain in session.chains:
                client = SessionClient(model_server=args.model_server, context=context,
                                       arm_namespace=chain.arm_namespace, namespace=chain.namespace or '/')
                clients.append(client)
                executor.add_node(client)
                chains.append(Replayer(chain, client, executor, options, alive=alive))
            result = SceneReplayer(session, chains, options).run()
            code = _report(session, options, result, args.max_diffs)
    except ReplayError as exc:
        print(f'replay: error: {exc}', file=sys.stderr)
    except (KeyboardInterrupt, ExternalShutdownException):
        code = 130
    finally:
        executor.shutdown()
        for client in clients:
            client.destroy_node()
        rclpy.try_shutdown(context=context)
        if suite is not None:
            problems = [f'{problem}; log in {suite.log_dir}' for problem in suite.stop(tail_lines=0)]
            for problem in problems:
                print(f'replay: warning: {problem}', file=sys.stderr)
            if code in (0, 1) and not problems:  # the logs tell nothing about a difference in the answers
                suite.remove_logs()
            else:
                print(f'replay: the suite\'s logs are in {suite.log_dir}', file=sys.stderr)
    return code


if __name__ == '__main__':
    sys.exit(main())
