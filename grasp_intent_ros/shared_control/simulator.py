r"""The shared-control loop on a simulated clock, with the functions the nodes call (ROS-free).

One episode (:func:`simulate`): an operator (:mod:`.operators`) teleoperates the mock MICO
(:class:`~grasp_intent_ros.mico.mock_arm.MockArm`, the mock arm node's core) through the assistance
(:class:`~grasp_intent_ros.shared_control.assistance.Assistance`, the assistance node's core) toward a grasp the
planner's policy (:func:`~grasp_intent_ros.mico.grasp.plan_grasp`, the planner node's core) plans for the
intent (:func:`~grasp_intent_ros.method.intent.interpret`, the interpreter's core), until the operator closes
the hand or the episode times out. Every ``period`` (0.01 s, the nodes' period): the arm's joints go to the
assistance (joint_states), the operator sends a twist seen ``reaction`` s late, the assistance answers with
one command, the arm follows it for one period. Every ``w_period`` (0.1 s) the estimator reports w, which is
interpreted and planned at once (the nodes take milliseconds: the simulation leaves their latency out),
warm-started from the previous plan of the stream, with the IK seeded at Home (the planner node seeds it with
the arm's joints: the grasp's pose does not depend on the seed, only which IK branch the planner reports, and
the assistance solves its own IK). The planner sees the object where the tracker says it is (``base_T_obj``
of the :class:`Scene`, the true pose plus the tracker's error); the judge sees the true one; the operator
drives to the shown grasp or to its own goals (each via its pre-grasp: :mod:`.operators`), which the caller plans
where the operator sees the object.

Conditions (:data:`CONDITIONS`)
-------------------------------
- ``'direct'``: the planner runs and its grasp is shown, alpha = 0 (``arbitration: none``).
- ``'ada'``: ADA's shared autonomy as published (Javdani et al.; personalrobotics/ada_assistance_policy):
  a goal distribution over the task-serving grasps (the planner's grasp for each certain task set), uniform
  at the start, updated from each operator twist u by log p(g) -= Q_g(x, u) - V_g(x) (Huber distance costs
  with ADA's constants, the action applied for ``ADA_APPLY_TIME``; no goal above 0.99), and the command
  u + sum_g p(g) a_g, a_g ADA's Huber-gradient twist toward goal g. Nothing is shown (ADA shows goal
  probabilities, not a grasp proposal); the robot assists with zero input too (additive, as published).
- ``'independent'``: the suite's assistance on the grasp separate per-task classifiers would choose: the
  planner's grasp for the single most likely task argmax_i w_i (v on that zone alone,
  :func:`~grasp_intent_ros.method.intent.single_task_v`, ties to the lowest index; the planner node's
  ``plan_for: most_likely_task``), shown; the assistance keeps v = interpret(w).
- ``'suite'``: the suite: v = interpret(w), the planner's grasp, the assistance's ``confidence`` rule, shown.

The grasp command (:func:`.loop_steps.execute_grasp`). Under the suite's assistance (``'suite'``,
``'independent'``), when the operator closes on the shown grasp, the suite executes that grasp, as the nodes do on
``grasp/execute`` then ``grasp/close``: the arm follows a trajectory from its joints to the newest plan's inverse
kinematics (nearest them, as the planner node seeds it with the arm's joints) at its velocity limits, then the
fingers close. The operator closes once the hand it sees is within the reach tolerance of the grasp, and a hand
that came down the approach axis is then up to that tolerance short of it: closed there, the grasp is shallower
than the planned one (the cup's transfer loses palm contact). Executed, the hand is at the grasp that was planned
(and shown, and trusted by the arbitration). Under ``'direct'`` and ``'ada'`` the hand closes where it is
(``execute=False`` in :func:`simulate` closes where it is under every condition).

With an :class:`~.estimator.IntentEstimator` (``estimator``), w comes from it instead of the intent script
(the intent node's place in the suite, ``suite --with intent_estimator``): it is reset at the start and fed,
every period, the operator's own twist (before blending, so the assistance never creates its own evidence)
with the hand's pose at that tick, and each grasp planned, as the proposal shown (the node's ``grasp/pose``);
every ``w_period`` its w is interpreted and planned as the script's would be. The script then gives only the
operator's true task set: the estimator never sees it. With ``classifier_prior`` the script's w also reaches the
estimator, as its task prior (:meth:`~.estimator.IntentEstimator.set_task_prior`; the node's ``intent/prior``),
every ``w_period`` before the estimator's w is read: the script plays the per-task classifiers whose w the
motion refines.

The simulation returns what happened, never a verdict: where the hand closed (base frame) and the closures the
fingers executed, when it closed, the operator's effort and each shown grasp's alpha-time, and how deep the open
hand's path went into the object's body on the way (:mod:`.sweep`, in the true frame: the loop has no contact
model, so a path may pass through the object); the caller judges, at the scene's true object pose (the task rules
never enter here: :func:`grasp_intent_ros.objects.judge.judge` is the benchmarks' judge).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..method.intent import Interpretation, ZoneInterpreter, all_zones, interpret, single_task_v
from ..method.model import GraspModel
from ..mico.collision import HandCollision
from ..mico.grasp import Grasp, plan_grasp
from ..mico.kinematics import BASE_FRAME, HOME_Q, MicoKinematics
from ..mico.mock_arm import MockArm, TwistCommand
from ..planning.options import Options
from .ada import AdaAssistance
from .assistance import Assistance
from .assistance_config import AssistanceConfig
from .clearance import default_hand
from .estimator import IntentEstimator
from .limits import TwistLimiter
from .loop_steps import Episode, close_hand, executes_shown, feed_plan, swept_into, take_operator_twist
from .operators import IntentScript, ScriptedOperator, certain_w
from .sweep import SWEEP_TICKS, PathSweep

__all__ = ['Condition', 'CONDITIONS', 'Scene', 'PlanStream', 'TraceRow', 'simulate', 'perturb_pose', 'certain_grasp',
           'certain_grasps']

Condition = Literal['direct', 'ada', 'independent', 'suite']
CONDITIONS: tuple[Condition, ...] = ('direct', 'ada', 'independent', 'suite')
_ZONES = all_zones(3)


def perturb_pose(base_T: NDArray[np.float64], position_rms: float, angle_rms: float,
                 rng: np.random.Generator) -> NDArray[np.float64]:
    """``base_T`` moved by N(0, (position_rms^2 / 3) I) m and turned by a rotation vector N(0, (angle_rms^2 / 3) I)."""
    import pinocchio as pin  # type: ignore[import-untyped, unused-ignore]

    out = base_T.copy()
    out[:3, 3] += rng.normal(0.0, position_rms / math.sqrt(3.0), 3)
    out[:3, :3] = np.asarray(pin.exp3(rng.normal(0.0, angle_rms / math.sqrt(3.0), 3))) @ base_T[:3, :3]
    return out


def certain_grasp(model: GraspModel, task_set: int, base_T_obj: NDArray[np.float64], kin: MicoKinematics,
                  options: Options | None = None, object_margin: float | None = None) -> Grasp:
    """The planner's grasp (cold, IK from Home) for the certain w of ``task_set`` (:func:`.operators.certain_w`).

    An operator's own grasp for its task set (bitmask over ``model.task_names``), chosen without the rules: the
    scripted operators' (the benchmarks', the scripted operator node's), and ADA's goals. ``options``: the
    planner's (:func:`~grasp_intent_ros.mico.grasp.plan_grasp`; None: the library's, an exact landing; the
    nodes' answers need :func:`~grasp_intent_ros.planning.options.node_default_options`); ``object_margin``: the
    collision check's, as :attr:`Scene.object_margin`.

    Raises
    ------
    ValueError
        If the planner finds no reachable grasp for the set (the object is out of the arm's reach).
    """
    zones = all_zones(len(model.task_names))
    read = interpret(certain_w(task_set, len(model.task_names)), zones)
    assert isinstance(read, Interpretation)  # a certain w never asks for clarification
    grasp = plan_grasp(model, read.v, zones, base_T_obj, kin, options=options, hand=_hand(object_margin),
                       margin=object_margin or 0.0)
    if not isinstance(grasp, Grasp):
        raise ValueError(f'no grasp for the certain task set {task_set}: {grasp}')
    return grasp


def certain_grasps(model: GraspModel, base_T_obj: NDArray[np.float64], kin: MicoKinematics,
                   options: Options | None = None, object_margin: float | None = None) -> dict[int, Grasp]:
    """:func:`certain_grasp` for each task set 1..2^m - 1 of the model's m tasks (arguments and errors as there)."""
    return {task_set: certain_grasp(model, task_set, base_T_obj, kin, options, object_margin)
            for task_set in range(1, 1 << len(model.task_names))}


def _hand(object_margin: float | None) -> HandCollision | None:
    """The hand :func:`~grasp_intent_ros.mico.grasp.plan_grasp` checks with ``object_margin`` (None: unchecked)."""
    return None if object_margin is None else default_hand()


@dataclass(frozen=True)
class Scene:
    """What one episode runs on: the model, the object's true and tracked poses, the kinematics, the planner's options.

    ``options`` None: the library's defaults (an exact landing); the planner node's are
    :func:`~grasp_intent_ros.planning.options.node_default_options`. ``object_margin`` (m): the planner's
    collision check (the planner node's ``collision_check``) with that object margin preferred (its
    ``object_margin``: :func:`~grasp_intent_ros.mico.grasp.plan_grasp`'s ``margin``); None: unchecked (the
    shipped demonstrations are all clear under :data:`~grasp_intent_ros.mico.collision.LIMITS` in the object
    frame, so without a margin the check turns none down and only costs time).
    """

    model: GraspModel
    base_T_obj_true: NDArray[np.float64]
    base_T_obj: NDArray[np.float64]
    kin: MicoKinematics
    options: Options | None = None
    object_margin: float | None = None


class PlanStream:
    """The planner node's stream of plans on the simulated clock: warm-started, cached by (v, warm start).

    ``cache`` may be shared between streams of the same scene and kind: the plan is a function of them.
    """

    def __init__(self, scene: Scene, kind: Literal['intent', 'single'], cache: dict[bytes, Grasp | None]) -> None:
        self.scene, self.kind, self.cache = scene, kind, cache
        self.warm: NDArray[np.float64] | None = None
        self._interpreter = ZoneInterpreter(3, _ZONES)

    def plan(self, w: NDArray[np.float64]) -> tuple[NDArray[np.float64] | None, Grasp | None]:
        """(v, grasp) for the estimator's ``w``; v None asks for clarification, grasp None: nothing reachable."""
        read = self._interpreter.interpret_checked(w)
        if not isinstance(read, Interpretation):
            return None, None
        v = read.v
        target = v
        if self.kind == 'single':  # separate per-task classifiers: the grasp for the most likely task alone
            single = single_task_v(v, _ZONES, 3)
            assert single is not None  # an interpretation's v sums to 1
            target = single
        key = self.kind.encode() + target.tobytes() + (b'' if self.warm is None else self.warm.tobytes())
        if key not in self.cache:
            planned = plan_grasp(self.scene.model, target, _ZONES, self.scene.base_T_obj, self.scene.kin,
                                 q_arm=HOME_Q, warm_start=self.warm, options=self.scene.options,
                                 hand=_hand(self.scene.object_margin), margin=self.scene.object_margin or 0.0)
            self.cache[key] = planned if isinstance(planned, Grasp) else None
        grasp = self.cache[key]
        if grasp is not None:
            self.warm = grasp.result.x
        return v, grasp


@dataclass
class TraceRow:
    """The loop's state over one ``w_period`` of an episode (``simulate(..., trace=...)``; nothing judged).

    Attributes
    ----------
    t : float
        Seconds from the start to the w report that opens the period.
    w : ndarray, shape (m,)
        The w reported (the script's or the estimator's).
    v : ndarray, shape (K,) or None
        Its interpretation (None: clarification asked).
    shown_set : int or None
        The task set (the demonstration's label, as the assistance finds it) of the grasp shown over the period;
        None for no grasp or a grasp that is no demonstration.
    shown : ndarray, shape (4, 4) or None
        The shown grasp's pose (base frame).
    shown_x : ndarray, shape (10,) or None
        The shown grasp's features as planned (the tracked object frame).
    hand : ndarray, shape (4, 4)
        The hand's pose at the report.
    alpha : float
        Mean arbitration weight over the period's commands.
    pursued : str
        'shown' or 'own': the goal the operator pursued at the period's last tick.
    task_set : int
        The operator's true task set at the report.
    """

    t: float
    w: NDArray[np.float64]
    v: NDArray[np.float64] | None
    shown_set: int | None
    shown: NDArray[np.float64] | None
    shown_x: NDArray[np.float64] | None
    hand: NDArray[np.float64]
    alpha: float = 0.0
    pursued: str = ''
    task_set: int = 0


def simulate(scene: Scene, condition: Condition, intent: IntentScript, operator: ScriptedOperator,
             own_goals: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]], intent_rng: np.random.Generator,
             closure_rng: np.random.Generator, *, ada_goals: list[tuple[NDArray[np.float64], NDArray[np.float64]]],
             plan_cache: dict[bytes, Grasp | None], timeout: float = 25.0, period: float = 0.01,
             w_period: float = 0.1, closure_error: float = 0.05, config: AssistanceConfig | None = None,
             estimator: IntentEstimator | None = None, classifier_prior: bool = False, execute: bool = True,
             trace: list[TraceRow] | None = None, twist_joint_limit: str = 'clip') -> Episode:
    """Run one episode (module docstring).

    Parameters
    ----------
    own_goals : dict task set -> (base_T_ee, closures)
        The operator's own grasp per task set (base frame; planned where the operator sees the object), chosen
        without the rules.
    ada_goals : list of (base_T_ee, features)
        ADA's goals, in the tracked frame (the robot's perception).
    intent_rng, closure_rng
        The estimator's noise; the hand's closure error (N(0, closure_error^2) per finger).
    config : AssistanceConfig, optional
        The suite's assistance settings (default: the node's defaults); ``arbitration`` is set by the condition.
    estimator : IntentEstimator, optional
        The source of w instead of ``intent.w`` (module docstring); reset here, its goals at the tracked object.
    classifier_prior : bool
        With ``estimator``: whether ``intent.w`` is the estimator's task prior (module docstring); False: the
        estimator's default prior.
    execute : bool
        Whether the suite's grasp command executes the shown grasp (module docstring); False: the hand closes
        where it is under every condition.
    trace : list of TraceRow, optional
        When given, one row per ``w_period`` is appended to it (the loop's state; a diagnostic's record).
    twist_joint_limit : str
        The mock arm's rule for a twist at a joint limit (:class:`~.mico.mock_arm.MockArm`): ``'clip'`` or ``'stop'``.
    """
    kin = scene.kin
    base = config or AssistanceConfig()
    rule = 'none' if condition == 'direct' else 'confidence'
    limiter = TwistLimiter(0.2, 1.0, 1.0, 5.0, max_dt=2.0 * period)
    assistance = Assistance(AssistanceConfig(**{**base.__dict__, 'arbitration': rule}), limiter, kin)
    assistance.set_object(scene.base_T_obj, scene.model.body)  # the robot's perception: the tracked pose
    ada = AdaAssistance([[g] for g, _ in ada_goals], limiter) if condition == 'ada' else None
    stream = PlanStream(scene, 'single' if condition == 'independent' else 'intent', plan_cache)
    arm = MockArm(kin, np.r_[HOME_Q, 0.0, 0.0, 0.0], twist_joint_limit=twist_joint_limit)
    reaction_ticks = max(int(round(operator.c.reaction / period)), 0)
    hands: deque[NDArray[np.float64]] = deque(maxlen=reaction_ticks + 1)
    shown_history: deque[Grasp | None] = deque(maxlen=reaction_ticks + 1)
    shown: Grasp | None = None
    episode = Episode()
    pull: dict[int, list[object]] = {}
    alpha_sum, commands = 0.0, 0
    w_every = max(int(round(w_period / period)), 1)
    ticks = int(round(timeout / period))
    tick = 0
    sweep = PathSweep(kin, scene.model.body, scene.base_T_obj_true)  # the judge's: nothing below reads it
    if estimator is not None:
        estimator.reset()
        estimator.set_task_prior(None)
    for tick in range(ticks):
        now = tick * period
        if tick % SWEEP_TICKS == 0:
            sweep.check(arm.q[:6])
        if tick % w_every == 0:
            if estimator is None:
                w = intent.w(now, intent_rng)
            else:
                if classifier_prior:
                    estimator.set_task_prior(intent.w(now, intent_rng))
                w = estimator.w
            v, grasp = stream.plan(w)
            feed_plan(assistance, scene.model, v, grasp)
            if v is not None and grasp is not None:
                shown = grasp
                if estimator is not None:
                    estimator.set_proposal(grasp.base_T_ee)
            if trace is not None:
                trace.append(TraceRow(now, w, v, assistance.task_set, None if shown is None else shown.base_T_ee,
                                      None if shown is None else shown.result.x, kin.fk(arm.q[:6]),
                                      task_set=intent.task_set(now)))
        q = arm.q[:6].copy()
        assistance.set_joints(q)
        assert assistance.base_T_ee is not None
        hand_now = assistance.base_T_ee
        hands.append(hand_now)
        shown_history.append(shown)
        seen, shown_seen = hands[0], shown_history[0]
        task_set = intent.task_set(now)
        own_pose, own_closures = own_goals[task_set]
        shown_pose = None if shown_seen is None or condition == 'ada' else shown_seen.base_T_ee  # on the screen
        goal, pursued = operator.choose_goal(shown_pose, own_pose)
        if trace:
            trace[-1].pursued = pursued
        if operator.at_goal(seen, goal):
            closures = own_closures if pursued == 'own' or shown_seen is None else shown_seen.positions[6:]
            executes = executes_shown(pursued, execute and condition in ('suite', 'independent'))
            now, episode.hand, episode.closures, episode.executed = close_hand(
                arm, hand_now, closures, shown if executes else None, now, period, closure_rng, closure_error,
                sweep.check)  # grasp/execute: the newest plan
            episode.closed_at, episode.pursued, episode.goal = now, pursued, goal
            break
        h = operator.twist(now, seen, goal)
        take_operator_twist(episode, h, hand_now, period, estimator)
        if ada is not None:
            twist = ada.command(hand_now, h, period)
            p = ada.distribution()
            alpha_sum += 1.0
            for i, pg in enumerate(p):
                pull.setdefault(-1 - i, [ada_goals[i][1], 0.0])[1] += float(pg) * period  # type: ignore[operator]
        else:
            assistance.set_operator(h, now)
            command = assistance.command(now)
            twist = command.twist
            alpha_sum += command.alpha
            if trace:
                trace[-1].alpha += command.alpha / w_every
            if command.alpha > 0.0 and shown is not None:
                entry = pull.setdefault(id(shown), [shown.result.x, 0.0])
                entry[1] += command.alpha * period  # type: ignore[operator]
        arm.command_twist(TwistCommand(twist[:3], twist[3:], BASE_FRAME), now)
        commands += 1
        arm.step(now + period, period)
    sweep.close(arm.q[:6])  # where the hand closed (or stood at the timeout)
    swept_into(episode, sweep)
    episode.task_set = intent.task_set(tick * period)
    episode.alpha_mean = alpha_sum / max(commands, 1)
    episode.pulls = [(np.asarray(x), float(s)) for x, s in pull.values()]  # type: ignore[arg-type]
    return episode

