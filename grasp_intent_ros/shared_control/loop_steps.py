r"""The steps both simulated loops take (ROS-free): the plan fed, the grasp command, an episode's record and sweep.

The one-object loop (:func:`.simulator.simulate`) and the loop over several objects
(:func:`.scene_simulator.simulate_scene`) deliver each plan as the nodes do (:func:`feed_plan`, into the assistance
or one object's channel of it), give the grasp command the same way (:func:`executes_shown` decides whether the
shown grasp is executed first; :func:`close_hand` closes, after :func:`execute_grasp` when it is: the nodes'
``grasp/execute`` then ``grasp/close``), and record what an episode did in an :class:`Episode`, the open hand's
sweep into the object's body included (:func:`swept_into`, from a :class:`~.sweep.PathSweep`); each operator twist
goes to the intent estimator, when one runs, and into the episode's effort (:func:`take_operator_twist`). Nothing
here judges.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..errors import CommandError
from ..method.intent import all_zones, default_task_names, zone_labels
from ..method.model import GraspModel
from ..mico.grasp import MIN_TRAJECTORY_TIME, Grasp, trajectory_duration
from ..mico.kinematics import ARM_JOINTS
from ..mico.mock_arm import MockArm
from ..mico.trajectory import TrajectoryCommand
from .arbitration import grasp_task_set
from .sweep import PathSweep

__all__ = ['PlanInputs', 'feed_plan', 'executes_shown', 'execute_grasp', 'close_hand', 'Episode', 'TwistEvidence',
           'take_operator_twist', 'swept_into']

_LABELS = zone_labels(all_zones(3), default_task_names(3))


class PlanInputs(Protocol):
    """What takes a plan's answer (:func:`feed_plan`): :class:`~.assistance.Assistance`'s setters."""

    def clarification(self) -> None: ...

    def set_v(self, v: NDArray[np.float64], labels: Sequence[str]) -> None: ...

    def set_grasp(self, base_T_grasp: NDArray[np.float64]) -> None: ...

    def set_posterior(self, posterior: NDArray[np.float64], zone_labels: Sequence[str],
                      task_names: Sequence[str]) -> None: ...

    def set_task_set(self, task_set: int | None) -> None: ...


def feed_plan(assistance: PlanInputs, model: GraspModel, v: NDArray[np.float64] | None,
              grasp: Grasp | None) -> None:
    """The planner's answer (v, grasp) to one w into ``assistance``, as the nodes deliver it.

    v None (clarification asked): ``clarification()``. Else ``set_v``, then with a grasp ``set_grasp``,
    ``set_posterior`` and ``set_task_set`` (the demonstration's set the grasp's features are nearest,
    :func:`~.arbitration.grasp_task_set`). ``assistance``: the one arm's :class:`~.assistance.Assistance`, or one
    object's channel into the assistance over several objects (:class:`~.scene_assistance.ObjectChannel`).
    """
    if v is None:
        assistance.clarification()
        return
    assistance.set_v(v, _LABELS)
    if grasp is not None:
        assistance.set_grasp(grasp.base_T_ee)
        assistance.set_posterior(grasp.result.posterior, model.zone_labels, model.task_names)
        assistance.set_task_set(grasp_task_set(grasp.result.x, model.demo_x, model.demo_sets, model.feature_scale))


def executes_shown(pursued: str, execute_shown: bool) -> bool:
    """Whether the grasp command on the goal ``pursued`` (``'shown'`` or ``'own'``) executes the shown grasp first.

    True on the shown grasp when ``execute_shown`` (the suite's assistance: conditions ``'suite'`` and
    ``'independent'`` here, the scripted operator's ``execute_shown`` and the live benchmark's ``confidence``
    there); otherwise the fingers close where the hand is (:mod:`.simulator`'s docstring, "The grasp command").
    """
    return execute_shown and pursued == 'shown'


def execute_grasp(arm: MockArm, base_T_grasp: NDArray[np.float64], now: float, period: float,
                  on_step: Callable[[NDArray[np.float64]], object] | None = None) -> float:
    """Move ``arm`` to the grasp ``base_T_grasp`` (4x4, base frame) from ``now``: the time (s) it arrives there.

    The trajectory goes from the arm's joints to the grasp's inverse kinematics from them (no restarts; the 2 pi
    branch nearest them), in :func:`~grasp_intent_ros.mico.grasp.trajectory_duration` at the arm's velocity
    limits (at least :data:`~grasp_intent_ros.mico.grasp.MIN_TRAJECTORY_TIME`), stepped every ``period`` until the
    arm holds (at most one second past the trajectory's end). Without an IK solution, or for a trajectory the arm
    refuses (a branch outside the joint limits), the arm stays and ``now`` is returned. The fingers are not moved.
    ``on_step``, when given, is called with the arm's joints (shape (6,)) after every step.
    """
    q = arm.q[:6].copy()
    ik = arm.kin.ik(base_T_grasp, q, restarts=0)
    if not ik.success:
        return now
    duration = trajectory_duration(q, ik.q, arm.velocity_limits[:6], min_duration=MIN_TRAJECTORY_TIME)
    try:
        arm.command_trajectory(TrajectoryCommand(ARM_JOINTS, [duration], [ik.q.tolist()], [[0.0] * 6], [[]], None),
                               now, allow_partial=True)
    except CommandError:
        return now
    end = now + duration + 1.0
    while arm.mode == 'trajectory' and now < end:
        arm.step(now + period, period)
        now += period
        if on_step is not None:
            on_step(arm.q[:6].copy())
    return now


def close_hand(arm: MockArm, hand: NDArray[np.float64], closures: NDArray[np.float64], execute: Grasp | None,
               now: float, period: float, closure_rng: np.random.Generator, closure_error: float,
               on_step: Callable[[NDArray[np.float64]], object] | None = None
               ) -> tuple[float, NDArray[np.float64], NDArray[np.float64], bool]:
    """The grasp command: (the time, the hand's pose, the closures the fingers executed, whether a plan was executed).

    With ``execute`` (a plan: grasp/execute, then grasp/close), the arm first moves to its grasp
    (:func:`execute_grasp`, ``on_step`` after every step) and the fingers close to its closures; else they close to
    ``closures`` where the hand is (``hand``, its pose now). Either closure gets the closure error
    N(0, ``closure_error``^2) per finger from ``closure_rng`` (clipped to the limits by the arm).
    """
    executed = execute is not None
    if execute is not None:
        now = execute_grasp(arm, execute.base_T_ee, now, period, on_step)
        closures, hand = execute.positions[6:], arm.kin.fk(arm.q[:6])
    return now, hand, arm.close_fingers(closures + closure_rng.normal(0.0, closure_error, 3)), executed


@dataclass
class Episode:
    """What one simulated episode did (nothing judged).

    Attributes
    ----------
    closed_at : float or None
        Seconds from the start to the grasp command; None when the episode timed out first.
    hand : ndarray, shape (4, 4) or None
        The hand's (end effector's) pose in the base frame where it closed; None when the episode timed out.
    closures : ndarray, shape (3,) or None
        The closures the fingers executed there (the grasp's plus the closure error, clipped to the limits), rad.
    task_set : int
        The operator's true task set at the end.
    pursued : str
        'shown' or 'own': the goal the operator closed on.
    goal : ndarray, shape (4, 4) or None
        The pose (base frame) the operator pursued when it closed the hand.
    executed : bool
        Whether the suite executed the shown grasp on the grasp command (:func:`execute_grasp`).
    effort_linear, effort_angular : float
        Integrals of the operator's twist's parts (m, rad).
    pulls : list of (ndarray, float)
        Each proposal the robot pulled toward (its features, in the tracked frame) and its alpha-seconds.
    alpha_mean : float
        The mean arbitration weight over the commands the loop sent (each period's one; 1 for ADA, whose help is
        added in full); 0 when it sent none.
    swept_palm, swept_finger : float
        The deepest (m) the palm/wrist and an open finger went into the object's body along the hand's path
        from the start until the hand closed (the executed trajectory included), in the true object frame
        (:class:`~.sweep.PathSweep`; negative: clear by that much; ``-inf``: never near it). A judge's figure.
    swept : bool
        Whether that path swept into the object: deeper than :data:`~grasp_intent_ros.mico.collision.LIMITS`.
    closing_palm, closing_finger : float
        The same depths at the pose where the hand closed (or stood at the timeout), m.
    in_at_closing : bool
        Whether that pose itself is deeper than the limits (a sweep at the grasp, not only on the way).
    """

    closed_at: float | None = None
    hand: NDArray[np.float64] | None = None
    closures: NDArray[np.float64] | None = None
    task_set: int = 0
    pursued: str = ''
    goal: NDArray[np.float64] | None = None
    executed: bool = False
    effort_linear: float = 0.0
    effort_angular: float = 0.0
    pulls: list[tuple[NDArray[np.float64], float]] = field(default_factory=list)
    alpha_mean: float = 0.0
    swept_palm: float = -math.inf
    swept_finger: float = -math.inf
    swept: bool = False
    closing_palm: float = -math.inf
    closing_finger: float = -math.inf
    in_at_closing: bool = False


class TwistEvidence(Protocol):
    """What reads the operator's own twist as evidence: :meth:`.estimator.IntentEstimator.update`, the scene's."""

    def update(self, base_T_ee: NDArray[np.float64], twist: NDArray[np.float64], dt: float) -> object: ...


def take_operator_twist(episode: Episode, twist: NDArray[np.float64], hand: NDArray[np.float64], period: float,
                        estimator: TwistEvidence | None) -> None:
    """The operator's own ``twist`` (shape (6,), before blending) held for ``period`` s with the hand at ``hand``.

    The estimator's evidence, when one runs (the assistance never creates its own), and the episode's effort: its
    ``effort_linear`` and ``effort_angular`` grow by the twist's linear and angular speeds times ``period``.
    """
    if estimator is not None:
        estimator.update(hand, twist, period)
    episode.effort_linear += float(np.linalg.norm(twist[:3])) * period
    episode.effort_angular += float(np.linalg.norm(twist[3:])) * period


def swept_into(episode: Episode, sweep: PathSweep) -> None:
    """``episode``'s sweep figures (``swept_palm`` ... ``in_at_closing``) from ``sweep``, closed at the hand's end."""
    episode.swept_palm, episode.swept_finger, episode.swept = sweep.palm, sweep.finger, sweep.swept()
    episode.closing_palm, episode.closing_finger = sweep.closing_palm, sweep.closing_finger
    episode.in_at_closing = sweep.in_at_closing()
