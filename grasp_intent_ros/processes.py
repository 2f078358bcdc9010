"""Node processes: ``python -m grasp_intent_ros.<module> --ros-args ...`` started, watched and stopped by PID.

Used by the demo, the replay suite (``--start-suite``, ``scripts/record_sessions.py``) and the system tests.

- :func:`node_environment`: the environment every node process gets: loopback-only discovery
  (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, no ``ROS_STATIC_PEERS``), the run's ``ROS_DOMAIN_ID``, and
  unbuffered output, so the log of a SIGKILLed node is complete.
- :class:`NodeProcess`: stdout and stderr go to files (no pipe can fill up and block a node); it is
  signalled only by its own PID, SIGKILLed after a deadline, and judged clean on exit code 0 with no
  traceback on stderr.

Never imports rclpy.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

__all__ = ['STOP_TIMEOUT', 'NodeProcess', 'node_environment']

STOP_TIMEOUT = 10.0
"""Seconds a node gets to exit after SIGINT/SIGTERM before it is SIGKILLed."""


def node_environment(domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment of a node process on ``domain_id``.

    Args:
        domain_id: ROS_DOMAIN_ID (0..101 for LOCALHOST discovery).
        base: Environment to start from (default ``os.environ``); not modified.

    Returns:
        ``base`` with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ROS_DOMAIN_ID, PYTHONUNBUFFERED=1 and
        RCUTILS_LOGGING_BUFFERED_STREAM=0 set and ROS_STATIC_PEERS removed.
    """
    env = {**(os.environ if base is None else base), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_DOMAIN_ID': str(domain_id), 'PYTHONUNBUFFERED': '1', 'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}
    env.pop('ROS_STATIC_PEERS', None)
    return env


class NodeProcess:
    """One process, started on construction, its output in ``<log_dir>/<prefix><module>.out`` and ``.err``.

    Args:
        command: The command line (:meth:`start` builds the one of a node module).
        module: Name of the process in log file names and messages (the node module's).
        env: Its whole environment (see :func:`node_environment`).
        log_dir: Existing directory for the two log files.
        prefix: Prepended to the log file names (e.g. ``'00_'``).
        cwd: Its working directory (default this process's).
        preexec_fn: Run in the child before the command (e.g. to set a resource limit).
    """

    def __init__(self, command: Sequence[str], *, module: str, env: Mapping[str, str], log_dir: Path,
                 prefix: str = '', cwd: Path | None = None,
                 preexec_fn: Callable[[], None] | None = None) -> None:
        self.module = module
        self.stdout_path = log_dir / f'{prefix}{module}.out'
        self.stderr_path = log_dir / f'{prefix}{module}.err'
        self._signal_sent: signal.Signals | None = None
        self._killed = False
        with self.stdout_path.open('wb') as out, self.stderr_path.open('wb') as err:
            self.popen = subprocess.Popen(list(command), cwd=cwd, env=dict(env), stdout=out, stderr=err,
                                          stdin=subprocess.DEVNULL, preexec_fn=preexec_fn)

    @classmethod
    def start(cls, module: str, ros_args: Sequence[str] = (), *, env: Mapping[str, str], log_dir: Path,
              prefix: str = '', cwd: Path | None = None) -> NodeProcess:
        """``python -m grasp_intent_ros.<module> --ros-args <ros_args>`` (no ``--ros-args`` when empty)."""
        command = [sys.executable, '-m', f'grasp_intent_ros.{module}']
        if ros_args:
            command += ['--ros-args', *ros_args]
        return cls(command, module=module, env=env, log_dir=log_dir, prefix=prefix, cwd=cwd)

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
        """After the exit: '' when clean (code 0, no 'Traceback' on stderr), else one line saying why not.

        Raises:
            RuntimeError: The process is still running.
        """
        code = self.popen.poll()
        if code is None:
            raise RuntimeError(f'{self.module} (pid {self.pid}) is still running')
        who = f'{self.module} (pid {self.pid})'
        if self._killed:
            sent = self._signal_sent.name if self._signal_sent is not None else 'no signal'
            return f'{who} did not exit after {sent} and was killed'
        if code != 0:
            return f'{who} exited with code {code}'
        if 'Traceback' in self.stderr():
            return f'{who} printed a traceback'
        return ''
