r"""Calibration of the intent estimator on scripted reaches, ROS-free: Brier score and calibration error of w.

Each seeded operator is the shared-control benchmark's (:mod:`bench_shared_control`: its intent draw, its
two-mode joystick with reaction delay, noise and speed limits) reaching, without assistance, on the mock
MICO's twist mode (:class:`~grasp_intent_ros.mico.mock_arm.MockArm`, 100 Hz) for a grasp of its true task set S.
``--device spacemouse`` gives it the package's six-axis spacemouse instead (it turns the wrist from the start;
the joystick only within 3 cm of its grasp). Two goal rules (``--goals``):

- ``fresh`` (default): a new grasp for S, drawn from the data set's prototypes of S with its person's noise
  (:func:`grasp_intent_ros.objects.demos.sample_grasp`), kept when the object's rules label it exactly S
  and the MICO takes it as a demonstration (:func:`grasp_intent_ros.objects.demos.taken`: the open hand clear,
  the arm reaches it from Home): a grasp the estimator's demonstrations do not contain;
- ``own``: the shared-control benchmarks' own grasp for S (:func:`_bench.closed_loop_record.own_goals`: the
  planner's for the certain w_S, at the true object).

The estimator (:class:`~grasp_intent_ros.shared_control.estimator.IntentEstimator`, goals: the model's reachable
demonstrations) gets each operator twist with the hand's pose at that tick; it never sees S, the rules or
the operator's goal, and the operator never sees the estimator. At 25 / 50 / 75 % of the hand's path length
(its translation, from the start to the grasp or the timeout) w is compared with S's indicator: the Brier
score (mean over tasks of (w_i - 1[i in S])^2, then over episodes) and the expected calibration error (10
equal-width bins over all (episode, task) pairs: sum over bins of n_b / n |mean w - frequency|), per object
and per true task set, against the estimator's prior (w before any motion) and the scripted w of the
shared-control benchmark (its ``Intent.w`` at the same instant). 95 % CIs of the paired Brier differences
are bootstrap (2,000 resamples of episodes). Also the time of one update (all goals; wall clock, and the
thread's CPU time, which a loaded machine's preemption does not enter) and, with ``--plot``,
a reliability diagram. The targets (the README's row "intent from the operator's reach"): at 50 % of the path a
Brier score <= 0.15 and a calibration error <= 0.1 (the prior's Brier score: 0.25); the method and the figures
measured: docs/intent_estimation.md, "Calibration (bench_intent_estimation)".

The estimator's settings are the node's defaults for the object's model
(:func:`~grasp_intent_ros.shared_control.parameters.default_estimator_config`: with its calibration map if the
defaults list one). ``--compare FIELD=VALUE ...`` also scores an estimator with those settings (the rest as the
defaults') on the same reaches: its Brier score and calibration error, and the paired Brier difference of the
defaults minus it; e.g. a candidate default, a calibration map (``calibration_slope=1.4 calibration_offset=-0.09``)
or none (``calibration_slope=1 calibration_offset=0``).

``--fit`` searches the estimator's rationality and memory on training seeds (``--seed`` + 100), both devices
(``--device`` is ignored), and prints the grid of both devices' scores and their mean, and the point whose mean
is least (:func:`fit`); ``--fit-calibration`` fits the calibration map of the marginals (``calibration_slope``,
``calibration_offset``: :mod:`grasp_intent_ros.shared_control.calibration`) to the uncalibrated estimator's w
at 25 / 50 / 75 % of the path of the training seeds' reaches, both devices, per object (the node's
``calibration_models``) and the objects pooled, and prints them with the training reaches' calibration error
before and after. The reported figures use ``--seed`` (the
shared-control benchmark's seeds), held out from both fits.

    .venv/bin/python benchmarks/bench_intent_estimation.py [--operators 50] [--goals fresh] [--plot docs/x.png] \
        [--compare rationality=3000]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import deque
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from _bench import uptime
from _bench.closed_loop import BASE_T_OBJ, OBJECTS, PERIOD, load_model
from _bench.closed_loop_record import own_goals
from bench_shared_control_sim import estimator_fields

from grasp_intent_ros.mico.frames import features_to_obj_T_ee
from grasp_intent_ros.mico.kinematics import BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm, check_twist
from grasp_intent_ros.objects.demos import ObjectRules, object_of, sample_grasp, taken
from grasp_intent_ros.sessions.closed_loop import reached
from grasp_intent_ros.shared_control.calibration import calibrate, fit_calibration
from grasp_intent_ros.shared_control.estimator import EstimatorConfig, IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_at, reachable_goals
from grasp_intent_ros.shared_control.operators import Device, OperatorConstants, ScriptedOperator, SharpeningIntent
from grasp_intent_ros.shared_control.parameters import default_estimator_config

FRACTIONS = (0.25, 0.5, 0.75)
BETAS = (30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0)
MEMORIES = (0.05, 0.1, 0.2, 0.4, 1.0)
"""The grid of ``--fit``: rationality (1/m) and memory (m)."""
FIT_DEVICES: tuple[Device, ...] = ('joystick', 'spacemouse')
"""The operator devices ``--fit`` and ``--fit-calibration`` score, alike."""
W_EVERY = 10
"""Operator ticks per scripted w (10 Hz, as the shared-control benchmark sends it)."""


@dataclass
class Reach:
    """One operator's reach: what the estimator is fed, and what judges it."""

    task_set: int
    hands: np.ndarray      # (T, 4, 4) the hand's pose at each tick
    twists: np.ndarray     # (T, 6) the operator's twist at each tick
    scripted: np.ndarray   # (T, 3) the shared-control benchmark's scripted w at each tick
    path: np.ndarray       # (T,) the hand's translation path so far, m
    success: bool
    seconds: float


FRESH_DRAWS = 20000
"""Draws :func:`fresh_goal` makes at most (the cup's usage, transfer and handover at once keeps few: its band is
narrow for the hand and the arm)."""


def fresh_goal(rules: ObjectRules, task_set: int, rng: np.random.Generator) -> np.ndarray:
    """A new grasp for exactly ``task_set`` near one of its prototypes, one the MICO takes from Home: base_T_ee.

    Taken as the data generator takes a demonstration (:func:`~grasp_intent_ros.objects.demos.taken`: the open hand
    clear, the arm reaches it from Home at the default object pose).
    """
    for _ in range(FRESH_DRAWS):
        protos = rules.prototypes[task_set]
        x = sample_grasp(protos[int(rng.integers(len(protos)))], rules.noise, rng)
        if rules.label(x) == task_set and taken(rules, x):
            return BASE_T_OBJ @ features_to_obj_T_ee(x)
    sys.exit(f'bench_intent_estimation: no grasp of set {task_set} the MICO takes in {FRESH_DRAWS} draws')


def simulate(op: OperatorConstants, goal: np.ndarray, intent_w: object, task_set: int, kin: MicoKinematics,
             rng: np.random.Generator, timeout: float, device_name: Device = 'joystick') -> Reach:
    """The scripted operator (its device ``device_name``) reaching ``goal`` directly (no assistance)."""
    arm = MockArm(kin, np.r_[HOME_Q, 0.0, 0.0, 0.0])
    seen: deque[np.ndarray] = deque(maxlen=max(1, round(op.reaction / PERIOD)) + 1)
    device = ScriptedOperator(device_name, op, rng, PERIOD)
    hands, twists, scripted, path = [], [], [], []
    walked, w = 0.0, None
    success = False
    tick = 0
    while True:
        t = tick * PERIOD
        hand = kin.fk(arm.q[:6])
        if hands:
            walked += float(np.linalg.norm(hand[:3, 3] - hands[-1][:3, 3]))
        seen.append(hand)
        if tick % W_EVERY == 0:
            w = intent_w(t, rng)  # type: ignore[operator]
        if reached(hand, goal):
            success = True
            break
        if t >= timeout:
            break
        command = device.twist(t, seen[0] if t >= op.reaction else None, goal)
        hands.append(hand)
        twists.append(command)
        scripted.append(w)
        path.append(walked)
        arm.command_twist(check_twist(command[:3], command[3:], BASE_FRAME), t)
        tick += 1
        arm.step(tick * PERIOD, PERIOD)
    return Reach(task_set, np.array(hands), np.array(twists), np.array(scripted), np.array(path), success,
                 tick * PERIOD)


def reaches(name: str, seed: int, operators: int, goals_rule: str, kin: MicoKinematics, op: OperatorConstants,
            timeout: float, device: Device = 'joystick') -> list[Reach]:
    """The reaches of ``operators`` seeded operators on object ``name``."""
    model = load_model(name)
    rules = object_of(model)
    assert rules is not None, f'{model.name} names no object with rules'
    own = own_goals(model, kin) if goals_rule == 'own' else {}
    out = []
    for i in range(operators):
        rng = np.random.default_rng([seed, list(OBJECTS).index(name), i])
        intent = SharpeningIntent.draw(rng)
        task_set = intent.true_set
        goal = own[task_set].base_T_ee if goals_rule == 'own' else fresh_goal(rules, task_set, rng)
        out.append(simulate(op, goal, intent.w, task_set, kin, rng, timeout, device))
    return out


def indicator(task_set: int, m: int = 3) -> np.ndarray:
    return np.array([float(task_set >> i & 1) for i in range(m)])


def estimates(runs: list[Reach], estimator: IntentEstimator, timings: list[float] | None = None) -> np.ndarray:
    """W at each fraction of each reach, shape (len(runs), len(FRACTIONS), m)."""
    out = np.empty((len(runs), len(FRACTIONS), estimator.goals.n_tasks))
    for r, run in enumerate(runs):
        estimator.reset()
        ticks = [int(np.searchsorted(run.path, f * run.path[-1])) for f in FRACTIONS]
        k = 0
        for tick in range(len(run.twists)):
            start, cpu = time.perf_counter(), time.thread_time()
            estimator.update(run.hands[tick], run.twists[tick], PERIOD)
            if timings is not None:
                timings.append((time.perf_counter() - start, time.thread_time() - cpu))
            while k < len(ticks) and tick >= ticks[k]:
                out[r, k] = estimator.w
                k += 1
        while k < len(ticks):
            out[r, k] = estimator.w
            k += 1
    return out


def scripted_at(runs: list[Reach]) -> np.ndarray:
    """The scripted w at each fraction, shape (len(runs), len(FRACTIONS), 3)."""
    return np.array([[run.scripted[min(int(np.searchsorted(run.path, f * run.path[-1])), len(run.path) - 1)]
                      for f in FRACTIONS] for run in runs])


def brier(w: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Per-episode Brier score, mean over tasks: w (n, m), truth (n, m) -> (n,)."""
    return np.mean((w - truth) ** 2, axis=-1)


def ece(w: np.ndarray, truth: np.ndarray, bins: int = 10) -> float:
    """Expected calibration error over all (episode, task) pairs, ``bins`` equal-width bins."""
    p, y = w.ravel(), truth.ravel()
    index = np.minimum((p * bins).astype(int), bins - 1)
    return float(sum(abs(p[index == b].mean() - y[index == b].mean()) * np.count_nonzero(index == b)
                     for b in range(bins) if np.any(index == b)) / p.size)


def ci95(diff: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    means = [float(np.mean(rng.choice(diff, diff.size))) for _ in range(2000)]
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def estimator_for(name: str, kin: MicoKinematics, config: EstimatorConfig | None = None) -> IntentEstimator:
    """Object ``name``'s estimator at :data:`BASE_T_OBJ` (its reachable goals), ``config`` or the node's defaults."""
    model = load_model(name)
    if config is None:
        config = default_estimator_config(model.name)
    return IntentEstimator(goals_at(model, BASE_T_OBJ, reachable_goals(model, BASE_T_OBJ, kin)), config)


def report(name: str, runs: list[Reach], est: np.ndarray, scripted: np.ndarray, prior: np.ndarray) -> dict[str, object]:
    truth = np.array([indicator(r.task_set) for r in runs])
    rng = np.random.default_rng(0)
    print(f'\n[{name}] {len(runs)} reaches, {sum(r.success for r in runs)} reached their grasp; median '
          f'{statistics.median(r.seconds for r in runs):.1f} s, path '
          f'{statistics.median(r.path[-1] for r in runs):.2f} m')
    print(f'{"path":>5s} {"Brier est":>10s} {"prior":>7s} {"scripted":>9s} {"ECE est":>8s} {"prior":>6s} '
          f'{"scripted":>9s}  est - prior [95% CI]        est - scripted [95% CI]')
    rows = {}
    for k, f in enumerate(FRACTIONS):
        b_est, b_scr = brier(est[:, k], truth), brier(scripted[:, k], truth)
        b_pri = brier(np.broadcast_to(prior, truth.shape), truth)
        lo1, hi1 = ci95(b_est - b_pri, rng)
        lo2, hi2 = ci95(b_est - b_scr, rng)
        rows[f] = (b_est.mean(), b_pri.mean(), b_scr.mean(), ece(est[:, k], truth))
        print(f'{f:5.0%} {b_est.mean():10.3f} {b_pri.mean():7.3f} {b_scr.mean():9.3f} {ece(est[:, k], truth):8.3f} '
              f'{ece(np.broadcast_to(prior, truth.shape), truth):6.3f} {ece(scripted[:, k], truth):9.3f}  '
              f'{(b_est - b_pri).mean():+.3f} [{lo1:+.3f}, {hi1:+.3f}]   {(b_est - b_scr).mean():+.3f} '
              f'[{lo2:+.3f}, {hi2:+.3f}]')
    print('per true task set at 50 % (n, Brier est / scripted, mean w est):')
    labels = {1: 'U', 2: 'T', 3: 'UT', 4: 'H', 5: 'UH', 6: 'TH', 7: 'UTH'}
    k = FRACTIONS.index(0.5)
    for s in sorted(set(r.task_set for r in runs)):
        sel = np.array([r.task_set == s for r in runs])
        print(f'  {labels[s]:4s} n={sel.sum():3d}  {brier(est[sel, k], truth[sel]).mean():.3f} / '
              f'{brier(scripted[sel, k], truth[sel]).mean():.3f}   w = '
              f'({", ".join(f"{v:.2f}" for v in est[sel, k].mean(axis=0))})')
    return rows


def compare(runs: list[Reach], est: np.ndarray, other: np.ndarray, label: str) -> None:
    """The defaults' w ``est`` against ``other``: another estimator's on the same reaches (as :func:`estimates`)."""
    truth = np.array([indicator(r.task_set) for r in runs])
    rng = np.random.default_rng(0)
    print(f'against {label} (same reaches): path, Brier defaults / it, ECE defaults / it, defaults - it [95% CI]')
    for k, f in enumerate(FRACTIONS):
        b_est, b_other = brier(est[:, k], truth), brier(other[:, k], truth)
        lo, hi = ci95(b_est - b_other, rng)
        print(f'{f:5.0%}  {b_est.mean():.3f} / {b_other.mean():.3f}  {ece(est[:, k], truth):.3f} / '
              f'{ece(other[:, k], truth):.3f}  {(b_est - b_other).mean():+.3f} [{lo:+.3f}, {hi:+.3f}]')


def fit(names: list[str], args: argparse.Namespace, kin: MicoKinematics, op: OperatorConstants) -> None:
    """Grid of rationality x memory on the training seeds (no calibration map), both devices.

    A grid point's score on one device is its mean Brier score over the fractions and the objects; the choice
    minimises the mean of the devices' scores (on an exact tie the first in grid order: the smaller rationality,
    then the smaller memory).
    """
    runs = {(name, device): reaches(name, args.seed + 100, args.operators, args.goals, kin, op, args.timeout, device)
            for name in names for device in FIT_DEVICES}
    base = {name: estimator_for(name, kin, EstimatorConfig()) for name in names}
    print(f'fit on seed {args.seed + 100}, {args.operators} operators per object and device; mean Brier over '
          f'25/50/75 % and the objects; each cell {" / ".join(FIT_DEVICES)} / their mean; memory {MEMORIES} m',
          flush=True)
    scores = np.zeros((len(BETAS), len(MEMORIES), len(FIT_DEVICES)))
    for i, beta in enumerate(BETAS):
        for j, memory in enumerate(MEMORIES):
            config = replace(EstimatorConfig(), rationality=beta, memory=memory, calibration_slope=1.0,
                             calibration_offset=0.0)
            for d, device in enumerate(FIT_DEVICES):
                for name in names:
                    base[name].config = config
                    truth = np.array([indicator(r.task_set) for r in runs[name, device]])
                    w = estimates(runs[name, device], base[name])
                    scores[i, j, d] += float(np.mean([brier(w[:, k], truth).mean()
                                                      for k in range(len(FRACTIONS))])) / len(names)
        print(f'  beta {beta:7.1f}: ' + '  '.join(' / '.join(f'{v:.4f}' for v in (*scores[i, j], scores[i, j].mean()))
                                                  for j in range(len(MEMORIES))), flush=True)
    i, j = np.unravel_index(int(np.argmin(scores.mean(axis=2))), scores.shape[:2])  # the first minimum, row-major
    print(f'best: beta {BETAS[i]}, memory {MEMORIES[j]} (mean {scores[i, j].mean():.4f}; '
          + ', '.join(f'{device} {v:.4f}' for device, v in zip(FIT_DEVICES, scores[i, j])) + ')')


def calibration_fit(names: list[str], args: argparse.Namespace, kin: MicoKinematics, op: OperatorConstants) -> None:
    """The calibration map fitted on the training seeds' reaches of both devices (module docstring)."""
    raw = replace(EstimatorConfig(), calibration_slope=1.0, calibration_offset=0.0)
    print(f'calibration fit on seed {args.seed + 100}, {args.operators} operators per object and device; '
          f'uncalibrated estimator (rationality {raw.rationality}, memory {raw.memory})', flush=True)
    cells: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for name in names:
        estimator = estimator_for(name, kin, raw)
        for device in FIT_DEVICES:
            runs = reaches(name, args.seed + 100, args.operators, args.goals, kin, op, args.timeout, device)
            truth = np.array([indicator(r.task_set) for r in runs])
            cells[name, device] = (estimates(runs, estimator), np.broadcast_to(truth[:, None, :], (len(runs),
                                   len(FRACTIONS), truth.shape[1])))
            print(f'  {name} {device}: {len(runs)} reaches; {uptime()}', flush=True)
    w = np.concatenate([c[0] for c in cells.values()])
    y = np.concatenate([c[1] for c in cells.values()])
    slope, offset = fit_calibration(w, y, raw.w_floor)
    print(f'fit (all pooled): calibration_slope={slope:.4f} calibration_offset={offset:.4f}')
    for name in names:
        one = [cells[name, d] for d in FIT_DEVICES]
        a, b = fit_calibration(np.concatenate([c[0] for c in one]), np.concatenate([c[1] for c in one]), raw.w_floor)
        print(f'  {name} alone: slope {a:.4f}, offset {b:.4f}')
    print('training reaches, ECE before / after the pooled map at 25 / 50 / 75 %:')
    for (name, device), (wc, yc) in cells.items():
        after = calibrate(wc, slope, offset, raw.w_floor)
        print(f'  {name:10s} {device:10s} ' + '  '.join(
            f'{ece(wc[:, k], yc[:, k]):.3f} / {ece(after[:, k], yc[:, k]):.3f}' for k in range(len(FRACTIONS))))


def plot(path: Path, curves: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot([0, 1], [0, 1], color='0.6', lw=1, ls='--', label='perfectly calibrated')
    edges = np.linspace(0.0, 1.0, 11)
    for label, (w, truth) in curves.items():
        p, y = w.ravel(), truth.ravel()
        index = np.minimum((p * 10).astype(int), 9)
        xs = [p[index == b].mean() for b in range(10) if np.any(index == b)]
        ys = [y[index == b].mean() for b in range(10) if np.any(index == b)]
        ax.plot(xs, ys, marker='o', label=label)
    ax.set_xticks(edges[::2])
    ax.set_xlabel('estimated w_i (bin mean)')
    ax.set_ylabel('frequency of task i in the true set')
    ax.set_title('Intent estimator: reliability at 50 % of the path')
    ax.legend(loc='upper left', fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f'wrote {path}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--operators', type=int, default=50)
    parser.add_argument('--objects', nargs='+', default=list(OBJECTS), choices=list(OBJECTS))
    parser.add_argument('--goals', choices=('fresh', 'own'), default='fresh')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--timeout', type=float, default=25.0)
    parser.add_argument('--device', choices=('joystick', 'spacemouse'), default='joystick')
    parser.add_argument('--fit', action='store_true',
                        help='search rationality x memory on seed + 100, both devices, instead')
    parser.add_argument('--fit-calibration', action='store_true',
                        help='fit the calibration map on seed + 100, both devices, instead')
    parser.add_argument('--compare', nargs='+', default=[], metavar='FIELD=VALUE',
                        help='also score an estimator with these EstimatorConfig fields on the same reaches, paired')
    parser.add_argument('--plot', type=Path, help='write the reliability diagram at 50 %% here (PNG)')
    args = parser.parse_args()
    kin, op = MicoKinematics(), OperatorConstants()
    print(f'bench_intent_estimation: {args.operators} operators per object, goals {args.goals}, device {args.device}; '
          f'{uptime()}', flush=True)
    if args.fit:
        fit(args.objects, args, kin, op)
        return
    if args.fit_calibration:
        calibration_fit(args.objects, args, kin, op)
        return
    curves = {}
    for name in args.objects:
        runs = reaches(name, args.seed, args.operators, args.goals, kin, op, args.timeout, args.device)
        estimator = estimator_for(name, kin)
        timings: list[tuple[float, float]] = []
        est = estimates(runs, estimator, timings)
        prior = IntentEstimator(estimator.goals, estimator.config).w
        report(name, runs, est, scripted_at(runs), prior)
        if args.compare:
            other = IntentEstimator(estimator.goals, replace(estimator.config, **dict(estimator_fields(args.compare))))
            compare(runs, est, estimates(runs, other), ' '.join(args.compare))
        t = np.array(timings) * 1e3
        print(f'one update, {len(estimator.goals)} goals ({len(t)} updates): wall median {np.median(t[:, 0]):.3f} ms, '
              f'p99 {np.percentile(t[:, 0], 99):.3f} ms; CPU (this thread) median {np.median(t[:, 1]):.3f} ms, '
              f'p99 {np.percentile(t[:, 1], 99):.3f} ms')
        truth = np.array([indicator(r.task_set) for r in runs])
        k = FRACTIONS.index(0.5)
        curves[f'{name}: estimator'] = (est[:, k], truth)
        curves[f'{name}: scripted w'] = (scripted_at(runs)[:, k], truth)
    print(f'done; {uptime()}')
    if args.plot:
        plot(args.plot, curves)


if __name__ == '__main__':
    main()
