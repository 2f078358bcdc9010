r"""Shared control under intent uncertainty, closed loop on a simulated clock: success at the reached grasp.

Runs :func:`grasp_intent_ros.shared_control.simulator.simulate` (the nodes' own core functions: interpreter,
planner policy, assistance, mock arm) for 2 objects x 3 operator models x 6 conditions (direct, ADA as
published, the suite on the independent-task grasp, the suite, the suite with estimated w, the suite with the
estimator's w on the script's w as its prior), on the same
seeded episodes, faster than real time, and prints per object and operator: success at the reached pose,
median time to grasp, operator effort, wrong-task pull, the runs whose hand path swept into the object, with
paired differences and 95% bootstrap confidence intervals over episodes.
The stream figures (rate, gaps, latency, opposition timing, the switch) are bench_shared_control.py's
(real processes).

The episodes
------------
- Intent (``--intent``): ``persistent`` (w held at the paper's ambiguous cases,
  :data:`~grasp_intent_ros.shared_control.operators.AMBIGUOUS_CASES`, episode i on case i mod 5, noise 0.05;
  T drawn from the case under the independent-task model) or ``sharpening`` (as
  bench_shared_control.py: w0 ~ U(0.2, 0.8)^3 sharpening to the certain w_T over U(1.5, 4) s).
- Operators (:mod:`grasp_intent_ros.shared_control.operators`): ``joystick`` (two modes), ``spacemouse``
  (six axes), ``goal-changing`` (a spacemouse operator whose true set changes once, at U(1.5, 3) s, to
  another set; w follows 1 s later). Each approaches a grasp via its pre-grasp, then down its approach axis.
- The object tracker's error (per episode): position N(0, (5 mm)^2 / 3) per axis, rotation vector
  N(0, (3 deg)^2 / 3) per axis (``--tracker-mm``, ``--tracker-deg``): 5 mm and 3 deg RMS. The hand's closure
  error on the grasp command: N(0, (0.05 rad)^2) per finger (the mock arm's ``closure_error``).
- What the operator perceives: the true object, with its own error (a person's eye is no exact tracker),
  drawn per episode independently of the tracker's, by default of the same size (``--operator-mm``,
  ``--operator-deg``; 0 and 0: an exact eye). The operator's own goal for T: the planner's grasp for the
  certain w_T on the object where the operator sees it (the planner's own choice for a certain intent; no rule
  is read). ADA's goals: the planner's grasps for the seven certain task sets, on the tracked object (the
  robot's perception). So every grasp is planned on a perceived object, the robot's on the tracker's, the
  operator's on its own view, each with an error of the same size; the judge alone sees the true object.
- The grasp command: under the suite's assistance, closing on the shown grasp executes it (the arm moves to
  the planned grasp, then closes: :func:`~grasp_intent_ros.shared_control.loop_steps.execute_grasp`);
  ``--no-execute`` closes where the hand is, as under direct and ADA.
- The planner (every plan: the shown grasps, the operators' own grasps, ADA's goals): the planner node's
  defaults (:func:`~grasp_intent_ros.planning.options.node_default_options`: planning for the documented 1x
  execution noise, 5 mm, 3 deg, 0.1 rad closures, the size of the simulated tracker and closure errors);
  ``--exact-landing`` plans for an exact landing (the node's ``execution_noise`` zero). ``--margin-sigmas K``
  (default 0: the collision check unasked, as the shipped demonstrations all pass it) plans the robot's grasps
  (shown, ADA's goals; not the operator's own) with the collision check and the node's ``object_margin`` at K x
  :func:`~grasp_intent_ros.mico.collision.tracker_margin` of the tracker's error, the lever arm the body's reach
  (docs/planner.md, "The hand's clearance").
- The mock arm at a joint limit: each joint clipped on its own, the mock arm node's default;
  ``--twist-joint-limit stop`` stops the arm's twist step as a whole there
  (:class:`~grasp_intent_ros.mico.mock_arm.MockArm`'s ``twist_joint_limit``).
- The suite's assistance: the node's defaults; ``--keep-pace`` sets its ``keep_pace`` (the robot's twist at least
  the operator's speed along the operator's direction, docs/shared_control.md, "Keeping the operator's pace") in
  every condition that assists with it (the suite, the independent-task grasp, estimated and fused w);
  ``--robot-agreement`` sets its ``robot_agreement`` (alpha also times the operator's agreement with the robot's
  own twist, docs/shared_control.md, "Agreeing with the robot's twist") in the same conditions;
  ``--no-assist-idle-part`` turns off its ``assist_idle_part`` (the robot's share alpha_max in the part the
  operator leaves idle, docs/shared_control.md, "The part the operator leaves idle"; on by default);
  ``--keep-joint-line`` sets its ``keep_joint_line`` (the joint-space robot twist scaled into its speed limits by one
  factor, docs/shared_control.md, "Keeping the joint line") in the same conditions.
- Repeats: each episode is run ``--repeats`` times with other operator-noise and closure-error seeds (the
  intent, its noise and the tracker error are the episode's).

Estimated w (condition ``estimated``): the suite, with w from the intent estimator
(:class:`~grasp_intent_ros.shared_control.estimator.IntentEstimator`, the node's default settings for the model,
:func:`~grasp_intent_ros.shared_control.parameters.default_estimator_config`, with its calibration map if the
defaults list one; ``--estimator FIELD=VALUE`` sets fields over them; goals: the model's demonstrations at the
tracked object that the arm reaches from Home) fed the operator's own twist before blending; the intent script's
w is not used, only its true set, which the operator pursues and the judge reads. The estimator never sees the
true set, the rules or the operator's goal.

Fused (condition ``fused``): as ``estimated``, and the intent script's w (the suite condition's, with its noise)
is the estimator's task prior, set every 0.1 s before its w is read (``simulate``'s ``classifier_prior``; the
node's ``intent/prior``): the script plays per-task classifiers whose w the operator's motion refines. Under
persistent ambiguity the true set is drawn from that w, so this prior is the one the episodes are drawn from;
the estimator still never sees the set.

Judged here, after the episode, by the data set's rules (never seen by the planner, the assistance or the
operator): success = the hand closed before the timeout and the object's rules hold for every task of the
true set at the reached pose with the executed closures, at the true object pose
(:func:`~grasp_intent_ros.objects.judge.judge`, the live benchmark's and the demo's judge). Wrong-task
pull: alpha-seconds toward proposals whose features (as planned) do not serve the true set (for ADA: the
goal probabilities' seconds, its assistance weight being 1).

Swept into the object (a judge's figure the simulation measures: it has no contact model, so a hand path may
pass through the object): a run swept when, along the hand's path from the start until it closed (the executed grasp's
trajectory included), the palm/wrist went deeper into the object's body than the planner's limit (1 mm) or an
open finger deeper than its (5 mm), in the true object frame
(:class:`~grasp_intent_ros.shared_control.sweep.PathSweep`); each record has ``swept`` and the deepest
``swept_palm_mm``, ``swept_finger_mm`` (None: never near the body), the same at the pose where the hand closed
(``closing_palm_mm``, ``closing_finger_mm``) and whether that pose itself is past the limits (``in_at_closing``:
the grasp as executed or reached, not only the way to it, went in), each cell's summary the count of runs that
swept per condition and how many of them were in at the closing pose. **Success with a clear path**
(``clear``): success, and the run did not sweep: what a real arm, whose hand would push or knock the object on
the way, could count on; reported beside success, per condition and paired (the same pairs), for records that
carry ``swept``.

Statistics: per episode the mean over repeats; paired differences (:data:`PAIRS`: the suite minus each other
condition, estimated w minus scripted w (the suite) and minus direct, fused minus the suite, estimated w, the
independent-task grasp, direct and ADA) with a 95% percentile bootstrap over
episodes (10,000 resamples, seeded).

Records (``--records F``): a JSON line per episode as it ends, the list of its runs' records, each carrying the
run's settings (``run``: :func:`run_settings`; files written before they did lack it). ``--summarise F`` prints
the figures of such a file (``.jsonl``, or gzip-compressed ``.jsonl.gz``) and runs nothing; with ``--by-case``,
the persistent intent's figures per ambiguous case instead (:func:`report_cases`: where the help matters most);
benchmarks/compare_records.py pairs the runs of two of them, a change's against main's or against the shipped
reference records of the README's rows (``benchmarks/reference/``).

    .venv/bin/python benchmarks/bench_shared_control_sim.py [--episodes 50] [--repeats 3] [--jobs 2] \
        [--intent persistent] [--conditions direct suite estimated] [--estimator rationality=300] \
        [--operator-mm 5 --operator-deg 3] [--twist-joint-limit stop] [--json out.json] [--records runs.jsonl] \
        [--summarise runs.jsonl [--by-case]]
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from _bench import bootstrap_ci, uptime
from _bench.closed_loop import BASE_T_OBJ, OBJECTS, assistance_changes, load_model

from grasp_intent_ros.mico.collision import tracker_margin
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.mico.mock_arm import TWIST_JOINT_LIMITS
from grasp_intent_ros.objects.demos import object_of
from grasp_intent_ros.objects.judge import Judgement, judge
from grasp_intent_ros.planning.options import Options, node_default_options
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.estimator import IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at, reachable_goals
from grasp_intent_ros.shared_control.operators import (
    AMBIGUOUS_CASES,
    ChangingIntent,
    OperatorConstants,
    PersistentIntent,
    ScriptedOperator,
    SharpeningIntent,
)
from grasp_intent_ros.shared_control.parameters import default_estimator_config
from grasp_intent_ros.shared_control.simulator import (
    CONDITIONS,
    Scene,
    TraceRow,
    certain_grasps,
    perturb_pose,
    simulate,
)

OPERATORS = ('joystick', 'spacemouse', 'goal-changing')
ESTIMATED = 'estimated'
FUSED = 'fused'
RUN = (*CONDITIONS, ESTIMATED, FUSED)
"""The conditions: the simulator's, the suite with the intent estimator's w, and with the estimator's w on the
script's w as its prior (module docstring)."""
PAIRS = (*(('suite', c) for c in CONDITIONS[:-1]), (ESTIMATED, 'suite'), (ESTIMATED, 'direct'),
         (FUSED, 'suite'), (FUSED, ESTIMATED), (FUSED, 'independent'), (FUSED, 'direct'), (FUSED, 'ada'))
"""The paired differences reported (a minus b)."""

_STATE: dict[str, Any] = {}


def _options(execution_noise: bool) -> Options | None:
    """The planner's options: the node's defaults (the 1x execution noise), or the library's (an exact landing)."""
    return node_default_options() if execution_noise else None


def _setup(name: str, execution_noise: bool) -> dict[str, Any]:
    key = f'{name}/{execution_noise}'
    if key not in _STATE:
        model = load_model(name)
        rules = object_of(model)
        assert rules is not None, f'{model.name} names no object with rules'
        _STATE[key] = {'kin': MicoKinematics(), 'model': model, 'rules': rules}
    return _STATE[key]


@dataclass(frozen=True)
class Task:
    """One episode: object, operator model, index, and the run's settings."""

    object: str
    operator: str
    index: int
    seed: int
    repeats: int
    intent: str
    timeout: float
    tracker_mm: float
    tracker_deg: float
    conditions: tuple[str, ...] = RUN
    execute: bool = True
    execution_noise: bool = True
    estimator: tuple[tuple[str, float], ...] = ()
    """EstimatorConfig fields set for the ``estimated`` condition (the rest: the node's defaults for the model)."""
    trace: bool = False
    """Whether each record carries the loop's trace and the failed rules (:func:`trace_record`)."""
    operator_mm: float = 5.0
    operator_deg: float = 3.0
    """The RMS error of the operator's view of the object (module docstring): mm, deg."""
    margin_sigmas: float = 0.0
    """The planner's object margin in tracker sigmas (module docstring); 0: the collision check unasked."""
    twist_joint_limit: str = 'clip'
    """The mock arm's rule for a twist at a joint limit (module docstring)."""
    keep_pace: bool = False
    """The suite's assistance with ``keep_pace`` (module docstring); False: its defaults."""
    robot_agreement: bool = False
    """The suite's assistance with ``robot_agreement`` (module docstring); False: its defaults."""
    assist_idle_part: bool = AssistanceConfig().assist_idle_part
    """The suite's assistance's ``assist_idle_part`` (module docstring); default: its default."""
    keep_joint_line: bool = False
    """The suite's assistance with ``keep_joint_line`` (module docstring); False: its defaults."""


EPISODE_SETTINGS = ('seed', 'intent', 'timeout', 'tracker_mm', 'tracker_deg', 'operator_mm', 'operator_deg')
"""The settings that make the episodes (the seeds, the intent, the tracker's and the operator's errors) and the
timeout that ends them: the runs of two record files pair only where these agree. The rest of a record's ``run``
(:func:`run_settings`) is the loop's: what a compared change may vary."""


def run_settings(task: Task) -> dict[str, Any]:
    """The run's settings, which every record carries as ``run``.

    :data:`EPISODE_SETTINGS`, then the loop's: the grasp command executing, the planner's execution noise and
    object margin, the estimator's fields set, the mock arm's ``twist_joint_limit`` when it is not ``'clip'`` and
    the assistance's fields that differ from its defaults (:func:`assistance_config`; runs of the defaults carry no
    such keys, as the records written before them; records written while ``assist_idle_part`` was off by default
    carry ``assist_idle_part: true`` where it was on).
    """
    limit = {} if task.twist_joint_limit == 'clip' else {'twist_joint_limit': task.twist_joint_limit}
    return {**{name: getattr(task, name) for name in EPISODE_SETTINGS}, 'execute': task.execute,
            'execution_noise': task.execution_noise, 'margin_sigmas': task.margin_sigmas,
            'estimator': dict(task.estimator), **limit, **assistance_changes(assistance_config(task))}


def assistance_config(task: Task) -> AssistanceConfig:
    """The suite's assistance of ``task``'s runs: its defaults with the task's options."""
    return AssistanceConfig(keep_pace=task.keep_pace, robot_agreement=task.robot_agreement,
                            assist_idle_part=task.assist_idle_part, keep_joint_line=task.keep_joint_line)


def read_records(path: str) -> list[dict[str, Any]]:
    """The records of a ``--records`` file (``.jsonl``, or gzip-compressed: ``.jsonl.gz``).

    JSON lines, each a list of records (one episode's, as :func:`run_tasks` appends them). Raises OSError
    (unreadable), ValueError (a line that is not a JSON list of objects).
    """
    with (gzip.open(path, 'rt') if path.endswith('.gz') else open(path)) as f:
        lines = [json.loads(line) for line in f if line.strip()]
    if not all(isinstance(line, list) and all(isinstance(r, dict) for r in line) for line in lines):
        raise ValueError(f'{path}: a line is not a JSON list of records (not a --records file)')
    return [r for line in lines for r in line]


def _intent(task: Task, rng: np.random.Generator) -> Any:
    if task.intent == 'sharpening':
        return SharpeningIntent.draw(rng)
    persistent = PersistentIntent.draw(task.index, rng)
    if task.operator != 'goal-changing':
        return persistent
    others = [s for s in range(1, 8) if s != persistent.true_set]
    return ChangingIntent(persistent, int(rng.choice(others)), float(rng.uniform(1.5, 3.0)))


def tracked_estimator(model: Any, base_T_obj: np.ndarray, kin: Any,
                      fields: tuple[tuple[str, float], ...] = ()) -> IntentEstimator:
    """The intent estimator the node prepares for an object tracked at ``base_T_obj`` (4x4, base frame).

    Its goals: ``model``'s demonstrations placed there that the arm reaches from Home; its settings the node's
    defaults for ``model`` (:func:`~grasp_intent_ros.shared_control.parameters.default_estimator_config`: its
    calibration map if the defaults list one) with ``fields`` set (:attr:`Task.estimator`).
    """
    return IntentEstimator(goals_at(model, base_T_obj, reachable_goals(model, base_T_obj, kin)),
                           replace(default_estimator_config(model.name), **dict(fields)))


def run_task(task: Task) -> list[dict[str, Any]]:
    """Every repeat and condition of one episode: judged records."""
    state = _setup(task.object, task.execution_noise)
    kin, model, rules = state['kin'], state['model'], state['rules']
    setup_rng = np.random.default_rng([task.seed, list(OBJECTS).index(task.object), OPERATORS.index(task.operator),
                                       task.index])
    intent = _intent(task, setup_rng)
    tracked = perturb_pose(BASE_T_OBJ, task.tracker_mm * 1e-3, math.radians(task.tracker_deg), setup_rng)
    seen = perturb_pose(BASE_T_OBJ, task.operator_mm * 1e-3, math.radians(task.operator_deg), setup_rng)
    options = _options(task.execution_noise)
    margin = None if task.margin_sigmas == 0.0 else task.margin_sigmas * tracker_margin(
        task.tracker_mm * 1e-3, math.radians(task.tracker_deg), model.body.reach)
    scene = Scene(model, BASE_T_OBJ, tracked, kin, options, margin)
    ada_goals = [(g.base_T_ee, g.result.x) for g in certain_grasps(model, tracked, kin, options, margin).values()]
    own = {s: (g.base_T_ee, g.positions[6:]) for s, g in certain_grasps(model, seen, kin, options).items()}
    cache: dict[bytes, Grasp | None] = {}
    estimator = None
    if {ESTIMATED, FUSED} & set(task.conditions):  # the goals the node would prepare for the tracked object
        estimator = tracked_estimator(model, tracked, kin, task.estimator)
    device = 'joystick' if task.operator == 'joystick' else 'spacemouse'
    records = []
    for repeat in range(task.repeats):
        for condition in task.conditions:
            intent_rng = np.random.default_rng([task.seed, task.index, 1])  # the same reports in every run
            op_rng = np.random.default_rng([task.seed, list(OBJECTS).index(task.object),
                                            OPERATORS.index(task.operator), task.index, repeat, 2])
            closure_rng = np.random.default_rng([task.seed, task.index, repeat, 3])
            operator = ScriptedOperator(device, OperatorConstants(), op_rng)
            t0 = time.perf_counter()
            estimated = condition in (ESTIMATED, FUSED)
            trace: list[TraceRow] | None = [] if task.trace else None
            ep = simulate(scene, 'suite' if estimated else condition, intent, operator, own, intent_rng,
                          closure_rng, ada_goals=ada_goals, plan_cache=cache, timeout=task.timeout,
                          estimator=estimator if estimated else None, classifier_prior=condition == FUSED,
                          execute=task.execute, trace=trace, config=assistance_config(task),
                          twist_joint_limit=task.twist_joint_limit)
            true_set = ep.task_set
            verdict = None if ep.hand is None else judge(model, scene.base_T_obj_true, ep.hand, ep.closures)
            success = verdict is not None and verdict.serves(true_set)
            wrong = sum(s for x, s in ep.pulls if rules.label(x) & true_set != true_set)
            records.append({'object': task.object, 'operator': task.operator, 'episode': task.index,
                            'repeat': repeat, 'condition': condition, 'task_set': true_set,
                            'success': bool(success), 'closed': ep.closed_at is not None,
                            'time': ep.closed_at if ep.closed_at is not None else task.timeout,
                            'pursued': ep.pursued, 'executed': ep.executed, 'effort_linear': ep.effort_linear,
                            'effort_angular': ep.effort_angular, 'wrong_pull': wrong, 'alpha_mean': ep.alpha_mean,
                            'swept': ep.swept, 'swept_palm_mm': _mm(ep.swept_palm),
                            'swept_finger_mm': _mm(ep.swept_finger), 'in_at_closing': ep.in_at_closing,
                            'closing_palm_mm': _mm(ep.closing_palm), 'closing_finger_mm': _mm(ep.closing_finger),
                            'wall_s': time.perf_counter() - t0, 'run': run_settings(task)})
            if trace is not None:
                records[-1].update(trace_record(trace, ep, rules, verdict))
    return records


def _mm(depth: float) -> float | None:
    """A depth (m) in mm for a record; None for ``-inf`` (the hand never came near the body)."""
    return None if depth == -math.inf else round(1e3 * depth, 2)


def trace_record(trace: list[TraceRow], ep: Any, rules: Any, verdict: Judgement | None) -> dict[str, Any]:
    """The loop's trace of one run, as JSON values, and what the judge found at the reached grasp.

    ``trace``: per w report (every 0.1 s) t, w, the shown grasp's demonstration set, the set the rules give
    its features as planned (``shown_label``), its palm position and rotation (base frame, m), the hand's palm
    position, mean alpha, the goal pursued, the true set. ``failed``: the rule
    conditions (``task.condition``) of the true set's tasks that fail at the reached grasp (``verdict``'s; empty on
    success or without a grasp). ``own``: whether the operator closed on its own grasp.
    """
    rows = [{'t': round(r.t, 3), 'w': [round(float(x), 4) for x in r.w], 'shown_set': r.shown_set,
             'shown_label': None if r.shown_x is None else rules.label(r.shown_x),
             'shown_p': None if r.shown is None else [round(float(x), 4) for x in r.shown[:3, 3]],
             'shown_R': None if r.shown is None else [round(float(x), 4) for x in r.shown[:3, :3].ravel()],
             'hand_p': [round(float(x), 4) for x in r.hand[:3, 3]], 'alpha': round(r.alpha, 4),
             'pursued': r.pursued, 'T': r.task_set} for r in trace]
    failed: list[str] = []
    if verdict is not None:
        names = rules.task_names
        for task, conditions in verdict.failed.items():
            if ep.task_set >> names.index(task) & 1:
                failed.extend(f'{task}.{name}' for name in conditions)
    return {'trace': rows, 'failed': failed}


def per_episode(records: list[dict[str, Any]], key: str) -> dict[str, dict[int, float]]:
    """Mean of ``key`` over repeats, by condition and episode."""
    out: dict[str, dict[int, list[float]]] = {}
    for r in records:
        out.setdefault(r['condition'], {}).setdefault(r['episode'], []).append(float(r[key]))
    return {c: {e: float(np.mean(v)) for e, v in eps.items()} for c, eps in out.items()}


def episode_figures(records: list[dict[str, Any]]) -> dict[str, dict[str, dict[int, float]]]:
    """Figure -> condition -> episode -> the mean over the episode's repeats (:func:`per_episode`).

    The figures: success, time (a run that never closed: the timeout) and, where every record carries ``swept``
    (older ``--records`` files lack it), ``clear``: success with a clear path.
    """
    figures = {'success': per_episode(records, 'success'), 'time': per_episode(records, 'time')}
    if all('swept' in r for r in records):
        figures['clear'] = per_episode([{**r, 'clear': r['success'] and not r['swept']} for r in records], 'clear')
    return figures


def paired_difference(a: dict[str, dict[int, float]], b: dict[str, dict[int, float]], rng: np.random.Generator,
                      rng_clear: np.random.Generator) -> dict[str, Any]:
    """``a`` minus ``b`` paired over ``a``'s episodes, with 95% bootstrap CIs (:func:`_bench.bootstrap_ci`).

    ``a``, ``b``: figure -> episode -> the mean over repeats, for one condition each (:func:`episode_figures`);
    ``b`` has every episode of ``a``. Success (``success_diff``, ``ci``): the mean of the episodes' differences, a
    share (x 100: points). Time (``time_ratio``, ``time_ratio_ci``): the geometric mean over episodes of the
    ratio of the episodes' mean times, a run that never closed counting as the timeout (its record's ``time``).
    Success with a clear path (``clear_diff``, ``clear_ci``) when both carry ``clear``, drawn from ``rng_clear``
    so that the success's CIs do not depend on whether the records carry it.
    """
    eps = sorted(a['success'])
    d, lo, hi = bootstrap_ci([a['success'][e] - b['success'][e] for e in eps], rng)
    m, rlo, rhi = bootstrap_ci([math.log(a['time'][e] / b['time'][e]) for e in eps], rng)
    out = {'success_diff': d, 'ci': [lo, hi],
           'time_ratio': math.exp(m), 'time_ratio_ci': [math.exp(rlo), math.exp(rhi)]}
    if 'clear' in a and 'clear' in b:
        d, lo, hi = bootstrap_ci([a['clear'][e] - b['clear'][e] for e in eps], rng_clear)
        out.update(clear_diff=d, clear_ci=[lo, hi])
    return out


def summarise(records: list[dict[str, Any]], timeout: float) -> dict[str, Any]:
    """The figures of one object x operator cell (module docstring)."""
    rng, rng_clear = np.random.default_rng(0), np.random.default_rng(1)  # success's CIs as without `clear`
    figures = episode_figures(records)
    success, swept, clear = figures['success'], 'clear' in figures, figures.get('clear', {})
    effort, wrong = per_episode(records, 'effort_linear'), per_episode(records, 'wrong_pull')
    table: dict[str, Any] = {}
    for c in [c for c in RUN if c in success]:
        eps = sorted(success[c])
        table[c] = {'success': float(np.mean([success[c][e] for e in eps])),
                    'median_time': float(np.median([r['time'] for r in records if r['condition'] == c])),
                    'effort_linear': float(np.median([effort[c][e] for e in eps])),
                    'wrong_pull': float(np.mean([wrong[c][e] for e in eps])),
                    'episodes': len(eps)}
        if swept:
            runs = [r for r in records if r['condition'] == c]
            table[c]['swept'] = [sum(r['swept'] for r in runs), len(runs)]
            if all('in_at_closing' in r for r in runs):  # older --records files lack it
                table[c]['in_at_closing'] = sum(r['in_at_closing'] for r in runs)
            table[c]['clear'] = float(np.mean([clear[c][e] for e in eps]))
    for a, other in [(a, b) for a, b in PAIRS if a in success and b in success]:
        table[f'{a}-{other}'] = paired_difference({k: v[a] for k, v in figures.items()},
                                                  {k: v[other] for k, v in figures.items()}, rng, rng_clear)
    return table


def estimator_fields(items: Sequence[str]) -> tuple[tuple[str, float], ...]:
    """``FIELD=VALUE`` strings as :attr:`Task.estimator` (checked by EstimatorConfig when the task runs)."""
    return tuple((k, float(v)) for k, v in (item.split('=', 1) for item in items))


def run_tasks(tasks: Sequence[Any], jobs: int, records_path: str | None,
              run: Callable[[Any], list[dict[str, Any]]] = run_task) -> list[dict[str, Any]]:
    """Every task's records by ``run``, ``jobs`` processes at once; each episode's appended to ``records_path``.

    ``run``: one task's records (:func:`run_task`; bench_shared_control_scene.py passes its own).
    """
    t0 = time.monotonic()
    records: list[dict[str, Any]] = []
    with ProcessPoolExecutor(jobs) as pool:
        for i, result in enumerate(pool.map(run, tasks)):
            records.extend(result)
            if records_path:
                with open(records_path, 'a') as f:
                    f.write(json.dumps(result) + '\n')
            if (i + 1) % 10 == 0:
                print(f'  {i + 1}/{len(tasks)} episodes, {time.monotonic() - t0:.0f} s; {uptime()}', flush=True)
    return records


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--episodes', type=int, default=50)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--objects', nargs='+', default=list(OBJECTS), choices=list(OBJECTS))
    parser.add_argument('--operators', nargs='+', default=list(OPERATORS), choices=list(OPERATORS))
    parser.add_argument('--intent', default='persistent', choices=('persistent', 'sharpening'))
    parser.add_argument('--timeout', type=float, default=25.0)
    parser.add_argument('--tracker-mm', type=float, default=5.0)
    parser.add_argument('--tracker-deg', type=float, default=3.0)
    parser.add_argument('--operator-mm', type=float, default=5.0, help='RMS position error of the operator\'s view '
                        'of the object (its own grasps are planned there; 0: the true object)')
    parser.add_argument('--operator-deg', type=float, default=3.0, help='RMS rotation error of the operator\'s view')
    parser.add_argument('--conditions', nargs='+', default=list(RUN), choices=list(RUN))
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--no-execute', action='store_true', help='the suite\'s grasp command closes the hand where '
                        'it is instead of executing the shown grasp (the simulator\'s execute=False)')
    parser.add_argument('--exact-landing', action='store_true', help='the planner plans for an exact landing '
                        '(the planner node\'s execution_noise zero; default: the node\'s default, the 1x noise)')
    parser.add_argument('--estimator', nargs='*', default=[], metavar='FIELD=VALUE',
                        help="EstimatorConfig fields for the estimated condition (default: the node's defaults)")
    parser.add_argument('--margin-sigmas', type=float, default=0.0, help='the planner\'s object margin (its '
                        'object_margin) in bounds on the tracker error\'s depth sigma (collision.tracker_margin, '
                        'lever arm: the body\'s reach); 0: the collision check unasked, as the demonstrations pass it')
    parser.add_argument('--twist-joint-limit', default='clip', choices=TWIST_JOINT_LIMITS, help='the mock arm\'s '
                        'rule for a twist at a joint limit: clip each joint, or stop the arm as a whole')
    parser.add_argument('--keep-pace', action='store_true', help='the suite\'s assistance keeps the operator\'s '
                        'pace (AssistanceConfig.keep_pace: the robot\'s twist at least the operator\'s speed along the '
                        'operator\'s direction; default: off)')
    parser.add_argument('--robot-agreement', action='store_true', help='the suite\'s assistance lowers alpha by '
                        'the operator\'s agreement with the robot\'s own twist (AssistanceConfig.robot_agreement; '
                        'default: off)')
    parser.add_argument('--no-assist-idle-part', dest='assist_idle_part', action='store_false', help='the suite\'s '
                        'assistance blends the part the operator leaves idle with alpha, as the moved part '
                        '(AssistanceConfig.assist_idle_part off; default: on, alpha_max there)')
    parser.add_argument('--keep-joint-line', action='store_true', help='the suite\'s assistance scales its joint-space '
                        'robot twist into the speed limits by one factor (AssistanceConfig.keep_joint_line; default: '
                        'off, each part to its own limit)')
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--json', help='write every record and the summaries here')
    parser.add_argument('--records', help='append each episode\'s records here as they come (JSON lines)')
    parser.add_argument('--summarise', metavar='JSONL', help='run nothing: summarise the records of a --records file '
                        '(.jsonl or .jsonl.gz; the cells it holds complete)')
    parser.add_argument('--by-case', action='store_true', help='with --summarise: the persistent intent\'s figures '
                        'per ambiguous case, each object\'s operators pooled')
    args = parser.parse_args()
    if args.by_case and not args.summarise:
        parser.error('--by-case summarises records: give --summarise JSONL')
    if args.summarise:
        done = read_records(args.summarise)
        objects = sorted({r['object'] for r in done})
        if args.by_case:
            intents = {r.get('run', {}).get('intent') for r in done}
            if intents != {'persistent'}:
                parser.error('--by-case needs records of the persistent intent alone; these hold '
                             f'{sorted(map(str, intents))}')
            report_cases(done, args, objects)
        else:
            report_cells(done, args, objects, sorted({r['operator'] for r in done}))
        return
    tasks = [Task(o, op, i, args.seed, args.repeats, args.intent, args.timeout, args.tracker_mm, args.tracker_deg,
                  tuple(c for c in RUN if c in args.conditions), not args.no_execute, not args.exact_landing,
                  estimator_fields(args.estimator), operator_mm=args.operator_mm, operator_deg=args.operator_deg,
                  margin_sigmas=args.margin_sigmas, keep_pace=args.keep_pace,
                  robot_agreement=args.robot_agreement, assist_idle_part=args.assist_idle_part,
                  keep_joint_line=args.keep_joint_line,
                  twist_joint_limit=args.twist_joint_limit)
             for i in range(args.episodes) for o in args.objects for op in args.operators]  # cells fill evenly
    print(f'bench_shared_control_sim: {len(tasks)} episodes x {args.repeats} repeats x {len(args.conditions)} '
          f'conditions, intent {args.intent}; {uptime()}', flush=True)
    t0 = time.monotonic()
    records = run_tasks(tasks, args.jobs, args.records)
    report = report_cells(records, args, args.objects, args.operators)
    print(f'\ndone in {time.monotonic() - t0:.0f} s; {uptime()}')
    if args.json:
        report['records'] = records
        with open(args.json, 'w') as f:
            json.dump(report, f, indent=1)


def report_cells(records: list[dict[str, Any]], args: argparse.Namespace, objects: Sequence[str],
                 operators: Sequence[str]) -> dict[str, Any]:
    """Print and return the summaries of every object x operator cell of ``records``."""
    report: dict[str, Any] = {'args': vars(args), 'cells': {}}
    repeats = 1 + max(r['repeat'] for r in records)
    for o in objects:
        for op in operators:
            cell = [r for r in records if r['object'] == o and r['operator'] == op]
            if not cell:
                continue
            table = summarise(cell, args.timeout)
            report['cells'][f'{o}/{op}'] = table
            episodes = max(row['episodes'] for c, row in table.items() if c in RUN)
            print(f'\n[{o} / {op}] {episodes} episodes x {repeats} repeats')
            for c in [c for c in RUN if c in table]:
                row = table[c]
                closing = f' ({row["in_at_closing"]} in at the closing pose)' if 'in_at_closing' in row else ''
                swept = (f'  swept {row["swept"][0]}/{row["swept"][1]} runs{closing}  clear success {row["clear"]:.3f}'
                         if 'swept' in row else '')
                print(f'  {c:12s} success {row["success"]:.3f}  median time {row["median_time"]:5.2f} s  '
                      f'effort {row["effort_linear"]:.3f} m  wrong pull {row["wrong_pull"]:.3f} alpha s{swept}')
            for a, other in [(a, b) for a, b in PAIRS if f'{a}-{b}' in table]:
                print(_pair_line(a, other, table[f'{a}-{other}']))
    return report


def _pair_line(a: str, other: str, d: dict[str, Any], *, clear: bool = True) -> str:
    """One printed line of ``a`` minus ``other`` (:func:`paired_difference`'s ``d``); the clear path's if ``clear``."""
    return (f'  {a} - {other:12s} success {100 * d["success_diff"]:+5.1f} points '
            f'[{100 * d["ci"][0]:+5.1f}, {100 * d["ci"][1]:+5.1f}]  time ratio {d["time_ratio"]:.2f} '
            f'[{d["time_ratio_ci"][0]:.2f}, {d["time_ratio_ci"][1]:.2f}]' +
            (f'  clear {100 * d["clear_diff"]:+5.1f} [{100 * d["clear_ci"][0]:+5.1f}, '
             f'{100 * d["clear_ci"][1]:+5.1f}]' if clear and 'clear_diff' in d else ''))


def report_cases(records: list[dict[str, Any]], args: argparse.Namespace, objects: Sequence[str]) -> dict[str, Any]:
    """Print and return, per object, the persistent intent's figures for each of :data:`AMBIGUOUS_CASES`.

    Episode i held case i mod 5 (:meth:`PersistentIntent.draw`); a case's figures pool the object's operator models,
    an episode being (operator, episode) for the pairing, and are :func:`summarise`'s (the same bootstrap).
    """
    report: dict[str, Any] = {'args': vars(args), 'cases': {}}
    for o in objects:
        for k, case in enumerate(AMBIGUOUS_CASES):
            cell = [{**r, 'episode': (OPERATORS.index(r['operator']), r['episode'])} for r in records
                    if r['object'] == o and r['episode'] % len(AMBIGUOUS_CASES) == k]
            if not cell:
                continue
            table = summarise(cell, args.timeout)
            report['cases'][f'{o}/{case}'] = table
            episodes = max(row['episodes'] for c, row in table.items() if c in RUN)
            print(f'\n[{o}, w = {case}] {episodes} episodes of {len({r["operator"] for r in cell})} operator models')
            print('  success ' + '  '.join(f'{c} {table[c]["success"]:.3f}' for c in RUN if c in table))
            for a, other in [(a, b) for a, b in PAIRS if a == 'suite' and f'{a}-{b}' in table]:
                print(_pair_line(a, other, table[f'{a}-{other}'], clear=False))
    return report


if __name__ == '__main__':
    main()
