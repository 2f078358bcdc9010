r"""The shared-control loop over several objects on a simulated clock (ROS-free): the two-object benchmark's episode.

:func:`simulate_scene` is :func:`.simulator.simulate` with several objects on the table, built from its parts (the
planner's stream per object :class:`~.simulator.PlanStream`, the plan fed as the nodes deliver it
:func:`~.loop_steps.feed_plan`, the grasp command :func:`~.loop_steps.close_hand`, the sweep :mod:`.sweep`) and the
assistance over several objects (:class:`~.scene_assistance.SceneAssistance`, the assistance node's core with
``objects``). docs/several_objects.md ("The simulated benchmark with two objects") gives the design.

Every ``period`` (0.01 s) the arm's joints go to the assistance, the operator's twist (seen ``reaction`` s late)
is answered with one command, the arm follows it for one period. Every ``w_period`` (0.1 s) the intent script
reports P(o) (the estimator's ``intent/objects``) and each object's w^o (its chain's ``intent/w``), in the
objects' order; each chain interprets and plans its w^o at once on the object where the tracker sees it
(:class:`~.simulator.PlanStream`) and its grasp is shown. Under ``'estimated'`` the intent estimator over the
objects reports them instead (below).

The operator (:class:`~.operators.ScriptedOperator`) wants the *true object* (:attr:`SceneIntent.true_object`)
and its true task set; it drives to that object's shown grasp when it is on its way (near its own grasp for the
set on that object), else to its own grasp there, and closes the hand once it sees the hand at the goal. It
never reads a rule, the judge or which object the assistance follows.

Conditions (:data:`SCENE_CONDITIONS`)
-------------------------------------
- ``'direct'``: every chain plans and shows its grasp, alpha = 0.
- ``'ada'``: ADA as published over objects (:class:`~.ada.AdaAssistance`): one goal per object whose targets are
  its task-serving grasps (the caller's :attr:`SceneObject.ada_targets`: the planner's grasp for each certain task
  set on the tracked object), the distribution over objects uniform at the start, updated from the operator's
  twist, a goal's value its target of least cost, the command u + sum_o p(o) a_o. Nothing is shown.
- ``'suite'``: the assistance over several objects: each chain's grasp, v, posterior and task set into its
  channel, P(o) from the script, the follower's hysteresis (``follow_rule``; default
  :class:`~.scene_target.FollowRule`'s).
- ``'top_object'``: the foil "bet on the top object": the suite's assistance on the grasp of one object alone,
  the most likely at the first report (the largest P(o) reported then, a tie to the first object), as if it were
  the only object (P(o) = 1), never switching. Every chain still plans and shows its grasp.
- ``'estimated'``: ``'suite'`` with P(o) and every w^o from the intent estimator over the objects
  (:class:`~.scene_estimator.SceneEstimator`, the ``intent_estimator`` node's core with ``objects``; the
  caller's, one object per scene object in their order, its goals each object's demonstrations at the tracked
  pose), as the suite runs with ``--with intent_estimator``: it is reset at the start and fed, every period, the
  operator's own twist (before blending: the assistance never creates its own evidence) with the hand's pose at
  that tick, and each object's grasp as it is planned, as that object's shown grasp (the node's
  ``/<object>/grasp/pose``); every ``w_period`` its P(o) goes to the assistance and each w^o to its chain. The
  script then gives only the true object and its true set, which the operator pursues and the caller judges:
  the estimator never sees them (nor the script's P(o) or w^o).
- ``'estimated_objects'`` and ``'estimated_tasks'`` (:data:`SPLIT_CONDITIONS`): ``'estimated'`` with one of its two
  sources scripted, to tell their shares apart. The estimator is fed as under ``'estimated'``; the script reports
  as under ``'suite'`` (every report drawn, in its order, so the scripted part is the suite's run's to the last
  bit). ``'estimated_objects'``: P(o) from the estimator, every w^o the script's; ``'estimated_tasks'``: every w^o
  from the estimator, P(o) the script's.

The operator that changes its mind (:meth:`SceneIntent.first_move_other`) heads for another object first (its
shown grasp when on its way, else its own grasp there for its intent's true set, the rule above) and turns to the
true object at :attr:`SceneIntent.t_switch`; what it sees of the shown grasps is ``reaction`` s old, whichever
object it pursues. Nothing else changes: the estimator takes its twist alone, the script's P(o) follows the
change late (:meth:`SceneIntent.object_probabilities`).

The grasp command. Under the suite's assistance (every condition but ``'direct'`` and ``'ada'``) a close on the
shown grasp executes the newest plan of the object *followed* (grasp/execute, then grasp/close: the mock arm
closes to the followed object's plan, docs/several_objects.md), which is another object's grasp when the
assistance follows another object than the operator's. Nothing followed yet, a close on the operator's own
grasp, ``execute`` False, or under ``'direct'`` and ``'ada'``: the fingers close where the hand is, to the closures
of the goal pursued, as in the one-object loop.

A scene of one object with P(o) = 1 (:meth:`SceneIntent.draw` with one object draws nothing for P(o)) runs the
one-object episode under ``'direct'`` and ``'suite'`` to the last bit (the assistance over one object is the
one-object assistance's, :mod:`.scene_assistance`): the same hand, closures, times, effort, alpha and sweeps from
the same seeds (tested). Not under ``'ada'``: ADA over objects has one goal for the object (its seven targets,
always p = 1), where the one-object ADA's goals are the seven grasps themselves.

The simulation returns what happened, never a verdict (:class:`SceneEpisode`): where the hand closed and the
closures executed, the object followed then, the assistance's weight on another object than the true one, and the
open hand's sweep into *each* object's body in its true frame; the caller judges at each object's true pose.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..mico.grasp import Grasp
from ..mico.kinematics import BASE_FRAME, HOME_Q
from ..mico.mock_arm import MockArm, TwistCommand
from .ada import AdaAssistance
from .assistance import Assistance
from .assistance_config import AssistanceConfig
from .limits import TwistLimiter
from .loop_steps import Episode, close_hand, executes_shown, feed_plan, swept_into, take_operator_twist
from .operators import PersistentIntent, ScriptedOperator
from .scene_assistance import SceneAssistance
from .scene_estimator import SceneEstimator
from .scene_target import FollowRule
from .simulator import PlanStream, Scene
from .sweep import SWEEP_TICKS, PathSweep

__all__ = ['SceneCondition', 'SCENE_CONDITIONS', 'SPLIT_CONDITIONS', 'ALL_SCENE_CONDITIONS', 'ESTIMATOR_CONDITIONS',
           'SceneIntent', 'SceneObject', 'SceneEpisode', 'simulate_scene']

SceneCondition = Literal['direct', 'ada', 'suite', 'top_object', 'estimated', 'estimated_objects', 'estimated_tasks']
SCENE_CONDITIONS: tuple[SceneCondition, ...] = ('direct', 'ada', 'suite', 'top_object', 'estimated')
"""The benchmark's conditions (module docstring)."""
SPLIT_CONDITIONS: tuple[SceneCondition, ...] = ('estimated_objects', 'estimated_tasks')
"""``'estimated'`` split into its two sources, one estimated and the other scripted (module docstring)."""
ALL_SCENE_CONDITIONS: tuple[SceneCondition, ...] = SCENE_CONDITIONS + SPLIT_CONDITIONS
ESTIMATOR_CONDITIONS: tuple[SceneCondition, ...] = ('estimated', *SPLIT_CONDITIONS)
"""The conditions run with the intent estimator over the objects (:func:`simulate_scene`'s ``estimator``)."""
_ESTIMATED_P: tuple[SceneCondition, ...] = ('estimated', 'estimated_objects')
"""The conditions whose P(o) is the estimator's."""
_ESTIMATED_W: tuple[SceneCondition, ...] = ('estimated', 'estimated_tasks')
"""The conditions whose w^o are the estimator's."""
_SUITE: tuple[SceneCondition, ...] = ('suite', 'estimated') + SPLIT_CONDITIONS
"""The conditions of the suite's assistance over every object with P(o) streamed to it."""


@dataclass(frozen=True)
class SceneIntent:
    """What the operator wants among several objects, and what the intent sources report (persistent ambiguity).

    Attributes
    ----------
    probabilities : tuple of float
        The held P(o), one per object (the objects' order), summing to 1.
    intents : tuple of PersistentIntent
        Each object's w^o script (held at a case with noise) and its true set, one per object.
    true_object : int
        The index of the object the operator wants (for good); its intent's true set is the operator's.
    noise : float
        The reported P(o)'s noise (module docstring of :meth:`object_probabilities`).
    first_object : int or None
        The object the operator heads for first, until ``t_switch`` (:meth:`first_move_other`); None: the
        true object from the first move.
    t_switch : float
        When (s from the episode's start) the operator turns to the true object for good (with ``first_object``).
    delay : float
        How long (s) after ``t_switch`` the reported P(o) follows the change (:meth:`object_probabilities`).
    """

    probabilities: tuple[float, ...]
    intents: tuple[PersistentIntent, ...]
    true_object: int
    noise: float = 0.05
    first_object: int | None = None
    t_switch: float = 0.0
    delay: float = 1.0

    @classmethod
    def draw(cls, index: int, n_objects: int, rng: np.random.Generator, favoured: float = 0.6) -> SceneIntent:
        """Episode ``index``'s intent over ``n_objects`` objects, drawn from ``rng`` in this order.

        Each object's w^o script: :meth:`PersistentIntent.draw` (``index``, so the paper's case ``index`` mod 5 for
        every object, each true set drawn from it). With one object, nothing more: P(o) = (1,), the true object the
        one (the one-object episode's draws exactly). With more: the favoured object uniform among them, its held
        P(o) ``favoured``, the rest shared equally by the others; then the true object drawn from the held P(o).
        """
        intents = tuple(PersistentIntent.draw(index, rng) for _ in range(n_objects))
        if n_objects == 1:
            return cls((1.0,), intents, 0)
        top = int(rng.integers(n_objects))
        held = np.full(n_objects, (1.0 - favoured) / (n_objects - 1))
        held[top] = favoured
        return cls(tuple(held.tolist()), intents, int(rng.choice(n_objects, p=held)))

    def first_move_other(self, rng: np.random.Generator, switch: tuple[float, float] = (1.5, 3.0)) -> SceneIntent:
        """This intent with an operator that first heads for another object, then changes its mind (a stated model).

        The object drawn as the true one (:attr:`true_object`, from the held P(o)) is the one the operator heads
        for first (its intent's true set there); the operator wants another object for good, uniform among the
        others (drawn from ``rng``; with two objects the other one, still one draw), from ``t_switch`` ~
        U(``switch``) s after the episode's start (then drawn from ``rng``), as the one-object goal-changing
        operator's change (``operators.ChangingIntent``). The reported P(o) follows ``delay`` s after the switch
        (:meth:`object_probabilities`). The held P(o), the objects' intents and their true sets are kept.
        Raises ValueError for fewer than two objects or an intent that changes already.
        """
        n = len(self.probabilities)
        if n < 2 or self.first_object is not None:
            raise ValueError(f'an operator heading for another object first needs two objects or more and a true '
                             f'object from the first move ({n} objects, first object {self.first_object})')
        others = [k for k in range(n) if k != self.true_object]
        true = int(rng.choice(others))
        return replace(self, true_object=true, first_object=self.true_object, t_switch=float(rng.uniform(*switch)))

    def pursued_object(self, t: float) -> int:
        """The object the operator heads for at ``t``: :attr:`first_object` before :attr:`t_switch`, then the true."""
        return self.true_object if self.first_object is None or t >= self.t_switch else self.first_object

    def task_set(self, t: float) -> int:
        """The operator's true task set: the true object's intent's."""
        return self.intents[self.true_object].task_set(t)

    def pursued_task_set(self, t: float) -> int:
        """The task set the operator pursues at ``t``: the intent's true set on :meth:`pursued_object` (``t``)."""
        return self.intents[self.pursued_object(t)].task_set(t)

    def object_probabilities(self, rng: np.random.Generator, t: float = 0.0) -> NDArray[np.float64]:
        """One report of P(o) at ``t``: the held P(o) with N(0, ``noise``^2) each, clipped to [0.02, 0.98], normalised.

        With :attr:`first_object` from ``t_switch + delay`` on, the held P(o) is replaced by the certain one of the
        true object (0.95 on it, 0.05 shared by the others; the same noise): the reported P(o) follows the change
        ``delay`` s late, as a goal-changing operator's w follows (``operators.ChangingIntent``). One object:
        exactly (1,), drawing nothing from ``rng``.
        """
        n = len(self.probabilities)
        if n == 1:
            return np.ones(1)
        held = np.asarray(self.probabilities)
        if self.first_object is not None and t >= self.t_switch + self.delay:
            held = np.full(n, 0.05 / (n - 1))
            held[self.true_object] = 0.95
        p = np.clip(held + rng.normal(0.0, self.noise, n), 0.02, 0.98)
        out: NDArray[np.float64] = p / p.sum()
        return out


@dataclass(frozen=True)
class SceneObject:
    """One object of the scene: its name, its :class:`~.simulator.Scene`, the operator's grasps and ADA's targets.

    ``own_goals``: the operator's own grasp per task set on this object (base_T_ee, closures), planned where the
    operator sees it (without the rules); ``ada_targets``: the planner's grasps for the certain task sets on the
    tracked object (ADA's targets of this object's goal).
    """

    name: str
    scene: Scene
    own_goals: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]]
    ada_targets: list[NDArray[np.float64]]


@dataclass
class SceneEpisode(Episode):
    """What one episode over several objects did (nothing judged): :class:`~.loop_steps.Episode`'s figures and these.

    Attributes
    ----------
    true_object : int
        The index of the object the operator wanted.
    followed : str or None
        The object the suite's assistance followed when the hand closed (or at the timeout); None under
        ``'direct'`` and ``'ada'``, or before any was followed.
    executed_object : str or None
        The object whose plan the grasp command executed (None: nothing executed).
    wrong_object_alpha : float
        Alpha-seconds of assistance toward another object than the true one (ADA: its goal probabilities' seconds
        on the other objects, its weight being 1).
    switches : int
        How many times the object the suite's assistance followed changed after the first (0 under ``'direct'``
        and ``'ada'``).
    estimated_p_true : float or None
        Under the estimator (``'estimated'``, :data:`SPLIT_CONDITIONS`): its P(o) of the true object when the hand
        closed (or at the timeout), whether or not it drove the assistance; None under the other conditions.
    follow_delay : float or None
        With an operator that changes its mind (:attr:`SceneIntent.first_object`) under the suite's assistance
        over every object: the time from the switch to the first output that followed the true object (0 when it
        did at the switch); None when none did before the end, the hand closed before the switch, or otherwise.
    estimate_delay : float or None
        As ``follow_delay`` under the estimator, for its P(o) of the true object above 0.5, read at each report
        (every ``w_period``).
    wrong_object_alpha_after : float or None
        With an operator that changes its mind: ``wrong_object_alpha`` from the switch on (None otherwise).
    swept_objects : tuple of bool
        Per object (the scene's order), whether the open hand's path swept into its body (:class:`~.sweep.PathSweep`
        in its true frame); the inherited ``swept`` is whether any did, ``swept_palm`` ... ``closing_finger`` the
        deepest over the objects, ``in_at_closing`` whether the closing pose was in any.
    """

    true_object: int = 0
    followed: str | None = None
    executed_object: str | None = None
    wrong_object_alpha: float = 0.0
    switches: int = 0
    estimated_p_true: float | None = None
    follow_delay: float | None = None
    estimate_delay: float | None = None
    wrong_object_alpha_after: float | None = None
    swept_objects: tuple[bool, ...] = field(default_factory=tuple)


def simulate_scene(objects: Sequence[SceneObject], condition: SceneCondition, intent: SceneIntent,
                   operator: ScriptedOperator, intent_rng: np.random.Generator, closure_rng: np.random.Generator, *,
                   plan_caches: Sequence[dict[bytes, Grasp | None]], timeout: float = 25.0, period: float = 0.01,
                   w_period: float = 0.1, closure_error: float = 0.05, config: AssistanceConfig | None = None,
                   follow_rule: FollowRule | None = None, execute: bool = True,
                   twist_joint_limit: str = 'clip', estimator: SceneEstimator | None = None) -> SceneEpisode:
    """Run one episode over ``objects`` (module docstring); they share one :class:`~.mico.kinematics.MicoKinematics`.

    ``intent`` has one entry per object, in their order. ``plan_caches``: one per object (each
    :class:`~.simulator.PlanStream`'s; may be shared between runs of the same object and tracked pose).
    ``intent_rng``: the reports' noise (per report: P(o), then each object's w^o in order); ``closure_rng``: the
    closure error. ``config``: the assistance's settings (default: the node's), its ``arbitration`` set by the
    condition. ``follow_rule``: the suite's hysteresis. ``execute``: whether the suite's grasp command executes the
    followed object's plan (module docstring). ``twist_joint_limit``: the mock arm's rule for a twist at a joint
    limit (:class:`~.mico.mock_arm.MockArm`). ``estimator``: the source of P(o) and w^o under ``'estimated'``
    (of one of them under :data:`SPLIT_CONDITIONS`; module docstring; reset here), its objects ``objects``' names
    in their order; given under those conditions alone.

    Raises ValueError for as many intents or plan caches as objects, or an ``estimator`` missing under
    ``'estimated'`` or a split condition, given under another condition, or over other objects than ``objects``'
    names in order.
    """
    if len(intent.intents) != len(objects) or len(plan_caches) != len(objects):
        raise ValueError(f'{len(objects)} objects need as many intents and plan caches')
    names = [o.name for o in objects]
    if (estimator is not None) != (condition in ESTIMATOR_CONDITIONS):
        raise ValueError(f'an intent estimator is given under \'estimated\' and its split alone (condition '
                         f'{condition!r}, estimator {"given" if estimator is not None else "missing"})')
    if estimator is not None and list(estimator) != names:
        raise ValueError(f'the estimator\'s objects {list(estimator)} are not the scene\'s {names}')
    kin = objects[0].scene.kin
    base = config or AssistanceConfig()
    limiter = TwistLimiter(0.2, 1.0, 1.0, 5.0, max_dt=2.0 * period)
    rule = 'none' if condition == 'direct' else 'confidence'
    assistance = Assistance(AssistanceConfig(**{**base.__dict__, 'arbitration': rule}), limiter, kin)
    scene_assistance: SceneAssistance | None = None
    if condition == 'direct' or condition in _SUITE:
        scene_assistance = _scene_assistance(assistance, objects, names, follow_rule)
    ada = AdaAssistance([o.ada_targets for o in objects], limiter) if condition == 'ada' else None
    streams = [PlanStream(o.scene, 'intent', cache) for o, cache in zip(objects, plan_caches)]
    arm = MockArm(kin, np.r_[HOME_Q, 0.0, 0.0, 0.0], twist_joint_limit=twist_joint_limit)
    true = intent.true_object
    changing = intent.first_object is not None
    reaction_ticks = max(int(round(operator.c.reaction / period)), 0)
    hands: deque[NDArray[np.float64]] = deque(maxlen=reaction_ticks + 1)
    shown_history: deque[tuple[Grasp | None, ...]] = deque(maxlen=reaction_ticks + 1)
    shown: list[Grasp | None] = [None] * len(objects)
    episode = SceneEpisode(true_object=true, wrong_object_alpha_after=0.0 if changing else None)
    alpha_sum, commands = 0.0, 0
    w_every = max(int(round(w_period / period)), 1)
    ticks = int(round(timeout / period))
    tick = 0
    sweeps = [PathSweep(kin, o.scene.model.body, o.scene.base_T_obj_true) for o in objects]  # the judge's

    def check(q: NDArray[np.float64]) -> None:
        for sweep in sweeps:
            sweep.check(q)

    if estimator is not None:
        estimator.reset()

    for tick in range(ticks):
        now = tick * period
        if tick % SWEEP_TICKS == 0:
            check(arm.q[:6])
        if tick % w_every == 0:
            scripted = condition != 'estimated'  # the script's report, drawn (in order) under any other
            p = intent.object_probabilities(intent_rng, now) if scripted else None
            if estimator is not None:
                p_estimated = estimator.object_probabilities
                if condition in _ESTIMATED_P:
                    p = p_estimated
                if changing and now >= intent.t_switch and episode.estimate_delay is None \
                        and p_estimated[true] > 0.5:
                    episode.estimate_delay = now - intent.t_switch
            assert p is not None
            if condition == 'top_object' and scene_assistance is None:  # the bet, once, on the first report
                top = int(np.argmax(p))
                scene_assistance = _scene_assistance(assistance, [objects[top]], [names[top]], follow_rule)
            elif scene_assistance is not None and condition in _SUITE:
                scene_assistance.set_probabilities(dict(zip(names, p.tolist())))
            for k, obj in enumerate(objects):
                w = intent.intents[k].w(now, intent_rng) if scripted else None
                if estimator is not None and condition in _ESTIMATED_W:
                    w = estimator.w(names[k])
                assert w is not None
                v, grasp = streams[k].plan(w)
                if scene_assistance is not None and names[k] in scene_assistance.objects:
                    feed_plan(scene_assistance.channel(names[k]), obj.scene.model, v, grasp)
                if v is not None and grasp is not None:
                    shown[k] = grasp
                    if estimator is not None:  # the object's grasp/pose
                        estimator[names[k]].set_proposal(grasp.base_T_ee)
        q = arm.q[:6].copy()
        assistance.set_joints(q)
        assert assistance.base_T_ee is not None
        hand_now = assistance.base_T_ee
        hands.append(hand_now)
        shown_history.append(tuple(shown))
        pursued_object = intent.pursued_object(now)
        seen, shown_seen = hands[0], shown_history[0][pursued_object]
        own_pose, own_closures = objects[pursued_object].own_goals[intent.pursued_task_set(now)]
        shown_pose = None if shown_seen is None or condition == 'ada' else shown_seen.base_T_ee  # on the screen
        goal, pursued = operator.choose_goal(shown_pose, own_pose)
        if operator.at_goal(seen, goal):
            closures = own_closures if pursued == 'own' or shown_seen is None else shown_seen.positions[6:]
            followed = None if scene_assistance is None else scene_assistance.followed
            plan = None if followed is None else shown[names.index(followed)]
            executes = (executes_shown(pursued, execute and condition not in ('direct', 'ada'))
                        and plan is not None)
            now, episode.hand, episode.closures, episode.executed = close_hand(
                arm, hand_now, closures, plan if executes else None, now, period, closure_rng, closure_error, check)
            episode.closed_at, episode.pursued, episode.goal = now, pursued, goal
            episode.executed_object = followed if executes else None
            break
        h = operator.twist(now, seen, goal)
        take_operator_twist(episode, h, hand_now, period, estimator)
        if ada is not None:
            twist = ada.command(hand_now, h, period)
            alpha_sum += 1.0
            wrong_alpha = float(1.0 - ada.distribution()[true]) * period
        else:
            assert scene_assistance is not None  # made at the first report, tick 0
            before = scene_assistance.followed
            scene_assistance.set_operator(h, now)
            command = scene_assistance.command(now)
            twist = command.twist
            alpha_sum += command.alpha
            if condition != 'direct' and before is not None and scene_assistance.followed != before:
                episode.switches += 1
            wrong_alpha = command.alpha * period if scene_assistance.followed not in (None, names[true]) else 0.0
            if changing and condition != 'direct' and now >= intent.t_switch and episode.follow_delay is None \
                    and scene_assistance.followed == names[true]:
                episode.follow_delay = now - intent.t_switch
        episode.wrong_object_alpha += wrong_alpha
        if changing and now >= intent.t_switch:
            episode.wrong_object_alpha_after = (episode.wrong_object_alpha_after or 0.0) + wrong_alpha
        arm.command_twist(TwistCommand(twist[:3], twist[3:], BASE_FRAME), now)
        commands += 1
        arm.step(now + period, period)
    for sweep in sweeps:
        sweep.close(arm.q[:6])  # where the hand closed (or stood at the timeout)
    _sweep_figures(episode, sweeps)
    episode.followed = None if scene_assistance is None or condition == 'direct' else scene_assistance.followed
    episode.task_set = intent.task_set(tick * period)
    if estimator is not None:
        episode.estimated_p_true = float(estimator.object_probabilities[true])
    episode.alpha_mean = alpha_sum / max(commands, 1)
    return episode


def _scene_assistance(assistance: Assistance, objects: Sequence[SceneObject], names: Sequence[str],
                      follow_rule: FollowRule | None) -> SceneAssistance:
    """The assistance over ``objects``, each object's tracked pose and body given (the robot's perception)."""
    scene_assistance = SceneAssistance(assistance, names, follow_rule)
    for obj, name in zip(objects, names):
        scene_assistance.channel(name).set_object(obj.scene.base_T_obj, obj.scene.model.body)
    return scene_assistance


def _sweep_figures(episode: SceneEpisode, sweeps: Sequence[PathSweep]) -> None:
    """Each object's sweep into ``episode``: per object whether swept, and the deepest over the objects."""
    figures = []
    for sweep in sweeps:
        one = Episode()
        swept_into(one, sweep)
        figures.append(one)
    episode.swept_objects = tuple(f.swept for f in figures)
    episode.swept = any(episode.swept_objects)
    episode.in_at_closing = any(f.in_at_closing for f in figures)
    episode.swept_palm = max(f.swept_palm for f in figures)
    episode.swept_finger = max(f.swept_finger for f in figures)
    episode.closing_palm = max(f.closing_palm for f in figures)
    episode.closing_finger = max(f.closing_finger for f in figures)
