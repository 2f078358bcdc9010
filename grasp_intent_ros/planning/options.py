"""The planner's methods and their options: one typed class per method, so an unused option cannot be given.

==============  ====================  ==================================================================
method          options class         what the options tune
==============  ====================  ==================================================================
'task'          :class:`TaskOptions`  which tasks are likely (``tau``, ``hysteresis``), what must be
                                      faithful to them (``faithful``), where the arm lands (``noise``)
'lm'            :class:`LmOptions`    the demonstration starts (``n_starts``, ``top_zones``)
'slsqp',        :class:`ScipyOptions` the demonstration starts, scipy's gradient, extra constraints
'trust-constr'
==============  ====================  ==================================================================

:func:`check_options` turns ``None`` into the method's defaults and raises a
:class:`~grasp_intent_ros.errors.PlanningError` for options of another method's class or out of range;
:func:`options_for` builds a method's options from keyword values and raises for a name the method does not
use (a node's parameters, a benchmark's command line); :func:`node_options` builds them from the planner node's
parameters.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import astuple, dataclass, fields
from typing import Any, Literal, Union, get_args

from ..errors import PlanningError
from .ranking import HYSTERESIS, TAU, Faithful
from .robustness import ExecutionNoise

__all__ = ['Method', 'METHODS', 'DEFAULT_METHOD', 'Gradient', 'TaskOptions', 'LmOptions', 'ScipyOptions', 'Options',
           'OPTIONS', 'check_options', 'options_for', 'noise_from', 'NODE_EXECUTION_NOISE', 'node_default_options',
           'node_options']

Method = Literal['task', 'lm', 'slsqp', 'trust-constr']
METHODS: tuple[Method, ...] = get_args(Method)
"""Every :data:`Method`, in order."""
DEFAULT_METHOD: Method = 'task'
"""The method :func:`~grasp_intent_ros.planning.planner.plan` uses unless told otherwise (the planner node's too)."""
Gradient = Literal['analytic', '2-point']


@dataclass(frozen=True)
class TaskOptions:
    """Method 'task' (serve the likely tasks, :mod:`~grasp_intent_ros.planning.ranking`).

    Attributes
    ----------
    tau : float in [0, 1]
        The probability at which a task beyond the top zone is likely.
    hysteresis : float in [0, 1]
        With a warm start, tasks the previous grasp is read as doing stay likely down to ``tau - hysteresis``.
    faithful : {'label', 'reading'}
        What must hold no task outside the likely ones: the demonstration's label (the tasks it does) and
        the model's reading of it (default), or only the reading.
    noise : ExecutionNoise or None
        Where the arm lands around the plan: the choice then maximises the expected success as executed
        (:mod:`~grasp_intent_ros.planning.robustness`; ``ExecutionNoise()`` is the documented 1x level). The
        first plan for a model and noise computes the estimate (about a second of CPU for 560 demonstrations);
        later plans reuse it.
        None (default): an exact landing.
    """

    tau: float = TAU
    hysteresis: float = HYSTERESIS
    faithful: Faithful = 'label'
    noise: ExecutionNoise | None = None


@dataclass(frozen=True)
class LmOptions:
    """Method 'lm' (the paper's planner: match P to v).

    Attributes
    ----------
    n_starts : int >= 1
        Demonstrations to start from (:func:`~grasp_intent_ros.planning.common.select_starts`).
    top_zones : int >= 1
        How many of the most likely zones supply those starts.
    """

    n_starts: int = 3
    top_zones: int = 2


@dataclass(frozen=True)
class ScipyOptions:
    """Methods 'slsqp' and 'trust-constr' (the paper's solvers, scipy, from the demonstration starts).

    Attributes
    ----------
    n_starts, top_zones : int >= 1
        As for :class:`LmOptions`.
    gradient : {'analytic', '2-point'}
        The analytic gradient, or scipy's finite differences (the paper's baseline).
    extra_constraints : sequence
        More smooth constraints, in the form the scipy method takes.
    """

    n_starts: int = 3
    top_zones: int = 2
    gradient: Gradient = 'analytic'
    extra_constraints: Sequence[Any] = ()


Options = Union[TaskOptions, LmOptions, ScipyOptions]
OPTIONS: Mapping[Method, type[TaskOptions] | type[LmOptions] | type[ScipyOptions]] = {
    'task': TaskOptions, 'lm': LmOptions, 'slsqp': ScipyOptions, 'trust-constr': ScipyOptions}
"""Method -> its options class."""


def check_options(method: str, options: Options | None) -> Options:
    """``options`` checked for ``method`` (its defaults when None).

    Raises
    ------
    PlanningError
        For an unknown method, options of another method's class, or a value out of range.
    """
    if method not in OPTIONS:
        raise PlanningError(f'method must be one of {", ".join(map(repr, METHODS))}, got {method!r}')
    cls = OPTIONS[method]  # type: ignore[index]
    if options is None:
        return cls()
    if type(options) is not cls:
        raise PlanningError(f'method {method!r} takes {cls.__name__}, got {type(options).__name__}')
    if isinstance(options, TaskOptions):
        if not (0.0 <= options.tau <= 1.0 and 0.0 <= options.hysteresis <= 1.0):
            raise PlanningError(f'tau and hysteresis must lie in [0, 1], got {options.tau!r} and '
                                f'{options.hysteresis!r}')
        if options.faithful not in get_args(Faithful):
            raise PlanningError(f"faithful must be 'label' or 'reading', got {options.faithful!r}")
        if options.noise is not None and not isinstance(options.noise, ExecutionNoise):
            raise PlanningError(f'noise must be an ExecutionNoise or None, got {type(options.noise).__name__}')
        return options
    if options.n_starts < 1 or options.top_zones < 1:
        raise PlanningError('n_starts and top_zones must be at least 1')
    if isinstance(options, ScipyOptions) and options.gradient not in get_args(Gradient):
        raise PlanningError(f"gradient must be 'analytic' or '2-point', got {options.gradient!r}")
    return options


def options_for(method: str, **values: Any) -> Options:
    """The options of ``method`` with ``values`` set, checked (:func:`check_options`).

    Raises
    ------
    PlanningError
        For an unknown method, a name the method's options do not have, or a value out of range.
    """
    if method not in OPTIONS:
        raise PlanningError(f'method must be one of {", ".join(map(repr, METHODS))}, got {method!r}')
    cls = OPTIONS[method]  # type: ignore[index]
    names = {f.name for f in fields(cls)}
    unused = sorted(set(values) - names)
    if unused:
        raise PlanningError(f'method {method!r} does not use {", ".join(unused)} '
                            f'(its options: {", ".join(sorted(names))})')
    return check_options(method, cls(**values))


def noise_from(values: Sequence[float]) -> ExecutionNoise | None:
    """The planner node's ``execution_noise`` (palm m, tilt rad, roll rad, closure rad) as the 'task' option.

    Returns None (an exact landing) when all four are zero.

    Raises
    ------
    PlanningError
        When it is not 4 numbers, or one is negative or not finite.
    """
    if len(values) != 4:
        raise PlanningError(f'execution noise must be 4 numbers (palm m, tilt rad, roll rad, closure rad), '
                            f'got {list(values)}')
    noise = ExecutionNoise(*(float(v) for v in values))
    return None if noise.is_zero else noise


NODE_EXECUTION_NOISE: tuple[float, float, float, float] = astuple(ExecutionNoise())
"""The planner node's default ``execution_noise`` (palm m, tilt rad, roll rad, closure rad): the documented 1x level."""


def node_default_options() -> Options:
    """The options the planner node plans with under its default parameters.

    :data:`DEFAULT_METHOD` planning for :data:`NODE_EXECUTION_NOISE`: what a scripted operator or a benchmark
    uses to know the node's answer.
    """
    return options_for(DEFAULT_METHOD, noise=noise_from(NODE_EXECUTION_NOISE))


def node_options(method: str, n_starts: int, execution_noise: Sequence[float] = (0.0, 0.0, 0.0, 0.0)) -> Options:
    """The planner node's options: ``method``'s defaults with its ``n_starts`` or ``execution_noise``.

    ``execution_noise`` becomes the 'task' option ``noise`` (:func:`noise_from`).

    The node's ``n_starts`` parameter is for the methods that start from demonstrations ('lm', 'slsqp',
    'trust-constr'); 'task' ranks every demonstration and takes none. Its ``execution_noise`` is for 'task'
    only (the other methods match P to v and do not plan for the landing).

    Raises
    ------
    PlanningError
        As :func:`options_for` and :func:`noise_from`.
    """
    if method == 'task':
        return options_for(method, noise=noise_from(execution_noise))
    return options_for(method, n_starts=n_starts)
