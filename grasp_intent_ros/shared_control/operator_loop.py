"""A scripted operator played on a wall clock against what it perceives: the scripted operator node's core.

ROS-free. One :class:`~.operators.ScriptedOperator` (the device and the goal choice, a stated model that never
reads an object's task rules) drives a live loop in episodes (:class:`OperatorEpisodes`); its inputs arrive
as they come (the hand's pose from the joint states, the grasp shown), each kept with the time it was received
(:class:`Perceived`) and read :attr:`~.operators.OperatorConstants.reaction` s late, as the model states.

One tick (:func:`operator_step`): the goal pursued is the shown grasp when it lies near the operator's own goal,
else its own (:meth:`~.operators.ScriptedOperator.choose_goal`); when the hand it sees is at that goal it
closes the hand (no twist), else it sends the device's twist toward the goal's approach
(:meth:`~.operators.ScriptedOperator.twist`). The benchmark's probe (``benchmarks/bench_shared_control.py``)
and the node call it.

An episode's states (:data:`STATES`), each tick of :meth:`OperatorEpisodes.step`:

====================  ==================================================================================
``waiting``           for the hand (a joint state) and the operator's own goal; zero twists
``starting``          ``start_delay`` s from the moment both are there; zero twists
``reaching``          :func:`operator_step` until it closes the hand (the step then says ``close``)
``holding``           ``hold`` s of zero twists after the close; then ``resetting``, or ``done`` after the
                      last episode
``resetting``         waits for :meth:`OperatorEpisodes.reset_done` (the caller resets the arm); then a new
                      episode starts at ``waiting``, its hand seen only from then on
``done``              zero twists
====================  ==================================================================================
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Generic, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..method.model import GraspModel
from ..mico.grasp import Grasp
from ..mico.kinematics import MicoKinematics
from ..planning.options import node_default_options
from .operators import ScriptedOperator
from .simulator import certain_grasp

__all__ = ['Perceived', 'Step', 'operator_step', 'task_set_of', 'own_grasp', 'State', 'STATES', 'Closed',
           'OperatorEpisodes']

T = TypeVar('T')

State = Literal['waiting', 'starting', 'reaching', 'holding', 'resetting', 'done']
STATES: tuple[State, ...] = ('waiting', 'starting', 'reaching', 'holding', 'resetting', 'done')


class Perceived(Generic[T]):
    """Values as they were received (times in s, non-decreasing), read as of a moment: a perception's delay.

    Parameters
    ----------
    keep : int
        How many of the newest values are kept (older ones are forgotten): enough to cover the delay read back
        at the rate they arrive (e.g. 200 joint states at 100 Hz hold 2 s).
    """

    def __init__(self, keep: int) -> None:
        self._values: deque[tuple[float, T]] = deque(maxlen=keep)

    def add(self, received: float, value: T) -> None:
        """Keep ``value``, received at ``received`` s."""
        self._values.append((received, value))

    def __len__(self) -> int:
        """How many values are kept."""
        return len(self._values)

    def at(self, t: float) -> T | None:
        """The newest value received at or before ``t`` s; None when none was (or it was forgotten)."""
        for received, value in reversed(tuple(self._values)):  # a copy: another thread may add meanwhile
            if received <= t:
                return value
        return None

    def clear(self) -> None:
        """Forget every value."""
        self._values.clear()


@dataclass(frozen=True)
class Step:
    """What the operator does at one tick.

    Attributes
    ----------
    twist : ndarray, shape (6,)
        The device's twist (base frame; m/s, rad/s); zero when it closes the hand.
    close : bool
        Whether it closes the hand now (the hand it sees is at the goal it pursues).
    goal : ndarray, shape (4, 4)
        The goal pursued (base frame).
    pursued : str
        'shown' or 'own'.
    """

    twist: NDArray[np.float64]
    close: bool
    goal: NDArray[np.float64]
    pursued: str


def operator_step(operator: ScriptedOperator, now: float, seen_hand: NDArray[np.float64] | None,
                  seen_shown: NDArray[np.float64] | None, own: NDArray[np.float64]) -> Step:
    """One tick of ``operator`` at ``now`` (s) with what it sees (module docstring); 4x4 poses, base frame.

    ``seen_hand`` None: it has not seen the hand yet; the twist is zero (its noise still advances).
    ``seen_shown`` None: no grasp shown yet; it pursues ``own``.
    """
    goal, pursued = operator.choose_goal(seen_shown, own)
    if seen_hand is not None and operator.at_goal(seen_hand, goal):
        return Step(np.zeros(6), True, goal, pursued)
    return Step(operator.twist(now, seen_hand, goal), False, goal, pursued)


def task_set_of(names: Sequence[str], task_names: Sequence[str]) -> int:
    """The task set (bitmask over ``task_names``, a model's tasks in order) of the task ``names``.

    Raises
    ------
    GraspIntentError
        (a ValueError) When ``names`` is empty or names a task ``task_names`` lacks, naming them and the tasks.
    """
    unknown = [name for name in names if name not in task_names]
    if unknown or not names:
        raise GraspIntentError(f'task_set {list(names)}: ' + (f'the model has no task {", ".join(unknown)}'
                                                              if unknown else 'no task named')
                               + f'; its tasks are {", ".join(task_names)}')
    return sum(1 << list(task_names).index(name) for name in set(names))


def own_grasp(model: GraspModel, names: Sequence[str], base_T_obj: NDArray[np.float64],
              kin: MicoKinematics) -> tuple[int, Grasp]:
    """An operator's task set (:func:`task_set_of` ``names`` over ``model``'s tasks) and its own grasp for it.

    The grasp is the planner's for the certain w of the set (:func:`.simulator.certain_grasp`) with the planner
    node's default options, the object at ``base_T_obj`` (4x4, base frame): the live benchmark's operator goal.

    Raises
    ------
    GraspIntentError
        For a task the model lacks, or when no grasp for the set is reachable.
    """
    task_set = task_set_of(names, model.task_names)
    try:
        return task_set, certain_grasp(model, task_set, base_T_obj, kin, options=node_default_options())
    except ValueError as exc:
        raise GraspIntentError(str(exc)) from None


@dataclass(frozen=True)
class Closed:
    """One episode's close: when (s from its reaching start), which goal it pursued ('shown'/'own'), and where."""

    episode: int
    time_to_grasp: float
    pursued: str
    goal: NDArray[np.float64]


@dataclass
class OperatorEpisodes:
    """A :class:`~.operators.ScriptedOperator` in episodes on a wall clock (module docstring).

    Parameters
    ----------
    operator : ScriptedOperator
    start_delay : float
        s from the moment the hand and the own goal are there to the reaching start (>= 0).
    hold : float
        s of zero twists after a close before the next episode's reset (>= 0).
    episodes : int
        How many episodes; 0: without end.
    keep : int
        Inputs kept per :class:`Perceived` (they must cover the reaction time).

    The caller feeds :meth:`hand` and :meth:`shown` as inputs arrive, sets :attr:`own` (None while it is
    prepared; another thread may set it), calls :meth:`step` every tick and, on ``resetting``, resets the arm and
    calls :meth:`reset_done`. While ``own`` is None a reach pauses (zero twists).
    """

    operator: ScriptedOperator
    start_delay: float
    hold: float
    episodes: int = 1
    keep: int = 200
    own: NDArray[np.float64] | None = None
    state: State = 'waiting'
    episode: int = 1
    """The current episode, from 1."""
    closed: list[Closed] = field(default_factory=list)
    pursued: str = ''
    """The goal pursued at the last reaching tick: 'shown' or 'own' ('' before any)."""

    def __post_init__(self) -> None:
        self.hands: Perceived[NDArray[np.float64]] = Perceived(self.keep)
        self.shown_grasps: Perceived[NDArray[np.float64]] = Perceived(self.keep)
        self._since = -math.inf  # when the current timed state (starting, reaching, holding) began

    def hand(self, received: float, base_T_ee: NDArray[np.float64]) -> None:
        """The hand's pose (4x4, base frame), received at ``received`` s."""
        self.hands.add(received, base_T_ee)

    def shown(self, received: float, base_T_grasp: NDArray[np.float64]) -> None:
        """A grasp shown (4x4, base frame), received at ``received`` s."""
        self.shown_grasps.add(received, base_T_grasp)

    def step(self, now: float) -> Step | None:
        """The tick at ``now`` (s): the reaching step, or None for the zero twist of every other state.

        Moves through the states (module docstring); a step with ``close`` ends the reaching (its
        :class:`Closed` is appended to :attr:`closed`).
        """
        own = self.own  # read once: another thread may set it meanwhile
        if self.state == 'waiting' and own is not None and self.hands.at(now) is not None:
            self.state, self._since = 'starting', now
        if self.state == 'starting' and now - self._since >= self.start_delay:
            self.state, self._since = 'reaching', now
        if self.state == 'holding' and now - self._since >= self.hold:
            self.state = 'done' if self.episode == self.episodes else 'resetting'
        if self.state != 'reaching' or own is None:
            return None
        seen = now - self.operator.c.reaction
        step = operator_step(self.operator, now, self.hands.at(seen), self.shown_grasps.at(seen), own)
        self.pursued = step.pursued
        if step.close:
            self.closed.append(Closed(self.episode, now - self._since, step.pursued, step.goal))
            self.state, self._since = 'holding', now
        return step

    def reset_done(self, success: bool) -> None:
        """The arm's reset answered (in ``resetting``): the next episode waits for a new hand; a failure ends."""
        if self.state != 'resetting':
            return
        if not success:
            self.state = 'done'
            return
        self.hands.clear()
        self.episode += 1
        self.state = 'waiting'

    def status(self, now: float) -> str:
        """The state at ``now`` (s) in words, for a status: what it waits for, the goal pursued, the last close."""
        if self.state == 'waiting':
            missing = [what for what, there in (('its own grasp', self.own is not None),
                                                ('the hand (joint_states)', self.hands.at(now) is not None))
                       if not there]
            return f'waiting for {" and ".join(missing)}' if missing else 'waiting'
        if self.state == 'starting':
            return f'reaching in {max(self.start_delay - (now - self._since), 0.0):.1f} s'
        if self.state == 'reaching':
            return f'reaching {"the shown" if self.pursued == "shown" else "its own"} grasp'
        if not self.closed:
            return self.state
        last = self.closed[-1]
        return f'{self.state}: episode {last.episode} reached the {last.pursued} grasp in {last.time_to_grasp:.2f} s'
