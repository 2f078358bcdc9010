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
- :class:`NodeProcess`: stdout and stderr go to files (no pipe can fill up and block a node); it runs in a
  session of its own, so it is signalled only by its own PID (a terminal's Ctrl-C reaches the command that
  started it, never the node directly), gets SIGTERM when the command that started it dies (on Linux; a
  killed test run or suite leaves no node on its domain), is SIGKILLed after a deadline, and is judged clean
  on exit code 0 with no traceback on stderr, or on death by the SIGTERM it was sent before it logged that it is ready.
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
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Collection, Mapping, MutableMapping, Sequence
from pathlib import Path
from types import TracebackType

from ..errors import GraspIntentError
from ..resources import config_dir
from ..ros.startup import WATCHDOG_EXIT_CODE, is_ready_line
from ..wire.topics import ARM_TRAJECTORY_COMMAND, ARM_TWIST_COMMAND, ASSISTANCE_TWIST, GRASP_TRAJECTORY
from .objects import SceneObject, chain_remappings, refuse_unbuilt, scene_node_args
from .parent_death import ended_with_this_process

__all__ = ['STOP_TIMEOUT', 'SUITE_NODES', 'SHARED_CONTROL_NODES', 'OPTIONAL_NODES', 'REMAPPINGS', 'MAX_DOMAIN_ID',
           'TEST_DOMAIN_IDS', 'RUN_DOMAIN_IDS', 'FASTDDS_PROFILE', 'SuiteError', 'domain_id_from_environment',
           'use_loopback_discovery', 'node_environment', 'optional_nodes', 'NodeProcess', 'NodeSuite']

STOP_TIMEOUT = 10.0
"""Seconds a node gets to exit after SIGINT/SIGTERM before it is SIGKILLed."""
SUITE_NODES = ('intent_interpreter', 'model_server', 'grasp_planner')
"""The node modules of the suite, in start order."""
SHARED_CONTROL_NODES = ('mock_arm', 'assistance')
"""The shared-control loop's nodes: the mock MICO and the assistance (``suite --shared-control``)."""
OPTIONAL_NODES: tuple[str, ...] = (*SHARED_CONTROL_NODES, 'intent_estimator', 'scripted_operator', 'viewer')
"""Node modules started only on request, after :data:`SUITE_NODES`: ``suite --with NAME``,
:meth:`NodeSuite.start_nodes`'s ``extra``. Each is ``python -m grasp_intent_ros.nodes.<name>`` with its
``config/<name>.yaml`` when there is one, like the suite's own nodes."""
REMAPPINGS: Mapping[str, tuple[str, ...]] = {
    'mock_arm': (f'{ARM_TRAJECTORY_COMMAND}:={GRASP_TRAJECTORY}', f'{ARM_TWIST_COMMAND}:={ASSISTANCE_TWIST}'),
}
"""Each node's remappings in the suite: the mock arm executes the planner's trajectory and the blended twist."""
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


class NodeProcess:
    """One process, started on construction, its output in ``<log_dir>/<prefix><module>.out`` and ``.err``.

    Parameters
    ----------
    command
        The command line (:meth:`start` builds the one of a node module).
    module
        Name of the process in messages and log file names (the node module's, or ``<object>/<module>`` for an
        object's chain: a '/' is a '.' in the file names).
    env
        Its whole environment (see :func:`node_environment`).
    log_dir
        Existing directory for the two log files.
    prefix
        Prepended to the log file names (e.g. ``'00_'``).
    cwd
        Its working directory (default this process's).
    preexec_fn
        Run in the child before the command (e.g. to set a resource limit).

    On Linux the process is sent SIGTERM when the thread that started it ends (``PR_SET_PDEATHSIG``), and
    is never started if this process has already ended: a test runner, suite or benchmark killed without
    its cleanup leaves no node behind on its ROS domain. So start processes from a thread that lives as long
    as they should (the main thread does).
    """

    def __init__(self, command: Sequence[str], *, module: str, env: Mapping[str, str], log_dir: Path,
                 prefix: str = '', cwd: Path | None = None,
                 preexec_fn: Callable[[], None] | None = None) -> None:
        self.module = module
        self.stdout_path = log_dir / f'{prefix}{module.replace("/", ".")}.out'
        self.stderr_path = log_dir / f'{prefix}{module.replace("/", ".")}.err'
        self._signal_sent: signal.Signals | None = None
        self._killed = False
        with self.stdout_path.open('wb') as out, self.stderr_path.open('wb') as err:
            self.popen = subprocess.Popen(list(command), cwd=cwd, env=dict(env), stdout=out, stderr=err,
                                          stdin=subprocess.DEVNULL,
                                          preexec_fn=ended_with_this_process(preexec_fn),
                                          start_new_session=True)

    @classmethod
    def start(cls, module: str, ros_args: Sequence[str] = (), *, env: Mapping[str, str], log_dir: Path,
              prefix: str = '', cwd: Path | None = None, name: str | None = None) -> NodeProcess:
        """``python -m grasp_intent_ros.nodes.<module> --ros-args <ros_args>``, named ``name`` (or ``module``)."""
        command = [sys.executable, '-m', f'grasp_intent_ros.nodes.{module}']
        if ros_args:
            command += ['--ros-args', *ros_args]
        return cls(command, module=name or module, env=env, log_dir=log_dir, prefix=prefix, cwd=cwd)

    @property
    def pid(self) -> int:
        """The process id."""
        return self.popen.pid

    def poll(self) -> int | None:
        """The exit code (negative: killed by that signal), or None while it runs."""
        return self.popen.poll()

    def stderr(self) -> str:
        """Everything it has written to stderr so far."""
        return self.stderr_path.read_text(errors='replace')

    def stderr_tail(self, lines: int = 15) -> str:
        """The last ``lines`` lines of stderr, indented with ``'    | '``, for a message."""
        try:
            tail = self.stderr().strip().splitlines()[-lines:]
        except OSError as exc:
            return f'    | (stderr unreadable: {exc})'
        return '\n'.join(f'    | {line}' for line in tail) if tail else '    | (empty)'

    def logged_ready(self) -> bool:
        """Whether its output so far holds its ready line (:func:`~grasp_intent_ros.ros.startup.is_ready_line`)."""
        return any(is_ready_line(line) for path in (self.stdout_path, self.stderr_path)
                   for line in path.read_text(errors='replace').splitlines())

    def send_signal(self, sig: signal.Signals) -> None:
        """Send ``sig`` to this PID unless the process has exited."""
        if self.popen.poll() is None:
            self.popen.send_signal(sig)
            self._signal_sent = sig

    def wait(self, timeout: float) -> int:
        """Wait up to ``timeout`` seconds for the exit, then SIGKILL; the exit code."""
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self._killed = True
            return self.popen.wait()

    def stop(self, sig: signal.Signals = signal.SIGTERM, timeout: float = STOP_TIMEOUT) -> int:
        """Send ``sig`` (unless it has exited), wait up to ``timeout`` s, then SIGKILL; the exit code."""
        self.send_signal(sig)
        return self.wait(timeout)

    def problem(self) -> str:
        """After the exit: '' when clean, else one line saying why not.

        Clean is exit code 0 with no 'Traceback' on stderr, or death by the SIGTERM this object sent before
        the process logged that it is ready (a node signalled while it still imports, before ``rclpy.init``
        installs its handlers, has built nothing).

        Raises
        ------
        RuntimeError
            The process is still running.
        """
        code = self.popen.poll()
        if code is None:
            raise RuntimeError(f'{self.module} (pid {self.pid}) is still running')
        who = f'{self.module} (pid {self.pid})'
        if self._killed:
            sent = self._signal_sent.name if self._signal_sent is not None else 'no signal'
            return f'{who} did not exit after {sent} and was killed'
        if code == -signal.SIGTERM and self._signal_sent is signal.SIGTERM and not self.logged_ready():
            return ''  # ended by our SIGTERM while importing, before rclpy's handlers: nothing built, nothing lost
        if code == WATCHDOG_EXIT_CODE:
            return f'{who} was ended by its watchdog: its stop did not finish in time (the stacks are in its log)'
        if code != 0:
            return f'{who} exited with code {code}'
        if 'Traceback' in self.stderr():
            return f'{who} printed a traceback'
        return ''


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
                    objects: Sequence[SceneObject] = ()) -> None:
        """Start :data:`SUITE_NODES` (once, or once per object), then ``extra``, each with :meth:`node_args`.

        Parameters
        ----------
        namespace : str
            '' or e.g. '/robot1' (``-r __ns:=``).
        model, models_dir : optional
            The model server's initial ``model`` and its ``models_dir`` (default: its config file's).
        objects : sequence of SceneObject
            One chain of :data:`SUITE_NODES` per object instead, each process named ``<object>/<module>``, then no
            ``model``, and of ``extra`` only those of ``launch.objects.SCENE_NODES`` (``shared_control``'s are).
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
            For ``objects`` with ``model`` or another ``extra``, before anything is started.
        OSError
            If a process cannot be started; those already started stay in :attr:`processes`.
        """
        wanted = optional_nodes(tuple(dict.fromkeys((*(SHARED_CONTROL_NODES if shared_control else ()), *extra))))
        if objects:
            refuse_unbuilt(wanted)
            if model is not None:
                raise GraspIntentError('objects name their own models: give no model')
        starts = [(module, obj.namespace(namespace), obj.model, obj.process_name(module), chain_remappings(namespace),
                   ()) for obj in objects for module in SUITE_NODES] + [  # then the nodes over every chain
                      (module, namespace, None, None, (), scene_node_args(objects)) for module in wanted] if objects \
            else [(module, namespace, model, None, (), ()) for module in (*SUITE_NODES, *wanted)]
        for module, node_ns, node_model, name, own, params in starts:
            more = [arg for remapping in (*own, *(remappings or {}).get(module, ())) for arg in ('-r', remapping)]
            self.start(module, *self.node_args(module, namespace=node_ns, model=node_model, models_dir=models_dir,
                                               params_files=params_files), *more, *params, name=name)

    @staticmethod
    def node_args(module: str, *, namespace: str = '', model: str | None = None,
                  models_dir: str | os.PathLike[str] | None = None,
                  params_files: Sequence[str | os.PathLike[str]] = ()) -> list[str]:
        """The ``--ros-args`` of a suite node (as :meth:`start_nodes` gives them), e.g. to restart it."""
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
        for remapping in REMAPPINGS.get(module, ()):
            ros_args += ['-r', remapping]
        if module == 'model_server':
            if model is not None:
                ros_args += ['-p', f'model:={model}']
            if models_dir is not None:
                ros_args += ['-p', f'models_dir:={Path(models_dir).resolve()}']
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
