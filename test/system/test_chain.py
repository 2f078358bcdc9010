"""The full chain as three real processes (interpreter, model server, grasp planner) over loopback DDS.

The test side is the in-process ``ros`` harness (private Context on the test's domain id) with an
:class:`~grasp_intent_ros.cli.send_intent.IntentSender`, whose answer to a w is the first plan (pose, joint
targets, posterior of equal stamps) stamped after the send. The models are the shipped
config/models, copied once per module so that the nodes and the expected answers read the same files.
Expected answers come from the core library with the planner node's options (config/grasp_planner.yaml)
and robot constraint (IK seeded from HOME_Q, ``ik_restarts`` restarts, restart seed 0); a node's first
plan on a model has no warm start, so its features match the core's (usually bit-identical; asserted to
1e-6, since the optimum is flat when P matches v exactly, so a second plan that warm-starts from the
first, e.g. after the sender repeated a w that was not lost after all, moves x by ~1e-7).
The demo's test runs the README's command, which also starts the mock arm, the assistance and the scripted
operator for its closed loop. Nothing sleeps: every wait polls with a deadline.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from numpy.testing import assert_allclose
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

from grasp_intent_ros.cli.paper_tables import CASES
from grasp_intent_ros.cli.send_intent import GraspAnswer, IntentSender
from grasp_intent_ros.method.features import FINGERS
from grasp_intent_ros.method.intent import all_zones, interpret, restrict
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pose_to_matrix, rotation_angle
from grasp_intent_ros.mico.grasp import ApproachReach
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.reachability import Reachability
from grasp_intent_ros.planning import common, planner
from grasp_intent_ros.planning.options import node_options
from grasp_intent_ros.ros.conversions import model_from_msg, posterior_from_msg, stamped_array_from_msg
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import matrix_to_pose_msg
from grasp_intent_ros.wire.arrays import Posterior, msg_to_array
from grasp_intent_ros.wire.diagnostics import KEY_MODEL
from grasp_intent_ros.wire.robot_state import pose_msg_to_matrix

REPO = Path(__file__).resolve().parents[2]
STARTUP = 30.0
"""Seconds for processes to start and discover each other (imports, DDS) on a loaded 2-core machine."""
REMATCH = 30.0
"""Seconds for DDS to match a restarted process (the dead one stays matched for about 20 s)."""
WARN = DiagnosticStatus.WARN
W_TWO = (0.9, 0.9, 0.1)
W_AMBIGUOUS = (0.9, 0.1, 0.9)
NEEDED_MODELS = ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')


# ---------------------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope='module')
def models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, GraspModel]]:
    """(models_dir, models): a copy of the shipped models plus ``broken.yaml`` (not a model)."""
    source = REPO / 'config' / 'models'
    missing = [name for name in NEEDED_MODELS if not (source / f'{name}.yaml').is_file()]
    if missing:
        pytest.fail(f'the shipped models {missing} are missing from {source} '
                    '(python -m grasp_intent_ros generate_data)')
    directory = tmp_path_factory.mktemp('chain_models')
    for name in NEEDED_MODELS:
        shutil.copy(source / f'{name}.yaml', directory / f'{name}.yaml')
    (directory / 'broken.yaml').write_text('format_version: 1\nname: broken\n')
    return directory, {name: GraspModel.load(directory / f'{name}.yaml') for name in NEEDED_MODELS}


@pytest.fixture(scope='module')
def kinematics() -> MicoKinematics:
    return MicoKinematics()


def _planner_parameters() -> dict[str, Any]:
    """The grasp planner's parameters from the file the processes are started with."""
    params = yaml.safe_load((REPO / 'config' / 'grasp_planner.yaml').read_text())
    return dict(params['/**/grasp_planner']['ros__parameters'])


def _planner_object_pose() -> np.ndarray:
    values = _planner_parameters()
    return pose_to_matrix(values['object_position'], values['object_orientation'])


def core_plan(model: GraspModel, w: tuple[float, ...], kin: MicoKinematics,
              warm_start: np.ndarray | None = None) -> common.PlanResult:
    """The core library's plan for w on ``model`` with the planner node's options and robot constraint."""
    options = _planner_parameters()
    v = restrict(interpret(w).v, all_zones(len(w)), model.zones)
    base_T_obj = _planner_object_pose()

    reachable = ApproachReach(Reachability(kin, base_T_obj, HOME_Q, restarts=options['ik_restarts']))

    return planner.plan(model, v, method=options['method'],
                        options=node_options(options['method'], options['n_starts'], options['execution_noise']),
                        accept=reachable, warm_start=warm_start)


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


class Chain:
    """The three node processes and what the test side sees of them."""

    def __init__(self, ros: Any, launch: Any, models_dir: Path) -> None:
        self.ros, self.launch, self.models_dir = ros, launch, models_dir
        self.statuses = ros.diagnostics()
        self.active = ros.subscribe(String, 'model/active', latched_qos())
        self.posteriors: list[Posterior[Any]] = []
        self.features: dict[int, np.ndarray] = {}
        ros.node.create_subscription(Float64MultiArray, 'grasp/posterior',
                                     lambda m: self.posteriors.append(posterior_from_msg(m)), 10)
        ros.node.create_subscription(Float64MultiArray, 'grasp/features', self._on_features, 10)
        self.sender = ros.add(IntentSender('test_sender', context=ros.context))
        self.set_client = ros.node.create_client(SetParameters, 'model_server/set_parameters')
        self.get_client = ros.node.create_client(GetParameters, 'model_server/get_parameters')
        self.procs: dict[str, Any] = {}
        self._alone_checked = False
        for name in ('intent_interpreter', 'model_server', 'grasp_planner'):
            self.start(name)

    def _on_features(self, msg: Float64MultiArray) -> None:
        stamp, _, x = stamped_array_from_msg(msg, what='features')
        self.features[_ns(stamp)] = x

    def start(self, name: str, *ros_args: str) -> Any:
        args = ['--params-file', str(REPO / 'config' / f'{name}.yaml'), *ros_args]
        if name == 'model_server':
            args += ['-p', f'models_dir:={self.models_dir}']
        self.procs[name] = self.launch.start(name, *args)
        return self.procs[name]

    def assert_running(self) -> None:
        for name, proc in self.procs.items():
            assert proc.popen.poll() is None, f'{name} exited with {proc.popen.returncode}:\n{proc.stderr()}'

    def send(self, w: tuple[float, ...], timeout: float = STARTUP) -> GraspAnswer:
        """The chain's answer to w (IntentSender republishes until answered).

        The first time, also checks that no foreign node shares the test's domain (a run that ignores the domain
        claims would answer in place of ours).
        """
        answer = self.sender.send(w, self.ros.executor, timeout=timeout)
        if not self._alone_checked:
            names = Counter(name for name, _ in self.ros.node.get_node_names_and_namespaces())
            foreign = names - Counter(('grasp_planner', 'intent_interpreter', 'model_server', 'test_probe',
                                       'test_sender'))
            assert not foreign, f'domain {self.ros.domain_id} is shared: {sorted(names.elements())}'
            self._alone_checked = True
        return answer

    def x_of(self, answer: GraspAnswer) -> np.ndarray:
        """Features x published with the answer's plan."""
        stamp = _ns(answer.posterior.stamp)
        assert self.ros.wait_for(lambda: stamp in self.features), 'no grasp/features with the plan\'s stamp'
        return self.features[stamp]

    def set_model(self, name: str) -> Any:
        """SetParameters(model=name) on the model server; its SetParametersResult."""
        assert self.ros.wait_for(self.set_client.service_is_ready, STARTUP)
        future = self.set_client.call_async(SetParameters.Request(
            parameters=[Parameter('model', value=name).to_parameter_msg()]))
        assert self.ros.wait_for(future.done, STARTUP)
        return future.result().results[0]

    def get_model(self) -> str:
        assert self.ros.wait_for(self.get_client.service_is_ready, STARTUP)
        future = self.get_client.call_async(GetParameters.Request(names=['model']))
        assert self.ros.wait_for(future.done, STARTUP)
        return future.result().values[0].string_value

    def status(self, suffix: str) -> Any:
        return next((s for s in reversed(self.statuses) if s.name.endswith(suffix)), None)

    def rejected_count(self, suffix: str) -> int:
        status = self.status(suffix)
        return 0 if status is None else int({kv.key: kv.value for kv in status.values}['messages rejected'])


@pytest.fixture
def chain(ros: Any, launch: Any, models: tuple[Path, dict[str, GraspModel]]) -> Chain:
    return Chain(ros, launch, models[0])


def _assert_fk_reproduces_pose(answer: GraspAnswer, kin: MicoKinematics) -> np.ndarray:
    """Joint targets: arm then finger names; FK of the arm joints is the published pose (1 mm, 0.01 rad)."""
    assert tuple(answer.joints.name) == ARM_JOINTS + FINGER_JOINTS
    q = np.array(answer.joints.position[:6])
    assert np.all(q >= kin.lower) and np.all(q <= kin.upper), f'joint targets {q} outside the limits'
    base_T_ee = pose_msg_to_matrix(answer.pose, frame_id=BASE_FRAME)
    fk = kin.fk(q)
    assert np.linalg.norm(fk[:3, 3] - base_T_ee[:3, 3]) <= 1e-3
    assert rotation_angle(fk[:3, :3], base_T_ee[:3, :3]) <= 0.01
    return base_T_ee


# ---------------------------------------------------------------------------------------------- (a)
def test_w_in_v_pose_joints_and_posterior_out_as_the_core_computes(chain, models, kinematics):
    model = models[1]['cup_7zone']
    answer = chain.send(W_TWO)
    assert answer.v_labels == ('U', 'T', 'H', 'UT', 'UH', 'TH', 'UTH')
    assert_allclose(answer.v, interpret(W_TWO).v, rtol=0, atol=1e-12)

    expected = core_plan(model, W_TWO, kinematics)
    post = answer.posterior
    assert (post.zone_labels, post.task_names) == (model.zone_labels, model.task_names)
    assert_allclose(chain.x_of(answer), expected.x, rtol=0, atol=1e-6)  # see the module docstring
    assert_allclose(post.p, expected.posterior, rtol=0, atol=1e-4)
    assert_allclose(post.w, expected.w, rtol=0, atol=1e-4)
    base_T_ee = _assert_fk_reproduces_pose(answer, kinematics)
    assert_allclose(base_T_ee, _planner_object_pose() @ features_to_obj_T_ee(expected.x), rtol=0, atol=1e-6)
    assert_allclose(answer.joints.position[6:], chain.x_of(answer)[FINGERS], rtol=0, atol=1e-12)  # closures as planned

    # a second w: the node warm-starts from its last plan (as published, within 1e-6 of the core's)
    previous = chain.x_of(answer)
    answer = chain.send(W_AMBIGUOUS)
    expected = core_plan(model, W_AMBIGUOUS, kinematics, warm_start=previous)
    assert_allclose(answer.posterior.p, expected.posterior, rtol=0, atol=1e-4)
    assert_allclose(answer.posterior.w, expected.w, rtol=0, atol=1e-4)
    _assert_fk_reproduces_pose(answer, kinematics)
    chain.assert_running()


# ---------------------------------------------------------------------------------------------- (b)
def _bad(data: list[float], label: str = '') -> Float64MultiArray:
    msg = Float64MultiArray(data=data)
    if label:
        msg.layout.dim = [MultiArrayDimension(label=label, size=len(data), stride=len(data))]
    return msg


BAD_W = [
    ('wrong length', _bad([0.5, 0.5]), 'w must have 3 entries (one per task), got 2'),
    ('NaN', _bad([0.5, math.nan, 0.5]), 'w contains NaN or infinity (first at index 1: nan)'),
    ('Inf', _bad([0.5, 0.5, math.inf]), 'w contains NaN or infinity (first at index 2: inf)'),
    ('above 1', _bad([1.5, 0.5, 0.5]), 'must lie in [0, 1], got [1.5, 0.5, 0.5]'),
    ('below 0', _bad([0.5, -0.25, 0.5]), 'must lie in [0, 1], got [0.5, -0.25, 0.5]'),
    ('empty', _bad([]), 'w is empty'),
    ('oversized', _bad([0.5] * 100_000), 'intent/w: oversized message of 8000'),
]
BAD_V = [
    ('wrong length', _bad([0.5, 0.5]), 'v must have 7 entries'),
    ('NaN', _bad([0.5, math.nan, 0.5, 0, 0, 0, 0]), 'v contains NaN or infinity (first at index 1: nan)'),
    ('Inf', _bad([0.5, 0.5, 0, 0, 0, 0, math.inf]), 'v contains NaN or infinity (first at index 6: inf)'),
    ('outside [0, 1]', _bad([1.5, -0.5, 0, 0, 0, 0, 0]), 'v must be non-negative and sum to 1 (within 1e-6)'),
    ('not summing to 1', _bad([0.5] * 7), 'sum 3.5'),
    ('empty', _bad([]), 'v is empty'),
    ('oversized', _bad([0.0] * 100_000), 'intent/v: oversized message of 8000'),
    ('unknown zone labels', _bad([1.0, 0, 0, 0, 0, 0, 0], 'A,B,C,D,E,F,G'), "unknown zone 'A'"),
]


def _model_doc(body: str, *, sha: str | None = None) -> String:
    digest = sha or hashlib.sha256(body.encode()).hexdigest()
    return String(data=f'# model_name: broken\n# model_version: 1\n# model_sha256: {digest}\n{body}')


BAD_MODEL = [
    ('no header', String(data='not a model document'), 'lacks the header lines'),
    ('hash mismatch', _model_doc('format_version: 1\n', sha='0' * 64), 'is corrupted: sha256'),
    ('invalid YAML', _model_doc('a: [1, 2\n'), 'not valid YAML'),
    ('not a model', _model_doc('format_version: 1\nname: broken\n'), "lacks field 'task_names'"),
]
BAD_X = [
    ('wrong length', _bad([0.1, 0.2, 0.3]), 'x must have shape (10,)'),
    ('NaN', _bad([0.0] * 9 + [math.nan]), 'x contains NaN or infinity (first at index 9: nan)'),
    ('empty', _bad([]), 'x is empty'),
    ('oversized', _bad([0.0] * 2000), 'x is oversized: 2000 values'),
]


def _reject_all(chain: Chain, publisher: Any, cases: list[tuple[str, Any, str]], status_suffix: str) -> None:
    """Send each bad message until ``status_suffix`` reports a WARN rejection with the expected reason."""
    for what, msg, reason in cases:
        count = chain.rejected_count(status_suffix)

        def reported(count: int = count, reason: str = reason) -> bool:
            status = chain.status(status_suffix)
            return (status is not None and status.level == WARN and reason in status.message
                    and chain.rejected_count(status_suffix) > count)

        assert chain.ros.publish_until(publisher, msg, reported, timeout=10.0, period=1.0), (
            f'{status_suffix}: no WARN naming {reason!r} for {what}; last: {chain.status(status_suffix)}')
    chain.assert_running()


def test_bad_input_is_rejected_with_a_named_reason_and_every_node_keeps_serving(chain, models):
    ros = chain.ros
    cup7 = models[1]['cup_7zone']
    chain.send(W_TWO)  # the chain is up
    valid_v = [interpret(W_TWO).v, interpret(W_AMBIGUOUS).v]

    # the interpreter: bad w, then a valid one; it published no v for the bad ones. The probe hears a v before
    # the bad w go out: a v subscription not yet matched would hear nothing and prove nothing.
    v_msgs = ros.subscribe(Float64MultiArray, 'intent/v')
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')
    assert ros.publish_until(w_pub, Float64MultiArray(data=list(W_TWO)), lambda: v_msgs, timeout=STARTUP), \
        'the probe heard no intent/v'
    _reject_all(chain, w_pub, BAD_W, 'intent_interpreter: intent')
    answer = chain.send(W_AMBIGUOUS)
    assert_allclose(answer.v, valid_v[1], rtol=0, atol=1e-12)
    assert v_msgs and all(any(np.allclose(msg_to_array(m), v, rtol=0, atol=1e-12) for v in valid_v)
                          for m in v_msgs), 'the interpreter published a v for bad input'

    # the planner: bad v and malformed model documents; the model server: bad feature vectors
    bad_from = ros.node.get_clock().now().nanoseconds  # any plan of the resent valid w is out by now
    _reject_all(chain, ros.publisher(Float64MultiArray, 'intent/v'), BAD_V, 'grasp_planner: inputs')
    model_pub = ros.publisher(String, 'model/active', latched_qos())
    _reject_all(chain, model_pub, BAD_MODEL, 'grasp_planner: inputs')
    ros.node.destroy_publisher(model_pub)
    query = ros.publisher(Float64MultiArray, 'model/query')
    _reject_all(chain, query, BAD_X, 'model_server: model')
    assert not [p for p in chain.posteriors if bad_from <= _ns(p.stamp)], 'a plan was published for bad input'

    # every node answers a valid input; the malformed documents did not replace the model
    answer = chain.send(W_TWO)
    assert answer.posterior.zone_labels == cup7.zone_labels
    assert_allclose(answer.v, valid_v[0], rtol=0, atol=1e-12)
    posteriors = ros.subscribe(Float64MultiArray, 'model/posterior')
    x = cup7.means[3]
    assert ros.publish_until(query, Float64MultiArray(data=list(x)), lambda: posteriors, timeout=10.0)
    assert_allclose(msg_to_array(posteriors[-1]), cup7.posterior(x), rtol=0, atol=1e-12)
    assert _ok_after_valid_w(chain, 'intent_interpreter: intent'), chain.status('intent_interpreter: intent')
    for suffix in ('grasp_planner: inputs', 'model_server: model'):
        assert ros.wait_for(lambda s=suffix: chain.status(s).level == DiagnosticStatus.OK, 5.0), \
            chain.status(suffix)
    chain.assert_running()


def _ok_after_valid_w(chain: Chain, suffix: str) -> bool:
    """``suffix``'s status is OK within 5 s, or after one more valid w (at most twice).

    The interpreter reads model documents on a thread of its own, and nothing waits for its verdicts on the
    bad ones: a verdict can come after the valid w, and is then its last outcome until the next w.
    """
    def ok() -> bool:
        return bool(chain.ros.wait_for(lambda: chain.status(suffix).level == DiagnosticStatus.OK, 5.0))

    if ok():
        return True
    for _ in range(2):
        chain.send(W_TWO)
        if ok():
            return True
    return False


# ---------------------------------------------------------------------------------------------- (c)
def test_switching_the_model_at_run_time_changes_the_plan_and_unknown_models_are_rejected(chain, models,
                                                                                          kinematics):
    ros = chain.ros
    cup5 = models[1]['cup_5zone']
    first = chain.send(W_AMBIGUOUS)
    x7 = chain.x_of(first)
    assert first.posterior.zone_labels == models[1]['cup_7zone'].zone_labels

    switched_at = ros.node.get_clock().now().nanoseconds
    result = chain.set_model('cup_5zone')
    assert result.successful, result.reason
    # the planner replans the last v on the new model by itself
    assert ros.wait_for(lambda: any(p.zone_labels == cup5.zone_labels and _ns(p.stamp) > switched_at
                                    for p in chain.posteriors), STARTUP)
    replanned = next(p for p in chain.posteriors if p.zone_labels == cup5.zone_labels)
    stamp = _ns(replanned.stamp)
    assert ros.wait_for(lambda: stamp in chain.features)
    x5 = chain.features[stamp]
    assert np.linalg.norm(x5 - x7) > 1e-3, 'the plan did not change with the model'
    expected = core_plan(cup5, W_AMBIGUOUS, kinematics)  # first plan on this model: no warm start
    assert_allclose(x5, expected.x, rtol=0, atol=1e-6)
    assert_allclose(replanned.p, expected.posterior, rtol=0, atol=1e-4)
    assert model_from_msg(chain.active[-1]).name == 'cup_5zone'

    n_docs = len(chain.active)
    for name, reason in (('no_such_model', "unknown model 'no_such_model'"),
                         ('broken', "lacks field 'task_names'")):
        result = chain.set_model(name)
        assert not result.successful and reason in result.reason, result.reason
    assert chain.get_model() == 'cup_5zone'
    answer = chain.send(W_TWO)  # still planned on cup_5zone
    assert answer.posterior.zone_labels == cup5.zone_labels
    assert len(chain.active) == n_docs and model_from_msg(chain.active[-1]).name == 'cup_5zone'
    chain.assert_running()


# ---------------------------------------------------------------------------------------------- (c2)
def test_intents_the_system_cannot_serve_get_one_clarification_each(chain, models):
    """Intents that cannot be served get one clarification each.

    cup_4zone has no "usage only" zone, so w = (0.9, 0, 0) cannot be served although P(no task) = 0.1; an
    object out of reach cannot be grasped for any intent. Each such intent gets one message on
    intent/clarification with the reason, and the nodes' status fields say what happened last.
    """
    ros = chain.ros
    clarifications = ros.subscribe(String, 'intent/clarification')
    values = lambda status: {kv.key: kv.value for kv in status.values}  # noqa: E731
    assert chain.set_model('cup_4zone').successful
    interpreter_knows = lambda: (s := chain.status('intent_interpreter: intent')) is not None and \
        values(s)['active model'].startswith('cup_4zone')  # noqa: E731
    assert ros.wait_for(interpreter_knows, STARTUP), 'the interpreter did not follow model/active'
    w_pub = ros.publisher(Float64MultiArray, 'intent/w')
    assert ros.wait_for(lambda: w_pub.get_subscription_count() >= 1, STARTUP)
    # one w, published until its clarification arrives (the first message after matching may be lost)
    assert ros.publish_until(w_pub, Float64MultiArray(data=[0.9, 0.0, 0.0]), lambda: clarifications,
                             timeout=STARTUP, period=2.0)
    assert 'no zone of the model has non-zero probability' in clarifications[0].data
    assert 'cup_4zone: zones T,UT,TH,UTH' in clarifications[0].data
    assert ros.wait_for(lambda: values(chain.status('intent_interpreter: intent'))['last outcome'].startswith(
        'clarification requested: no zone of the model'))
    # the chain still serves an intent the model can serve; still one clarification for the first
    assert ros.wait_for(lambda: len(chain.sender.clarifications) == 1)  # not taken as the next answer
    planner_knows = lambda: (s := chain.status('grasp_planner: planning')) is not None and \
        values(s).get(KEY_MODEL, '').startswith('cup_4zone')  # noqa: E731
    assert ros.wait_for(planner_knows, STARTUP), 'the planner did not follow model/active'
    answer = chain.send(W_TWO)
    assert answer.posterior.zone_labels == models[1]['cup_4zone'].zone_labels
    assert len(clarifications) == 1, [m.data for m in clarifications]
    assert ros.wait_for(lambda: values(chain.status('intent_interpreter: intent'))['last outcome'] == 'v published')

    # no reachable grasp: the object 1.2 m away (within the workspace radius, beyond reach); the planner
    # re-plans the last intent for the new pose
    pose_pub = ros.publisher(PoseStamped, 'object/pose')
    far = matrix_to_pose_msg(pose_to_matrix((1.2, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)), frame_id=BASE_FRAME,
                             stamp=ros.node.get_clock().now().to_msg())
    assert ros.publish_until(pose_pub, far, lambda: len(clarifications) == 2, timeout=STARTUP, period=2.0)
    assert clarifications[1].data.startswith('no reachable grasp: IK failed for all')
    planning = lambda: chain.status('grasp_planner: planning')  # noqa: E731
    assert ros.wait_for(lambda: planning().level == WARN and values(planning()).get(
        'last plan status', '').startswith('clarification requested: no reachable grasp'))
    assert planning().message.startswith('clarification requested: no reachable grasp')
    chain.assert_running()


# ---------------------------------------------------------------------------------------------- (d)
def test_sigkilled_model_server_and_interpreter_are_restarted_without_restarting_the_others(chain, models):
    ros = chain.ros
    cup5 = models[1]['cup_5zone']
    chain.send(W_AMBIGUOUS)
    planner_pid = chain.procs['grasp_planner'].pid
    interpreter_pid = chain.procs['intent_interpreter'].pid

    assert chain.procs['model_server'].stop(signal.SIGKILL) == -signal.SIGKILL
    killed_at = ros.node.get_clock().now().nanoseconds
    chain.start('model_server', '-p', 'model:=cup_5zone')
    # the planner receives the new server's latched model and replans the last v on it
    assert ros.wait_for(lambda: any(p.zone_labels == cup5.zone_labels and _ns(p.stamp) > killed_at
                                    for p in chain.posteriors), REMATCH), \
        'the planner did not re-receive model/active'
    assert chain.send(W_TWO, timeout=REMATCH).posterior.zone_labels == cup5.zone_labels

    assert chain.procs['intent_interpreter'].stop(signal.SIGKILL) == -signal.SIGKILL
    chain.start('intent_interpreter')
    answer = chain.send(W_AMBIGUOUS, timeout=REMATCH)
    assert answer.posterior.zone_labels == cup5.zone_labels
    assert_allclose(answer.v, interpret(W_AMBIGUOUS).v, rtol=0, atol=1e-12)
    assert chain.procs['intent_interpreter'].pid != interpreter_pid
    assert [p.module for p in chain.launch.processes] == [  # the planner was never restarted
        'intent_interpreter', 'model_server', 'grasp_planner', 'model_server', 'intent_interpreter']
    assert chain.procs['grasp_planner'].pid == planner_pid
    chain.assert_running()


# ---------------------------------------------------------------------------------------------- (e)
DEMO_DEADLINE = 120.0


def _is_node_process(pid: int) -> bool:
    try:
        return b'grasp_intent_ros.' in Path(f'/proc/{pid}/cmdline').read_bytes()
    except OSError:
        return False


def readme_demo_lines() -> list[str]:
    """The lines of the README's expected demo output that it does not say vary.

    Not the pids, the domain, a line with a time (an answer's, the operator's, alpha's over the motion), where the
    helped hand ended (at the grasp within the IK's tolerance, 0.1 mm: asserted below), nor the episode without
    help but its heading (where the operator stops varies with the wall clock's timing).
    """
    text = (REPO / 'README.md').read_text()
    block = text.split('Expected output (trimmed', 1)[1].split('```\n', 1)[1].split('```', 1)[0]
    lines, unhelped = [], False
    for line in block.splitlines():
        if line.startswith('  ') and not line.startswith('    '):
            unhelped = line.startswith('  without it')
        elif unhelped:
            continue
        if line.strip() not in ('', '...') and not re.search(r'\(pid \d|\d s\b|ROS_DOMAIN_ID=|hand ended', line):
            lines.append(line)
    return lines


def closed_loop_episodes(stdout: str) -> tuple[list[str], list[str]]:
    """The lines of the demo's closed-loop episodes, with the help and without it (their headings left out)."""
    loop = stdout.split('\nClosed loop: ', 1)[1]
    helped = loop.split('\n  with the help', 1)[1].split('\n  without it', 1)[0]
    unhelped = loop.split('\n  without it', 1)[1].split('\n  one episode each', 1)[0]
    return helped.splitlines()[1:], unhelped.splitlines()[1:]


def test_the_demo_runs_to_completion_and_leaves_no_process(domain_id, tmp_path):
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'ROS_DOMAIN_ID': str(domain_id)}
    env.pop('ROS_STATIC_PEERS', None)
    out_path, err_path = tmp_path / 'demo.out', tmp_path / 'demo.err'
    with out_path.open('wb') as out, err_path.open('wb') as err:
        demo = subprocess.Popen([sys.executable, '-m', 'grasp_intent_ros', 'demo', '--timeout', '30'], cwd=REPO,
                                env=env, stdout=out, stderr=err, stdin=subprocess.DEVNULL)
    read = lambda: out_path.read_text(errors='replace')  # noqa: E731
    def node_pids() -> list[int]:  # the demo's first line names them
        return [int(p) for p in re.findall(r'\(pid (\d+)\)', read().partition('\n')[0])]

    try:
        code = demo.wait(DEMO_DEADLINE)
    except subprocess.TimeoutExpired:
        demo.send_signal(signal.SIGINT)  # the demo stops its nodes
        try:
            demo.wait(30.0)
        except subprocess.TimeoutExpired:
            demo.kill()
            demo.wait()
        for pid in node_pids():
            if _is_node_process(pid):
                os.kill(pid, signal.SIGKILL)
        pytest.fail(f'the demo did not finish within {DEMO_DEADLINE:g} s:\n{read()[-3000:]}\n'
                    f'{err_path.read_text()}')
    stdout, stderr = read(), err_path.read_text(errors='replace')
    assert code == 0, f'demo exited with {code}:\n{stdout[-3000:]}\n{stderr}'
    assert 'Traceback' not in stderr, stderr
    assert len(node_pids()) == 6  # the suite's three, the mock arm, the assistance, the scripted operator
    assert not [pid for pid in node_pids() if _is_node_process(pid)], 'a node outlived the demo'
    for title, w, names in CASES:
        for name in names:
            assert f'model {name} (' in stdout and f'w = {w}' in stdout
    assert stdout.count('joint targets') == sum(len(names) for _, _, names in CASES)
    assert 'asks for clarification: P(no task) = 0.7290' in stdout
    assert 'nodes stopped (cleanly)' in stdout
    helped, unhelped = closed_loop_episodes(stdout)
    rows = {line[4:22].strip(): line[22:] for line in helped}
    assert rows['serves (rules)'] == "usage, transfer (UT) at the reached pose: the operator's tasks served", helped
    assert rows['grasp command'].startswith('grasp/execute (following the latest trajectory from now'), helped
    distance, angle = map(float, re.findall(r'([\d.]+) (?:mm|rad)', rows['hand ended']))  # executed: at the grasp
    assert distance < 1.0 and angle < 0.01, helped
    assert float(re.findall(r'max ([\d.]+)', rows["robot's share"])[0]) > 0.5, helped  # the robot helped
    rows = {line[4:22].strip(): line[22:] for line in unhelped}
    assert rows["robot's share"].startswith('alpha mean 0.00, max 0.00'), unhelped
    assert rows['grasp command'] == 'grasp/close where the operator stopped', unhelped
    assert re.fullmatch(r'.+ at the reached pose: .+', rows['serves (rules)']), unhelped
    lines, at = stdout.splitlines(), 0
    expected = readme_demo_lines()
    assert len(expected) >= 10, expected
    for line in expected:  # in the README's order
        assert line in lines[at:], f"README.md's expected demo output has {line!r}; the demo printed:\n{stdout}"
        at = lines.index(line, at) + 1
