r"""Shared control over two objects, closed loop on a simulated clock: success on the true object at the reached grasp.

Runs :func:`grasp_intent_ros.shared_control.scene_simulator.simulate_scene` (the nodes' own cores: each chain's
interpreter and planner policy, the assistance over several objects, the mock arm) on a cup and a flashlight on
the table, for the operator models x 5 conditions (direct, ADA as published over objects, the suite, the suite
betting on the top object, the suite with P(o) and w^o estimated from the operator's motion), on the same seeded
episodes, faster than real time, and prints per operator model:
success, wrong-object closes, median time to grasp, alpha on the wrong object, the runs that swept into an object,
with paired differences and 95% bootstrap confidence intervals over episodes (bench_shared_control_sim.py's).
docs/several_objects.md ("The simulated benchmark with two objects") gives the design.

The episodes
------------
- The objects' poses (:func:`draw_positions`, per episode): both upright in their default orientation (half a
  turn about z), each position (x, y) on the table (z = 0) uniform in [0.25, 0.35] x [-0.35, -0.05] m, redrawn
  until the two are at least the sum of their bodies' reach (the bounding sphere of each body about its frame)
  plus 2 cm apart: no overlap. In that region the pair ends up near opposite ends of the y range (about 0.26 to
  0.32 m apart), either object the nearer one. The whole draw (poses
  and the two views below) is repeated until the planner reaches the grasp for every certain task set on each
  object both as the operator and as the tracker sees it (:func:`draw_objects`; the region's edges are not
  everywhere reachable for every set).
- Each object seen by the tracker with its error, as bench_shared_control_sim.py: position N(0, (5 mm)^2 / 3)
  per axis, rotation vector N(0, (3 deg)^2 / 3) per axis (``--tracker-mm``, ``--tracker-deg``), drawn per object;
  the operator sees each with its own error of the same size (``--operator-mm``, ``--operator-deg``).
- The intent (:class:`~grasp_intent_ros.shared_control.scene_simulator.SceneIntent`, persistent): each object's
  w^o held at the paper's case (episode i mod 5) with N(0, 0.05^2) noise per report, as the one-object persistent
  script (each object's own true set drawn from it); P(o) held ambiguous: the favoured object uniform of the two,
  its P ``--favoured`` (0.6), the other 1 - that, each report N(0, 0.05^2) per object, clipped to [0.02, 0.98],
  renormalised; the true object drawn from the held P(o) (so it is the favoured one in 60% of the episodes), the
  true set its w's draw.
- The operator (``--operators``: ``joystick``, ``spacemouse``; the one-object benchmark's devices and constants)
  reaches for the true object: its own grasp for the true set is the planner's for the certain w on that object
  where it sees it; it follows that object's shown grasp when it lies on its way (the one-object rule); it never
  reads a rule or which object the assistance follows.
- The operator that changes its mind (``joystick-changing``, ``spacemouse-changing``: that device's episode, the
  same draws, then :meth:`~grasp_intent_ros.shared_control.scene_simulator.SceneIntent.first_move_other`): it heads
  first for the object the device's operator reaches in that episode (drawn from the held P(o); its shown grasp
  when on its way, else its own grasp there for that object's true set), and at a time drawn U(1.5, 3) s after
  the start turns to the other object for good, the true one, with that object's true set; the script's P(o)
  follows 1 s later (then certain of the true object: 0.95 with the same noise), as the one-object goal-changing
  operator's w follows its change; under ``estimated`` the estimator takes the operator's twist alone, as always.
  Recorded beside the figures: when it switched (``switch_at``, s), how long after the switch the assistance first
  followed the true object (``follow_delay``) and the estimator's P(o) of it first passed 0.5 (``estimate_delay``,
  read every 0.1 s), and the alpha-seconds on the other object from the switch on (``wrong_object_alpha_after``).
- The conditions (:data:`~grasp_intent_ros.shared_control.scene_simulator.SCENE_CONDITIONS`): ``direct`` (alpha 0),
  ``ada`` (one goal per object, its targets the planner's grasps for the seven certain task sets on the tracked
  object, the distribution over objects from the operator's motion, u + sum_o p(o) a_o), ``suite`` (the
  assistance over several objects, P(o) from the script, the hysteresis's defaults), ``top_object`` (the suite's
  assistance on the top object's grasp alone, chosen at the first report, never switching), ``estimated`` (the
  suite, with P(o) and every w^o from the intent estimator over the objects,
  :class:`~grasp_intent_ros.shared_control.scene_estimator.SceneEstimator`, the node's default settings for each
  object's model (its calibration map if the defaults list one), fed the operator's own twist before blending and
  each object's shown grasp; each object's goals: its model's demonstrations at the tracked object that the arm
  reaches from Home, as the node prepares them, :func:`scene_estimator`; the script's P(o) and w^o are not used,
  only the true object and its true set, which the operator pursues and the judge reads). Under the suite's
  assistance a close on the shown grasp executes the followed object's newest plan (the simulator's docstring).
  Not run by default: ``estimated_objects`` (P(o) from the estimator, each w^o the script's) and
  ``estimated_tasks`` (each w^o from the estimator, P(o) the script's), ``estimated`` split into its two sources
  (the scripted part the suite's run's reports to the last bit).
- The planner: the node's defaults (:func:`~grasp_intent_ros.planning.options.node_default_options`), no
  collision check, as bench_shared_control_sim.py's default.
- The mock arm at a joint limit: each joint clipped on its own, the mock arm node's default;
  ``--twist-joint-limit stop`` stops the arm's twist step as a whole there
  (:class:`~grasp_intent_ros.mico.mock_arm.MockArm`'s ``twist_joint_limit``).
- The suite's assistance: the node's defaults; ``--no-assist-idle-part`` turns off its ``assist_idle_part`` (the
  robot's share alpha_max in the part the operator leaves idle, docs/shared_control.md, "The part the operator
  leaves idle"; on by default).
- Repeats: each episode is run ``--repeats`` times with other operator-noise and closure-error seeds (the
  poses, the intent, its noise and the errors are the episode's).

Judged here, after the episode, at the objects' true poses (nothing judged informs the planner, the assistance or
the operator): **success** = the hand closed before the timeout on the true object with a grasp that serves the
true task set by that object's rules with the executed closures
(:func:`~grasp_intent_ros.objects.judge.judge_scene`: ``serves``), and the open hand's path, from the start until
it closed, did not sweep into either object (:class:`~grasp_intent_ros.shared_control.sweep.PathSweep` per object,
its true frame). Reported beside it: ``serves`` (the rules alone, the one-object benchmark's success), the
**wrong-object closes** (the closed hand holds the other object: its rules give the grasp some task there), the
time to grasp (the timeout for a run that never closed), the alpha-seconds on the wrong object (the assistance
following the other object; ADA: its probability-seconds on the other object), the runs that swept, and under
``estimated`` the estimator's mean P(o) of the true object when the hand closed (or at the timeout).

Statistics: per episode the mean over repeats; paired differences (:data:`PAIRS`) of success (points) and of
the time (geometric mean ratio), 95% percentile bootstrap over episodes (10,000 resamples, seeded):
bench_shared_control_sim.py's :func:`paired_difference`. Records (``--records F``): a JSON line per episode,
its runs' records, each carrying the run's settings (``run``: :func:`run_settings`); ``--summarise F`` prints the
figures of such a file (``.jsonl`` or ``.jsonl.gz``) and runs nothing; benchmarks/compare_records.py pairs the
runs of two of them, a change's against main's or against the shipped reference records of the README's row
(``benchmarks/reference/scene.jsonl.gz``).

    .venv/bin/python benchmarks/bench_shared_control_scene.py [--episodes 50] [--repeats 3] [--jobs 2] \
        [--operators joystick] [--conditions direct ada suite top_object estimated] [--twist-joint-limit stop] \
        [--records runs.jsonl] \
        [--summarise runs.jsonl]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from _bench import uptime
from _bench.closed_loop import BASE_T_OBJ, assistance_changes
from bench_shared_control_sim import (
    _mm,
    _options,
    _setup,
    paired_difference,
    per_episode,
    read_records,
    run_tasks,
    tracked_estimator,
)

from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.mock_arm import TWIST_JOINT_LIMITS
from grasp_intent_ros.objects.judge import judge_scene
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.operators import OperatorConstants, ScriptedOperator
from grasp_intent_ros.shared_control.scene_estimator import SceneEstimator
from grasp_intent_ros.shared_control.scene_simulator import (
    ALL_SCENE_CONDITIONS,
    ESTIMATOR_CONDITIONS,
    SCENE_CONDITIONS,
    SceneIntent,
    SceneObject,
    simulate_scene,
)
from grasp_intent_ros.shared_control.simulator import Scene, certain_grasps, perturb_pose

SCENE_OBJECTS = ('cup', 'flashlight')
"""The scene's objects, in the order of every per-object list (the models: _bench.closed_loop.OBJECTS)."""
OPERATORS = ('joystick', 'spacemouse', 'joystick-changing', 'spacemouse-changing')
"""The operator models: the devices, then each device's operator that heads for the other object first."""
REGION = ((0.25, 0.35), (-0.35, -0.05))
"""Where each object's position (x, y, m) is drawn (:func:`draw_positions`)."""
GAP = 0.02
"""The least gap (m) between two objects' bounding spheres."""
EPISODE_SETTINGS = ('seed', 'timeout', 'tracker_mm', 'tracker_deg', 'operator_mm', 'operator_deg', 'favoured')
"""The settings of :func:`run_settings` that make other episodes (the poses, the views, the intent, the operator's
noise); the others (``execute``, ``twist_joint_limit``) are the loop's."""
PAIRS = (('suite', 'direct'), ('suite', 'ada'), ('suite', 'top_object'), ('estimated', 'suite'),
         ('estimated', 'direct'), ('estimated', 'ada'), ('estimated', 'top_object'),
         ('estimated_objects', 'suite'), ('estimated_tasks', 'suite'), ('estimated', 'estimated_objects'),
         ('estimated', 'estimated_tasks'))
"""The paired differences reported (a minus b)."""


def draw_positions(reaches: list[float], rng: np.random.Generator) -> list[np.ndarray]:
    """Each object's true pose (4x4, base frame): :data:`BASE_T_OBJ`'s orientation, (x, y) uniform in :data:`REGION`.

    Redrawn (the whole set) until every two objects' positions are at least their ``reaches`` summed plus
    :data:`GAP` apart. Draws x then y per object, in order.
    """
    while True:
        xy = [np.array([rng.uniform(*REGION[0]), rng.uniform(*REGION[1])]) for _ in reaches]
        if all(np.linalg.norm(xy[i] - xy[j]) >= reaches[i] + reaches[j] + GAP
               for i in range(len(xy)) for j in range(i)):
            break
    poses = []
    for p in xy:
        pose = BASE_T_OBJ.copy()
        pose[:2, 3] = p
        poses.append(pose)
    return poses


def draw_objects(models: list[Any], kin: Any, task: SceneTask, rng: np.random.Generator
                 ) -> tuple[list[SceneObject], list[np.ndarray]]:
    """The episode's objects (:data:`SCENE_OBJECTS`' order) and their true poses, drawn from ``rng``.

    The true poses (:func:`draw_positions`), then per object the tracker's view and the operator's
    (:func:`~grasp_intent_ros.shared_control.simulator.perturb_pose`); the whole draw is repeated until the planner
    (the node's options) reaches the grasp for every certain task set on every object both as the operator sees it
    (the operator's own grasps) and as the tracker sees it (ADA's targets).
    """
    options = _options(True)
    while True:
        true_poses = draw_positions([m.body.reach for m in models], rng)
        objects = []
        try:
            for name, model, true_pose in zip(SCENE_OBJECTS, models, true_poses):
                tracked = perturb_pose(true_pose, task.tracker_mm * 1e-3, math.radians(task.tracker_deg), rng)
                seen = perturb_pose(true_pose, task.operator_mm * 1e-3, math.radians(task.operator_deg), rng)
                own = {s: (g.base_T_ee, g.positions[6:]) for s, g in certain_grasps(model, seen, kin, options).items()}
                ada = [g.base_T_ee for g in certain_grasps(model, tracked, kin, options).values()]
                objects.append(SceneObject(name, Scene(model, true_pose, tracked, kin, options), own, ada))
        except ValueError:  # a certain task set out of the arm's reach: the whole draw again
            continue
        return objects, true_poses


def scene_estimator(objects: list[SceneObject], kin: Any) -> SceneEstimator:
    """The intent estimator over ``objects`` (in their order), each object's as the node prepares it.

    Each object's goals at its tracked pose: bench_shared_control_sim.py's :func:`tracked_estimator` (the node's
    default settings for the object's model).
    """
    estimator = SceneEstimator()
    for obj in objects:
        estimator.set_object(obj.name, tracked_estimator(obj.scene.model, obj.scene.base_T_obj, kin))
    return estimator


@dataclass(frozen=True)
class SceneTask:
    """One episode: the operator model, its index, and the run's settings."""

    operator: str
    index: int
    seed: int
    repeats: int
    timeout: float
    tracker_mm: float = 5.0
    tracker_deg: float = 3.0
    operator_mm: float = 5.0
    operator_deg: float = 3.0
    favoured: float = 0.6
    conditions: tuple[str, ...] = SCENE_CONDITIONS
    execute: bool = True
    twist_joint_limit: str = 'clip'
    assist_idle_part: bool = AssistanceConfig().assist_idle_part


def run_settings(task: SceneTask) -> dict[str, Any]:
    """The run's settings, which every record carries as ``run``.

    The mock arm's ``twist_joint_limit`` only when not ``'clip'``, the assistance's fields only where they differ
    from its defaults (``assist_idle_part`` off): records of the defaults carry the settings records carried before
    the options (records written while it was off by default carry ``assist_idle_part: true`` where it was on).
    """
    limit = {} if task.twist_joint_limit == 'clip' else {'twist_joint_limit': task.twist_joint_limit}
    return {**{name: getattr(task, name) for name in (*EPISODE_SETTINGS, 'execute')}, **limit,
            **assistance_changes(assistance_config(task))}


def assistance_config(task: SceneTask) -> AssistanceConfig:
    """The suite's assistance of ``task``'s runs: its defaults with the task's ``assist_idle_part``."""
    return AssistanceConfig(assist_idle_part=task.assist_idle_part)


def run_scene_task(task: SceneTask) -> list[dict[str, Any]]:
    """Every repeat and condition of one episode: judged records.

    An operator that changes its mind (``*-changing``) runs its device's episode (the same seeds and draws) with
    the intent then changed (:meth:`SceneIntent.first_move_other`, from the same generator).
    """
    states = [_setup(name, True) for name in SCENE_OBJECTS]
    kin = states[0]['kin']
    models = [state['model'] for state in states]
    device = task.operator.removesuffix('-changing')
    changing = device != task.operator
    setup_rng = np.random.default_rng([task.seed, OPERATORS.index(device), task.index, 7])
    intent = SceneIntent.draw(task.index, len(models), setup_rng, task.favoured)
    objects, true_poses = draw_objects(models, kin, task, setup_rng)
    if changing:
        intent = intent.first_move_other(setup_rng)
    caches: list[dict[bytes, Grasp | None]] = [{} for _ in objects]
    estimator = scene_estimator(objects, kin) if set(ESTIMATOR_CONDITIONS) & set(task.conditions) else None
    true = intent.true_object
    records = []
    for repeat in range(task.repeats):
        for condition in task.conditions:
            intent_rng = np.random.default_rng([task.seed, task.index, 1, 7])  # the same reports in every run
            op_rng = np.random.default_rng([task.seed, OPERATORS.index(device), task.index, repeat, 2, 7])
            closure_rng = np.random.default_rng([task.seed, task.index, repeat, 3, 7])
            operator = ScriptedOperator(device, OperatorConstants(), op_rng)  # type: ignore[arg-type]
            t0 = time.perf_counter()
            ep = simulate_scene(objects, condition, intent, operator, intent_rng, closure_rng,  # type: ignore[arg-type]
                                plan_caches=caches, timeout=task.timeout, execute=task.execute,
                                twist_joint_limit=task.twist_joint_limit,
                                config=assistance_config(task),
                                estimator=estimator if condition in ESTIMATOR_CONDITIONS else None)
            verdict = None if ep.hand is None else judge_scene(
                [(o.scene.model, o.scene.base_T_obj_true) for o in objects], true, ep.task_set, ep.hand,
                ep.closures if ep.closures is not None else np.zeros(3))
            serves = verdict is not None and verdict.serves
            records.append({'operator': task.operator, 'episode': task.index, 'repeat': repeat,
                            'condition': condition, 'true_object': SCENE_OBJECTS[true],
                            'favoured': intent.probabilities[true] == max(intent.probabilities),
                            'task_set': ep.task_set, 'success': bool(serves and not ep.swept), 'serves': bool(serves),
                            'wrong_object': bool(verdict is not None and verdict.wrong_object),
                            'closed': ep.closed_at is not None,
                            'time': ep.closed_at if ep.closed_at is not None else task.timeout,
                            'pursued': ep.pursued, 'executed': ep.executed, 'executed_object': ep.executed_object,
                            'followed': ep.followed, 'switches': ep.switches,
                            'estimated_p_true': ep.estimated_p_true,
                            'wrong_object_alpha': ep.wrong_object_alpha, 'alpha_mean': ep.alpha_mean,
                            'effort_linear': ep.effort_linear, 'swept': ep.swept,
                            'swept_objects': dict(zip(SCENE_OBJECTS, ep.swept_objects)),
                            'in_at_closing': ep.in_at_closing, 'swept_palm_mm': _mm(ep.swept_palm),
                            'swept_finger_mm': _mm(ep.swept_finger),
                            'positions': [[round(float(v), 4) for v in p[:2, 3]] for p in true_poses],
                            'wall_s': time.perf_counter() - t0, 'run': run_settings(task)})
            if changing:
                assert intent.first_object is not None
                records[-1].update({'first_object': SCENE_OBJECTS[intent.first_object],
                                    'switch_at': intent.t_switch, 'follow_delay': ep.follow_delay,
                                    'estimate_delay': ep.estimate_delay,
                                    'wrong_object_alpha_after': ep.wrong_object_alpha_after})
    return records


def episode_figures(records: list[dict[str, Any]]) -> dict[str, dict[str, dict[int, float]]]:
    """The figures paired: figure -> condition -> episode -> the mean over the episode's repeats.

    Success and time (a run that never closed: the timeout). No separate clear-path success: this benchmark's
    success already requires that no object was swept.
    """
    return {'success': per_episode(records, 'success'), 'time': per_episode(records, 'time')}


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The figures of one operator model's records (module docstring), by condition, and the paired differences."""
    rng, rng_clear = np.random.default_rng(0), np.random.default_rng(1)
    figures = episode_figures(records)
    success = figures['success']
    table: dict[str, Any] = {}
    for c in [c for c in ALL_SCENE_CONDITIONS if c in success]:
        runs = [r for r in records if r['condition'] == c]
        eps = sorted(success[c])
        table[c] = {'success': float(np.mean([success[c][e] for e in eps])),
                    'serves': float(np.mean([r['serves'] for r in runs])),
                    'success_favoured': _share(runs, 'success', True),
                    'success_other': _share(runs, 'success', False),
                    'wrong_object': [sum(r['wrong_object'] for r in runs), len(runs)],
                    'median_time': float(np.median([r['time'] for r in runs])),
                    'wrong_object_alpha': float(np.mean([r['wrong_object_alpha'] for r in runs])),
                    'swept': [sum(r['swept'] for r in runs), len(runs)],
                    'timeouts': sum(not r['closed'] for r in runs), 'episodes': len(eps),
                    'estimated_p_true': _mean([r.get('estimated_p_true') for r in runs])}
        if any('switch_at' in r for r in runs):  # the operator that changes its mind
            table[c].update(_delays(runs, 'follow_delay'), **_delays(runs, 'estimate_delay'),
                            wrong_object_alpha_after=float(np.mean([r['wrong_object_alpha_after'] for r in runs])))
    for a, b in [(a, b) for a, b in PAIRS if a in success and b in success]:
        table[f'{a}-{b}'] = paired_difference({f: v[a] for f, v in figures.items()},
                                              {f: v[b] for f, v in figures.items()}, rng, rng_clear)
    return table


def _delays(runs: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """``key``'s median and 90th percentile over the runs that have it, and how many have none (never, closed first)."""
    present = [r[key] for r in runs if r.get(key) is not None]
    return {f'{key}_median': float(np.median(present)) if present else None,
            f'{key}_p90': float(np.percentile(present, 90)) if present else None,
            f'{key}_none': len(runs) - len(present)}


def _mean(values: list[float | None]) -> float | None:
    """The mean of the values that are not None; None without any."""
    present = [v for v in values if v is not None]
    return float(np.mean(present)) if present else None


def _share(runs: list[dict[str, Any]], key: str, favoured: bool) -> float | None:
    """The mean of ``key`` over the runs whose true object was (not) the favoured one; None without such runs."""
    chosen = [r[key] for r in runs if r['favoured'] == favoured]
    return float(np.mean(chosen)) if chosen else None


def report(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Print and return each operator model's summary."""
    out: dict[str, Any] = {}
    repeats = 1 + max(r['repeat'] for r in records)
    for op in [op for op in OPERATORS if any(r['operator'] == op for r in records)]:
        table = summarise([r for r in records if r['operator'] == op])
        out[op] = table
        episodes = max(row['episodes'] for c, row in table.items() if c in ALL_SCENE_CONDITIONS)
        print(f'\n[cup + flashlight / {op}] {episodes} episodes x {repeats} repeats')
        for c in [c for c in ALL_SCENE_CONDITIONS if c in table]:
            row = table[c]
            split = ' / '.join('-' if s is None else f'{s:.3f}' for s in (row['success_favoured'],
                                                                           row['success_other']))
            print(f'  {c:10s} success {row["success"]:.3f} (true object favoured / not: {split})  serves '
                  f'{row["serves"]:.3f}  wrong object {row["wrong_object"][0]}/{row["wrong_object"][1]}  median time '
                  f'{row["median_time"]:5.2f} s  alpha on the wrong object {row["wrong_object_alpha"]:.3f} s  swept '
                  f'{row["swept"][0]}/{row["swept"][1]}  timeouts {row["timeouts"]}'
                  + ('' if row['estimated_p_true'] is None else
                     f'  estimated P(true object) at the close {row["estimated_p_true"]:.3f}'))
            if 'follow_delay_none' in row:
                print(f'  {"":10s} after the switch: alpha on the wrong object {row["wrong_object_alpha_after"]:.3f} s'
                      + ''.join(f'  {what} median / p90 {_seconds(row[key + "_median"])} / '
                                f'{_seconds(row[key + "_p90"])} (none in {row[key + "_none"]} runs)'
                                for what, key in (('true object followed', 'follow_delay'),
                                                  ('estimated P(true) > 0.5', 'estimate_delay'))
                                if key != 'estimate_delay' or row['estimated_p_true'] is not None))
        for a, b in [(a, b) for a, b in PAIRS if f'{a}-{b}' in table]:
            d = table[f'{a}-{b}']
            print(f'  {a} - {b:10s} success {100 * d["success_diff"]:+5.1f} points [{100 * d["ci"][0]:+5.1f}, '
                  f'{100 * d["ci"][1]:+5.1f}]  time ratio {d["time_ratio"]:.2f} [{d["time_ratio_ci"][0]:.2f}, '
                  f'{d["time_ratio_ci"][1]:.2f}]')
    return out


def _seconds(value: float | None) -> str:
    """``value`` s to two decimals, '-' for None."""
    return '-' if value is None else f'{value:.2f} s'


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--episodes', type=int, default=50)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--operators', nargs='+', default=['joystick'], choices=list(OPERATORS))
    parser.add_argument('--conditions', nargs='+', default=list(SCENE_CONDITIONS), choices=list(ALL_SCENE_CONDITIONS))
    parser.add_argument('--timeout', type=float, default=25.0)
    parser.add_argument('--tracker-mm', type=float, default=5.0)
    parser.add_argument('--tracker-deg', type=float, default=3.0)
    parser.add_argument('--operator-mm', type=float, default=5.0)
    parser.add_argument('--operator-deg', type=float, default=3.0)
    parser.add_argument('--favoured', type=float, default=0.6, help='the held P(o) of the favoured object')
    parser.add_argument('--no-execute', action='store_true', help='the suite\'s grasp command closes the hand where '
                        'it is instead of executing the followed object\'s plan')
    parser.add_argument('--twist-joint-limit', default='clip', choices=TWIST_JOINT_LIMITS, help='the mock arm\'s '
                        'rule for a twist at a joint limit: clip each joint, or stop the arm as a whole')
    parser.add_argument('--no-assist-idle-part', dest='assist_idle_part', action='store_false', help='the suite\'s '
                        'assistance blends the part the operator leaves idle with alpha, as the moved part '
                        '(AssistanceConfig.assist_idle_part off; default: on, alpha_max there)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--records', help='append each episode\'s records here as they come (JSON lines)')
    parser.add_argument('--summarise', metavar='JSONL', help='run nothing: summarise the records of a --records file')
    args = parser.parse_args()
    if not 0.5 <= args.favoured < 1.0:
        parser.error('--favoured must be in [0.5, 1)')
    if args.summarise:
        report(read_records(args.summarise))
        return
    tasks = [SceneTask(op, i, args.seed, args.repeats, args.timeout, args.tracker_mm, args.tracker_deg,
                       args.operator_mm, args.operator_deg, args.favoured,
                       tuple(c for c in ALL_SCENE_CONDITIONS if c in args.conditions), not args.no_execute,
                       args.twist_joint_limit, args.assist_idle_part)
             for i in range(args.episodes) for op in args.operators]
    print(f'bench_shared_control_scene: {len(tasks)} episodes x {args.repeats} repeats x {len(args.conditions)} '
          f'conditions; {uptime()}', flush=True)
    t0 = time.monotonic()
    records = run_tasks(tasks, args.jobs, args.records, run_scene_task)
    report(records)
    print(f'\ndone in {time.monotonic() - t0:.0f} s; {uptime()}')


if __name__ == '__main__':
    main()
