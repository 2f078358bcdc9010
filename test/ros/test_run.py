"""grasp_intent_ros.ros.run: the node run idiom (a process per case: run_node initialises rclpy itself)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import rclpy
from rclpy.executors import ExternalShutdownException

from grasp_intent_ros.launch.suite import node_environment
from grasp_intent_ros.ros.compat import ShutdownSafeExecutor
from grasp_intent_ros.ros.run import publish_all, release_free_memory
from grasp_intent_ros.ros.startup import WATCHDOG_EXIT_CODE

REPO = Path(__file__).resolve().parents[2]


def _run_script(domain_id: int, code: str) -> subprocess.CompletedProcess[str]:
    """``python -c code`` in the repository on the test's loopback domain, to its end (60 s at most)."""
    return subprocess.run([sys.executable, '-c', code], cwd=REPO, env=node_environment(domain_id),
                          capture_output=True, text=True, timeout=60)


def test_a_configuration_error_exits_1_with_one_line(domain_id: int) -> None:
    code = ('from grasp_intent_ros.ros.params import ParameterError\n'
            'from grasp_intent_ros.ros.run import run_node\n'
            'def build():\n'
            '    raise ParameterError("model: unknown model \'mug\'")\n'
            'run_node(build, [])\n')
    result = _run_script(domain_id, code)
    assert result.returncode == 1, result.stderr
    assert "cannot start: model: unknown model 'mug'" in result.stderr and 'Traceback' not in result.stderr


def test_spin_on_a_shut_down_context_ends_like_a_shutdown(ros) -> None:
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros.domain_id)
    executor = ShutdownSafeExecutor(context=context)
    node = rclpy.create_node('run_probe', context=context)
    executor.add_node(node)
    rclpy.shutdown(context=context)
    with pytest.raises(ExternalShutdownException):
        executor.spin_once(timeout_sec=0.1)
    executor.shutdown()
    node.destroy_node()


def test_publish_all_drops_messages_only_after_a_shutdown(ros) -> None:
    class Failing:
        def publish(self, msg: object) -> None:
            raise RuntimeError('publisher gone')

    with pytest.raises(RuntimeError, match='publisher gone'):
        publish_all(ros.node, {'t': Failing()}, {'t': object()})
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros.domain_id)
    node = rclpy.create_node('run_probe', context=context)
    rclpy.shutdown(context=context)
    publish_all(node, {'t': Failing()}, {'t': object()})
    node.destroy_node()


def _stuck(domain_id: int, node_body: str, exit_code: int) -> str:
    """Run a node (``node_body``: its class body after the timer) with a 0.5 s grace, SIGTERM it; its stderr.

    The process must end by itself with ``exit_code``.
    """
    code = ('import ctypes, sys, threading\n'
            'from rclpy.node import Node\n'
            'from grasp_intent_ros.ros import run\n'
            'class Stuck(Node):\n'
            '    def __init__(self):\n'
            '        super().__init__("stuck")\n'
            '        self.create_timer(0.05, self.tick)\n'
            f'{node_body}'
            'run.run_node(Stuck, [], shutdown_grace=0.5)\n')
    proc = subprocess.Popen([sys.executable, '-c', code], cwd=REPO, env=node_environment(domain_id),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == 'up\n'  # spinning: now ask it to stop
        proc.terminate()
        assert proc.wait(timeout=30) == exit_code
    finally:
        proc.kill()
        proc.wait()
    return proc.stderr.read() if proc.stderr is not None else ''


def _stopped_by_the_watchdog(domain_id: int, node_body: str) -> str:
    """:func:`_stuck` ended by the watchdog: its own exit code (the parent can tell), its ERROR; the stderr."""
    err = _stuck(domain_id, node_body, WATCHDOG_EXIT_CODE)
    assert 'shutdown not finished 0.5 s after the stop request' in err
    return err


def test_a_hung_shutdown_is_ended_by_the_watchdog_with_the_threads_stacks(domain_id: int) -> None:
    err = _stopped_by_the_watchdog(domain_id, '    def tick(self):\n'
                                              '        print("up", flush=True)\n'
                                              '    def destroy_node(self):\n'
                                              '        threading.Event().wait()  # a shutdown that never finishes\n')
    assert 'in destroy_node' in err  # the stuck thread's stack, from faulthandler


def test_a_teardown_that_holds_the_gil_from_its_start_is_ended_by_faulthandler_with_the_stacks(domain_id: int) -> None:
    """The middleware's shutdown livelock (docs/nodes.md) spins in C++ holding the GIL from the first call.

    Here destroy_node calls libc's sleep through ctypes.PyDLL, which keeps the GIL: no Python thread runs
    again, so only the faulthandler timer armed when the spin ended can end the process (exit 1, stacks).
    """
    err = _stuck(domain_id, '    def tick(self):\n'
                            '        print("up", flush=True)\n'
                            '    def destroy_node(self):\n'
                            '        ctypes.PyDLL(None).sleep(3600)  # holds the GIL\n', 1)
    assert 'Timeout (' in err and 'in destroy_node' in err, err


def test_a_spin_the_signal_does_not_end_is_ended_by_the_watchdog(domain_id: int) -> None:
    err = _stopped_by_the_watchdog(domain_id, '    def tick(self):\n'
                                              '        print("up", flush=True)\n'
                                              '        threading.Event().wait()  # a callback that never returns\n')
    assert 'in tick' in err


@pytest.mark.parametrize('grace', [5.0, None], ids=['with watchdog', 'without watchdog'])
def test_a_shutdown_after_the_executor_was_woken_still_ends_the_spin(domain_id: int, grace: float | None) -> None:
    """The signal thread of rclpy wakes the executor and then shuts the context down, from C.

    An executor that woke in between saw its context valid and waits again. Here that state is made at
    will: the context is shut down (as rclpy's signal thread does it, without Python's shutdown callbacks)
    once the executor is blocked in rcl_wait, in a node with no timer and no traffic. run_node must still
    return, at once, without the watchdog.
    """
    code = ('import linecache, os, sys, threading, time\n'
            'from rclpy.node import Node\n'
            'from grasp_intent_ros.ros import run\n'
            'def waiting(thread):  # its innermost Python frame is the executor\'s call of rcl_wait\n'
            '    frame = sys._current_frames().get(thread.ident)\n'
            '    line = "" if frame is None else linecache.getline(frame.f_code.co_filename, frame.f_lineno)\n'
            '    return line.strip().startswith("wait_set.wait(")\n'
            'class Quiet(Node):  # no timer, no traffic: nothing else wakes its executor\n'
            '    def __init__(self):\n'
            '        super().__init__("quiet")\n'
            '        spinner = threading.current_thread()\n'
            '        threading.Thread(target=self.stop, args=(spinner,), daemon=True).start()\n'
            '    def stop(self, spinner):\n'
            '        deadline = time.monotonic() + 30.0\n'
            '        while not waiting(spinner):\n'
            '            if time.monotonic() > deadline:\n'
            '                print("the executor never waited", flush=True)\n'
            '                os._exit(2)\n'
            '            threading.Event().wait(0.005)\n'
            '        print("stopping", flush=True)\n'
            '        self.context.handle.shutdown()  # rcl_shutdown, as rclpy\'s signal thread calls it\n'
            f'run.run_node(Quiet, [], shutdown_grace={grace})\n'
            'print("returned", flush=True)\n')
    result = _run_script(domain_id, code)  # the old code: ended by the watchdog 5 s later, or never (timeout)
    assert result.stdout == 'stopping\nreturned\n' and result.returncode == 0, (result.stdout, result.stderr)
    assert 'shutdown not finished' not in result.stderr


_DONE_NODE = ('import rclpy\n'
              'from rclpy.node import Node\n'
              'from grasp_intent_ros.ros import run\n'
              'class Done(Node):  # shuts itself down at once\n'
              '    def __init__(self):\n'
              '        super().__init__("done")\n'
              '        self.create_timer(0.05, rclpy.shutdown)\n')


def test_the_watchdog_leaves_a_process_alone_once_the_shutdown_has_finished(domain_id: int) -> None:
    """run_node has returned: the process goes on past the grace (and faulthandler's later timer)."""
    code = ('import time\n' + _DONE_NODE +
            'run.run_node(Done, [], shutdown_grace=0.2)\n'
            'time.sleep(3.0)  # beyond the grace and the C timer 2 s after it\n'
            'print("still here", flush=True)\n')
    proc = _run_script(domain_id, code)
    assert proc.returncode == 0 and proc.stdout == 'still here\n', proc.stderr
    assert 'shutdown not finished' not in proc.stderr


def test_guard_exit_ends_a_process_whose_exit_hangs_after_run_node_with_the_stacks(domain_id: int) -> None:
    """A hang in the interpreter's exit (here a thread that never ends) is ended with code 1 and its stack."""
    code = ('import threading\n' + _DONE_NODE +
            'def stuck_at_exit():\n'
            '    threading.Event().wait()\n'
            'run.run_node(Done, [], shutdown_grace=0.5)\n'
            'threading.Thread(target=stuck_at_exit).start()  # not a daemon: the exit waits for it\n'
            'run.guard_exit(0.5)\n'
            'print("returned", flush=True)\n')
    result = _run_script(domain_id, code)
    assert result.stdout == 'returned\n' and result.returncode == 1, (result.stdout, result.stderr)
    assert 'in stuck_at_exit' in result.stderr


def test_guard_exit_leaves_a_process_that_ends_alone(domain_id: int) -> None:
    """The guard's grace as the nodes' default: the interpreter's exit took over 0.5 s at load 12-16 on 2 cores."""
    result = _run_script(domain_id, _DONE_NODE + 'run.run_node(Done, [], shutdown_grace=0.5)\nrun.guard_exit()\n')
    assert result.returncode == 0 and 'Timeout' not in result.stderr, result.stderr


def _resident_anonymous_bytes() -> int:
    for line in Path('/proc/self/status').read_text().splitlines():
        if line.startswith('RssAnon:'):
            return int(line.split()[1]) * 1024
    raise AssertionError('no RssAnon in /proc/self/status')


@pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='reads the resident set from /proc')
def test_release_free_memory_returns_the_pages_malloc_kept() -> None:
    """Blocks freed between kept ones stay resident in malloc's heap until trimmed."""
    blocks = [bytes(4000) for _ in range(20_000)]  # 80 MB from malloc (each over pymalloc's 512 bytes)
    kept = blocks[1::50]  # one in 50 stays: the heap cannot shrink from its top
    del blocks
    before = _resident_anonymous_bytes()
    assert release_free_memory()
    released = before - _resident_anonymous_bytes()
    assert len(kept) == 400 and released > 40 << 20, released
