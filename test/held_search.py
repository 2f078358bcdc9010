"""Path searches for the tests of :class:`~grasp_intent_ros.shared_control.path_search.PathWorker`'s process.

Module-level functions, so that the worker's process imports them (its import path is the caller's). The tests
bind ``gate`` (a directory) with ``functools.partial``; the functions talk to the test through files in it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.shared_control.path_search import PathAnswer, PathRequest, seek_path

HOLD_LIMIT = 60.0
"""Seconds a held search waits for its release at most."""


def held(gate: Path, kin: MicoKinematics, request: PathRequest) -> PathAnswer:
    """:func:`seek_path`, held while ``gate/armed`` exists until ``gate/release`` does.

    Writes ``gate/started`` (the process id; it appears whole, by a rename) when it holds; after each search, the
    request's grasp to ``gate/grasp_<n>.npy`` and a line ``<process id>`` to ``gate/sought`` (n: the searches
    before it).
    """
    if (gate / 'armed').exists():
        (gate / 'started.tmp').write_text(str(os.getpid()))
        os.replace(gate / 'started.tmp', gate / 'started')  # whole: the test reads it as soon as it exists
        deadline = time.monotonic() + HOLD_LIMIT
        while not (gate / 'release').exists() and time.monotonic() < deadline:
            time.sleep(0.002)
    answer = seek_path(kin, request)
    sought = gate / 'sought'
    n = len(sought.read_text().splitlines()) if sought.exists() else 0
    np.save(gate / f'grasp_{n}.npy', request.base_T_grasp)
    with sought.open('a') as out:
        out.write(f'{os.getpid()}\n')
    return answer


def failing(kin: MicoKinematics, request: PathRequest) -> PathAnswer:
    """A search that raises RuntimeError('a search that fails')."""
    raise RuntimeError('a search that fails')
