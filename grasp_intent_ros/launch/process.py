"""One node process of a run: started, its output in two log files, signalled by its PID alone, stopped, judged.

:class:`NodeProcess`: stdout and stderr go to files (no pipe can fill up and block a node); it runs in a
session of its own, so it is signalled only by its own PID (a terminal's Ctrl-C reaches the command that
started it, never the node directly), gets SIGTERM when the command that started it dies (on Linux; a
killed test run or suite leaves no node on its domain), is SIGKILLed after a deadline, and is judged clean
on exit code 0 with no traceback on stderr, or on death by the SIGTERM it was sent before it logged that it is ready.

:class:`~grasp_intent_ros.launch.suite.NodeSuite` starts and stops the processes of a run; a test or a benchmark
starts one alone. Never imports rclpy.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from ..ros.startup import WATCHDOG_EXIT_CODE, is_ready_line
from .parent_death import ended_with_this_process

__all__ = ['STOP_TIMEOUT', 'NodeProcess']

STOP_TIMEOUT = 10.0
"""Seconds a node gets to exit after SIGINT/SIGTERM before it is SIGKILLed."""


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
