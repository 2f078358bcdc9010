"""Grasp planner node: target vector v + active model + object pose -> MICO grasp (paper Algorithm 1).

Run: ``python -m grasp_intent_ros.grasp_planner [--ros-args --params-file config/grasp_planner.yaml]``

Topics (relative; ``-r __ns:=/robot1`` moves them)
    in   ``intent/v``              std_msgs/Float64MultiArray over all 2^m - 1 zones of the model's m tasks;
                                   its dim label names the zones ("U,T,H,UT,UH,TH,UTH"); without a
                                   layout the core zone order is assumed
    in   ``model/active``          std_msgs/String, latched: the versioned model document
    in   ``object/pose``           geometry_msgs/PoseStamped, object frame in ``m1n6s300_link_base``
                                   (default: the ``object_*`` parameters)
    in   ``joint_states``          sensor_msgs/JointState, any name order; seeds IK and times the
                                   trajectory; messages without the six arm joints are ignored
    out  ``grasp/pose``            geometry_msgs/PoseStamped, end-effector (``m1n6s300_end_effector``)
                                   in ``m1n6s300_link_base``
    out  ``grasp/joint_targets``   sensor_msgs/JointState: ``m1n6s300_joint_1..6`` (IK, 2 pi branch
                                   nearest the seed) and ``m1n6s300_joint_finger_1..3`` (planned closures)
    out  ``grasp/trajectory``      trajectory_msgs/JointTrajectory, one point with the same joints, zero
                                   velocities, time_from_start = slowest arm joint at its velocity limit
                                   from the latest joint state (HOME_Q before the first one), >= 0.1 s;
                                   header stamp zero: "start now" (the trajectory_msgs convention)
    out  ``grasp/posterior``       std_msgs/Float64MultiArray, shape (1, K + m): P(zone | x) over the
                                   model's K zones, then the reconstructed w. dim[0] (size 1) is labelled
                                   "stamp=<sec>.<nanosec>", dim[1] "<zones>|<tasks>", e.g.
                                   "U,T,H,UT,UH,TH,UTH|usage,transfer,handover"; read it with
                                   :func:`grasp_intent_ros.ros.robot.posterior_from_msg`
    out  ``grasp/features``        std_msgs/Float64MultiArray, shape (1, d): x, the same stamp axis, then
                                   the feature names (:func:`~grasp_intent_ros.ros.robot.stamped_array_from_msg`)
    out  ``grasp/markers``         visualization_msgs/MarkerArray: object cylinder, approach arrow, fingers,
                                   top zones
    out  ``intent/clarification``  std_msgs/String, the reason, when the newest intent cannot be served:
                                   v gives no zone of the active model any probability, or no candidate
                                   grasp is reachable; one message per intent (v) and model
    out  ``/diagnostics``          ``<node>: inputs`` (messages received / rejected and why) and
                                   ``<node>: planning`` (plans, last planning time, reachability counts)
Every output of one plan but the trajectory carries the same stamp: the node-clock time at which the
newest input of the plan (v, model or object pose) arrived. The trajectory's stamp is zero ("start
now"); it is published right after the joint targets of the same plan.

Behaviour
    Latest-only: callbacks validate and store the newest inputs and wake a planning thread, which plans
    the newest snapshot and never works through a backlog (input QoS keep-last 1). v is restricted to the
    model's zones (:func:`~grasp_intent_ros.core.intent.restrict`); when it gives them no probability the
    node publishes no grasp but a clarification request. Reachability is the planner's robot
    constraint: a candidate is accepted when IK of ``base_T_obj @ features_to_obj_T_ee(x)`` converges
    (seed: latest joint state, else HOME_Q; random restarts); the best reachable candidate is published
    and a fallback is reported; with none reachable no grasp is published but a clarification request
    with the reason. ``last plan status`` in the diagnostics says what the newest plan led to.
    Plans of the same model warm-start from the previous solution.

Parameters: see :data:`PARAMETERS` and ``config/grasp_planner.yaml``.
"""

from __future__ import annotations

import math
import threading
import time
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from .core import planner
from .core.errors import InvalidIntentError, ModelError
from .core.features import FINGERS, MICO_3F
from .core.intent import MAX_TASKS, all_zones, parse_zones, restrict, zone_labels
from .core.kinematics import (ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, HOME_Q, MicoKinematics,
                              Reachability, features_to_obj_T_ee, pose_to_matrix)
from .ros.conversions import ModelDocument, model_from_msg, msg_labels, msg_to_array
from .ros.diagnostics import OK, WARN, NodeDiagnostics
from .ros.params import ParameterError, ParamSpec, declare_parameters
from .ros.qos import input_qos, latched_qos, output_qos
from .ros.robot import (check_unit_quaternion, grasp_markers, joint_positions, joint_state_msg,
                        joint_trajectory_msg, matrix_to_pose_msg, pose_msg_to_matrix, posterior_to_msg,
                        stamped_array_to_msg, trajectory_duration, zone_summary)
from .ros.run import run_node

__all__ = ['GraspPlanner', 'PARAMETERS', 'MIN_TRAJECTORY_TIME', 'main']

MIN_TRAJECTORY_TIME = 0.1
"""Shortest time_from_start of the trajectory point (s); controllers reject 0."""
_MAX_ZONES = (1 << MAX_TASKS) - 1


_METHODS: tuple[str, ...] = typing.get_args(planner.Method)


def _check_method(value: str) -> None:
    if value not in _METHODS:
        raise ValueError(f'must be one of {", ".join(_METHODS)}; got {value!r}')


def _check_position(value: Sequence[float]) -> None:
    if len(value) != 3 or not all(math.isfinite(v) for v in value):
        raise ValueError(f'must be 3 finite numbers (x, y, z in m), got {list(value)}')


def _check_orientation(value: Sequence[float]) -> None:
    check_unit_quaternion(value)  # KinematicsError is a ValueError with the reason


def _check_size(value: Sequence[float]) -> None:
    if len(value) != 2 or not all(math.isfinite(v) and v > 0.0 for v in value):
        raise ValueError(f'must be 2 positive numbers (diameter, height in m), got {list(value)}')


PARAMETERS = (
    ParamSpec('method', 'lm', "Planner method: 'lm' (default: exact matches by log-odds projection, else "
              "least squares), 'slsqp' (SQP) or 'trust-constr' (interior point).", validator=_check_method,
              constraints=f'one of {", ".join(_METHODS)}'),
    ParamSpec('n_starts', 3, 'Demonstrations the planner starts from (plus the warm start).', range=(1, 20)),
    ParamSpec('ik_restarts', 8, 'Random IK restarts after the seeded attempt fails.', range=(0, 100)),
    ParamSpec('object_position', (0.3, -0.3, 0.0),
              'Object pose until one arrives on object/pose (and whenever set): position (x, y, z) of the '
              'object frame in m1n6s300_link_base, m.', validator=_check_position),
    ParamSpec('object_orientation', (0.0, 0.0, 1.0, 0.0),
              'Object pose orientation: unit quaternion (x, y, z, w) in m1n6s300_link_base. The default '
              'turns the cup handle (+x of the object) towards the arm.', validator=_check_orientation,
              constraints='unit norm within 1e-3'),
    ParamSpec('object_marker_size', (0.08, 0.10), 'Diameter and height of the object marker, m.',
              validator=_check_size),
    ParamSpec('min_replan_period', 0.0, 'Least time between the starts of two plans, s (0: plan at once).',
              range=(0.0, 10.0)),
    ParamSpec('urdf_path', '', "MICO URDF; '' means the package's config/mico_3f.urdf.", read_only=True),
)


@dataclass(frozen=True)
class _Inputs:
    """The newest inputs; ``version`` counts the updates that call for a new plan."""

    model: ModelDocument | None = None
    v: NDArray[np.float64] | None = None
    v_labels: tuple[str, ...] | None = None
    v_seq: int = 0
    base_T_obj: NDArray[np.float64] | None = None
    q_arm: NDArray[np.float64] | None = None
    stamp: Time | None = None
    version: int = 0


def _v_zones(v: NDArray[np.float64], labels: tuple[str, ...] | None, task_names: Sequence[str]) -> tuple[int, ...]:
    """Zone bitmasks of the entries of v: all zones of the model's tasks, in label (or core) order."""
    expected = all_zones(len(task_names))
    if labels is None:
        if v.size != len(expected):
            raise InvalidIntentError(f'v must have {len(expected)} entries (all zones of the model\'s '
                                     f'{len(task_names)} tasks), got {v.size}')
        return expected
    try:
        zones = parse_zones(labels, task_names)
    except InvalidIntentError as exc:
        raise InvalidIntentError(f'v labels do not match the model\'s {len(task_names)} tasks: {exc}') from None
    if sorted(zones) != sorted(expected):
        raise InvalidIntentError(f'v labels {",".join(labels)} must name each of the {len(expected)} zones of '
                                 f'the model\'s tasks once ({",".join(zone_labels(expected, task_names))})')
    return zones


class GraspPlanner(Node):
    """Plans a MICO grasp for the newest v, model and object pose. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'grasp_planner', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._inputs_diag = NodeDiagnostics(self, 'inputs')
        self._plan_diag = NodeDiagnostics(self, 'planning')
        self._params = declare_parameters(self, PARAMETERS, on_change=self._on_parameters)
        try:
            self._kin = MicoKinematics(self._params['urdf_path'] or None)
        except FileNotFoundError as exc:
            raise ParameterError(f'urdf_path: {exc}') from None
        self._lock = threading.Lock()
        self._inputs = _Inputs(base_T_obj=self._object_pose_from_parameters())
        self._wake, self._stop = threading.Event(), threading.Event()
        self._warm: tuple[tuple[str, str], NDArray[np.float64]] | None = None
        self._counts = dict.fromkeys(('plans', 'best grasp reachable', 'fallback to a reachable candidate',
                                      'no reachable grasp', 'clarifications requested', 'inputs superseded'), 0)
        self._clarified: tuple[int, tuple[str, str]] | None = None  # (v_seq, model) last clarified
        self._plan_diag.set_state(OK, 'waiting for model/active and intent/v')
        out = output_qos()
        self._pose_pub = self.create_publisher(PoseStamped, 'grasp/pose', out)
        self._joints_pub = self.create_publisher(JointState, 'grasp/joint_targets', out)
        self._trajectory_pub = self.create_publisher(JointTrajectory, 'grasp/trajectory', out)
        self._posterior_pub = self.create_publisher(Float64MultiArray, 'grasp/posterior', out)
        self._features_pub = self.create_publisher(Float64MultiArray, 'grasp/features', out)
        self._markers_pub = self.create_publisher(MarkerArray, 'grasp/markers', out)
        self._clarification_pub = self.create_publisher(String, 'intent/clarification', out)
        guard, latest = self._inputs_diag.guard, input_qos(depth=1)
        self._subs = [
            self.create_subscription(Float64MultiArray, 'intent/v', guard(self._on_v), latest),
            self.create_subscription(String, 'model/active', guard(self._on_model), latched_qos()),
            self.create_subscription(PoseStamped, 'object/pose', guard(self._on_object_pose), latest),
            # not keep-last 1: arm and finger states may come from different publishers
            self.create_subscription(JointState, 'joint_states', guard(self._on_joint_state), input_qos()),
        ]
        self._worker = threading.Thread(target=self._work, name=f'{node_name}_planning', daemon=True)
        # SIGINT/SIGTERM shut the context down before destroy_node runs: stop planning at once
        self.context.on_shutdown(self._stop.set)
        self._worker.start()

    def destroy_node(self) -> None:
        """Stop the planning thread (after its current plan), then destroy the node."""
        self._stop.set()
        self._wake.set()
        if self._worker.is_alive() and threading.current_thread() is not self._worker:
            self._worker.join()
        super().destroy_node()

    # ---------------------------------------------------------------- inputs (executor thread)
    def _update(self, trigger: bool = True, **changes: Any) -> None:
        with self._lock:
            if trigger:
                changes.update(stamp=self.get_clock().now(), version=self._inputs.version + 1)
            self._inputs = replace(self._inputs, **changes)
        if trigger:
            self._wake.set()

    def _on_v(self, msg: Float64MultiArray) -> None:
        v = msg_to_array(msg, max_size=_MAX_ZONES, error=InvalidIntentError, what='v')
        if np.any(v < 0.0) or abs(float(v.sum()) - 1.0) > 1e-6:
            raise InvalidIntentError(f'v must be non-negative and sum to 1 (within 1e-6); sum '
                                     f'{float(v.sum()):.9g}, min {float(v.min()):.6g}')
        labels = msg_labels(msg)[0] if msg.layout.dim and msg.layout.dim[0].label else None
        if labels is not None and len(labels) != v.size:
            raise InvalidIntentError(f'v has {v.size} values but its label names {len(labels)} zones')
        model = self._inputs.model
        if model is not None:
            _v_zones(v, labels, model.model.task_names)
        self._update(v=v, v_labels=labels, v_seq=self._inputs.v_seq + 1)

    def _on_model(self, msg: String) -> None:
        doc = model_from_msg(msg)
        if doc.model.feature_names != MICO_3F.names:
            raise ModelError(f'model {doc.name!r} has features {list(doc.model.feature_names)}; this planner '
                             f'maps the MICO 3-finger features {list(MICO_3F.names)} to a pose')
        previous = self._inputs.model
        same = previous is not None and (previous.name, previous.sha256) == (doc.name, doc.sha256)
        self._update(trigger=not same, model=doc)
        self._plan_diag.set_value('model', f'{doc.name} (version {doc.version}, zones '
                                           f'{",".join(doc.model.zone_labels)})')

    def _on_object_pose(self, msg: PoseStamped) -> None:
        self._update(base_T_obj=pose_msg_to_matrix(msg, frame_id=BASE_FRAME))

    def _on_joint_state(self, msg: JointState) -> None:
        q = joint_positions(msg, ARM_JOINTS)
        if q is not None:
            self._update(trigger=False, q_arm=q)

    def _object_pose_from_parameters(self) -> NDArray[np.float64]:
        return pose_to_matrix(self._params['object_position'], self._params['object_orientation'])

    def _on_parameters(self, changed: Mapping[str, Any]) -> None:
        if {'object_position', 'object_orientation'} & set(changed):
            self._update(base_T_obj=self._object_pose_from_parameters())

    # ---------------------------------------------------------------- planning thread
    def _work(self) -> None:
        planned = 0
        plan = self._plan_diag.guard(self._plan)
        last_start = -math.inf
        while not self._stop.is_set():
            if not self._wake.wait(timeout=0.5):
                continue
            wait = last_start + self._params['min_replan_period'] - time.monotonic()
            if wait > 0.0 and self._stop.wait(wait):
                break
            self._wake.clear()
            with self._lock:
                inputs = self._inputs
            if inputs.version == planned:
                continue
            if inputs.model is None or inputs.v is None:
                missing = ' and '.join(t for t, x in (('model/active', inputs.model), ('intent/v', inputs.v))
                                       if x is None)
                self._plan_diag.set_state(OK, f'waiting for {missing}')
                continue
            self._plan_diag.set_state(OK, '')
            self._counts['inputs superseded'] += max(0, inputs.version - planned - 1)
            planned, last_start = inputs.version, time.monotonic()
            plan(inputs)
            for key, count in self._counts.items():
                self._plan_diag.set_value(key, count)

    def _plan(self, inputs: _Inputs) -> None:
        assert inputs.model is not None and inputs.v is not None and inputs.base_T_obj is not None
        doc, base_T_obj = inputs.model, inputs.base_T_obj
        model = doc.model
        v = restrict(inputs.v, _v_zones(inputs.v, inputs.v_labels, model.task_names), model.zones)
        if v is None:
            self._clarify(inputs, f'v gives no probability to the zones {",".join(model.zone_labels)} of '
                                  f'model {doc.name!r}')
            return
        reachable = Reachability(self._kin, base_T_obj, inputs.q_arm, restarts=self._params['ik_restarts'])

        self._counts['plans'] += 1
        key = (doc.name, doc.sha256)
        warm = self._warm[1] if self._warm is not None and self._warm[0] == key else None
        result = planner.plan(model, v, method=self._params['method'], n_starts=self._params['n_starts'],
                              warm_start=warm, accept=reachable)
        self._plan_diag.set_value('last planning time [ms]', f'{1e3 * result.wall_time_s:.3f}')
        self._plan_diag.set_value('last IK time [ms]', f'{1e3 * reachable.seconds:.3f}')
        n = len(result.candidates)
        if result.status == 'rejected':
            self._counts['no reachable grasp'] += 1
            self._plan_diag.set_value('last plan reachability', f'none of {n} candidates reachable')
            closest = min(reachable.answers.values(), key=lambda a: a.pos_error_m)
            self._clarify(inputs, f'no reachable grasp: IK failed for all {n} candidates with the object at '
                                  f'{np.round(base_T_obj[:3, 3], 3).tolist()} m '
                                  f'({np.linalg.norm(base_T_obj[:3, 3]):.2f} m from the base); closest: '
                                  f'{closest.message}')
            return
        self._plan_diag.set_value('last plan status', f'grasp published ({result.message})')
        if result.rejected:
            self._counts['fallback to a reachable candidate'] += 1
            note = (f'best grasp unreachable: published candidate {result.rejected + 1} of {n} (objective '
                    f'{result.objective:.3g}, best {result.candidates[0].objective:.3g})')
            self.get_logger().warning(note, throttle_duration_sec=5.0)
        else:
            self._counts['best grasp reachable'] += 1
            note = f'best of {n} candidates reachable'
        self._plan_diag.set_value('last plan reachability', note)
        self._warm = (key, result.x)
        if self._stop.is_set():
            return
        try:
            self._publish(inputs, doc, result, reachable.answer(result.x).q)
        except Exception:
            if self.context.ok():
                raise
            # the context was shut down (a signal) between the check above and a publish: nothing to send to

    def _clarify(self, inputs: _Inputs, reason: str) -> None:
        """The newest intent cannot be served: ask for clarification (once per intent and model), and say
        so in the diagnostics (WARN until a grasp is published again)."""
        assert inputs.model is not None
        self._plan_diag.set_value('last plan status', f'clarification requested: {reason}')
        self._plan_diag.note(f'clarification requested: {reason}', level=WARN)
        intent = (inputs.v_seq, (inputs.model.name, inputs.model.sha256))
        if intent == self._clarified or self._stop.is_set():
            return  # e.g. the object moved but the intent is the same: asked already
        self._clarified = intent
        self._counts['clarifications requested'] += 1
        self.get_logger().warning(f'clarification requested: {reason}')
        try:
            self._clarification_pub.publish(String(data=reason))
        except Exception:
            if self.context.ok():
                raise

    def _publish(self, inputs: _Inputs, doc: ModelDocument, result: planner.PlanResult,
                 q: NDArray[np.float64]) -> None:
        assert inputs.stamp is not None and inputs.base_T_obj is not None
        stamp, model = inputs.stamp.to_msg(), doc.model
        base_T_ee = inputs.base_T_obj @ features_to_obj_T_ee(result.x)
        names, positions = ARM_JOINTS + FINGER_JOINTS, np.concatenate([q, result.x[FINGERS]])
        duration = trajectory_duration(HOME_Q if inputs.q_arm is None else inputs.q_arm, q,
                                       self._kin.velocity_limits, min_duration=MIN_TRAJECTORY_TIME)
        self._posterior_pub.publish(posterior_to_msg(result.posterior, result.w, model.zone_labels,
                                                     model.task_names, stamp=stamp))
        self._features_pub.publish(stamped_array_to_msg(result.x, model.feature_names, stamp=stamp))
        self._pose_pub.publish(matrix_to_pose_msg(base_T_ee, frame_id=BASE_FRAME, stamp=stamp))
        self._joints_pub.publish(joint_state_msg(names, positions, stamp=stamp))
        self._trajectory_pub.publish(joint_trajectory_msg(names, positions, duration))  # stamp 0: start now
        text = f'{doc.name}\n{zone_summary(model.zone_labels, result.posterior)}'
        self._markers_pub.publish(grasp_markers(inputs.base_T_obj, base_T_ee, result.x[FINGERS], text,
                                                frame_id=BASE_FRAME, stamp=stamp,
                                                object_size=self._params['object_marker_size']))


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(GraspPlanner, args)


if __name__ == '__main__':
    main()
