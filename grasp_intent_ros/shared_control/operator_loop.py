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

The grasp command (:func:`executes`, :class:`GraspCommand`): under the suite's assistance, a close on the shown
grasp executes it first, as the simulated loop models (:mod:`.simulator`, "The grasp command"): zero twists until
the hand is seen at rest (:func:`hand_at_rest`), then ``grasp/execute`` (the mock arm follows the planner's latest
``grasp/trajectory`` from then on), then ``grasp/close`` once that trajectory has had its time, so the fingers
close at the planned grasp, not up to the reach tolerance short of it. On its own grasp (or without the suite's
assistance) the hand closes where it is. The node and the probe time it with the same :class:`GraspCommand`.

An episode's states (:data:`STATES`), each tick of :meth:`OperatorEpisodes.step`:

====================  ==================================================================================
``waiting``           for the hand (a joint state) and the operator's own goal; zero twists
``starting``          ``start_delay`` s from the moment both are there; zero twists
``reaching``          :func:`operator_step` until it closes the hand: on the shown grasp with
                      ``execute_shown`` then ``closing`` (a zero twist), else the step says ``close``
                      (then ``holding``)
``closing``           zero twists; once the hand is seen at rest (at the latest :data:`STOP_WAIT` s) the
                      step says ``execute``; the caller reports the execute's answer
                      (:meth:`OperatorEpisodes.executed`); once the :class:`GraspCommand` is due (the
                      trajectory's time, at once when refused, at the latest ``execute_timeout`` s from the
                      request) the step says ``close``; then ``holding``
``holding``           ``hold`` s of zero twists from the fingers' close; then ``resetting``, or ``done`` after
                      the last episode
``resetting``         waits for :meth:`OperatorEpisodes.reset_done` (the caller resets the arm); then a new
                      episode starts at ``waiting``, its hand seen only from then on
``done``              zero twists; after the last episode, ``resetting`` again once ``episodes`` is raised
                      past the current one or set to 0 (a parameter change: a new episode without a
                      restart); after a failed reset, for good
====================  ==================================================================================

A reset is asked only after ``holding``: it never cuts an execution short.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Generic, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..method.model import GraspModel
from ..mico.frames import offset
from ..mico.grasp import Grasp
from ..mico.kinematics import MicoKinematics
from ..planning.options import node_default_options
from .loop_steps import executes_shown
from .operators import ScriptedOperator
from .simulator import certain_grasp

__all__ = ['Perceived', 'Step', 'operator_step', 'task_set_of', 'own_grasp', 'SETTLE', 'EXECUTE_TIMEOUT', 'STOP_WAIT',
           'REST_DISTANCE', 'REST_ANGLE', 'hand_at_rest', 'executes', 'GraspCommand',
           'State', 'STATES', 'Closed', 'OperatorEpisodes']

T = TypeVar('T')

State = Literal['waiting', 'starting', 'reaching', 'closing', 'holding', 'resetting', 'done']
STATES: tuple[State, ...] = ('waiting', 'starting', 'reaching', 'closing', 'holding', 'resetting', 'done')


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
        newest = self.newest(t, 1)
        return newest[0] if newest else None

    def newest(self, t: float, n: int) -> list[T]:
        """The ``n`` newest values received at or before ``t`` s, newest first (fewer when fewer are kept)."""
        out: list[T] = []
        for received, value in reversed(tuple(self._values)):  # a copy: another thread may add meanwhile
            if received <= t:
                out.append(value)
                if len(out) == n:
                    break
        return out

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
        Whether it closes the hand now (the hand it sees is at the goal it pursues; in
        :meth:`OperatorEpisodes.step`, the fingers close now: ``grasp/close``).
    goal : ndarray, shape (4, 4)
        The goal pursued (base frame).
    pursued : str
        'shown' or 'own'.
    execute : bool
        Only from :meth:`OperatorEpisodes.step`: the grasp command executes the shown grasp now
        (``grasp/execute``); the fingers close at a later step (``close``).
    """

    twist: NDArray[np.float64]
    close: bool
    goal: NDArray[np.float64]
    pursued: str
    execute: bool = False


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
              kin: MicoKinematics, held_w: Sequence[float] | None = None) -> tuple[int, Grasp]:
    """An operator's task set (:func:`task_set_of` ``names`` over ``model``'s tasks) and its own grasp for it.

    The grasp is the planner's for the certain w of the set (:func:`.simulator.certain_grasp`) with the planner
    node's default options, the object at ``base_T_obj`` (4x4, base frame): the live benchmark's operator goal.
    ``held_w``: the w the operator publishes (the scripted operator node's with ``intent: held``), checked first.

    Raises
    ------
    GraspIntentError
        For a ``held_w`` without one probability per task of the model, a task the model lacks, or when no grasp
        for the set is reachable.
    """
    if held_w is not None and len(held_w) != len(model.task_names):
        raise GraspIntentError(f'w {list(held_w)} has not one probability per task of the model '
                               f'({", ".join(model.task_names)})')
    task_set = task_set_of(names, model.task_names)
    try:
        return task_set, certain_grasp(model, task_set, base_T_obj, kin, options=node_default_options())
    except ValueError as exc:
        raise GraspIntentError(str(exc)) from None


SETTLE = 0.1
"""Seconds from an executed trajectory's end to the fingers' close: a few of the arm's 0.01 s joint-state periods
and a service answer's latency, so that the close finds the arm at the trajectory's last point."""
EXECUTE_TIMEOUT = 10.0
"""The default longest wait (s) from ``grasp/execute`` to ``grasp/close`` (:class:`GraspCommand`): the node's
``execute_timeout``, the live benchmark's."""
STOP_WAIT = 1.0
"""The longest wait (s) from the operator's close to ``grasp/execute`` for the hand seen at rest (a real arm's
joint noise may never look still); the assistance's acceleration limit brings its output to zero in a few ticks."""
REST_DISTANCE = 1e-5
REST_ANGLE = 1e-4
"""Two successive hand poses within these (m, rad) say the hand is at rest: 1 mm/s and 0.01 rad/s at 100 Hz."""


def hand_at_rest(hands: Perceived[NDArray[np.float64]], now: float) -> bool:
    """Whether the two newest hand poses (4x4, base frame) received by ``now`` (s) agree within the rest tolerances.

    Why before ``grasp/execute``: when the operator stops, the assistance's output decelerates within its
    acceleration limit over a few ticks, and a non-zero twist ends a trajectory the mock arm has begun; once
    the hand is at rest, the twists that reach the arm are zero, which leave the trajectory running.
    """
    newest = hands.newest(now, 2)
    if len(newest) < 2:
        return False
    distance, angle = offset(newest[0], newest[1])
    return distance <= REST_DISTANCE and angle <= REST_ANGLE


def executes(step: Step, execute_shown: bool) -> bool:
    """Whether the grasp command at ``step`` executes the goal before the fingers close (module docstring).

    True for a close on the shown grasp when ``execute_shown`` (the suite's assistance), by the simulated loop's
    rule (:func:`~.loop_steps.executes_shown`); a close on the operator's own grasp, or without ``execute_shown``,
    closes the hand where it is.
    """
    return step.close and executes_shown(step.pursued, execute_shown)


@dataclass
class GraspCommand:
    """When ``grasp/execute`` is asked and the fingers close, from the operator's close at ``started`` s.

    The caller sends zero twists, asks ``grasp/execute`` once :meth:`ready` (the hand seen at rest, at the latest
    :data:`STOP_WAIT` s after ``started``) and calls :meth:`request`, reports the answer (:meth:`answered`) and
    calls ``grasp/close`` once :meth:`due`. The close is due :data:`SETTLE` s after the executed trajectory's end:
    ``duration`` (its last ``time_from_start``, the latest ``grasp/trajectory`` received) counted from the answer
    (the arm started it when it served the request, before answering); at once when the execute is refused (no
    trajectory kept, ``trajectory_execution: on_arrival``, no service: :attr:`refused` says why); and never later
    than ``timeout`` s after the request (no answer, or no trajectory's time known).

    The trajectory's time, not the arm seen at rest again, ends the wait: the mock arm reaches the trajectory's
    last point at exactly that time on its own clock, while an arm at rest cannot be told from one that has not
    yet started (the hand is at rest when the execute is asked).

    Parameters
    ----------
    started : float
        When the operator closed on the shown grasp, s.
    timeout : float
        The longest wait for the close from the request, s (> 0).
    """

    started: float
    timeout: float
    requested: float | None = None
    """When ``grasp/execute`` was asked (s); None before."""
    answered_at: float | None = None
    """When the answer came (s); None before it."""
    refused: str = ''
    """Why the execute was refused ('' unless it was)."""
    close_at: float = math.inf
    """When the fingers close (s); infinite before the request."""

    def ready(self, now: float, at_rest: bool) -> bool:
        """Whether to ask ``grasp/execute`` at ``now`` (s): not yet asked, and ``at_rest`` or :data:`STOP_WAIT` s on."""
        return self.requested is None and (at_rest or now - self.started >= STOP_WAIT)

    def request(self, now: float) -> None:
        """``grasp/execute`` asked at ``now`` (s): the close is due ``timeout`` s later at the latest."""
        self.requested, self.close_at = now, now + self.timeout

    def answered(self, now: float, success: bool, message: str, duration: float | None) -> None:
        """The execute's answer at ``now`` (s); ``duration``: the trajectory's time (s), None if unknown.

        Only the first answer to a request counts.
        """
        if self.requested is None or self.answered_at is not None:
            return
        self.answered_at = now
        if not success:
            self.refused, self.close_at = message or 'refused', min(self.close_at, now)
        elif duration is not None:
            self.close_at = min(self.close_at, now + duration + SETTLE)

    def due(self, now: float) -> bool:
        """Whether the fingers close at ``now`` (s) (never before the request)."""
        return now >= self.close_at


@dataclass(frozen=True)
class Closed:
    """One episode's close: when the fingers closed (s from its reaching start), the goal pursued, where.

    ``pursued``: 'shown' or 'own'; ``executed``: whether the grasp command executed the goal first; ``refused``:
    why an execute asked was not done ('' otherwise).
    """

    episode: int
    time_to_grasp: float
    pursued: str
    goal: NDArray[np.float64]
    executed: bool = False
    refused: str = ''


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
    execute_shown : bool
        Whether a close on the shown grasp executes it first (:func:`executes`; the ``closing`` state).
    execute_timeout : float
        The longest wait from an execute to the fingers' close, s (:class:`GraspCommand`).

    The caller feeds :meth:`hand` and :meth:`shown` as inputs arrive, sets :attr:`own` (None while it is
    prepared; another thread may set it), calls :meth:`step` every tick (on a step with ``execute`` it asks the
    arm to execute and reports the answer to :meth:`executed`; on one with ``close`` it closes the fingers) and,
    on ``resetting``, resets the arm and calls :meth:`reset_done`. While ``own`` is None a reach pauses (zero
    twists).
    """

    operator: ScriptedOperator
    start_delay: float
    hold: float
    episodes: int = 1
    keep: int = 200
    execute_shown: bool = False
    execute_timeout: float = EXECUTE_TIMEOUT
    own: NDArray[np.float64] | None = None
    state: State = 'waiting'
    episode: int = 1
    """The current episode, from 1."""
    closed: list[Closed] = field(default_factory=list)
    pursued: str = ''
    """The goal pursued at the last reaching tick: 'shown' or 'own' ('' before any)."""
    command: GraspCommand | None = None
    """The grasp command of the current ``closing`` state (the last one after it)."""

    def __post_init__(self) -> None:
        self.hands: Perceived[NDArray[np.float64]] = Perceived(self.keep)
        self.shown_grasps: Perceived[NDArray[np.float64]] = Perceived(self.keep)
        self._since = -math.inf  # when the current timed state (starting, reaching, holding) began
        self._reset_failed = False  # a reset failed: done for good
        self._goal = np.eye(4)  # the goal being executed (closing)

    def hand(self, received: float, base_T_ee: NDArray[np.float64]) -> None:
        """The hand's pose (4x4, base frame), received at ``received`` s."""
        self.hands.add(received, base_T_ee)

    def shown(self, received: float, base_T_grasp: NDArray[np.float64]) -> None:
        """A grasp shown (4x4, base frame), received at ``received`` s."""
        self.shown_grasps.add(received, base_T_grasp)

    def step(self, now: float) -> Step | None:
        """The tick at ``now`` (s): a step of ``reaching`` or ``closing``, or None for a zero twist.

        Moves through the states (module docstring). A step with ``close`` closes the fingers (its
        :class:`Closed` is appended to :attr:`closed`, and ``holding`` counts from it); one with ``execute``
        starts the ``closing`` state's :attr:`command`.
        """
        own = self.own  # read once: another thread may set it meanwhile
        if self.state == 'done' and not self._reset_failed and (self.episodes == 0 or self.episode < self.episodes):
            self.state = 'resetting'
        if self.state == 'waiting' and own is not None and self.hands.at(now) is not None:
            self.state, self._since = 'starting', now
        if self.state == 'starting' and now - self._since >= self.start_delay:
            self.state, self._since = 'reaching', now
        if self.state == 'holding' and now - self._since >= self.hold:
            self.state = 'done' if self.episode == self.episodes else 'resetting'
        if self.state == 'closing':
            return self._closing(now)
        if self.state != 'reaching' or own is None:
            return None
        seen = now - self.operator.c.reaction
        step = operator_step(self.operator, now, self.hands.at(seen), self.shown_grasps.at(seen), own)
        self.pursued = step.pursued
        if executes(step, self.execute_shown):
            self.state, self._goal = 'closing', step.goal
            self.command = GraspCommand(now, self.execute_timeout)
            return replace(step, close=False)
        if step.close:
            self._close(now, step.pursued, step.goal)
        return step

    def executed(self, now: float, success: bool, message: str, duration: float | None) -> None:
        """The execute's answer at ``now`` (s), as :meth:`GraspCommand.answered`; ignored outside ``closing``."""
        if self.state == 'closing' and self.command is not None:
            self.command.answered(now, success, message, duration)

    def _closing(self, now: float) -> Step | None:
        command = self.command
        assert command is not None
        if command.ready(now, hand_at_rest(self.hands, now)):  # the hand as it is now: the suite's, not the operator's
            command.request(now)
            return Step(np.zeros(6), False, self._goal, 'shown', execute=True)
        if not command.due(now):
            return None
        unanswered = '' if command.answered_at is not None else f'no answer within {command.timeout:g} s'
        self._close(now, 'shown', self._goal, executed=not (command.refused or unanswered),
                    refused=command.refused or unanswered)
        return Step(np.zeros(6), True, self._goal, 'shown')

    def _close(self, now: float, pursued: str, goal: NDArray[np.float64], *, executed: bool = False,
               refused: str = '') -> None:
        self.closed.append(Closed(self.episode, now - self._since, pursued, goal, executed, refused))
        self.state, self._since = 'holding', now

    def reset_done(self, success: bool) -> None:
        """The arm's reset answered (in ``resetting``): the next episode waits for a new hand; a failure ends."""
        if self.state != 'resetting':
            return
        if not success:
            self.state, self._reset_failed = 'done', True
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
        if self.state == 'closing':
            return ('executing the shown grasp' if self.command is not None and self.command.requested is not None
                    else 'stopping to execute the shown grasp')
        if not self.closed:
            return self.state
        last = self.closed[-1]
        how = ' (executed)' if last.executed else f' (execute refused: {last.refused})' if last.refused else ''
        return (f'{self.state}: episode {last.episode} reached the {last.pursued} grasp in {last.time_to_grasp:.2f} s'
                + how)
