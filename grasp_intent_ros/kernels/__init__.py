"""Compiled inner loops (numba): the planner's projection, least squares and selection; the MICO's IK.

One module per job, each stating what it computes:

geometry       the object's body: signed distance, its derivatives, projection onto the feasible set X
linalg         small dense solves written as loops (Gram matrices, Cholesky, the minimum-norm step)
posterior      the model's posterior P(k|x), the objective 1/2 |v - P|^2 and their derivatives
projection     the log-odds projection onto P(x) = v (Gauss-Newton)
least_squares  Levenberg-Marquardt and Newton on 1/2 |v - P(x)|^2 over X
rounds         the planner's least squares (its rule 5) in one call
selection      ranking, screening and choosing candidates without float-noise ties
voting         a kernel vote over labelled points, its bandwidth search, and soft thresholds at landings
               (the robustness estimate)
ik             the MICO's inverse kinematics (:meth:`grasp_intent_ros.mico.kinematics.MicoKinematics.ik`)
types          the shared arrays as typed tuples: the body (:class:`~.types.Body`), the model's Gaussians
               (:class:`~.types.Mixture`)

The algorithms are stated where they are used (:mod:`grasp_intent_ros.planning.lm`,
:mod:`grasp_intent_ros.planning.common`) and in the solvers' docstrings; these modules only run them without
numpy's per-call overhead (an iteration is ~10^3 flops, so that overhead, not the arithmetic, is the cost):
the iterations work in arrays allocated once per call and write their small products and solves as loops.
The public functions below take and return numpy arrays and are typed; the compiled ones (leading
underscore) are typed by numba from their arguments (setup.cfg says why mypy does not ask them for
annotations) and pass the body and the model's Gaussians on as one :class:`~.types.Body` and one
:class:`~.types.Mixture`.

Compiled code is cached next to the modules (``cache=True``); the first call in a fresh installation
compiles it, which ``python -m grasp_intent_ros.kernels`` (:func:`warm_up`) does ahead of time.
numba checks a cached function against its own file only, not against the kernels it calls from other
modules; :func:`_drop_stale_caches` therefore drops every module's cache when any kernel source changes.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np


def _drop_stale_caches(directory: Path) -> None:
    """Remove numba's cache files of ``directory``'s modules unless they were compiled from its current sources.

    The sources are the modules but ``__init__`` and ``__main__`` (which compile nothing); their SHA-256 is
    kept in ``__pycache__/kernels.sources.sha256``, next to the cache files. A directory that cannot be
    written (a read-only installation, whose sources do not change) is left alone.
    """
    sources = sorted(p for p in directory.glob('*.py') if p.name not in ('__init__.py', '__main__.py'))
    digest = hashlib.sha256(b''.join(p.read_bytes() for p in sources)).hexdigest()
    cache = directory / '__pycache__'
    stamp = cache / 'kernels.sources.sha256'
    try:
        if stamp.read_text() == digest:
            return
    except OSError:
        pass
    try:
        for path in cache.glob('*.nb[ic]'):
            path.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass


_drop_stale_caches(Path(__file__).parent)  # before any kernel is compiled or loaded

from .geometry import clearance, feasible  # noqa: E402
from .ik import ik_descent  # noqa: E402
from .posterior import fit_and_distance, log_joints, score  # noqa: E402
from .projection import project  # noqa: E402
from .rounds import least_squares_rounds  # noqa: E402
from .selection import choice_order, distinct, lex_order, screen, select_demonstrations  # noqa: E402
from .voting import landed_thresholds, landed_votes, search_bandwidths  # noqa: E402

__all__ = ['project', 'least_squares_rounds', 'feasible', 'score', 'fit_and_distance', 'log_joints', 'screen',
           'choice_order', 'select_demonstrations', 'distinct', 'lex_order', 'ik_descent', 'clearance', 'landed_votes',
           'landed_thresholds', 'search_bandwidths', 'warm_up', 'loaded_signatures']


def loaded_signatures() -> int:
    """How many compiled signatures the kernel modules' numba functions hold now, compiled or loaded from the cache.

    It grows whenever a call compiles or loads a kernel for new argument types; a caller that takes it after
    :func:`warm_up` and again after its work learns whether that work waited on one (the count, not a time).
    """
    from numba.core.dispatcher import Dispatcher

    from . import geometry, ik, least_squares, linalg, posterior, projection, rounds, selection, voting

    return sum(len(obj.signatures) for module in (geometry, ik, least_squares, linalg, posterior, projection, rounds,
                                                  selection, voting)
               for obj in vars(module).values() if isinstance(obj, Dispatcher))


def warm_up() -> None:
    """Compile (or load from the cache) every kernel on a tiny problem with the planner's argument types.

    ``scripts/venv.sh`` calls it at set-up time (the cache), and the planner node before it is ready.
    """
    d = 10
    cylinder = (np.zeros(1, dtype=np.int64), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]),
                np.array([[1.0, 0.0, 0.0]]), np.ones(1), np.ones(1), np.zeros((1, 3)), 0.001)
    for body in (cylinder, (np.ones(1, dtype=np.int64), *cylinder[1:6], np.ones((1, 3)), 0.001)):
        project(np.full((1, d), 0.5), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
                np.ones(1, dtype=np.int64), 0, np.zeros(1), np.ones(d), -np.ones(d), np.ones(d), 3, 6, body,
                maxiter=2, stall=12, damping=1e-3, htol=1e-11, steptol=1e-9)
        v = np.array([0.5, 0.5])
        least_squares_rounds(np.full((1, d), 0.5), v, v, np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
                             -np.ones(d), np.ones(d), np.ones(d), 3, 6, body, lm=(2, 1, 3, 1e-7, 1e-7),
                             newton=(1, 2, 1, 3, 1e-10), screened=np.full(d, 0.5), fingers=(7, 10), open_f=-1.0,
                             open_lm=2, equations=(np.ones(1, dtype=np.int64), 0, np.zeros(1), np.zeros(1)),
                             near_f=1.0, gn=(2, 12, 1e-3, 1e-11, 1e-9), tol=1e-12)
        feasible(np.full((1, d), 0.5), -np.ones(d), np.ones(d), 3, 6, body)
        clearance(np.zeros((1, 3)), body)
    score(np.full((1, d), 0.5), np.array([0.5, 0.5]), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2),
          np.zeros(d), np.ones(d))
    log_joints(np.full((1, d), 0.5), np.zeros((2, d)), np.stack([np.eye(d)] * 2), np.zeros(2))
    known = np.full((1, 2), 0.5), np.full((1, d), 0.5)
    for array in known:  # the planner's per-model candidates are read-only, a type of their own to numba
        array.setflags(write=False)
    fit_and_distance(known[0], np.array([0.5, 0.5]), known[1], np.zeros(d), np.ones(d))
    for log_v in (np.zeros(2), np.zeros(0)):
        screen(np.zeros((2, 3)), log_v, np.full((3, 2), 0.5), np.array([0.5, 0.5]), 1, 1e-12)
    distinct(np.ones((2, d)), 1e-18)
    lex_order(np.ones((2, 3)))
    landed_votes(np.ones((2, d)), np.ones((2, 2)), np.ones((2, d)), np.zeros((2, d)), 1)
    search_bandwidths(np.ones((2, d)), np.ones(2), np.ones(d), 0, -1, 1, 1, 1e-9)
    landed_thresholds(np.zeros((2, d)), np.zeros(1, dtype=np.int64), np.zeros(1), np.ones(1),
                      np.array([0, 1], dtype=np.int64), 1)
    choice_order(np.ones(2), np.ones(2), np.arange(2), np.ones((2, d)), np.ones(2, dtype=np.bool_), 1e-12, 1e-6, 3e-3,
                 1e-6, 1e-18)
    select_demonstrations(np.full((2, 2), 0.5), np.array([0.5, 0.5]), np.ones((2, 2), dtype=np.bool_),
                          np.zeros(1, dtype=np.int64), 1, 1e-12)
    eye = np.eye(3)
    limits = -np.ones(2), np.ones(2)
    for limit in limits:  # MicoKinematics's joint limits are read-only arrays, a type of their own to numba
        limit.setflags(write=False)
    ik_descent(np.zeros(2), *limits, (np.stack([eye, eye]), np.zeros((2, 3)),
               np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), eye, np.array([1.0, 0.0, 0.0])), eye,
               np.array([0.0, 1.0, 0.0]), 2)
