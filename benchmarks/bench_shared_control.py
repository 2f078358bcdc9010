r"""Closed-loop shared control without hardware: scripted operators, five real node processes.

The interpreter, model server, planner, mock arm and assistance run as ``python -m`` processes over
loopback (:meth:`~grasp_intent_ros.launch.suite.NodeSuite.start_nodes` with ``shared_control=True``); this
process is the operator (a probe node). Each seeded operator is run once per condition, in a rotating order,
switched by the assistance node's ``arbitration`` parameter and the planner node's ``plan_for``
(:data:`ARBITRATION`, :data:`PLAN_FOR`): ``none`` (direct teleoperation, alpha = 0), ``blend`` (ADA's baseline:
alpha_max when v's top zone leads by ``margin``), ``confidence`` (the suite's), and ``independent`` (the paper's
foil, the simulated loop's condition of that name: the grasp separate per-task classifiers would choose, the
planner's for v on the zone of the single most likely task alone, ``plan_for: most_likely_task``
(:func:`~grasp_intent_ros.method.intent.single_task_v`: argmax_i w_i, ties to the first task), shown, under the
suite's assistance, ``confidence``, which keeps the interpreter's v of the whole w). Between two runs the mock
arm is reset to Home (``mock_arm/reset``). Prints figures, asserts nothing; ``--json`` keeps every run. The method
and the figures measured: docs/shared_control.md, "The closed-loop benchmark (real processes)"; the targets: the
README's rows "closed loop with real node processes".

The grasp command. Under the suite's assistance (``confidence``, ``independent``: :data:`EXECUTES`), a close on
the shown grasp executes it, as
the scripted operator node does and the simulated loop models (``shared_control/simulator.py``, "The grasp
command"): zero twists until the hand is seen at rest, ``grasp/execute`` (the mock arm follows the planner's
latest ``grasp/trajectory``), zero twists until that trajectory has had its time
(:class:`~grasp_intent_ros.shared_control.operator_loop.GraspCommand`, the node's timing), then ``grasp/close``.
Under ``none`` and ``blend`` (the simulated loop's ``direct`` and ADA, which close where the hand is: executing is
the suite's command, not the baselines'), a close on the shown grasp calls ``grasp/close`` where the operator
stopped; ``--no-execute`` closes there under every condition. The mock arm closes the fingers to the latest plan's
closures plus its closure error (N(0, ``closure_error``^2) per finger, one draw per close from its stream seeded by
``closure_seed``). The probe sets ``closure_seed`` to the operator's closure seed before each of its runs (the set
restarts the stream): the one close of a run draws the stream's first error, so an operator's closes draw the same
error in every condition (paired, as the simulated loop's). The probe sends zero twists until it receives a joint
state sampled at least ``CLOSE_SETTLE`` (0.3 s) after the close's answer with the fingers at rest
(:func:`~grasp_intent_ros.wire.joint_states.fingers_settled`, as the demo reads them: still for 0.5 s, from
positions; both timed by the joint states' stamps, so a backlog sampled before the close and taken after it is
never the closed hand), and the hand is judged there: its pose and the closures the fingers
executed.

A close on the operator's OWN grasp calls no ``grasp/close``: the mock arm would close to the latest plan's
closures, a grasp the operator did not choose, and judging those would credit (or blame) the planner for the
operator's own grasp. As in the simulated loop, the own grasp's closures are judged plus the closure error model:
N(0, ``closure_error``^2) per finger (the mock arm's parameter, read from it), the first draw of the operator's closure
seed (the error the mock arm would draw on the run's close: the same in every condition, and whether the
operator closes on its own grasp or the shown one), clipped to the fingers' limits as the mock arm clips
(``MockArm.close_fingers``), with the hand where it came to rest under zero twists.

The tracker's error. Per operator, the probe publishes the object's pose on ``object/pose`` (the planner and the
assistance take it: the robot's perception) as the simulated benchmark's tracker sees it: the true pose perturbed
by :func:`~grasp_intent_ros.shared_control.simulator.perturb_pose`, 5 mm and 3 deg RMS (``--tracker-mm``,
``--tracker-deg``), and waits up to 5 s for the plan the new pose causes. The operator sees the object with its own
error, of the same size by default (``--operator-mm``, ``--operator-deg``), and plans its own grasp there. Both
views and the closure seed (an integer in [0, 2^31)) come from one stream seeded by (seed, object, operator,
:data:`VIEWS`): the conditions of an operator see the same. The judge takes the TRUE pose
(:data:`_bench.closed_loop.BASE_T_OBJ`).
The latency and stream phases run before the first operator's pose, at the true pose; ``--record`` publishes none.

The scripted operator (a stated, simple model)
----------------------------------------------
- **Intent** (``--intent``). ``sharpening`` (the default): a prior w0 ~ U(0.2, 0.8)^3 over (usage, transfer,
  handover); the true task set S is drawn from it (task i with probability w0_i, redrawn until not empty). The
  intent inference's w sharpens linearly from w0 to the certain w_S (0.95 for the tasks of S, 0.05 for the
  others) over T ~ U(1.5, 4) s, with N(0, (0.08 (1 - s))^2) noise per task (s the sharpening's progress, w
  clipped to [0.02, 0.98]). ``persistent``: the simulated benchmark's persistent ambiguity
  (:meth:`~grasp_intent_ros.shared_control.operators.PersistentIntent.draw`): operator i's w held at the paper's
  case i mod 5 (:data:`~grasp_intent_ros.shared_control.operators.AMBIGUOUS_CASES`) with N(0, 0.05^2) noise per
  task, S drawn from the case the same way. Either is published at 10 Hz on ``intent/w``.
- **Goal** (:class:`~grasp_intent_ros.shared_control.operators.ScriptedOperator`, which never reads the
  rules). Its own grasp for S: the planner's grasp for the certain w_S, planned offline from Home
  (:func:`~grasp_intent_ros.shared_control.simulator.certain_grasp`) where the operator sees the object, with the
  planner node's default options (:func:`~grasp_intent_ros.planning.options.node_default_options`: for the 1x
  execution noise).
  It follows the grasp the planner shows (``grasp/pose``) when that is on its way (within 6 cm and 0.8 rad
  of its own), else drives to its own. The rule is the same under every condition (the shown grasp is
  on the screen whatever alpha is).
- **Device.** A joystick with two modes, as in ADA's studies: translation (3 axes) or rotation (3 axes),
  never both; switching costs 0.5 s of no input. The operator steers to the goal's pre-grasp (8 cm back
  along its approach axis), then, once the hand is in the approach corridor, down the axis to the goal
  (the operators' module docstring, "The approach"); it translates until within 3 cm of the pose steered
  to, then rotates until within 0.03 rad, then translates again (back to translation whenever the hand is
  more than 6 cm away). Proportional command (gain 1.5 /s) limited to 0.12 m/s and 0.6 rad/s, plus
  Ornstein-Uhlenbeck noise (time constant 0.3 s; 0.01 m/s, 0.05 rad/s) on the active mode; the hand and the
  shown grasp are perceived 0.25 s late. Twists at 100 Hz on ``operator/twist`` in the base frame.

Figures per object and condition (the same seeded operators): success (the operator closes the hand, its
seen hand within 1 cm and 0.1 rad of the goal it pursues, within ``--timeout`` s, and the data set's task
rules, :data:`grasp_intent_ros.objects.demos.CUP_RULES` / ``FLASHLIGHT_RULES``, hold for every task of S at
the true object pose, at the reached pose with the executed closures, judged after closing
(:func:`~grasp_intent_ros.objects.judge.judge`, the demo's and the simulated benchmark's judge; never seen by the
operator, the planner or the assistance)), time to grasp (to the close, an execution included; median of the
successful runs, and over all runs with a failure counted as the timeout), operator effort (integral of
|operator twist|, linear m and angular rad), wrong-task pulls (the integral of alpha over the time the shown
grasp did not serve S by the rules, and how many operators met any), mean alpha. A latency phase first (``arbitration``
none, 100 Hz operator twists carrying a sequence number in ``angular.z``): the blended twist's rate and the
latency from the operator's publish to the blended twist's receipt (the middleware's receive time). Then a stream
phase (:func:`stream_phase`, ``confidence``), whose gaps while the operator heads at the grasp are measured between
the blended twists' receipts (the middleware's receive time: what a servo that receives promptly sees), as
``source_*`` between their source times (the assistance's middleware's time at each publish: the node's own gaps,
without this process's receive delays), and, as ``callback_*``, between the times this process's callback ran (its
own delays included: the executor thread shares the interpreter's lock with the operator's thread, and callbacks
queue behind the joint states' kinematics). ``--thread-priority P`` gives the assistance node its
``thread_priority`` (a params file after its own); the stream phase reports how many of its threads ran at
``SCHED_FIFO`` (``fifo_threads`` of ``threads``), read from /proc after the phase.

``--record BAG`` runs no benchmark: it records one operator (the first of ``--only``, of the first of ``--objects``)
under ``confidence`` as a closed-loop session bag, holding still for 2 s after the grasp
(:func:`_bench.closed_loop_record.record_session`; the grasp command executes and closes nothing: a replay sends the
operator's twists only; the object at its true pose, its own grasp planned there; its printed success judges the
pursued grasp's planned closures where the hand stopped), in an ambiguous episode: w held at the paper's (0.9, 0.9,
0.1) with the noise of an unsharpened intent, the operator wanting usage and transfer; bags/shared_control_cup is
``--objects cup --only 0 --record``. With ``--estimator`` the suite runs the intent estimator, the only source of w
(this process publishes none; its operator twists are stamped), and the operator wants transfer (T), heading for its
own grasp for T or the shown one when that serves T; bags/shared_control_cup_estimated is ``--objects cup --only 4
--record bags/shared_control_cup_estimated --estimator`` (keep a recording whose hand ended at the last grasp
planned, which the replay checks, and whose replay passes: the replay is deterministic, but the live estimator took
the twists stamped just after a new grasp before that grasp arrived, which the bag does not hold; and the live loop
differs between recordings of one operator: three of operator 1 ended with w_handover 0.23, 0.63 and 0.05).

Network rule: refuses to run unless ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_DOMAIN_ID are set.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=97 \
        .venv/bin/python benchmarks/bench_shared_control.py [--quick] [--operators 50] [--json runs.json] \
            [--intent sharpening] [--conditions none blend confidence independent] [--no-execute] \
            [--tracker-mm 5 --tracker-deg 3] [--operator-mm 5 --operator-deg 3]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from _bench import REPO, Probe, bootstrap_ci, loopback_domain, stopped_after, uptime
from _bench.closed_loop import BASE_T_OBJ, OBJECTS, PERIOD, W_EVERY, Loop, Run, load_model, run_operator
from _bench.closed_loop_record import record_session

from grasp_intent_ros.mico.frames import offset, pose_error
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm
from grasp_intent_ros.planning.options import node_default_options
from grasp_intent_ros.ros.realtime import thread_policies
from grasp_intent_ros.shared_control.limits import clip_norm
from grasp_intent_ros.shared_control.operators import OperatorConstants, PersistentIntent, SharpeningIntent
from grasp_intent_ros.shared_control.simulator import certain_grasp, perturb_pose

CONDITIONS = ('none', 'blend', 'confidence', 'independent')
ARBITRATION = {'none': 'none', 'blend': 'blend', 'confidence': 'confidence', 'independent': 'confidence'}
"""The assistance node's ``arbitration`` per condition (module docstring)."""
PLAN_FOR = {'none': 'v', 'blend': 'v', 'confidence': 'v', 'independent': 'most_likely_task'}
"""The planner node's ``plan_for`` per condition (module docstring)."""
PAIRS = (('confidence', 'none'), ('confidence', 'blend'), ('blend', 'none'), ('confidence', 'independent'))
"""The paired comparisons (:func:`paired`): the first condition against the second, on the same operators."""
EXECUTES = ('confidence', 'independent')
"""The conditions whose grasp command executes the shown grasp (the suite's assistance; module docstring)."""
VIEWS = 1
"""The last seed word of an operator's views (the tracker's and its own) and closure seed: a stream of its own, so
the intent's and the device's draws (the seed without it) are those of the benchmark before the views."""


def latency_phase(loop: Loop, seconds: float) -> dict[str, float]:
    """Operator twists at 100 Hz with arbitration none: the blended rate and the twist -> twist latency."""
    loop.set_arbitration('none')
    loop.outputs.clear()
    sent: list[int] = []
    start = time.monotonic()
    n = int(seconds / PERIOD)
    for i in range(n):
        delay = start + i * PERIOD - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
        msg = loop.twist(np.r_[0.0, 0.0, 0.0, 0.0, 0.0, (i + 1) * 1e-6])
        sent.append(time.time_ns())
        loop.twist_pub.publish(msg)
    loop.probe.wait_for(lambda: False, 0.2)
    outputs = list(loop.outputs)
    first: dict[int, int] = {}
    for received, value in outputs:
        seq = round(value * 1e6)
        if 1 <= seq <= n and seq not in first:
            first[seq] = received
    latency = np.array([(first[s] - sent[s - 1]) * 1e-6 for s in sorted(first)])
    window = [r for r, _ in outputs if sent[0] <= r <= sent[-1]]
    rate = (len(window) - 1) / ((window[-1] - window[0]) * 1e-9) if len(window) > 1 else 0.0
    return {'twists': n, 'answered': len(first), 'rate_hz': rate, 'median_ms': float(np.median(latency)),
            'p99_ms': float(np.percentile(latency, 99)), 'max_ms': float(latency.max())}


STREAM_W = (0.9, 0.9, 0.1)
"""The intent the stream phase's estimator reports (10 Hz, no noise): the paper's ambiguous case."""


def _send_for(loop: Loop, seconds: float, twist_of: Any) -> tuple[float, float]:
    """Publish ``twist_of(now)`` at 100 Hz and :data:`STREAM_W` at 10 Hz for ``seconds``; (start, end) monotonic."""
    start = time.monotonic()
    tick = 0
    while time.monotonic() - start < seconds:
        if tick % W_EVERY == 0:
            loop.send_w(np.array(STREAM_W))
        loop.twist_pub.publish(loop.twist(twist_of(time.monotonic())))
        tick += 1
        delay = start + tick * PERIOD - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
    return start, time.monotonic()


def stream_phase(loop: Loop) -> dict[str, float]:
    """The stream a servo sees under the suite's rule, opposition, the switch and zero input (module docstring)."""
    loop.set_arbitration('confidence')
    loop.enable(True)
    out: dict[str, float] = {}
    # zero input from a fresh start, with the intent streaming: the hand must not move (the suite's mock arm
    # follows the planner's grasp/trajectory only on grasp/execute)
    loop.reset_arm()
    _send_for(loop, 0.5, lambda now: np.zeros(6))
    first = loop.hand_at(time.monotonic())
    _send_for(loop, 3.0, lambda now: np.zeros(6))
    last = loop.hand_at(time.monotonic())
    assert first is not None and last is not None
    out['zero_input_motion_mm'] = 1e3 * float(np.linalg.norm(last[:3, 3] - first[:3, 3]))
    # heading at the grasp: rate, gaps, alpha
    plan = loop.plan_at(time.monotonic())
    assert plan is not None
    goal = plan[0]

    def toward(now: float) -> np.ndarray:
        hand = loop.hand_at(now)
        error = pose_error(hand, goal) if hand is not None else np.zeros(6)
        return np.r_[clip_norm(1.5 * error[:3], 0.05), clip_norm(1.5 * error[3:], 0.3)]

    loop.reset_arm()
    start, end = _send_for(loop, 4.0, toward)
    receipts = [(t, received, sent) for t, received, sent in loop.receipts if start <= t <= end]
    received = np.array([r for _, r, _ in receipts], dtype=np.int64)  # the middleware's receive times (ns)
    gaps = np.diff(received) * 1e-9
    out['rate_hz'] = (received.size - 1) / float((received[-1] - received[0]) * 1e-9)
    out['max_gap_ms'] = 1e3 * float(gaps.max())
    out['gaps_over_20ms'] = int(np.sum(gaps > 0.02))
    gaps = np.diff([t for t, _, _ in receipts])  # when this process's callback ran: its own delays too
    out['callback_max_gap_ms'] = 1e3 * float(gaps.max())
    out['callback_gaps_over_20ms'] = int(np.sum(gaps > 0.02))
    gaps = np.diff(np.array([s for _, _, s in receipts], dtype=np.int64)) * 1e-9  # the node's publishes
    out['source_max_gap_ms'] = 1e3 * float(gaps.max())
    out['source_gaps_over_20ms'] = int(np.sum(gaps > 0.02))
    alphas = [a for t, a in loop.alphas if start <= t <= end]
    out['alpha_heading_mean'] = float(np.mean(alphas))
    # sustained opposition: from 1 s into an assisted reach (the hand well short of the grasp), straight away
    # from the grasp at 0.1 m/s for 3 s
    loop.reset_arm()
    _send_for(loop, 1.0, toward)
    hand0 = loop.hand_at(time.monotonic())
    assert hand0 is not None
    toward_grasp = pose_error(hand0, goal)[:3]
    away = np.r_[-0.1 * toward_grasp / float(np.linalg.norm(toward_grasp)), 0.0, 0.0, 0.0]
    start, end = _send_for(loop, 3.0, lambda now: away)
    low = [t for t, a in loop.alphas if t >= start and a <= 0.1]
    out['opposition_to_alpha_0.1_s'] = (low[0] - start) if low else math.inf
    zero = [t for t, a in loop.alphas if t >= start and a == 0.0]
    out['opposition_to_alpha_0_s'] = (zero[0] - start) if zero else math.inf
    hand1 = loop.hand_at(end)
    assert hand1 is not None
    out['opposition_moved_away_cm'] = 1e2 * (offset(hand1, goal)[0] - offset(hand0, goal)[0])
    # the switch: off, the operator's twist exactly
    loop.enable(False)
    loop.probe.wait_for(lambda: False, 0.1)
    fast = np.r_[0.05, -0.03, 0.02, 0.1, 0.0, -0.1]
    start, end = _send_for(loop, 1.0, lambda now: fast)
    outs = [tw for t, tw in loop.blended if start + 0.05 <= t <= end]
    out['switch_off_exact_fraction'] = float(np.mean([np.array_equal(tw, fast) for tw in outs]))
    loop.enable(True)
    out['load'] = float(uptime().split()[2].rstrip(','))
    return out


def run_object(name: str, args: argparse.Namespace, domain_id: int,
               op: OperatorConstants) -> tuple[list[Run], dict[str, float]]:
    from grasp_intent_ros.launch.suite import NodeSuite

    model, kin = load_model(name), MicoKinematics()
    fingers = MockArm(kin, np.r_[HOME_Q, 0.0, 0.0, 0.0])  # its close_fingers: the own closures as the arm clips
    suite = NodeSuite(domain_id, cwd=REPO)
    folder = tempfile.TemporaryDirectory()  # the nodes read their params files as they start: kept until they stop
    priority = Path(folder.name) / 'thread_priority.yaml'
    priority.write_text(f'/**/assistance:\n  ros__parameters:\n    thread_priority: {args.thread_priority}\n')
    suite.start_nodes(model=OBJECTS[name], shared_control=True, params_files=[priority])
    probe = Probe(domain_id, 'bench_operator')
    runs: list[Run] = []
    with folder, stopped_after(suite, probe):
        loop = Loop(probe, kin)
        warm = np.array([0.9, 0.1, 0.1])
        if not probe.wait_for(lambda: (loop.plans and loop.hands and loop.alphas) or loop.send_w(warm), 90.0,
                              poll=0.5):
            sys.exit(f'bench_shared_control: the suite did not answer within 90 s\n{suite.died()}')
        print(f'[{name}] latency phase ({args.latency_seconds:g} s), {uptime()}', flush=True)
        latency = latency_phase(loop, args.latency_seconds)
        latency['load'] = uptime()
        stream = stream_phase(loop)
        assistance = next(p for p in suite.processes if p.module.endswith('assistance'))
        policies = thread_policies(assistance.popen.pid).values()
        stream['fifo_threads'], stream['threads'] = sum(p == os.SCHED_FIFO for p in policies), len(policies)
        print(f'[{name}] stream: ' + ', '.join(f'{k} {v:.3g}' for k, v in stream.items()), flush=True)
        latency.update({f'stream_{k}': v for k, v in stream.items()})
        if args.stream_only:
            return runs, latency
        closure_error = loop.closure_error()
        for i in args.only or range(args.operators):
            chosen = [c for c in CONDITIONS if c in args.conditions]
            order = chosen[i % len(chosen):] + chosen[:i % len(chosen)]  # each first equally often
            views = np.random.default_rng([args.seed, list(OBJECTS).index(name), i, VIEWS])
            tracked = perturb_pose(BASE_T_OBJ, 1e-3 * args.tracker_mm, math.radians(args.tracker_deg), views)
            seen = perturb_pose(BASE_T_OBJ, 1e-3 * args.operator_mm, math.radians(args.operator_deg), views)
            closure_seed = int(views.integers(2**31))
            own_error = np.random.default_rng(closure_seed).normal(0.0, closure_error, 3)  # the arm's first draw
            if not loop.show_object(tracked):
                print(f'bench_shared_control: no plan within 5 s of operator {i}\'s object pose', file=sys.stderr)
            own: Grasp | None = None
            for condition in order:
                rng = np.random.default_rng([args.seed, list(OBJECTS).index(name), i])
                intent = (PersistentIntent.draw(i, rng) if args.intent == 'persistent'
                          else SharpeningIntent.draw(rng))
                if own is None:  # the operator's own grasp for its set, planned where it sees the object
                    own = certain_grasp(model, intent.true_set, seen, kin, options=node_default_options())
                loop.set_arbitration(ARBITRATION[condition])
                loop.set_plan_for(PLAN_FOR[condition])
                loop.set_closure_seed(closure_seed)
                loop.reset_arm()
                run = Run(name, i, condition, intent.true_set)
                run_operator(loop, op, intent, own, model, rng, args.timeout, run,
                             execute=condition in EXECUTES and not args.no_execute,
                             own_closures=fingers.close_fingers(own.positions[6:] + own_error))
                runs.append(run)
                print(f'[{name}] operator {i:3d} {condition:10s} S={intent.true_set} success={run.success!s:5s} '
                      f't={run.time_to_grasp:6.2f} s wrong pull {run.wrong_pull:5.2f} s alpha {run.alpha_mean:.2f}',
                      flush=True)
            if problem := suite.died():
                sys.exit(f'bench_shared_control: {problem}')
    return runs, latency


def summary(runs: list[Run], timeout: float) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    for condition in CONDITIONS:
        mine = [r for r in runs if r.condition == condition]
        if not mine:
            continue
        ok = [r.time_to_grasp for r in mine if r.success]
        censored = [r.time_to_grasp if r.success else timeout for r in mine]
        out[condition] = {
            'n': len(mine), 'success': sum(r.success for r in mine) / len(mine),
            'median_ttg_success': float(np.median(ok)) if ok else math.nan,
            'median_ttg_all': float(np.median(censored)),
            'effort_linear': float(np.median([r.effort_linear for r in mine])),
            'effort_angular': float(np.median([r.effort_angular for r in mine])),
            'wrong_pull_total': float(sum(r.wrong_pull for r in mine)),
            'wrong_pull_operators': sum(r.wrong_pull > 0.0 for r in mine),
            'alpha_mean': float(np.mean([r.alpha_mean for r in mine])),
        }
    return out


def paired(runs: list[Run], timeout: float) -> dict[str, dict[str, Any]]:
    """Per pair of :data:`PAIRS` run on the same operators: the success difference and the time-to-grasp ratio.

    ``success_diff``: the mean over operators of success(a) - success(b), with its 95% bootstrap CI (10 000
    resamples of the operators, seeded 0); ``time_ratio``: exp of the mean log ratio of the times to grasp (a
    failure counted as ``timeout``), with its CI the same way.
    """
    rng = np.random.default_rng(0)
    by = {(r.condition, r.operator): r for r in runs}
    out: dict[str, dict[str, Any]] = {}
    for a, b in PAIRS:
        ops = sorted(i for c, i in by if c == a and (b, i) in by)
        if not ops:
            continue

        def time(r: Run) -> float:
            return r.time_to_grasp if r.success else timeout

        d, lo, hi = bootstrap_ci([float(by[a, i].success) - float(by[b, i].success) for i in ops], rng)
        m, rlo, rhi = bootstrap_ci([math.log(time(by[a, i]) / time(by[b, i])) for i in ops], rng)
        out[f'{a}-{b}'] = {'operators': len(ops), 'success_diff': d, 'ci': [lo, hi], 'time_ratio': math.exp(m),
                           'time_ratio_ci': [math.exp(rlo), math.exp(rhi)]}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--operators', type=int, default=50, help='seeded operators per object')
    parser.add_argument('--quick', action='store_true', help='3 operators per object, a 5 s latency phase')
    parser.add_argument('--objects', nargs='+', default=list(OBJECTS), choices=list(OBJECTS))
    parser.add_argument('--intent', default='sharpening', choices=('sharpening', 'persistent'),
                        help='the operators\' w: sharpening to the true set, or held at the paper\'s ambiguous cases')
    parser.add_argument('--timeout', type=float, default=25.0, help='seconds an operator gets')
    parser.add_argument('--latency-seconds', type=float, default=20.0)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--only', type=int, nargs='+', metavar='I', help='run only these operators (e.g. to look '
                        'into one); their seeds are those of the full run')
    parser.add_argument('--json', help='write every run and the summaries here')
    parser.add_argument('--estimator', action='store_true', help='with --record: w from the intent estimator node '
                        '(module docstring)')
    parser.add_argument('--stream-only', action='store_true', help='the latency and stream phases only')
    parser.add_argument('--thread-priority', type=int, default=0, metavar='P', help='the assistance node\'s '
                        'thread_priority (0: off, its default; 1-99: SCHED_FIFO); the stream phase reports how many '
                        'of its threads ran at SCHED_FIFO')
    parser.add_argument('--conditions', nargs='+', default=list(CONDITIONS), choices=CONDITIONS,
                        help='run only these conditions (rotating: operator i starts with the (i mod n)-th of them, '
                             'in the order of the full run)')
    parser.add_argument('--tracker-mm', type=float, default=5.0, help='RMS position error (mm) of the object pose '
                        'published to the suite, drawn per operator (module docstring)')
    parser.add_argument('--tracker-deg', type=float, default=3.0, help='RMS rotation error (deg) of that pose')
    parser.add_argument('--operator-mm', type=float, default=5.0, help='RMS position error (mm) of the operator\'s '
                        'view of the object, where its own grasp is planned')
    parser.add_argument('--operator-deg', type=float, default=3.0, help='RMS rotation error (deg) of its view')
    parser.add_argument('--no-execute', action='store_true', help='the grasp command executes nothing: the hand is '
                        'judged where the operator closed it under every condition')
    parser.add_argument('--record', type=Path, metavar='BAG',
                        help='instead of the benchmark: record the first --only operator (default 0) of the first '
                             'object under confidence as a closed-loop session bag (replaced), e.g. for bags/')
    args = parser.parse_args()
    if args.record is not None:
        record_session(args.objects[0], (args.only or [0])[0], args.record, args,
                       loopback_domain('bench_shared_control'), OperatorConstants(), args.estimator)
        return
    if args.quick:
        args.operators, args.latency_seconds = 3, 5.0
    domain_id = loopback_domain('bench_shared_control')
    op = OperatorConstants()
    print(f'bench_shared_control: {args.operators} operators per object, {", ".join(args.objects)}, the '
          f'{args.intent} intent; {uptime()}', flush=True)
    report: dict[str, Any] = {'operator': asdict(op), 'intent': args.intent, 'objects': {}}
    for name in args.objects:
        runs, latency = run_object(name, args, domain_id, op)
        table, pairs = summary(runs, args.timeout), paired(runs, args.timeout)
        report['objects'][name] = {'latency': latency, 'summary': table, 'paired': pairs,
                                   'runs': [asdict(r) for r in runs]}
        print(f'\n[{name}] blended twist: {latency["rate_hz"]:.1f} Hz, operator -> blended latency median '
              f'{latency["median_ms"]:.2f} ms, p99 {latency["p99_ms"]:.2f} ms, max {latency["max_ms"]:.2f} ms '
              f'({latency["answered"]}/{latency["twists"]} answered; {latency["load"]})')
        print(f'{"condition":12s} {"n":>3s} {"success":>8s} {"TTG med ok":>11s} {"TTG med all":>12s} '
              f'{"effort m":>9s} {"effort rad":>10s} {"wrong pull s":>13s} {"operators":>9s} {"alpha":>6s}')
        for condition, row in table.items():
            print(f'{condition:12s} {row["n"]:3.0f} {row["success"]:8.2f} {row["median_ttg_success"]:11.2f} '
                  f'{row["median_ttg_all"]:12.2f} {row["effort_linear"]:9.3f} {row["effort_angular"]:10.3f} '
                  f'{row["wrong_pull_total"]:13.2f} {row["wrong_pull_operators"]:9.0f} {row["alpha_mean"]:6.2f}')
        for pair, diff in pairs.items():
            print(f'{pair:18s} success {diff["success_diff"]:+.2f} [{diff["ci"][0]:+.2f}, {diff["ci"][1]:+.2f}], '
                  f'time to grasp ratio {diff["time_ratio"]:.2f} [{diff["time_ratio_ci"][0]:.2f}, '
                  f'{diff["time_ratio_ci"][1]:.2f}] ({diff["operators"]} operators, 95% bootstrap CIs)')
        if 'none' in table and 'confidence' in table:
            ratio = table['confidence']['median_ttg_all'] / table['none']['median_ttg_all']
            print(f'confidence / direct median time to grasp (failures at the timeout): {ratio:.2f} '
                  f'({100 * (1 - ratio):.0f}% lower)', flush=True)
        if 'independent' in table and 'confidence' in table:
            ratio = table['confidence']['median_ttg_all'] / table['independent']['median_ttg_all']
            print(f'confidence / independent median time to grasp (failures at the timeout): {ratio:.2f}', flush=True)
    print(f'done; {uptime()}')
    if args.json:
        with open(args.json, 'w') as f:
            json.dump(report, f, indent=1, default=float)


if __name__ == '__main__':
    main()
