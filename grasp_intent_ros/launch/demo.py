"""The README's main command: the suite as separate processes, the paper's intent cases, then the closed loop.

Run: ``python -m grasp_intent_ros demo [--models-dir DIR] [--timeout S]`` (``scripts/demo.sh`` does this)

1. Refuses a domain on which other nodes (:func:`other_nodes`: not hidden ones, such as the ``ros2`` CLI's
   daemon) show up within :data:`DOMAIN_CHECK` seconds, then starts ``intent_interpreter``,
   ``model_server``, ``grasp_planner``, ``mock_arm``, ``assistance`` and ``scripted_operator`` as
   ``python -m`` processes (with their ``config/<node>.yaml`` parameter files; the operator held back with
   the closed loop's parameters, :func:`~grasp_intent_ros.launch.demo_loop.operator_args`) and waits, up to
   ``--timeout`` seconds, until each is up: the interpreter subscribes to ``intent/w`` and reports on
   ``/diagnostics``, the model server publishes ``model/active`` and offers its parameter services, the
   planner reports the model it received, the mock arm reports and publishes ``joint_states``, the
   assistance reports and offers ``assistance/enable``, the scripted operator reports and offers its
   parameter services. A node that does not come up is named, with the end of its stderr.
2. Sends the cases of :data:`grasp_intent_ros.cli.paper_tables.CASES` through the running chain with
   :class:`~grasp_intent_ros.cli.send_intent.IntentSender` (an answer is the first plan stamped after the send)
   and prints each with :func:`~grasp_intent_ros.cli.send_intent.format_grasp`: v, P, reconstructed w,
   end-effector pose, MICO joint targets. Before a case on another model it sets the model server's
   ``model`` parameter through its parameter service, then waits until the planner reports the new
   model document (name and version) on ``/diagnostics``; the answer must carry that model's zones.
   A last case with a low intent (0.1, 0.1, 0.1) shows the interpreter's clarification request.
   Below each grasp it prints which tasks the grasp serves by the object's rules (Table I,
   :data:`grasp_intent_ros.objects.demos.OBJECTS`, the judge the planner never sees,
   :mod:`~grasp_intent_ros.objects.judge`): the features are recovered from the published end-effector
   pose, the finger targets and the planner's object pose (its ``object_position`` and
   ``object_orientation`` parameters, read once through its parameter service).
3. The closed loop (:mod:`~grasp_intent_ros.launch.demo_loop`): on ``cup_7zone`` the scripted operator, who
   wants usage and transfer and holds the ambiguous w (0.9, 0.9, 0.1), drives the mock MICO under the
   assistance for one episode: the grasp shown and the tasks it serves, the robot's share (alpha), the time to
   grasp, where the hand ended after the grasp command's execute and close, and the judge's verdict there with
   the closures the fingers executed; then one episode of the same operator with the help off. Each stage waits
   up to ``--timeout`` seconds; one that does not complete is named with what is missing.
4. Stops every node with SIGINT (SIGKILL after a deadline) and checks each exited with code 0 and
   printed no traceback.

Network: :func:`main` sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and drops ``ROS_STATIC_PEERS`` in
its own environment before it initialises rclpy, and the nodes get the same
(:class:`~grasp_intent_ros.launch.suite.NodeSuite`), so no DDS traffic leaves the loopback interface. The
domain id is ``ROS_DOMAIN_ID`` when set, else one derived from the process id
(:func:`~grasp_intent_ros.launch.suite.domain_id_from_environment`).

Exit codes: 0 every case answered, the closed loop's two episodes done and every node exited 0; 1 a node did
not come up, a case was not answered as expected, a stage of the closed loop did not complete in time, or a
node did not shut down cleanly; 2 bad arguments; 130 interrupted (SIGINT or
SIGTERM; the nodes are stopped first).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from types import FrameType

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

from ..cli.paper_tables import CASES
from ..cli.send_intent import GraspAnswer, IntentSender, NoGrasp, format_grasp
from ..errors import GraspIntentError
from ..method.features import FINGERS
from ..method.model import GraspModel
from ..mico.frames import pose_to_matrix
from ..objects.judge import judge
from ..ros.conversions import model_from_msg
from ..ros.qos import input_qos, latched_qos
from ..wire.diagnostics import KEY_MODEL
from ..wire.model_document import ModelDocument
from .demo_loop import LOOP_MODEL, LoopError, LoopObserver, operator_args, run_closed_loop
from .suite import NodeSuite, SuiteError, domain_id_from_environment, use_loopback_discovery

__all__ = ['CLARIFICATION_CASE', 'DemoError', 'other_nodes', 'main']

CLARIFICATION_CASE = ('Clarification: low intent', (0.1, 0.1, 0.1))
"""Sent last: P(no task) = 0.729 >= the default threshold 0.5, so the interpreter asks for clarification."""

DOMAIN_CHECK = 1.5
"""Seconds the demo looks for other nodes on its domain before it starts its own."""

_PACKAGE_PARENT = Path(__file__).resolve().parents[2]


class DemoError(RuntimeError):
    """The chain did not behave as the demo expects; the message says which node and why."""


class _Interrupted(Exception):
    """SIGTERM (or SIGINT) arrived: stop the nodes and exit 130."""


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise _Interrupted(signal.Signals(signum).name)


def other_nodes(names_and_namespaces: Sequence[tuple[str, str]], own: Collection[str]) -> list[str]:
    """The nodes that make a domain in use for the demo: ``namespace/name``, sorted.

    Its own nodes (``own``) and hidden nodes (a name that starts with an underscore, by ROS convention a
    tool's, e.g. the ``ros2`` CLI's daemon ``_ros2cli_daemon_<domain>_<id>``, which outlives the command that
    started it) are left out: neither is a chain the demo could talk to by mistake.
    """
    return sorted(f'{ns.rstrip("/")}/{name}' for name, ns in names_and_namespaces
                  if name not in own and not name.startswith('_'))


def served_tasks(model: GraspModel, base_T_obj: np.ndarray, answer: GraspAnswer) -> str:
    """Which tasks the answered grasp serves by its object's rules, e.g. 'usage, transfer (UT)', or why unknown.

    :func:`~grasp_intent_ros.objects.judge.judge` of the answer's end-effector pose (in the base frame),
    ``base_T_obj`` and the finger targets (the last three joint targets).
    """
    p, o = answer.pose.pose.position, answer.pose.pose.orientation
    base_T_ee = pose_to_matrix((p.x, p.y, p.z), (o.x, o.y, o.z, o.w))
    fingers = np.asarray(answer.joints.position, dtype=np.float64)[-(FINGERS.stop - FINGERS.start):]
    return judge(model, base_T_obj, base_T_ee, fingers).text


# ------------------------------------------------------------------------------------------ the ROS side
class _ChainObserver(Node):
    """What the demo watches besides the answers.

    model/active, /diagnostics, the intent topics' graph, clarification requests, and the model server's
    parameter client.
    """

    def __init__(self) -> None:
        super().__init__('grasp_intent_demo')
        self.models: list[ModelDocument] = []
        self.clarifications: list[String] = []
        self.statuses: dict[str, dict[str, str]] = {}
        self.parameters = AsyncParameterClient(self, 'model_server')
        self.planner_parameters = AsyncParameterClient(self, 'grasp_planner')
        self.create_subscription(String, 'model/active', self._on_model, latched_qos())
        self.create_subscription(String, 'intent/clarification', self.clarifications.append, input_qos())
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 50)

    def _on_model(self, msg: String) -> None:
        try:
            self.models.append(model_from_msg(msg))
        except GraspIntentError as exc:
            self.get_logger().warning(f'ignored a malformed model/active: {exc}')

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.statuses[status.name] = {kv.key: kv.value for kv in status.values}

    def status(self, suffix: str) -> dict[str, str] | None:
        """Values of the last status whose name ends with ``suffix`` (e.g. 'grasp_planner: planning')."""
        return next((values for name, values in self.statuses.items() if name.endswith(suffix)), None)


class _Demo:
    """The running chain seen from the demo: node processes, the sender, the observer."""

    def __init__(self, suite: NodeSuite, timeout: float) -> None:
        self.suite = suite
        self.timeout = timeout
        self.sender = IntentSender('grasp_intent_demo_sender')
        self.observer = _ChainObserver()
        self.loop = LoopObserver(self._spin_until)
        self.executor = SingleThreadedExecutor()
        for node in (self.sender, self.observer, self.loop):
            self.executor.add_node(node)
        self.base_T_obj: np.ndarray | None = None

    def close(self) -> None:
        self.executor.shutdown()
        for node in (self.sender, self.observer, self.loop):
            node.destroy_node()

    def _check_alive(self) -> None:
        if problem := self.suite.died():
            raise DemoError(problem)

    def _spin_until(self, predicate: Callable[[], object], timeout: float | None = None) -> bool:
        """Spin until ``predicate()`` holds (True) or ``timeout`` (default ``self.timeout``) s pass (False).

        DemoError as soon as a node process has exited.
        """
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not predicate():
            self._check_alive()
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                return bool(predicate())
            self.executor.spin_once(timeout_sec=min(remaining, 0.05))
        return True

    def _active(self) -> ModelDocument | None:
        return self.observer.models[-1] if self.observer.models else None

    def _planner_model(self) -> str:
        status = self.observer.status('grasp_planner: planning')
        return '' if status is None else status.get(KEY_MODEL, '')

    def check_domain_unused(self, domain_id: int) -> None:
        """DemoError if other nodes (:func:`other_nodes`) show up on the domain within DOMAIN_CHECK seconds.

        The demo would talk to them (another run's model_server answers set_parameters just as well). Evidence, not
        proof: discovery on loopback normally takes well under a second.
        """
        own = {node.get_name() for node in (self.sender, self.observer, self.loop)}

        def others() -> list[str]:
            return other_nodes(self.observer.get_node_names_and_namespaces(), own)

        if self._spin_until(others, DOMAIN_CHECK):
            raise DemoError(f'ROS_DOMAIN_ID={domain_id} is in use by {", ".join(others())}; '
                            f'set ROS_DOMAIN_ID to a free domain (0..101)')

    def wait_until_up(self) -> None:
        """Wait until every node is up; DemoError naming those that are not, with their stderr."""
        obs = self.observer
        missing: dict[str, Callable[[], str]] = {
            'intent_interpreter': lambda: (
                'no /diagnostics from it' if obs.status('intent_interpreter: intent') is None else
                'nobody subscribes to intent/w' if obs.count_subscribers('intent/w') == 0 else ''),
            'model_server': lambda: (
                'no model/active received' if self._active() is None else
                'its parameter services are not ready' if not obs.parameters.services_are_ready() else ''),
            'grasp_planner': lambda: (
                'no /diagnostics from it' if obs.status('grasp_planner: planning') is None else
                'it reports no model received' if not self._planner_model() else ''),
            'mock_arm': lambda: (
                'no /diagnostics from it' if obs.status('mock_arm: arm') is None else
                'no joint_states from it' if self.loop.hand() is None else ''),
            'assistance': lambda: (
                'no /diagnostics from it' if obs.status('assistance: assistance') is None else
                'its enable service is not ready' if not self.loop.enable_client.service_is_ready() else ''),
            'scripted_operator': lambda: (
                'no /diagnostics from it' if self.loop.operator_status() is None else
                'its parameter services are not ready' if not self.loop.operator_parameters.services_are_ready()
                else ''),
        }
        try:
            down = self.suite.wait_ready(lambda: {name: why for name, check in missing.items() if (why := check())},
                                         lambda seconds: self.executor.spin_once(timeout_sec=seconds), self.timeout)
        except SuiteError as exc:
            raise DemoError(str(exc)) from None
        if down:
            raise DemoError('\n'.join(f'{name} did not come up within {self.timeout:g} s ({why}); its stderr ends '
                                      f'with:\n{self.suite.node(name).stderr_tail()}' for name, why in down.items()))

    def object_pose(self) -> np.ndarray:
        """base_T_obj, from the planner's object_position and object_orientation parameters."""
        client = self.observer.planner_parameters
        if not self._spin_until(client.services_are_ready):
            raise DemoError(f'grasp_planner offered no parameter services within {self.timeout:g} s')
        future = client.get_parameters(['object_position', 'object_orientation'])
        if not self._spin_until(future.done):
            raise DemoError(f'grasp_planner did not answer get_parameters within {self.timeout:g} s')
        position, orientation = (list(value.double_array_value) for value in future.result().values)
        return pose_to_matrix(position, orientation)

    def switch_model(self, name: str) -> ModelDocument:
        """Make ``name`` the active model (parameter service) and wait until the planner has it."""
        active = self._active()
        assert active is not None
        if active.name != name:
            request = [Parameter('model', Parameter.Type.STRING, name)]
            future = self.observer.parameters.set_parameters(request)
            if not self._spin_until(future.done):
                raise DemoError(f'model_server did not answer set_parameters(model={name!r}) within '
                                f'{self.timeout:g} s')
            result = future.result().results[0]
            if not result.successful:
                raise DemoError(f'model_server rejected model {name!r}: {result.reason}')
            if not self._spin_until(lambda: (doc := self._active()) is not None and doc.name == name):
                raise DemoError(f'model_server accepted model {name!r} but published no such model/active')
            active = self._active()
            assert active is not None
        expected = f'{active.name} (version {active.version},'
        if not self._spin_until(lambda: self._planner_model().startswith(expected)):
            raise DemoError(f'grasp_planner did not report model {active.name!r} version {active.version} '
                            f'within {self.timeout:g} s (it reports {self._planner_model()!r}); its stderr '
                            f'ends with:\n{self.suite.node("grasp_planner").stderr_tail()}')
        return active

    def run_case(self, title: str, w: Sequence[float], model: str | None) -> None:
        """Send w (on ``model``, if given) and print the answer; DemoError if it is not the expected one."""
        doc = self.switch_model(model) if model is not None else None
        where = (f'model {doc.name} ({len(doc.model.zones)} zones)' if doc is not None
                 else 'no model involved (the interpreter answers)')
        print(f'  {where}, w = {tuple(w)}')
        n_clarifications = len(self.observer.clarifications)
        start = time.monotonic()
        try:
            answer = self.sender.send(w, self.executor, timeout=self.timeout)
        except NoGrasp as exc:
            asked = lambda: len(self.observer.clarifications) > n_clarifications  # noqa: E731
            if doc is None and self._spin_until(asked, timeout=2.0):  # the sender may have heard it first
                print(f'    no grasp: the intent interpreter asks for clarification: '
                      f'{self.observer.clarifications[-1].data}\n')
                return
            self._check_alive()
            raise DemoError(f'case {title!r}, w = {tuple(w)}: {exc}') from None
        if doc is None:
            raise DemoError(f'case {title!r}: expected a clarification request, got a grasp:\n'
                            f'{format_grasp(answer)}')
        if answer.posterior.zone_labels != doc.model.zone_labels:
            raise DemoError(f'case {title!r}: the grasp has zones {",".join(answer.posterior.zone_labels)}, '
                            f'model {doc.name} has {",".join(doc.model.zone_labels)}')
        print('    ' + format_grasp(answer).replace('\n', '\n    '))
        if self.base_T_obj is None:
            self.base_T_obj = self.object_pose()
        print(f'    {"serves (rules)":<18}{served_tasks(doc.model, self.base_T_obj, answer)}')
        print(f'    answered in {time.monotonic() - start:.2f} s\n')


def _run(models_dir: Path | None, timeout: float) -> int:
    domain_id = domain_id_from_environment()
    requested_range = use_loopback_discovery()  # before rclpy.init: this process's participant too
    if requested_range not in (None, '', 'LOCALHOST'):
        print(f'demo: ROS_AUTOMATIC_DISCOVERY_RANGE={requested_range} overridden with LOCALHOST',
              file=sys.stderr)
    pythonpath = os.pathsep.join(p for p in (str(_PACKAGE_PARENT), os.environ.get('PYTHONPATH')) if p)
    start = time.monotonic()
    code = 1
    suite = NodeSuite(domain_id, env={'PYTHONPATH': pythonpath})
    demo: _Demo | None = None
    try:
        rclpy.init(domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        demo = _Demo(suite, timeout)
        demo.check_domain_unused(domain_id)
        suite.start_nodes(models_dir=models_dir, shared_control=True)
        suite.start('scripted_operator', *suite.node_args('scripted_operator'), *operator_args())
        print(f'ROS_DOMAIN_ID={domain_id}, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; started '
              + ', '.join(f'{p.module} (pid {p.pid})' for p in suite.processes), flush=True)
        demo.wait_until_up()
        print(f'all nodes up after {time.monotonic() - start:.1f} s\n', flush=True)
        for title, w, models in CASES:
            print(title)
            for name in models:
                demo.run_case(title, w, name)
        print(CLARIFICATION_CASE[0])
        demo.run_case(*CLARIFICATION_CASE, None)
        print('Closed loop: a scripted operator reaches with an ambiguous intent; the assistance helps (mock MICO)')
        doc = demo.switch_model(LOOP_MODEL)
        run_closed_loop(demo.loop, doc, demo.object_pose() if demo.base_T_obj is None else demo.base_T_obj,
                        timeout)
        code = 0
    except (DemoError, LoopError) as exc:
        print(f'demo: {exc}', file=sys.stderr)
    except (_Interrupted, KeyboardInterrupt):
        print('demo: interrupted, stopping the nodes', file=sys.stderr)
        code = 130
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the nodes are stopped once, completely
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if demo is not None:
            demo.close()
        rclpy.try_shutdown()
        problems = suite.stop(signal.SIGINT)
        suite.remove_logs()
    for problem in problems:  # after a failure, one line each: the failure was reported with its stderr
        print(f'demo: {problem if code == 0 else problem.splitlines()[0]}', file=sys.stderr)
    if problems and code == 0:
        code = 1
    stopped = f'nodes stopped ({"cleanly" if not problems else "with problems"}); ' if suite.processes else ''
    print(f'{stopped}demo {"done" if code == 0 else "failed"} in {time.monotonic() - start:.1f} s', flush=True)
    return code


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--models-dir', type=Path, default=None,
                        help="directory of the trained models (default: the package's config/models)")
    parser.add_argument('--timeout', type=float, default=30.0,
                        help='seconds to wait for the nodes to come up, for each answer and for each stage of '
                             'the closed loop (default 30)')
    args = parser.parse_args(argv)
    if not args.timeout > 0.0:
        parser.error('--timeout must be positive')
    if args.models_dir is not None and not args.models_dir.is_dir():
        parser.error(f'--models-dir {str(args.models_dir)!r} is not a directory')
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        return _run(None if args.models_dir is None else args.models_dir.resolve(), args.timeout)
    except (DemoError, SuiteError) as exc:
        print(f'demo: {exc}', file=sys.stderr)
        return 1
    except _Interrupted:
        return 130


if __name__ == '__main__':
    sys.exit(main())
