"""A node process tuned for a fast start and quick answers.

A node module runs as a process through :func:`run` (its ``main``), which applies the settings below and
runs the node with :func:`grasp_intent_ros.ros.run.run_node`; a node whose worker thread answers with
compiled kernels loads them ahead with a :class:`KernelWarmUp`. Two node modules run this way: the grasp
planner (whose kernels and restart are the reason for the start's settings below) and the assistance node
(a timed stream, whose collections then never traverse the start's objects).

**The start.** A restarted planner is CPU-bound until its first grasp (imports, numba's CPU target, the cached kernels,
nearly all of it under one GIL), so what it does not have to do shortens its restart. Two things, for the
process's start only:

- The cyclic garbage collector is off (:func:`begin`) until the node's code is loaded (:func:`end`).
  Importing numba, scipy, pinocchio and rclpy and loading the compiled kernels creates some 200,000
  objects, of which a small part becomes cyclic garbage, and the collector would run hundreds of times
  meanwhile, a sizeable share of the CPU the planner's start takes.
  :func:`end` then moves everything alive into the permanent generation (``gc.freeze``) and turns the
  collector on: later collections never traverse the startup objects (so a full collection soon after the
  start is cheap), at the cost of keeping that startup garbage.
  Reference counting still frees a frozen object (e.g. the first model, once replaced); only a reference
  cycle among them is never collected.
- OpenBLAS runs single-threaded, unless ``OPENBLAS_NUM_THREADS`` is set already (read when numpy and
  scipy load it): each of the two OpenBLAS libraries (numpy's and scipy's) otherwise starts worker threads
  (by the machine's cores), each spinning on the CPU for a while as it starts, while the planner's
  matrices (at most 10 x 10) are far below the size at which OpenBLAS would hand work to a second thread.

:func:`begin` must run before the node's module imports numpy to have its full effect: a node module calls
it first thing when it runs as ``python -m`` (``__name__ == '__main__'``: a module's imports run before
any of its functions can), and :func:`run` calls it again (a console script imports
the module first). :func:`end` is called once the node's code is loaded: by :meth:`KernelWarmUp.at_start` in
the planner's worker thread, and at the end of the assistance node's constructor (after its warm-up). Only a
process that called :func:`begin` is changed by :func:`end`: a node built in a test process leaves that
process's collector alone.

**The answers.** :func:`run` sets the GIL switch interval to :data:`GIL_SWITCH_INTERVAL`, and
:class:`KernelWarmUp` loads every compiled kernel in the worker thread while the node discovers its peers
and waits for its first inputs, compiling what numba's cache lacks (a fresh installation), so that no answer
ever compiles or loads one; only then does the node log :data:`READY_LOG` (:func:`announce_ready`).

**Ready.** A node logs :data:`READY_LOG` at INFO once it answers without a compile: :func:`run_node
<grasp_intent_ros.ros.run.run_node>` as it starts to spin, or, for a node that warms up (``announces_ready``
True), its warm-up when done. The suite command prints that it is up once every node has (:func:`is_ready_line`).

This module imports neither rclpy nor numpy (it runs before them); what it calls of them it imports late.
"""

from __future__ import annotations

import gc
import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.node import Node

__all__ = ['begin', 'end', 'run', 'KernelWarmUp', 'GIL_SWITCH_INTERVAL', 'READY_LOG', 'announce_ready',
           'is_ready_line', 'WATCHDOG_EXIT_CODE']

GIL_SWITCH_INTERVAL = 0.0005
"""Seconds (Python's default: 0.005) a node's worker thread may hold the GIL while the executor thread waits.

The executor thread needs the GIL several times per message; with the default it could wait up to 5 ms
each time behind a plan in progress, so a new input waited while the worker started on an older one.
"""

WATCHDOG_EXIT_CODE = 3
"""The exit code of a node process whose stop did not finish within its grace, ended by the watchdog of
:mod:`grasp_intent_ros.ros.run` (its log holds every thread's stack)."""

READY_LOG = 'ready'
"""The start of the INFO line a node logs once it is ready (module docstring, "Ready")."""

_paused = False
"""Whether :func:`begin` turned the collector off and :func:`end` has not turned it on yet (process-wide, as gc)."""


def begin() -> None:
    """Start a node process: OpenBLAS single-threaded (unless set), the cyclic garbage collector off."""
    global _paused
    os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
    if gc.isenabled():
        gc.disable()
        _paused = True


def end() -> None:
    """The node's code is loaded: freeze what is alive and turn the collector back on (after :func:`begin`)."""
    global _paused
    if _paused:
        _paused = False
        gc.freeze()
        gc.enable()


def run(node_factory: Callable[[], Node], args: Sequence[str] | None = None) -> None:
    """A node process's ``main``: :func:`begin`, :data:`GIL_SWITCH_INTERVAL`, then the node until SIGINT/SIGTERM.

    The node runs with :func:`grasp_intent_ros.ros.run.run_node` (``args`` as there), and the process's
    own exit is guarded by :func:`grasp_intent_ros.ros.run.guard_exit`. A node stopped while a
    :class:`KernelWarmUp` still loads (a first start compiles for tens of seconds) exits with code 0 within
    :data:`~grasp_intent_ros.latest_only.FINISH_WAIT` s, saying so on stderr: a compile cannot be cut short,
    and its worker thread is left to end with the process (:func:`~grasp_intent_ros.ros.run.guard_exit`).
    """
    begin()
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    from .run import guard_exit, run_node  # late: rclpy loads after begin()

    run_node(node_factory, args)
    guard_exit()  # the interpreter's exit too must end, or leave the stacks; at once if a thread is left working


def announce_ready(log: Callable[[str], object], detail: str = '') -> None:
    """Log that the node is ready with ``log`` (a logger's ``info``): :data:`READY_LOG`, then ``detail``."""
    log(f'{READY_LOG}{": " if detail else ""}{detail}')


def is_ready_line(line: str) -> bool:
    """Whether ``line`` of a node's output is its :func:`announce_ready` line (rclpy's default log format)."""
    return line.partition(']: ')[2].startswith(READY_LOG)


class KernelWarmUp:
    """Every compiled kernel a node's answers use, loaded (or compiled) in its worker thread before its first answer.

    Pass :meth:`at_start` as the ``prepare`` of a :class:`~grasp_intent_ros.ros.worker.LatestOnlyWorker`
    and report :meth:`loaded_late` after each answer. Neither raises: a load that fails is reported with
    ``warn``, and the answer that needs the kernels loads them and reports what fails.

    Parameters
    ----------
    first : callable
        Loads the node's own uses of the kernels (e.g. one IK of the arm's home pose); then
        :func:`grasp_intent_ros.kernels.warm_up` loads every kernel with the planner's argument types.
    report : callable
        ``report(key, value)`` with the milliseconds the load took, as text, under
        :data:`~grasp_intent_ros.wire.diagnostics.KEY_KERNELS_LOAD_TIME`; e.g. a
        :meth:`NodeDiagnostics.set_value <grasp_intent_ros.ros.diagnostics.NodeDiagnostics.set_value>`.
    warn : callable
        ``warn(text)`` for a load that failed, e.g. a logger's ``warning``.
    ready : callable
        ``ready(detail)`` once the kernels are loaded (or failed to), e.g. :func:`announce_ready` with a
        logger's ``info``.
    """

    def __init__(self, first: Callable[[], object], *, report: Callable[[str, str], object],
                 warn: Callable[[str], object], ready: Callable[[str], object]) -> None:
        self._first, self._report, self._warn, self._ready = first, report, warn, ready
        self._loaded: int | None = None

    def at_start(self) -> None:
        """Load every kernel, then :func:`end` (the node's code is loaded), then ``ready``: before the first answer."""
        from ..kernels import loaded_signatures, warm_up
        from ..wire.diagnostics import KEY_KERNELS_LOAD_TIME

        def load() -> None:
            self._first()
            warm_up()

        try:
            took = self._timed(KEY_KERNELS_LOAD_TIME, load)
        finally:
            end()
        self._loaded = loaded_signatures()
        self._ready('' if took is None else f'compiled kernels loaded in {took:.0f} ms')

    def loaded_late(self) -> int:
        """Kernel signatures compiled or loaded since :meth:`at_start` ended (0: no answer waited on one).

        Raises
        ------
        RuntimeError
            Before :meth:`at_start` has ended.
        """
        from ..kernels import loaded_signatures

        if self._loaded is None:
            raise RuntimeError('the kernels are still loading')
        return loaded_signatures() - self._loaded

    def _timed(self, key: str, load: Callable[[], object]) -> float | None:
        start = time.perf_counter()
        try:
            load()
        except Exception as exc:  # noqa: BLE001 - then an answer loads them, and reports what fails
            self._warn(f'compiled planner kernels not loaded ahead: {exc}')
            return None
        took = 1e3 * (time.perf_counter() - start)
        self._report(key, f'{took:.0f}')
        return took
