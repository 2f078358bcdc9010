"""A node process tuned for a fast start and quick answers.

A node module runs as a process through :func:`run` (its ``main``), which applies the settings below and
runs the node with :func:`grasp_intent_ros.ros.run.run_node`; a node whose worker thread answers with
compiled kernels loads them ahead with a :class:`KernelWarmUp`.

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
  (one on a 2-core machine), each spinning on the CPU for a while as it starts, while the planner's
  matrices (at most 10 x 10) are far below the size at which OpenBLAS would hand work to a second thread.

:func:`begin` must run before the node's module imports numpy to have its full effect: a node module calls
it first thing when it runs as ``python -m`` (``__name__ == '__main__'``: a module's imports run before
any of its functions can), and :func:`run` calls it again (a console script imports
the module first). Only a process that called :func:`begin` is changed by :func:`end`: a node built in a
test process leaves that process's collector alone.

**The answers.** :func:`run` sets the GIL switch interval to :data:`GIL_SWITCH_INTERVAL`, and
:class:`KernelWarmUp` loads the compiled kernels in the worker thread while the node discovers its peers
and waits for its first inputs (the kernels a first answer needs), and right after its first answer (the
others), so that a restarted node answers sooner and never compiles or loads in a later answer.

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

__all__ = ['begin', 'end', 'run', 'KernelWarmUp', 'GIL_SWITCH_INTERVAL']

GIL_SWITCH_INTERVAL = 0.0005
"""Seconds (Python's default: 0.005) a node's worker thread may hold the GIL while the executor thread waits.

The executor thread needs the GIL several times per message; with the default it could wait up to 5 ms
each time behind a plan in progress, so a new input waited while the worker started on an older one.
"""

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
    own exit is guarded by :func:`grasp_intent_ros.ros.run.guard_exit`.
    """
    begin()
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    from .run import guard_exit, run_node  # late: rclpy loads after begin()

    run_node(node_factory, args)
    guard_exit()  # the interpreter's exit too must end, or leave the stacks


class KernelWarmUp:
    """Compiled kernels loaded ahead of the answers that need them, in a node's worker thread.

    Pass :meth:`at_start` and :meth:`after_first` as the ``prepare`` and ``after_first`` of a
    :class:`~grasp_intent_ros.ros.worker.LatestOnlyWorker`. Neither raises: a load that fails is reported
    with ``warn``, and the answer that needs the kernels loads them and reports what fails.

    Parameters
    ----------
    first : callable
        Loads numba's CPU target and the kernels every answer uses (e.g. one IK of the arm's home pose).
    report : callable
        ``report(key, value)`` with the milliseconds a load took, as text, under
        :data:`~grasp_intent_ros.wire.protocol.KEY_KERNELS_LOAD_TIME` (:meth:`at_start`) or
        :data:`~grasp_intent_ros.wire.protocol.KEY_KERNELS_LATE_LOAD_TIME` (:meth:`after_first`); e.g. a
        :meth:`NodeDiagnostics.set_value <grasp_intent_ros.ros.diagnostics.NodeDiagnostics.set_value>`.
    warn : callable
        ``warn(text)`` for a load that failed, e.g. a logger's ``warning``.
    """

    def __init__(self, first: Callable[[], object], *, report: Callable[[str, str], object],
                 warn: Callable[[str], object]) -> None:
        self._first, self._report, self._warn = first, report, warn

    def at_start(self) -> None:
        """Run ``first``, then :func:`end` (the node's code is loaded): before the first answer."""
        from ..wire.protocol import KEY_KERNELS_LOAD_TIME

        try:
            self._timed(KEY_KERNELS_LOAD_TIME, self._first)
        finally:
            end()

    def after_first(self) -> None:
        """Load the kernels the first answer did not use (loaded ones cost nothing): right after it."""
        from ..kernels import warm_up
        from ..wire.protocol import KEY_KERNELS_LATE_LOAD_TIME

        self._timed(KEY_KERNELS_LATE_LOAD_TIME, warm_up)

    def _timed(self, key: str, load: Callable[[], object]) -> None:
        start = time.perf_counter()
        try:
            load()
        except Exception as exc:  # noqa: BLE001 - then an answer loads them, and reports what fails
            self._warn(f'compiled planner kernels not loaded ahead: {exc}')
            return
        self._report(key, f'{1e3 * (time.perf_counter() - start):.0f}')
