"""Task-success benchmark: does the planned grasp serve the operator's task? Prints figures, asserts nothing.

The judge is the object's Table I rules (:data:`grasp_intent_ros.objects.demos.OBJECTS`, ``label(x)``): the
planner never sees them. Operator model (the paper's own assumption): the intent inference gives w, and the
operator's true task set T holds each task i independently with probability w_i, conditioned on T being
non-empty. A grasp x succeeds when the rule of every task in T holds, T <= label(x), so its success is

    S(x; w) = P(T <= label(x) | T != {}) = (prod_{i not in label(x)} (1 - w_i) - u_0) / (1 - u_0),
    u_0 = prod_i (1 - w_i)

(exact; ``--draws`` also prints the Monte-Carlo estimate with that many draws of T per w, the sampling check
of the exact sum). Per model and method, on seeded random w (uniform in [0, 1]^3, w asking for clarification
redrawn, as bench_planner) and on the paper's seven cases per object (every task alone, every pair, all three
at 0.9 against 0.1):

- ``success``: mean S(x; w);
- ``top``: share of plans that serve the most likely task set (label(x) contains the tasks of v's top zone);
- ``none``: share of plans that serve no task (label(x) empty);
- ``faithful``: the model's reading of the grasp (the tasks of its most likely zone, argmax P(x)) holds no
  task the operator is unlikely to want: none with w_i < 0.25 unless it is a task of v's top zone; and, in
  brackets, the same of the tasks the grasp does by the rules, label(x) (a grasp that does every task but
  that the model misreads passes the first and fails the second);
- ``legible``: strict legibility, argmax P(x) = argmax v;
- ``f`` and ``max|v-P|``: the paper's objective 1/2 |v - P|^2 (mean) and the largest deviation (mean);
- ``density``: the grasp's mixture density sum_k pi_k N_k(x) as a percentile of the demonstrations' (median);
- the rule conditions that failed, for the plans that miss a task of the top zone (most frequent first);
- ``executed``: success of the grasp as executed, at each level of ``--noise`` (multiples of the documented
  1x :class:`~grasp_intent_ros.planning.robustness.ExecutionNoise`): the mean of S(x'; w) over ``--landings``
  landings x' of x, the same landings (seeded) for every w and every method, judged by the rules.

Per model and noise level, ``robust - exact`` and ``robust - ceiling``: the mean paired difference of
success as executed (the same w and landings), in points, with its 95% confidence interval (:func:`paired`).

``ceiling`` is no planner: the best pick among the demonstrations the exact planner would choose from
without noise (those that serve v's top zone, are faithful and have the highest expected success, all
serving the same tasks), made knowing the rules: at each noise level, the one with the highest success over
``--landings`` other landings (a second seed, so that the pick is not fitted to the landings that judge it).

Methods: ``exact`` (:func:`planner.plan` with its defaults: the task-serving planner, its threshold tau
``--tau``, planning for an exact landing), ``robust`` (the same planning for the 1x execution noise, the
option ``TaskOptions(noise=ExecutionNoise())``), ``reading`` (``exact`` with ``faithful='reading'``: only the
model's reading of the demonstration must hold no unlikely task, not its label), ``paper`` (method ``'lm'``:
exact P = v, else least squares), ``slsqp`` (the paper's run: one start, SLSQP, finite differences; slow, so
on ``--slsqp-n`` of the w), ``start`` (Algorithm 1's start, unmoved), ``top-only`` (the paper's planner on the
one-hot v of the top zone) and ``ceiling`` (above). Models: the four shipped ones, and 7-zone models trained
on data sets generated with each seed of ``--data-seeds`` (the shipped data sets are seed 0), so no figure is
a property of one data set.
``--frontier`` prints the task planner's trade-off (success, faithfulness, legibility, fit) over a range of
thresholds.

``--physics`` (needs the ``bench`` extra, MuJoCo) runs the planner node's policy (``mico.grasp.plan_grasp``, IK
included, the node's default options: the 1x execution noise) on the 7-zone models with the object at the
suite's default pose, without and with the hand's
collision check (``mico.collision``), and has an independent judge (``judge_physics``: MuJoCo on the URDF, the
plan's joint targets, the table plane z = 0 of the object frame and the object's body of the rules) say which
published grasps put a hand part > 5 mm below the table with the fingers open or the wrist/palm > 2 mm into the
object, and how many fingers meet the table while closing; with success counting a w without a grasp as 0,
and the median planning time without and with the check (the planner with the check as its ``accept``, IK left
out; the check's verdicts for the model's candidates computed once before, as a running planner keeps them).

    python benchmarks/bench_task_success.py [--n 500] [--seed 0] [--methods exact,robust,paper,start,top-only,slsqp]
        [--models cup_7zone,...] [--data-seeds 1,2] [--draws 20] [--slsqp-n 50] [--frontier] [--cases-only]
        [--noise 0,1,2] [--landings 40] [--physics]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from bench_planner import CASES, random_targets  # the same w as the planner benchmark's
from numpy.typing import NDArray

from grasp_intent_ros.method import intent
from grasp_intent_ros.method.log_space import log_sum_exp
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.objects import demos as rules_module
from grasp_intent_ros.objects.demos import OBJECTS, ObjectRules, object_of
from grasp_intent_ros.planning import common, planner, ranking
from grasp_intent_ros.planning.options import ScipyOptions, TaskOptions, node_default_options
from grasp_intent_ros.planning.robustness import ExecutionNoise, perturb, standard_draws
from grasp_intent_ros.resources import config_dir

MODELS = ('cup_7zone', 'flashlight_7zone', 'cup_5zone', 'cup_4zone')
UNLIKELY = 0.25
"""A task with w_i below this is one the operator is unlikely to want (faithfulness)."""
LANDING_SEED = 1000
"""Seed of the landings that judge grasps as executed; the ceiling picks on LANDING_SEED + 1's."""

Planned = Callable[[GraspModel, NDArray[np.float64]], NDArray[np.float64]]


def rules_for(model: GraspModel) -> ObjectRules:
    """The judge of a model: the rules of the object its document names (:func:`~.demos.object_of`)."""
    rules = object_of(model)
    if rules is not None:
        return rules
    raise KeyError(f'no rules for model {model.name!r}: its document names the object {model.object_name!r} '
                   f'(field "object"; known: {", ".join(OBJECTS)})')


def success(label: int, w: NDArray[np.float64]) -> float:
    """S(x; w) for a grasp whose rules hold the tasks of ``label`` (module docstring), exact."""
    none = math.prod(1.0 - wi for wi in w.tolist())
    unserved = math.prod(1.0 - wi for i, wi in enumerate(w.tolist()) if not label >> i & 1)
    return (unserved - none) / (1.0 - none)


def sampled_success(label: int, w: NDArray[np.float64], draws: int, rng: np.random.Generator) -> float:
    """S(x; w) estimated from ``draws`` non-empty task sets T drawn under the operator model."""
    hits = 0
    for _ in range(draws):
        while True:
            t = int(((rng.uniform(size=w.size) < w) * (1 << np.arange(w.size))).sum())
            if t:
                break
        hits += (t & label) == t
    return hits / draws


def top_zone(model: GraspModel, v: NDArray[np.float64]) -> int:
    """Index of v's most likely zone (the planner's own order: v at 1e-9, ties to the first zone)."""
    return int(common.zone_order(v)[0])


def log_density(model: GraspModel, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The mixture's log density, log sum_k pi_k N_k(x), for rows x (N, d)."""
    return log_sum_exp(model.log_joint(x))


@dataclass
class Tally:
    """Running figures of one method on one set of w."""

    success: list[float] = field(default_factory=list)
    sampled: list[float] = field(default_factory=list)
    top: int = 0
    none: int = 0
    faithful: int = 0
    does_wanted: int = 0
    legible: int = 0
    f: list[float] = field(default_factory=list)
    dev: list[float] = field(default_factory=list)
    density: list[float] = field(default_factory=list)
    failed: Counter[str] = field(default_factory=Counter)
    ms: list[float] = field(default_factory=list)
    executed: dict[float, list[float]] = field(default_factory=dict)

    def line(self) -> str:
        n = len(self.success)
        pct = lambda k: f'{100 * k / n:5.1f}%'  # noqa: E731
        sampled = f' (sampled {100 * np.mean(self.sampled):5.1f}%)' if self.sampled else ''
        return (f'success {100 * np.mean(self.success):5.1f}%{sampled}  top {pct(self.top)}  none {pct(self.none)}  '
                f'faithful {pct(self.faithful)} (label {pct(self.does_wanted)})  legible {pct(self.legible)}  '
                f'f {np.mean(self.f):.2e}  '
                f'max|v-P| {np.mean(self.dev):.3f}  density pct {np.median(self.density):5.1f}  '
                f'ms {np.median(self.ms):6.2f}'
                + ''.join(f'  executed {level:g}x {100 * np.mean(v):5.1f}%' for level, v in self.executed.items()))


class Judge:
    """Scores grasps of one model by its object's rules (the rules stay here, out of core)."""

    def __init__(self, model: GraspModel) -> None:
        self.model = model
        self.rules = rules_for(model)
        self.demo_density = np.sort(log_density(model, model.demo_x))

    def label(self, x: NDArray[np.float64]) -> int:
        return self.rules.label(x)

    def add(self, tally: Tally, x: NDArray[np.float64], w: NDArray[np.float64], v: NDArray[np.float64],
            draws: int, rng: np.random.Generator) -> int:
        """Score x for (w, v) into ``tally``; returns label(x)."""
        model = self.model
        label = self.label(x)
        post = model.posterior(x)
        k_top = top_zone(model, v)
        z_top = model.zones[k_top]
        reading = model.zones[int(np.argmax(post))]
        allowed = z_top | sum(1 << i for i, wi in enumerate(w.tolist()) if wi >= UNLIKELY)
        tally.success.append(success(label, w))
        if draws:
            tally.sampled.append(sampled_success(label, w, draws, rng))
        tally.top += (label & z_top) == z_top
        tally.none += label == 0
        tally.faithful += (reading & ~allowed) == 0
        tally.does_wanted += (label & ~allowed) == 0
        tally.legible += int(np.argmax(post)) == k_top
        r = v - post
        tally.f.append(0.5 * float(r @ r))
        tally.dev.append(float(np.abs(r).max()))
        dens = float(log_density(model, x[None, :])[0])
        tally.density.append(100.0 * np.searchsorted(self.demo_density, dens) / self.demo_density.size)
        if (label & z_top) != z_top:
            for task, checks in self.rules.explain(x).items():
                i = self.rules.task_names.index(task)
                if z_top >> i & 1:
                    tally.failed.update(f'{task}: {name}' for name, ok in checks.items() if not ok)
        return label


class Landings:
    """A grasp judged as executed: the rules' labels of its landings under one noise level, kept per grasp."""

    def __init__(self, judge: Judge, level: float, count: int, seed: int) -> None:
        self.judge = judge
        self.noise = ExecutionNoise().scaled(level)
        self.z = standard_draws(count, seed)
        self._labels: dict[bytes, NDArray[np.int64]] = {}

    def labels(self, x: NDArray[np.float64]) -> NDArray[np.int64]:
        """label(x') of each landing x' of x, shape (landings,)."""
        key = x.tobytes()
        if key not in self._labels:
            landed = perturb(x[None, :], self.z, self.noise, self.judge.model.features)[0]
            self._labels[key] = np.array([self.judge.label(y) for y in landed], dtype=np.int64)
        return self._labels[key]

    def success(self, x: NDArray[np.float64], w: NDArray[np.float64]) -> float:
        """Mean S(x'; w) over the landings x' of x."""
        table = np.array([success(label, w) for label in range(1 << w.size)])
        return float(table[self.labels(x)].mean())


def paired(a: Sequence[float], b: Sequence[float]) -> str:
    """Mean of the paired differences a - b (the same w) in points, with its 95% confidence interval.

    The interval is the mean +- 1.96 standard errors (sample standard deviation / sqrt(n)): the normal
    approximation, sound for the hundreds of w the benchmark draws.
    """
    d = 100.0 * (np.asarray(a) - np.asarray(b))
    half = 1.96 * float(d.std(ddof=1)) / math.sqrt(d.size) if d.size > 1 else math.inf
    return f'{d.mean():+5.1f} [{d.mean() - half:+5.1f}, {d.mean() + half:+5.1f}]'


def ceiling_pick(model: GraspModel, v: NDArray[np.float64], w: NDArray[np.float64], picker: Landings | None
                 ) -> NDArray[np.float64]:
    """The module docstring's ``ceiling``: among the noise-free planner's best candidates, the best as executed.

    ``picker`` judges them (other landings than the judging ones); None: the planner's own first (no noise).
    """
    x_ref = common.Feasible(model).project(common.select_starts(model, v, 1, 1)[:1])[0]
    ranked = ranking.rank(model, v, top_zone(model, v), x_ref)
    best = (ranked.tier == ranked.tier[0]) & (np.abs(ranked.expected - ranked.expected[0]) <= 1e-9)
    xs = ranked.x[best]
    if picker is None:
        return xs[0]
    scores = [picker.success(x, w) for x in xs]
    return xs[int(np.argmax(scores))]


def methods(tau: float | None) -> dict[str, Planned]:
    """The methods side by side (module docstring)."""
    def one_hot(model: GraspModel, v: NDArray[np.float64]) -> NDArray[np.float64]:
        e = np.zeros_like(v)
        e[top_zone(model, v)] = 1.0
        return planner.plan(model, e, method='lm').x

    exact = TaskOptions() if tau is None else TaskOptions(tau=tau)
    robust = replace(exact, noise=ExecutionNoise())
    reading = replace(exact, faithful='reading')
    return {
        'robust': lambda model, v: planner.plan(model, v, options=robust).x,
        'exact': lambda model, v: planner.plan(model, v, options=exact).x,
        'reading': lambda model, v: planner.plan(model, v, method='task', options=reading).x,
        'paper': lambda model, v: planner.plan(model, v, method='lm').x,
        'slsqp': lambda model, v: planner.plan(model, v, method='slsqp',
                                               options=ScipyOptions(n_starts=1, top_zones=1, gradient='2-point')).x,
        'start': lambda model, v: common.select_starts(model, v, 1, 1)[0],
        'top-only': one_hot,
        'ceiling': lambda model, v: ceiling_pick(model, v, np.zeros(0), None),  # its w-dependent picks: run_model
    }


def regenerated(seed: int) -> list[GraspModel]:
    """7-zone models of both objects trained on data sets generated with ``seed`` (shipped: seed 0)."""
    out = []
    for name, rules in OBJECTS.items():
        data = rules_module.generate(rules, seed=seed)
        out.append(GraspModel.fit(data, name=f'{name}_7zone@seed{seed}', body=rules.body, object_name=name))
    return out


def run_model(model: GraspModel, chosen: dict[str, Planned], n: int, seed: int, draws: int, slsqp_n: int,
              cases_only: bool, levels: Sequence[float], landings: int) -> None:
    judge = Judge(model)
    targets = [] if cases_only else list(random_targets(model, n, seed))
    print(f'  {model.name} ({len(model.zones)} zones): {len(targets)} random w')
    judges = {level: Landings(judge, level, landings, LANDING_SEED) for level in levels}
    pickers = {level: Landings(judge, level, landings, LANDING_SEED + 1) for level in levels}
    tallies: dict[str, Tally] = {}
    for name, method in chosen.items():
        tally = tallies[name] = Tally()
        rng = np.random.default_rng(seed + 7)
        for i, (w, v) in enumerate(targets):
            if name == 'slsqp' and i >= slsqp_n:
                break
            t0 = time.perf_counter()
            x = method(model, v)
            tally.ms.append(1e3 * (time.perf_counter() - t0))
            judge.add(tally, x, w, v, draws, rng)
            for level, landed in judges.items():
                if name == 'ceiling' and level > 0.0:
                    x = ceiling_pick(model, v, w, pickers[level])
                tally.executed.setdefault(level, []).append(landed.success(x, w))
        if tally.success:
            print(f'    {name:9s} {tally.line()}' + (f'  [{len(tally.success)} w]' if name == 'slsqp' else ''))
            if tally.failed:
                print('              failed: ' + ', '.join(f'{k} {c}' for k, c in tally.failed.most_common(4)))
    for other in ('exact', 'ceiling'):
        if 'robust' in tallies and other in tallies and tallies[other].executed:
            print(f'    robust - {other:7s} ' + '  '.join(
                f'{level:g}x {paired(tallies["robust"].executed[level], tallies[other].executed[level])}'
                for level in levels))
    if len(model.zones) == 7:
        cases(model, judge, chosen)


def cases(model: GraspModel, judge: Judge, chosen: dict[str, Planned]) -> None:
    """The paper's seven cases: per method the tasks the grasp serves by the rules, and the summary figures."""
    names = judge.rules.task_names
    symbol = lambda z: intent.zone_label(z, names) if z else '-'  # noqa: E731
    print(f'    paper cases (w -> served tasks per method: {", ".join(chosen)}; "-" = no task)')
    tallies = {name: Tally() for name in chosen}
    rng = np.random.default_rng(0)
    for w_case in CASES:
        w = np.array(w_case)
        r = intent.interpret(w, model.zones)
        assert r.v is not None
        served = []
        for name, method in chosen.items():
            t0 = time.perf_counter()
            x = method(model, r.v)
            tallies[name].ms.append(1e3 * (time.perf_counter() - t0))
            served.append(symbol(judge.add(tallies[name], x, w, r.v, 0, rng)))
        print(f'      {str(w_case):17s} top {symbol(model.zones[top_zone(model, r.v)]):3s} -> '
              + ' '.join(f'{s:4s}' for s in served))
    for name, tally in tallies.items():
        print(f'    {name:9s} {tally.line()}')


def frontier(models: Sequence[GraspModel], n: int, seed: int, taus: Sequence[float]) -> None:
    """The task planner's trade-off over tau and ``faithful``: success against faithfulness, legibility and fit."""
    print("frontier of the task planner over tau (the w_i a task needs to join the top zone) and 'faithful'")
    for model in models:
        judge = Judge(model)
        targets = list(random_targets(model, n, seed))
        for faithful in ('label', 'reading'):
            for tau in taus:
                tally = Tally()
                rng = np.random.default_rng(0)
                for w, v in targets:
                    t0 = time.perf_counter()
                    x = planner.plan(model, v, method='task',
                                     options=TaskOptions(tau=tau, hysteresis=0.0, faithful=faithful)).x
                    tally.ms.append(1e3 * (time.perf_counter() - t0))
                    judge.add(tally, x, w, v, 0, rng)
                print(f'  {model.name:24s} {faithful:7s} tau {tau:4.2f}  {tally.line()}')


def physics(models: Sequence[GraspModel], n: int, seed: int) -> None:
    """Plans of the node's policy without and with the collision check, judged by MuJoCo (module docstring)."""
    from judge_physics import PALM_LIMIT, TABLE_LIMIT, PhysicsJudge  # the bench extra: only this section needs it

    from grasp_intent_ros.mico.collision import CollisionFree, HandCollision
    from grasp_intent_ros.mico.frames import default_base_T_obj
    from grasp_intent_ros.mico.grasp import Grasp, plan_grasp
    from grasp_intent_ros.mico.kinematics import MicoKinematics

    base_T_obj, options = default_base_T_obj(), node_default_options()  # the planner node's defaults
    kin, hand = MicoKinematics(), HandCollision()
    print(f'physics: plan_grasp at the default object pose, judged by MuJoCo {__import__("mujoco").__version__} '
          f'(table > {1e3 * TABLE_LIMIT:g} mm, palm > {1e3 * PALM_LIMIT:g} mm)')
    for model in models:
        if len(model.zones) != 7:
            continue
        judge, rules = PhysicsJudge(rules_for(model).body, base_T_obj), Judge(model)
        targets = list(random_targets(model, n, seed))
        t0 = time.perf_counter()
        clear = CollisionFree(hand, model.body)
        candidates = common.feasible_demonstrations(model)
        screened = sum(clear(x) for x in candidates)  # once per model, as the node does: plans then look it up
        print(f'  {model.name}: {screened} of {len(candidates)} demonstrations clear by the check '
              f'(all checked in {time.perf_counter() - t0:.1f} s)')
        ms: dict[bool, list[float]] = {False: [], True: []}
        for _, v in targets:  # the planner alone, without and with the check, paired (the same load)
            for checked in (False, True):
                t1 = time.perf_counter()
                planner.plan(model, v, options=options, accept=CollisionFree(hand, model.body) if checked else None)
                ms[checked].append(1e3 * (time.perf_counter() - t1))
        ratio = np.array(ms[True]) / np.array(ms[False])
        print(f'    plan median without / with the check {np.median(ms[False]):.3f} / {np.median(ms[True]):.3f} ms '
              f'(paired ratio median {np.median(ratio):.2f})')
        for checked in (False, True):
            plans = no_grasp = table = palm = collide = fingers_on_table = 0
            scores: list[float] = []
            for w, v in targets:
                grasp = plan_grasp(model, v, intent.all_zones(3), base_T_obj, kin, options=options,
                                   hand=hand if checked else None)
                if not isinstance(grasp, Grasp):
                    no_grasp += 1
                    scores.append(0.0)
                    continue
                plans += 1
                verdict = judge.judge(grasp.positions)
                table += verdict.table > TABLE_LIMIT
                palm += verdict.palm > PALM_LIMIT
                collide += verdict.collides
                fingers_on_table += verdict.finger_on_table > 0
                scores.append(success(rules.label(grasp.result.x), w))
            print(f'    {"checked" if checked else "unchecked":9s} success {100 * np.mean(scores):5.1f}%  grasps '
                  f'{plans}/{len(targets)}  in collision {collide} (table {table}, palm {palm})  a finger meets the '
                  f'table closing {fingers_on_table}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--n', type=int, default=500, help='random w per model (default 500)')
    parser.add_argument('--seed', type=int, default=0, help='seed of the random w (default 0)')
    parser.add_argument('--methods', default='exact,robust,reading,paper,slsqp,start,top-only,ceiling')
    parser.add_argument('--models', default=','.join(MODELS), help='shipped models (default: all four)')
    parser.add_argument('--data-seeds', default='1,2', help="data-set seeds of regenerated 7-zone models ('' none)")
    parser.add_argument('--draws', type=int, default=0, help='also estimate success with this many T per w')
    parser.add_argument('--slsqp-n', type=int, default=50, help='w per model for the slow slsqp method (default 50)')
    parser.add_argument('--tau', type=float, default=None, help="the task method's threshold (default: its own)")
    parser.add_argument('--frontier', action='store_true', help="print the task method's trade-off over tau")
    parser.add_argument('--cases-only', action='store_true', help='only the paper cases')
    parser.add_argument('--noise', default='0,1,2', help="execution noise levels, multiples of the 1x ('' none)")
    parser.add_argument('--landings', type=int, default=40, help='landings per grasp at each noise level (default 40)')
    parser.add_argument('--physics', action='store_true', help='plans with and without the collision check, '
                        'judged by MuJoCo (the bench extra)')
    args = parser.parse_args()
    levels = [float(s) for s in args.noise.split(',') if s.strip()]
    table = methods(args.tau)
    chosen = {name: table[name] for name in args.methods.split(',') if name}
    shipped = [GraspModel.load(config_dir() / 'models' / f'{name}.yaml') for name in args.models.split(',') if name]
    fresh = [m for s in args.data_seeds.split(',') if s.strip() for m in regenerated(int(s))]
    print(f'bench_task_success: n={args.n}, seed={args.seed}, methods {", ".join(chosen)}; '
          f'load average {", ".join(f"{a:.2f}" for a in os.getloadavg())}')
    if args.physics:
        physics(shipped + fresh, args.n, args.seed)
    elif args.frontier:
        frontier(shipped + fresh, args.n, args.seed, (0.0, 0.1, 0.2, 0.25, 0.3, 0.4, 0.5, 1.0))
    else:
        for model in shipped + fresh:
            run_model(model, chosen, args.n, args.seed, args.draws, args.slsqp_n, args.cases_only, levels,
                      args.landings)
    print(f'load average after: {", ".join(f"{a:.2f}" for a in os.getloadavg())}')


if __name__ == '__main__':
    main()
