"""A node process's start made cheaper: the CPU a restarted node spends before its first answer.

A restarted planner is CPU-bound until its first grasp (imports, numba's CPU target, the cached kernels,
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
it first thing when it runs as ``python -m`` (``__name__ == '__main__'``), and again in ``main`` (a
console script imports the module first). Only a process that called :func:`begin` is changed by
:func:`end`: a node built in a test process leaves that process's collector alone.
"""

from __future__ import annotations

import gc
import os

__all__ = ['begin', 'end']

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
