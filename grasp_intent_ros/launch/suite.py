"""The node suite as processes on one loopback-only ROS domain.

``python -m grasp_intent_ros.nodes.<module> --ros-args ...`` started, watched and stopped by PID.

One :class:`NodeSuite` serves the suite command (:mod:`grasp_intent_ros.launch.suite_command`), the
demo, the replay (``--start-suite``), the fixture recording (:mod:`grasp_intent_ros.sessions.fixtures`)
and the system tests.

- :func:`domain_id_from_environment`: the run's ROS domain id, chosen and validated once
  (``ROS_DOMAIN_ID`` if set, 0..101, else one derived from the process id).
- :func:`use_loopback_discovery`: called by a tool's ``main`` before it initialises rclpy (never at
  import), so its own participant stays on the loopback interface too (and uses the suite's Fast DDS
  discovery timing, so that it finds a restarted node as soon as the nodes do).
- :func:`node_environment`: the environment every node process gets: loopback-only discovery
  (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, no ``ROS_STATIC_PEERS``), the run's ``ROS_DOMAIN_ID``,
  unbuffered output, so the log of a SIGKILLed node is complete, and the Fast DDS discovery timing of
  ``config/fastdds_loopback.xml`` (:data:`FASTDDS_PROFILE`; it also puts user data on UDP 127.0.0.1).
- :class:`~grasp_intent_ros.launch.process.NodeProcess` (:mod:`.process`): one node process, its logs and its stop.
- Nodes are stopped one at a time, the last started first (:meth:`NodeSuite.stop`). Stopped together,
  two nodes can end in a livelock of the middleware: rmw_fastrtps destroys a process's DDS participant with
  its last node, first calling ``DomainParticipant::set_listener(nullptr)``, which in Fast DDS 2.14.5 as
  built in the Jazzy wheels spins forever, holding the listener's mutex and the GIL, when a discovery
  callback is running at that instant, i.e. when a peer's endpoints are coming or going: the peer's own
  shutdown (docs/nodes.md, "Shutdown"). A node stopped while its peers are steady meets no such callback.
- :class:`NodeSuite`: the processes of one run: start (one node, or the three suite nodes with their
  ``config/<node>.yaml``, or one such chain per object of the scene (:mod:`grasp_intent_ros.launch.objects`),
  and :data:`OPTIONAL_NODES` on request), wait until ready, notice a death, stop them all.

Never imports rclpy.
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
import time
from collections.abc import Callable, Collection, Mapping, MutableMapping, Sequence
from pathlib import Path
from types import TracebackType

from ..errors import GraspIntentError
from ..resources import config_dir
from ..wire.topics import ARM_TRAJECTORY_COMMAND, ARM_TWIST_COMMAND, ASSISTANCE_TWIST, GRASP_TRAJECTORY
from .objects import SceneObject, chain_remappings, operator_object, scene_node_args
from .process import STOP_TIMEOUT, NodeProcess

__all__ = ['SUITE_NODES', 'SHARED_CONTROL_NODES', 'OPTIONAL_NODES', 'REMAPPINGS', 'CHAIN_REMAPPINGS', 'MAX_DOMAIN_ID',
           'TEST_DOMAIN_IDS', 'RUN_DOMAIN_IDS', 'FASTDDS_PROFILE', 'SuiteError', 'domain_id_from_environment',
           'use_loopback_discovery', 'node_environment', 'optional_nodes', 'NodeSuite']

SUITE_NODES = ('intent_interpreter', 'model_server', 'grasp_planner')
"""The node modules of the suite, in start order."""
SHARED_CONTROL_NODES = ('mock_arm', 'assistance')
"""The shared-control loop's nodes: the mock MICO and the assistance (``suite --shared-control``)."""
OPTIONAL_NODES: tuple[str, ...] = (*SHARED_CONTROL_NODES, 'intent_estimator', 'scripted_operator', 'viewer')
"""Node modules started only on request, after :data:`SUITE_NODES`: ``suite --with NAME``,
:meth:`NodeSuite.start_nodes`'s ``extra``. Each is ``python -m grasp_intent_ros.nodes.<name>`` with its
``config/<name>.yaml`` when there is one, like the suite's own nodes."""
REMAPPINGS: Mapping[str, tuple[str, ...]] = {'mock_arm': (f'{ARM_TWIST_COMMAND}:={ASSISTANCE_TWIST}',)}
"""Each node's remappings in the suite: the mock arm executes the blended twist."""
CHAIN_REMAPPINGS: Mapping[str, tuple[str, ...]] = {'mock_arm': (f'{ARM_TRAJECTORY_COMMAND}:={GRASP_TRAJECTORY}',)}
"""Each node's remappings in a suite of one chain, before :data:`REMAPPINGS`: the mock arm executes the planner's
trajectory. Over a scene's chains it reads each ``<object>/grasp/trajectory`` itself (:mod:`..nodes.arm_plans`)."""
MAX_DOMAIN_ID = 101
"""Largest ROS domain id usable with LOCALHOST discovery."""
TEST_DOMAIN_IDS = range(1, MAX_DOMAIN_ID - 10)
"""The domain ids the tests claim, one per test (1..90); runs that choose their own use the rest."""
RUN_DOMAIN_IDS = range(MAX_DOMAIN_ID - 10, MAX_DOMAIN_ID + 1)
"""The domain ids a run without ``ROS_DOMAIN_ID`` picks from (91..101): never one a test may hold."""
FASTDDS_PROFILE = 'fastdds_loopback.xml'
"""Fast DDS profile in the config directory: user data over UDP on 127.0.0.1, announcements every 0.1 s, and
sample payloads held only while a sample is (so a peer's huge message does not leave its size in memory).

So a node restarted after a SIGKILL serves again sooner: its peers reach it at once (over shared memory they
kept writing into the killed process's port for up to a few seconds), and it learns of a peer from the peer's
announcement within 0.1 s, not 3 s. Which interfaces discovery uses still comes from
ROS_AUTOMATIC_DISCOVERY_RANGE (the file's comment says more).
"""


class SuiteError(RuntimeError):
    """The suite cannot run: a bad ROS_DOMAIN_ID, or a node process exited while it was waited for."""


def domain_id_from_environment(environ: Mapping[str, str] | None = None, *, unset: int | None = None) -> int:
    """The run's ROS domain id: ``ROS_DOMAIN_ID`` if set, else ``unset``, else one of :data:`RUN_DOMAIN_IDS`.

    The last is chosen by the process id, so two runs may share one (set ``ROS_DOMAIN_ID`` to be sure), but
    a run never lands on a domain a test holds.

    A run that starts its own nodes keeps off other runs' domains; one that joins running nodes passes
    ``unset=0``, ROS's own default.

    Raises
    ------
    SuiteError
        If ``ROS_DOMAIN_ID`` is set but not an integer in 0..:data:`MAX_DOMAIN_ID`.
    """
    value = (os.environ if environ is None else environ).get('ROS_DOMAIN_ID', '').strip()
    if not value:
        return RUN_DOMAIN_IDS[os.getpid() % len(RUN_DOMAIN_IDS)] if unset is None else unset
    if not value.isdigit() or int(value) > MAX_DOMAIN_ID:
        raise SuiteError(f'ROS_DOMAIN_ID must be an integer in 0..{MAX_DOMAIN_ID}, got {value!r}')
    return int(value)


def use_loopback_discovery(environ: MutableMapping[str, str] | None = None) -> str | None:
    """Set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and drop ``ROS_STATIC_PEERS``; the range replaced.

    In ``environ`` (default ``os.environ``), before this process initialises rclpy. Also sets the suite's
    Fast DDS profile (:data:`FASTDDS_PROFILE`) unless FASTRTPS_DEFAULT_PROFILES_FILE is set, and with it
    RMW_FASTRTPS_USE_QOS_FROM_XML=1, without which rmw_fastrtps ignores the profile's history memory policy
    (the profile's comment says why it matters). Returns the range it replaced (None if unset).
    """
    env = os.environ if environ is None else environ
    previous = env.get('ROS_AUTOMATIC_DISCOVERY_RANGE')
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_STATIC_PEERS', None)
    if 'FASTRTPS_DEFAULT_PROFILES_FILE' in env:
        return previous
    try:
        profile = config_dir() / FASTDDS_PROFILE
    except FileNotFoundError:
        return previous
    if profile.is_file():
        env['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(profile)
        env['RMW_FASTRTPS_USE_QOS_FROM_XML'] = '1'
    return previous


def node_environment(domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment of a node process on ``domain_id``.

    Parameters
    ----------
    domain_id
        ROS_DOMAIN_ID (0..101 for LOCALHOST discovery).
    base
        Environment to start from (default ``os.environ``); not modified.

    Returns
    -------
        ``base`` with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ROS_DOMAIN_ID, PYTHONUNBUFFERED=1 and
        RCUTILS_LOGGING_BUFFERED_STREAM=0 set and ROS_STATIC_PEERS removed; FASTRTPS_DEFAULT_PROFILES_FILE
        is the config directory's :data:`FASTDDS_PROFILE` (and RMW_FASTRTPS_USE_QOS_FROM_XML=1) unless
        ``base`` sets it (or there is none).
    """
    env = {**(os.environ if base is None else base), 'ROS_DOMAIN_ID': str(domain_id), 'PYTHONUNBUFFERED': '1',
           'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}
    use_loopback_discovery(env)
    return env


def optional_nodes(names: Sequence[str]) -> tuple[str, ...]:
    """``names``, each checked against :data:`OPTIONAL_NODES`.

    Raises
    ------
    SuiteError
        Naming the unknown ones and the optional nodes there are.
    """
    if unknown := [name for name in names if name not in OPTIONAL_NODES]:
        raise SuiteError(f'no optional node {", ".join(unknown)}; there are: {", ".join(OPTIONAL_NODES) or "none"}')
    return tuple(names)


class NodeSuite:
    """The node processes of one run, all on ``domain_id`` with loopback-only discovery.

    Parameters
    ----------
    domain_id : int
        ROS_DOMAIN_ID of every process (0..:data:`MAX_DOMAIN_ID`).
    log_dir : path, optional
        Where each process's stdout/stderr go; default a new temporary directory
        (:meth:`remove_logs` deletes it).
    cwd : path, optional
        Working directory of the processes (default this process's).
    numbered_logs : bool
        Prefix log file names with the start order (``00_``, ``01_``, ...), for a run that starts one
        module several times.
    env : mapping, optional
        Extra environment variables of the processes.

    Raises
    ------
    SuiteError
        For a domain id outside 0..:data:`MAX_DOMAIN_ID`.
    """

    def __init__(self, domain_id: int, *, log_dir: str | os.PathLike[str] | None = None,
                 cwd: str | os.PathLike[str] | None = None, numbered_logs: bool = False,
                 env: Mapping[str, str] | None = None) -> None:
        if not 0 <= domain_id <= MAX_DOMAIN_ID:
            raise SuiteError(f'ROS domain id must be in 0..{MAX_DOMAIN_ID}, got {domain_id}')
        self.domain_id = domain_id
        self._own_log_dir = log_dir is None
        self.log_dir = Path(log_dir) if log_dir is not None else Path(tempfile.mkdtemp(prefix='grasp_intent_ros_'))
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._cwd = None if cwd is None else Path(cwd)
        self._numbered = numbered_logs
        self.env = {**node_environment(domain_id), **(env or {})}
        self.processes: list[NodeProcess] = []

    def start(self, module: str, *ros_args: str, name: str | None = None) -> NodeProcess:
        """Start ``python -m grasp_intent_ros.nodes.<module> --ros-args <ros_args>``, named ``name`` (or ``module``)."""
        prefix = f'{len(self.processes):02d}_' if self._numbered else ''
        proc = NodeProcess.start(module, ros_args, env=self.env, log_dir=self.log_dir, prefix=prefix,
                                 cwd=self._cwd, name=name)
        self.processes.append(proc)
        return proc

    def start_nodes(self, *, namespace: str = '', model: str | None = None,
                    models_dir: str | os.PathLike[str] | None = None,
                    params_files: Sequence[str | os.PathLike[str]] = (), extra: Sequence[str] = (),
                    shared_control: bool = False, remappings: Mapping[str, Sequence[str]] | None = None,
                    objects: Sequence[SceneObject] = (), operator: str = '') -> None:
        """Start :data:`SUITE_NODES` (once, or once per object), then ``extra``, each with :meth:`node_args`.

        Parameters
        ----------
        namespace : str
            '' or e.g. '/robot1' (``-r __ns:=``).
        model, models_dir : optional
            The model server's initial ``model`` and its ``models_dir`` (default: its config file's).
        objects, operator : sequence of SceneObject, str
            One chain of :data:`SUITE_NODES` per object instead, each process named ``<object>/<module>``, then no
            ``model``; the optional nodes serve the scene, the scripted operator reaching for ``operator``.
        params_files : sequence of paths
            ROS parameters files given to every node after its own ``config/<node>.yaml``; the node-name
            keys in a file pick what each node reads, and a later file wins.
        extra : sequence of str
            Names from :data:`OPTIONAL_NODES`, started after the suite's own nodes.
        shared_control : bool
            Also start :data:`SHARED_CONTROL_NODES` (the mock arm and the assistance), before ``extra``.
        remappings : mapping module -> remappings ('from:=to'), optional
            Given to that node after :data:`REMAPPINGS` (e.g. the replay of an estimated session feeds the
            estimator the recorded grasps).

        Raises
        ------
        SuiteError
            For a name in ``extra`` that is not in :data:`OPTIONAL_NODES`, before anything is started.
        GraspIntentError
            For ``objects`` with ``model``, or an ``operator`` that is none of them, before anything is started.
        OSError
            If a process cannot be started; those already started stay in :attr:`processes`.
        """
        wanted = optional_nodes(tuple(dict.fromkeys((*(SHARED_CONTROL_NODES if shared_control else ()), *extra))))
        if objects:
            operator_object(objects, operator)
            if model is not None:
                raise GraspIntentError('objects name their own models: give no model')
        starts = [(module, obj.namespace(namespace), obj.model, obj.process_name(module), chain_remappings(namespace),
                   ()) for obj in objects for module in SUITE_NODES] + [  # then the nodes over every chain
                      (module, namespace, None, None, (), objects) for module in wanted] if objects \
            else [(module, namespace, model, None, (), ()) for module in (*SUITE_NODES, *wanted)]
        for module, node_ns, node_model, name, own, scene in starts:
            more = [arg for remapping in (*own, *(remappings or {}).get(module, ())) for arg in ('-r', remapping)]
            self.start(module, *self.node_args(module, namespace=node_ns, model=node_model, models_dir=models_dir,
                                               params_files=params_files, objects=scene, operator=operator,
                                               estimated='intent_estimator' in wanted), *more, name=name)

    @staticmethod
    def node_args(module: str, *, namespace: str = '', model: str | None = None,
                  models_dir: str | os.PathLike[str] | None = None,
                  params_files: Sequence[str | os.PathLike[str]] = (), objects: Sequence[SceneObject] = (),
                  operator: str = '', estimated: bool = False) -> list[str]:
        """The ``--ros-args`` of a suite node (as :meth:`start_nodes` gives them), e.g. to restart it.

        With ``objects``, an optional node's over that scene: no :data:`CHAIN_REMAPPINGS`, and last
        :func:`~grasp_intent_ros.launch.objects.scene_node_args` (raising its GraspIntentError). The scripted
        operator with ``estimated`` (the intent estimator runs: it gives w, every object's in a scene) holds no w
        (``intent: none``), so that no chain gets w from two sources.
        """
        try:
            config: Path | None = config_dir()
        except FileNotFoundError:
            config = None
        ros_args: list[str] = []
        if config is not None and (config / f'{module}.yaml').is_file():
            ros_args += ['--params-file', str(config / f'{module}.yaml')]
        for path in params_files:
            ros_args += ['--params-file', str(Path(path).resolve())]
        if namespace:
            ros_args += ['-r', f'__ns:={namespace}']
        for remapping in (*(() if objects else CHAIN_REMAPPINGS.get(module, ())), *REMAPPINGS.get(module, ())):
            ros_args += ['-r', remapping]
        if module == 'model_server':
            if model is not None:
                ros_args += ['-p', f'model:={model}']
            if models_dir is not None:
                ros_args += ['-p', f'models_dir:={Path(models_dir).resolve()}']
        if objects:
            ros_args += scene_node_args(module, objects, operator=operator)
        if module == 'scripted_operator' and estimated:
            ros_args += ['-p', 'intent:=none']
        return ros_args

    def node(self, module: str) -> NodeProcess:
        """The last process started named ``module`` (``<object>/<module>`` in a chain). KeyError if none."""
        for proc in reversed(self.processes):
            if proc.module == module:
                return proc
        raise KeyError(module)

    def died(self) -> str:
        """'' while every process runs; else which one exited, with its code and the end of its stderr."""
        for proc in self.processes:
            code = proc.poll()
            if code is not None:
                return f'{proc.module} (pid {proc.pid}) exited with code {code}; its stderr ends with:\n' \
                       f'{proc.stderr_tail()}'
        return ''

    def wait_ready(self, missing: Callable[[], Collection[str]], spin: Callable[[float], object],
                   timeout: float) -> Collection[str]:
        """Call ``spin(seconds)`` until ``missing()`` is empty or ``timeout`` seconds pass.

        Returns
        -------
        What ``missing()`` last returned: empty when the suite is ready.

        Raises
        ------
        SuiteError
            As soon as a process has exited (:meth:`died`).
        """
        deadline = time.monotonic() + timeout
        while lacking := missing():
            if problem := self.died():
                raise SuiteError(problem)
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                return lacking
            spin(min(remaining, 0.05))
        return lacking

    def stop(self, sig: signal.Signals = signal.SIGTERM, *, timeout: float = STOP_TIMEOUT, tail_lines: int = 15,
             include_exited: bool = True) -> list[str]:
        """Stop every process still running, one at a time, the last started first: ``sig`` by PID, then wait.

        Each gets ``timeout`` s before SIGKILL. One at a time, because nodes stopped together can livelock in
        the middleware (module docstring).

        Parameters
        ----------
        include_exited : bool
            Also judge the processes that had exited before this call (False: only those it stops).

        Returns
        -------
        list of str
            The problems (non-zero exit, traceback, killed), each followed by the last ``tail_lines``
            lines of that process's stderr (none for 0).
        """
        judged = [p for p in self.processes if include_exited or p.poll() is None]
        for proc in reversed(judged):
            proc.stop(sig, timeout)
        problems = []
        for proc in judged:
            if problem := proc.problem():
                problems.append(f'{problem}:\n{proc.stderr_tail(tail_lines)}' if tail_lines else problem)
        return problems

    def remove_logs(self) -> None:
        """Delete the log directory if this suite created it (a temporary one); after :meth:`stop`."""
        if self._own_log_dir:
            shutil.rmtree(self.log_dir, ignore_errors=True)

    def __enter__(self) -> NodeSuite:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()
