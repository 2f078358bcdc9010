"""grasp_intent_ros.launch.process on plain ``python -c`` processes: its logs, its stop, its problems.

And launch.parent_death through it: a node process ends with the launcher that started it.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import node_environment

from .probe_process import READY_SLEEPER, SLEEPER, run, wait_logged_ready


def test_clean_exit_and_log_files(tmp_path: Path) -> None:
    proc = NodeProcess([sys.executable, '-c', 'import sys; print("out"); print("err", file=sys.stderr)'],
                       module='probe', env=node_environment(97), log_dir=tmp_path, prefix='03_')
    assert proc.wait(10.0) == 0
    assert proc.problem() == ''
    assert (tmp_path / '03_probe.out').read_text() == 'out\n'
    assert proc.stderr() == 'err\n'
    assert proc.stderr_tail() == '    | err'


def test_stop_by_signal_reports_the_exit_code(tmp_path: Path) -> None:
    proc = wait_logged_ready(run(tmp_path, READY_SLEEPER))
    assert proc.poll() is None
    with pytest.raises(RuntimeError, match='still running'):
        proc.problem()
    assert proc.stop(signal.SIGTERM) == -signal.SIGTERM
    assert proc.problem() == f'probe (pid {proc.pid}) exited with code {-signal.SIGTERM}'
    assert proc.stop() == -signal.SIGTERM  # exited: no signal is sent


def test_death_by_our_sigterm_before_the_ready_line_is_clean(tmp_path: Path) -> None:
    importing = run(tmp_path, SLEEPER)  # as a node still importing: no handler, no ready line
    assert importing.stop(signal.SIGTERM) == -signal.SIGTERM
    assert importing.problem() == ''


def test_traceback_is_a_problem(tmp_path: Path) -> None:
    proc = run(tmp_path, 'import sys\ntry:\n    1 / 0\nexcept ZeroDivisionError:\n'
                         '    import traceback; traceback.print_exc(); sys.exit(0)')
    assert proc.wait(10.0) == 0
    assert proc.problem() == f'probe (pid {proc.pid}) printed a traceback'
    assert 'ZeroDivisionError' in proc.stderr_tail(1)


def test_sigkill_after_the_deadline(tmp_path: Path) -> None:
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})  # inherited: the child never sees SIGTERM
    try:
        proc = run(tmp_path, SLEEPER)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    assert proc.stop(signal.SIGTERM, timeout=0.5) == -signal.SIGKILL
    assert proc.problem() == f'probe (pid {proc.pid}) did not exit after SIGTERM and was killed'


def _gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie not yet reaped by whoever adopted it counts as ended)."""
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return True
    return state in ('Z', 'X')


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='PR_SET_PDEATHSIG is Linux only')
def test_a_process_ends_when_the_command_that_started_it_is_killed(tmp_path: Path) -> None:
    """A launcher SIGKILLed (no cleanup runs) leaves no process: each gets SIGTERM from the kernel."""
    launcher_code = (
        'import sys, time\n'
        'from pathlib import Path\n'
        'from grasp_intent_ros.launch.process import NodeProcess\n'
        'from grasp_intent_ros.launch.suite import node_environment\n'
        f'proc = NodeProcess([sys.executable, "-c", {SLEEPER!r}], module="orphan", env=node_environment(97), '
        f'log_dir=Path({str(tmp_path)!r}))\n'
        'print(proc.pid, flush=True)\n'
        'time.sleep(60)\n')
    launcher = subprocess.Popen([sys.executable, '-c', launcher_code], stdout=subprocess.PIPE, text=True)
    try:
        assert launcher.stdout is not None
        child = int(launcher.stdout.readline())
        assert not _gone(child)
    finally:
        launcher.kill()
        launcher.wait()
    deadline = time.monotonic() + 10.0
    while not _gone(child):
        assert time.monotonic() < deadline, f'process {child} outlived the launcher that started it'
        time.sleep(0.01)
