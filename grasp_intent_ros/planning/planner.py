"""Grasp planning under intent uncertainty: :func:`plan`, the one entry to every method.

Every method takes a model and v (K entries, a probability vector over the model's zones, e.g.
:func:`grasp_intent_ros.method.intent.interpret`), optionally a warm start (the previous plan of a stream)
and an ``accept`` hook (e.g. IK reachability, asked about candidates in the choice order; the first it
takes is returned, status 'rejected' when it takes none), and answers within the feasible set X
(:mod:`.common`). Two stated problems (docs/planner.md puts them side by side with the figures that decided
the default), one module each:

- ``method='task'`` (the default, :mod:`.task`): the demonstration that serves the likely tasks;
- ``method='lm'`` (the paper's planner, :mod:`.lm`): a match of P to v, nearest to a reference;
- ``method='slsqp'`` and ``'trust-constr'`` (the paper's solvers, :mod:`.scipy_methods`): f minimised from
  the demonstration starts, with the choice of 'lm'.

Each method has one typed options class (:mod:`.options`); the result (:class:`~.common.PlanResult`) means
the same for every method. Machine independence: methods 'task' and 'lm' give the same bits under any BLAS;
the scipy methods may differ in their last bits between machines (their modules say why).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PlanningError
from ..method.model import GraspModel
from .common import WARM_BAND, Feasible, PlanResult, Search, check_v, select_starts
from .lm import plan_lm
from .options import DEFAULT_METHOD, Method, Options, ScipyOptions, TaskOptions, check_options
from .scipy_methods import plan_scipy
from .task import serve

__all__ = ['plan']


def plan(model: GraspModel, v: ArrayLike, *, method: Method = DEFAULT_METHOD, options: Options | None = None,
         warm_start: ArrayLike | None = None,
         accept: Callable[[NDArray[np.float64]], bool] | None = None) -> PlanResult:
    """Plan a grasp for target v (module docstring): by default the demonstration that serves the likely tasks.

    Parameters
    ----------
    model : GraspModel
    v : array_like, shape (K,)
        Target vector over the model's zones (see :func:`grasp_intent_ros.method.intent.interpret`).
    method : {'task', 'lm', 'slsqp', 'trust-constr'}
        ``'task'`` (default, :data:`~.options.DEFAULT_METHOD`): serve the likely tasks (:mod:`.task`). The
        paper's planner: ``'lm'``, the exact match by log-odds projection, then projected Levenberg-Marquardt
        least squares when no exact match is found (:mod:`.lm`); ``'slsqp'`` and ``'trust-constr'``, the
        paper's solvers on f from the demonstration starts (:mod:`.scipy_methods`).
    options : TaskOptions, LmOptions or ScipyOptions, optional
        The method's options (:mod:`.options`: one class per method); None for its defaults.
    warm_start : array_like, shape (d,), optional
        The reference and first start (e.g. the previous plan).
    accept : callable x -> bool, optional
        Robot constraint that cannot be written as a smooth function (e.g. IK reachability): the first
        candidate in the choice order it accepts is returned.

    Returns
    -------
    PlanResult
        Its fields mean the same for every method; :class:`~.common.Candidate` says where 'task' differs.

    Raises
    ------
    PlanningError
        For a v that is not a probability vector over the model's zones, an unknown method, options of
        another method's class or out of range, or a bad warm start.
    """
    t0 = time.perf_counter()
    v_arr = check_v(model, v)
    opts = check_options(method, options)
    n_starts, top_zones = (1, 1) if isinstance(opts, TaskOptions) else (opts.n_starts, opts.top_zones)
    demo: NDArray[np.float64] | None = None  # the demonstration starts, Algorithm 1's first
    if warm_start is not None:
        ws = np.asarray(warm_start, dtype=np.float64)
        if ws.shape != (model.features.dim,) or not np.all(np.isfinite(ws)):
            raise PlanningError(f'warm_start must be a finite vector of shape ({model.features.dim},)')
        first = ws[None, :]
    else:
        demo = select_starts(model, v_arr, n_starts, top_zones)
        first = demo[:1]  # Algorithm 1's start
    feas = Feasible(model)
    x_ref = feas.project(first)[0]
    if isinstance(opts, TaskOptions):
        return serve(model, v_arr, x_ref, warm_start is not None, accept, opts, t0)
    band = WARM_BAND if warm_start is not None else 0.0  # rule 6 of .lm: a stream keeps its branch within the band
    search = Search(model, v_arr, x_ref, feas, band, accept, demo, n_starts, top_zones, method, t0)
    if method == 'lm':
        return search.result(plan_lm(search))
    assert isinstance(opts, ScipyOptions)
    plan_scipy(search, method, opts)
    return search.result(None)
