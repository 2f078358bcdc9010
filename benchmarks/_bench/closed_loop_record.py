"""The live closed loop recorded as a session bag: ``bench_shared_control.py --record`` (its docstring says when).

One operator under ``confidence`` on a fresh suite, the recorder in the probe's context: :func:`record_session`.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _bench import REPO, Probe, stopped_after
from _bench.closed_loop import BASE_T_OBJ, OBJECTS, PERIOD, Loop, Run, load_model, run_operator
from grasp_intent_ros.method.intent import all_zones, interpret
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.grasp import Grasp, plan_grasp
from grasp_intent_ros.mico.kinematics import MicoKinematics
from grasp_intent_ros.planning.options import node_default_options
from grasp_intent_ros.shared_control.operators import OperatorConstants, PersistentIntent
from grasp_intent_ros.shared_control.simulator import certain_grasps
from grasp_intent_ros.wire.diagnostics import ESTIMATOR_COMPONENT


def own_goals(model: GraspModel, kin: MicoKinematics) -> dict[int, Grasp]:
    """The recorded operator's own grasp per task set: at the true pose, without the rules."""
    return certain_grasps(model, BASE_T_OBJ, kin, options=node_default_options())


RECORDED_TOPICS = ('intent/w', 'object/pose', 'joint_states', 'model/active', 'intent/v', 'intent/clarification',
                   'grasp/pose', 'grasp/joint_targets', 'grasp/posterior', 'operator/twist', 'assistance/twist',
                   'assistance/alpha', '/diagnostics')
"""What ``--record`` records: what a closed-loop replay sends and compares, and the report's shared-control plot."""
HOLD_S = 2.0
"""Seconds a recorded operator holds still (zero twists) after reaching the grasp, letting the loop settle."""
RECORDED_W = (0.9, 0.9, 0.1)
RECORDED_TASKS = 0b011
"""The recorded episode's intent: w held at the paper's ambiguous case, the operator wanting usage and transfer."""
ESTIMATED_TASKS = 0b011
"""What the operator of a session recorded with the intent estimator wants: usage and transfer (the handle root,
tilted: its shown grasp comes within the operator's reach of its own, so the session ends at a planned grasp)."""


def record_session(name: str, index: int, out: Path, args: argparse.Namespace, domain_id: int,
                   op: OperatorConstants, estimated: bool = False) -> None:
    """Record operator ``index`` of object ``name`` under ``confidence`` into the session bag ``out`` (replaced).

    A fresh suite (a replay starts one too), the recorder in the probe's context on an executor and thread of
    its own, no warm-up: the session's first w is the planner's first. After success (or the timeout) the
    operator holds still for :data:`HOLD_S`; then the bag is compacted (of /diagnostics only the rejections,
    and with ``estimated`` the estimator's first status: the intent estimator ran, the only source of w).
    """
    from grasp_intent_ros.launch.suite import NodeSuite
    from grasp_intent_ros.sessions.fixtures import compact_into, recording

    model, kin = load_model(name), MicoKinematics()
    work = Path(tempfile.mkdtemp(prefix='record_closed_loop_'))
    suite = NodeSuite(domain_id, cwd=REPO, log_dir=work / 'logs')
    suite.start_nodes(model=OBJECTS[name], shared_control=True)  # the estimator after the recorder (below)
    probe = Probe(domain_id, 'bench_operator')
    rng = np.random.default_rng([args.seed, list(OBJECTS).index(name), index])
    intent = PersistentIntent(RECORDED_W, ESTIMATED_TASKS if estimated else RECORDED_TASKS,
                              noise=0.08)  # an unsharpened intent's noise (its w unused with the estimator)
    run = Run(name, index, 'confidence', intent.true_set)
    with stopped_after(suite, probe), recording(work / 'raw', RECORDED_TOPICS, probe.context,
                                                  discovery_period=0.5) as recorder:
        loop = Loop(probe, kin, sends_w=not estimated)
        needed = {recorder.resolve_topic_name(t) for t in RECORDED_TOPICS
                  if t not in ('object/pose', 'intent/clarification')}  # nobody publishes these here
        if estimated:
            # its one prior w is planned on at once: start it once the recorder and this process listen (started with
            # the suite, its prior came before they had subscribed to intent/w and grasp/pose, and nothing was planned)
            if not probe.wait_for(lambda: loop.hands and loop.alphas
                                  and needed - {recorder.resolve_topic_name('intent/w')}
                                  <= set(recorder.recorded_topics), 90.0, poll=0.1):
                sys.exit(f'bench_shared_control: the suite or the recorder not ready within 90 s; recorded '
                         f'{sorted(recorder.recorded_topics)}\n{suite.died()}')
            suite.start('intent_estimator', *suite.node_args('intent_estimator'))
        if not probe.wait_for(lambda: loop.hands and loop.alphas and needed <= set(recorder.recorded_topics),
                              90.0, poll=0.1):
            sys.exit(f'bench_shared_control: the suite or the recorder not ready within 90 s; recorded '
                     f'{sorted(recorder.recorded_topics)}\n{suite.died()}')
        loop.set_arbitration('confidence')
        if estimated:  # its own grasp for its set, or the shown one when that serves the set
            goal = own_goals(model, kin)[intent.true_set]
        else:  # the recorded operator wants the grasp it is shown: the planner's for the recorded w, from Home
            shown = plan_grasp(model, interpret(np.array(RECORDED_W)).v, all_zones(3), BASE_T_OBJ, kin,
                               options=node_default_options())
            assert isinstance(shown, Grasp), shown
            goal = shown
        run_operator(loop, op, intent, goal, model, rng, args.timeout, run, sends_w=not estimated)
        still = loop.twist(np.zeros(6))
        end = time.monotonic() + HOLD_S
        while time.monotonic() < end:
            loop.twist_pub.publish(still)
            time.sleep(PERIOD)
        probe.wait_for(lambda: False, 0.5)  # the last messages reach the recorder
    counts, size = compact_into(work / 'raw', out, keep_components=(ESTIMATOR_COMPONENT,) if estimated else ())
    shutil.rmtree(work)
    print(f'{out}: operator {index} of {name}, task set {intent.true_set}, success {run.success} after '
          f'{run.time_to_grasp:.2f} s, {sum(counts.values())} messages, {size / 1024:.1f} KiB')
