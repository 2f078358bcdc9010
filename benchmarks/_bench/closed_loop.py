"""The live closed-loop benchmark's probe side: the operator's loop on the suite, one operator's run, the judge.

Shared by ``bench_shared_control.py`` (its module docstring states the operator, the grasp command and the judge)
and its recording (:mod:`_bench.closed_loop_record`): :class:`Loop` (this process's subscriptions, publishers and
service clients on the running suite), :func:`run_operator` (one scripted operator until it closes the hand or
times out, judged after by the object's rules at the true pose), :class:`Run` (its figures).
"""

from __future__ import annotations

import math
import sys
import threading
import time
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from _bench import Probe
from grasp_intent_ros.method.features import FINGERS
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import default_base_T_obj
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, MicoKinematics
from grasp_intent_ros.objects.demos import object_of
from grasp_intent_ros.objects.judge import judge
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.operator_loop import (
    EXECUTE_TIMEOUT,
    GraspCommand,
    Perceived,
    executes,
    hand_at_rest,
    operator_step,
)
from grasp_intent_ros.shared_control.operators import IntentScript, OperatorConstants, ScriptedOperator
from grasp_intent_ros.wire.joint_states import CLOSE_SETTLE, Hand, HandTracker, fingers_settled

OBJECTS = {'cup': 'cup_7zone', 'flashlight': 'flashlight_7zone'}
"""The benchmark's objects and their models; the judge's rules are each model's object's (``object_of``)."""
BASE_T_OBJ = default_base_T_obj()
"""The true object pose: the planner's default (:func:`~grasp_intent_ros.mico.frames.default_base_T_obj`)."""
PERIOD = 0.01
W_EVERY = 10
"""Operator ticks per w (10 Hz)."""
CLOSE_TIMEOUT = 10.0
"""Seconds the probe waits for the fingers at rest after ``grasp/close`` (they close at their speed limit)."""


def assistance_changes(config: AssistanceConfig) -> dict[str, Any]:
    """The fields of ``config`` that differ from :class:`AssistanceConfig`'s defaults, by name.

    What a simulated benchmark's record carries of the suite's assistance in its ``run``: nothing for the defaults,
    so records of the defaults compare with records written before an option existed.
    """
    default = AssistanceConfig()
    return {f.name: getattr(config, f.name) for f in fields(config)
            if getattr(config, f.name) != getattr(default, f.name)}


def load_model(name: str) -> GraspModel:
    """The shipped model of object ``name`` (:data:`OBJECTS`)."""
    return ModelFiles(config_dir() / 'models').load(OBJECTS[name])


def joystick(op: OperatorConstants, rng: np.random.Generator) -> ScriptedOperator:
    """The scripted operator's two-mode joystick (bench_shared_control's docstring), its noise drawn from ``rng``."""
    return ScriptedOperator('joystick', op, rng, PERIOD)


@dataclass
class Run:
    """The figures of one operator under one condition."""

    object: str
    operator: int
    condition: str
    task_set: int
    success: bool = False
    pursued: str = ''
    time_to_grasp: float = math.nan
    effort_linear: float = 0.0
    effort_angular: float = 0.0
    wrong_pull: float = 0.0
    alpha_mean: float = 0.0
    closures: list[float] = field(default_factory=list)
    """The closures judged (rad): the fingers' at rest after ``grasp/close``, or the own grasp's (run_operator)."""
    verdict: str = ''
    """The judge's verdict in words (which rules failed); '' when nothing was judged."""
    alpha_samples: int = field(default=0, repr=False)


class Loop:
    """The probe side: subscriptions, the operator's publishers, the service clients."""

    def __init__(self, probe: Probe, kin: MicoKinematics, sends_w: bool = True) -> None:
        from geometry_msgs.msg import PoseStamped, TwistStamped
        from rcl_interfaces.srv import SetParameters
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64, Float64MultiArray
        from std_srvs.srv import Trigger
        from trajectory_msgs.msg import JointTrajectory

        from grasp_intent_ros.errors import GraspIntentError
        from grasp_intent_ros.ros.qos import input_qos, output_qos
        from grasp_intent_ros.wire.arrays import stamped_values
        from grasp_intent_ros.wire.robot_state import pose_msg_to_matrix, trajectory_time

        self.probe, self.kin = probe, kin
        node = probe.node
        self.hands: Perceived[np.ndarray] = Perceived(keep=200)  # base_T_ee by monotonic receipt
        self.tracker = HandTracker(kin)  # received on the monotonic clock; the rest by the stamps
        self.plans: list[tuple[float, np.ndarray, np.ndarray]] = []  # (monotonic, base_T_grasp, features)
        self.alphas: list[tuple[float, float]] = []
        self.outputs: list[tuple[int, float]] = []  # (receive ns, angular.z)
        self._poses: dict[tuple[int, int], np.ndarray] = {}
        self._lock = threading.Lock()

        def on_joints(msg: Any) -> None:
            received = time.monotonic()
            try:
                named = self.tracker.add(msg, received)
            except GraspIntentError as exc:  # not read: the hand stays the previous messages'
                print(f'bench_shared_control: joint_states not read: {exc}', file=sys.stderr)
                return
            if any(name in ARM_JOINTS for name in named) and (arm := self.tracker.joints.read(ARM_JOINTS)) is not None:
                self.hands.add(received, kin.fk(arm.positions))

        def on_pose(msg: Any) -> None:
            self._poses[(msg.header.stamp.sec, msg.header.stamp.nanosec)] = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)

        def on_features(msg: Any) -> None:
            x, _, stamp = stamped_values(msg)
            base_T = self._poses.pop((stamp.sec, stamp.nanosec), None) if stamp is not None else None
            if base_T is not None:
                with self._lock:
                    self.plans.append((time.monotonic(), base_T, x))

        node.create_subscription(JointState, 'joint_states', on_joints, input_qos(100))
        node.create_subscription(PoseStamped, 'grasp/pose', on_pose, input_qos(100))
        self.trajectory_time: float | None = None  # the latest grasp/trajectory's last time_from_start, s

        def on_trajectory(msg: Any) -> None:
            self.trajectory_time = trajectory_time(msg)

        node.create_subscription(JointTrajectory, 'grasp/trajectory', on_trajectory, input_qos(100))
        node.create_subscription(Float64MultiArray, 'grasp/features', on_features, input_qos(100))
        node.create_subscription(Float64, 'assistance/alpha', lambda m: self.alphas.append(
            (time.monotonic(), m.data)), input_qos(1000))
        def on_blended(m: Any, info: Any) -> None:
            self.receipts.append((time.monotonic(), info['received_timestamp'], info['source_timestamp']))
            self.outputs.append((info['received_timestamp'], m.twist.angular.z))
            t = m.twist
            self.blended.append((time.monotonic(), np.array([t.linear.x, t.linear.y, t.linear.z, t.angular.x,
                                                             t.angular.y, t.angular.z])))

        self.blended: list[tuple[float, np.ndarray]] = []  # (monotonic, twist)
        self.receipts: list[tuple[float, int, int]] = []  # (monotonic in the callback, the middleware's receive
        # ns, the publisher's source ns: its middleware's time at the publish)
        node.create_subscription(TwistStamped, 'assistance/twist', on_blended, input_qos(1000))
        self.twist_pub = node.create_publisher(TwistStamped, 'operator/twist', output_qos())
        self.w_pub = node.create_publisher(Float64MultiArray, 'intent/w', output_qos()) if sends_w else None
        self._set_params = node.create_client(SetParameters, 'assistance/set_parameters')
        self._planner_set_params = node.create_client(SetParameters, 'grasp_planner/set_parameters')
        self._reset = node.create_client(Trigger, 'mock_arm/reset')
        self._execute = node.create_client(Trigger, 'grasp/execute')
        self._close = node.create_client(Trigger, 'grasp/close')
        self._object_pub: Any = None  # made by show_object: a recording's suite sees no publisher of the pose
        self._pose_type, self._output_qos = PoseStamped, output_qos
        from rcl_interfaces.srv import GetParameters
        self._arm_parameters = node.create_client(GetParameters, 'mock_arm/get_parameters')
        self._arm_set_parameters = node.create_client(SetParameters, 'mock_arm/set_parameters')
        self._get_parameters = GetParameters
        from std_srvs.srv import SetBool
        self._enable = node.create_client(SetBool, 'assistance/enable')
        self._set_bool = SetBool
        self._twist_type, self._w_type, self._trigger = TwistStamped, Float64MultiArray, Trigger

    def twist(self, values: np.ndarray) -> Any:
        msg = self._twist_type()
        msg.header.frame_id = BASE_FRAME
        msg.header.stamp = self.probe.node.get_clock().now().to_msg()
        t = msg.twist
        t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z = (float(v) for v in values)
        return msg

    def send_w(self, w: np.ndarray) -> None:
        assert self.w_pub is not None, 'this loop sends no w'
        self.w_pub.publish(self._w_type(data=[float(x) for x in w]))

    def call(self, client: Any, request: Any, timeout: float = 30.0) -> Any:
        if not client.wait_for_service(timeout_sec=timeout):
            sys.exit(f'bench_shared_control: service {client.srv_name} not available')
        future = client.call_async(request)
        if not self.probe.wait_for(future.done, timeout):
            sys.exit(f'bench_shared_control: no answer from {client.srv_name}')
        return future.result()

    def _set_parameter(self, client: Any, name: str, value: Any) -> None:
        """Set one parameter through ``client`` (a node's ``set_parameters``); a refusal stops the benchmark."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        result = self.call(client, request).results[0]
        assert result.successful, f'{client.srv_name} {name}: {result.reason}'

    def set_arbitration(self, rule: str) -> None:
        self._set_parameter(self._set_params, 'arbitration', rule)

    def set_plan_for(self, target: str) -> None:
        """The planner's ``plan_for`` (``v`` or ``most_likely_task``): a change replans the newest inputs."""
        self._set_parameter(self._planner_set_params, 'plan_for', target)

    def set_closure_seed(self, seed: int) -> None:
        """The mock arm's ``closure_seed``: its closes from now draw the errors of ``seed`` from their start."""
        self._set_parameter(self._arm_set_parameters, 'closure_seed', seed)

    def enable(self, on: bool) -> None:
        assert self.call(self._enable, self._set_bool.Request(data=on)).success

    def reset_arm(self) -> None:
        assert self.call(self._reset, self._trigger.Request()).success

    def execute(self) -> float:
        """The grasp command's execution: when the fingers close (monotonic s).

        Zero twists until the hand is seen at rest, ``grasp/execute``, zero twists until the trajectory has had
        its time: :class:`~grasp_intent_ros.shared_control.operator_loop.GraspCommand`, as the scripted operator
        node; a refused execute is due at once (the hand closes where it is).
        """
        command, still = GraspCommand(time.monotonic(), EXECUTE_TIMEOUT), self.twist(np.zeros(6))
        while not command.ready(now := time.monotonic(), hand_at_rest(self.hands, now)):
            self.twist_pub.publish(still)
            time.sleep(PERIOD)
        command.request(time.monotonic())
        answer = self.call(self._execute, self._trigger.Request(), timeout=EXECUTE_TIMEOUT)
        command.answered(time.monotonic(), answer.success, answer.message, self.trajectory_time)
        if command.refused:
            print(f'bench_shared_control: grasp/execute refused: {command.refused}', file=sys.stderr)
        while not command.due(now := time.monotonic()):
            self.twist_pub.publish(still)
            time.sleep(min(PERIOD, command.close_at - now))
        return time.monotonic()

    def hold(self, done: Any, timeout: float) -> bool:
        """Zero twists at 100 Hz until ``done(now)`` (monotonic s) holds (True) or ``timeout`` s pass (False)."""
        still, end = self.twist(np.zeros(6)), time.monotonic() + timeout
        while not done(now := time.monotonic()):
            if now > end:
                return False
            self.twist_pub.publish(still)
            time.sleep(PERIOD)
        return True

    def hand(self) -> Hand | None:
        """The hand of the joint states so far (:class:`~grasp_intent_ros.wire.joint_states.HandTracker`)."""
        return self.tracker.hand()

    def close(self) -> Hand | None:
        """The grasp command's close: ``grasp/close``, then zero twists until the fingers are seen at rest.

        The hand read in joint states sampled at least :data:`~grasp_intent_ros.wire.joint_states.CLOSE_SETTLE` s
        after the answer, the fingers at rest (:func:`~grasp_intent_ros.wire.joint_states.fingers_settled`: still
        for the rest rule's window, from positions, both timed by the joint states' stamps, which the mock arm takes
        from the system clock this process reads too; by receipts once they are not usable): its fingers are the
        closures the mock arm executed (the latest plan's plus its closure error), never a backlog of joint states
        sampled before the close and taken after it (the subscription keeps 100). None when the close is refused or
        the fingers are not at rest within :data:`CLOSE_TIMEOUT` s (both printed).
        """
        answer = self.call(self._close, self._trigger.Request())
        if not answer.success:
            print(f'bench_shared_control: grasp/close refused: {answer.message}', file=sys.stderr)
            return None
        closed, closed_ns = time.monotonic(), self.probe.node.get_clock().now().nanoseconds
        if not self.hold(lambda now: fingers_settled(self.hand(), closed, CLOSE_SETTLE, closed_ns=closed_ns),
                         CLOSE_TIMEOUT):
            print(f'bench_shared_control: the fingers not at rest {CLOSE_TIMEOUT:g} s after grasp/close',
                  file=sys.stderr)
            return None
        return self.hand()

    def show_object(self, base_T_obj: np.ndarray) -> bool:
        """Publish ``base_T_obj`` on ``object/pose`` (the tracker's), then wait up to 5 s for the plan it causes.

        The planner replans its latest v on a new object pose; whether that plan came (it does not when the planner
        has no v yet or finds nothing reachable). The assistance takes the pose from the same message.
        """
        from grasp_intent_ros.ros.robot import matrix_to_pose_msg

        if self._object_pub is None:
            self._object_pub = self.probe.node.create_publisher(self._pose_type, 'object/pose', self._output_qos())
            matched = self.probe.wait_for(lambda: self._object_pub.get_subscription_count() >= 2, 10.0)
            assert matched, 'the planner and the assistance do not subscribe to object/pose'
        plans = len(self.plans)
        self._object_pub.publish(matrix_to_pose_msg(base_T_obj, frame_id=BASE_FRAME,
                                                    stamp=self.probe.node.get_clock().now().to_msg()))
        return self.probe.wait_for(lambda: len(self.plans) > plans, 5.0)

    def closure_error(self) -> float:
        """The mock arm's ``closure_error`` (rad): the standard deviation of each finger's error on a close."""
        answer = self.call(self._arm_parameters, self._get_parameters.Request(names=['closure_error']))
        return float(answer.values[0].double_value)

    def plan_at(self, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The last plan received by monotonic time ``t``: (base_T_grasp, features)."""
        with self._lock:
            for received, base_T, x in reversed(self.plans):
                if received <= t:
                    return base_T, x
        return None

    def hand_at(self, t: float) -> np.ndarray | None:
        return self.hands.at(t)


def run_operator(loop: Loop, op: OperatorConstants, intent: IntentScript, own: Grasp, model: GraspModel,
                 rng: np.random.Generator, timeout: float, run: Run, sends_w: bool = True,
                 execute: bool = False, own_closures: np.ndarray | None = None) -> None:
    """Run one operator until it closes the hand or ``timeout``; fills ``run`` (judged after, at the true pose).

    ``sends_w`` False: w comes from elsewhere (the intent estimator), the operator waits for a plan only.
    ``execute``: a close on the shown grasp executes it first (:meth:`Loop.execute`); the time to grasp runs to the
    execution's end. ``own_closures`` (shape (3,), rad), the benchmark's: a close on the shown grasp calls
    ``grasp/close`` and the hand is judged at rest with the fingers' executed closures (:meth:`Loop.close`); a close
    on the operator's own grasp closes nothing and is judged where the hand came to rest with ``own_closures`` (the
    own grasp's plus a closure error: bench_shared_control's docstring). None (the recording): nothing closes, the
    hand is judged where it is with the closures of the grasp pursued (the plan seen, or the own grasp). The judge:
    :func:`~grasp_intent_ros.objects.judge.judge` with ``model``'s object's rules, never seen by the operator.
    """
    rules = object_of(model)
    assert rules is not None, f'the model {model.name!r} names no object the rules know'

    task_set = intent.task_set(0.0)
    if sends_w:
        first_plan = len(loop.plans)
        w_first = intent.w(0.0, rng)  # the intent before the motion: wait for its plan (sent again each second)
        if not loop.probe.wait_for(lambda: len(loop.plans) > first_plan or loop.send_w(w_first), 60.0, poll=1.0):
            sys.exit('bench_shared_control: no plan for the first w within 60 s')
    elif not loop.probe.wait_for(lambda: bool(loop.plans), 60.0, poll=0.1):
        sys.exit('bench_shared_control: no plan for the estimator\'s first w within 60 s')
    device = joystick(op, rng)
    alpha_from = len(loop.alphas)
    start = time.monotonic()
    tick = 0
    while True:
        now = time.monotonic()
        t = now - start
        if sends_w and tick % W_EVERY == 0:
            loop.send_w(intent.w(t, rng))
        plan_seen = loop.plan_at(now - op.reaction)
        step = operator_step(device, now, loop.hand_at(now - op.reaction),
                             None if plan_seen is None else plan_seen[0], own.base_T_ee)
        if step.close:  # the hand it saw is there: the hand now is too (seen later)
            on_own = step.pursued == 'own' or plan_seen is None
            closures = own.positions[6:] if on_own or plan_seen is None else plan_seen[1][FINGERS]
            if executes(step, execute):  # the arm goes to the newest plan, whose closures the fingers take
                now = loop.execute()
                t, newest = now - start, loop.plan_at(now)
                closures = closures if newest is None else newest[1][FINGERS]
            run.pursued, run.time_to_grasp = step.pursued, t
            base_T_ee = loop.hand_at(now)
            if own_closures is not None and on_own:  # nothing to close to: the mock arm closes to the plan's
                loop.hold(lambda now: hand_at_rest(loop.hands, now), CLOSE_TIMEOUT)
                base_T_ee, closures = loop.hand_at(time.monotonic()), own_closures
            elif own_closures is not None:
                hand = loop.close()
                base_T_ee, closures = (None, closures) if hand is None else (hand.base_T_ee, hand.fingers)
            if base_T_ee is not None:
                verdict = judge(model, BASE_T_OBJ, base_T_ee, closures)
                run.success = verdict.serves(task_set)
                run.verdict = verdict.text
            run.closures = [float(c) for c in closures]
            break
        if t >= timeout:
            break
        command = step.twist
        loop.twist_pub.publish(loop.twist(command))
        run.effort_linear += float(np.linalg.norm(command[:3])) * PERIOD
        run.effort_angular += float(np.linalg.norm(command[3:])) * PERIOD
        tick += 1
        delay = start + tick * PERIOD - time.monotonic()
        if delay > 0.0:
            time.sleep(delay)
    end = time.monotonic()
    samples = [(t, a) for t, a in loop.alphas[alpha_from:] if start <= t <= end]
    run.alpha_samples = len(samples)
    run.alpha_mean = float(np.mean([a for _, a in samples])) if samples else 0.0
    previous = start
    for t, alpha in samples:
        plan = loop.plan_at(t)
        if plan is not None and rules.label(plan[1]) & task_set != task_set:
            run.wrong_pull += alpha * min(t - previous, 2 * PERIOD)
        previous = t
