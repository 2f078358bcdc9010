"""Intent estimator node: the operator's reach -> task probabilities w on ``intent/w`` (docs/intent_estimation.md).

Run: ``python -m grasp_intent_ros intent_estimator [--ros-args --params-file config/intent_estimator.yaml]``
(in the suite: ``python -m grasp_intent_ros suite --shared-control --with intent_estimator``)

Topics (relative)
    in   ``operator/twist`` (the operator's own twist, before blending: TwistStamped, or Twist with
         ``operator_message_type``; frame ``m1n6s300_link_base`` or ``m1n6s300_end_effector``, '' =
         ``operator_frame``), ``joint_states`` (the hand's pose), ``object/pose`` (default: the ``object_*``
         parameters), ``model/active`` (latched: the goals are its demonstrations), ``grasp/pose`` (the
         planner's grasp, shown to the operator: the proposal an operator may take for its own)
    out  ``intent/w`` (std_msgs/Float64MultiArray, m values in [w_floor, 1 - w_floor], flat as ``ros2 topic
         pub`` sends it), ``/diagnostics`` (``intent estimator``)

Behaviour
    The maths is :mod:`grasp_intent_ros.shared_control.estimator`. Each operator twist updates the estimate with the
    hand's pose from the newest joint state, taken to act since the previous twist (the difference of their
    header stamps when both are set: the operator's own timing, which delivery delays do not change; else of
    their arrival times), on the executor (one update over all goals of a 7-zone model
    takes a fraction of a millisecond). w is published every ``publish_period`` while the operator's last
    twist is at most ``operator_timeout`` old, and once when the estimate restarts (the prior). The goals
    (the model's demonstrations at the object, those the arm reaches from the newest joint state) are
    prepared in a thread of their own whenever the model changes or the object moves by more than
    ``object_tolerance`` (m) or ``angle_tolerance`` (rad); meanwhile no w is published and twists are not
    used; then the estimate restarts from the prior. Another publisher on ``intent/w`` is not stopped: both
    reach the interpreter, which answers each w in arrival order, so the plan follows whichever spoke
    last; the status turns WARN and says so while one is matched.

Parameters: :data:`PARAMETERS`, ``config/intent_estimator.yaml``.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from numpy.typing import NDArray
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ..errors import GraspIntentError
from ..method.intent import zone_label
from ..mico.frames import pose_to_matrix
from ..mico.grasp import check_mico_model, check_workspace
from ..mico.kinematics import ARM_JOINTS, BASE_FRAME, EE_FRAME, JOINT_LIMIT_MARGIN, MicoKinematics
from ..mico.mock_arm import check_twist
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.model_follower import ModelFollower, served_models
from ..ros.params import TASK_NAMES, ParameterError, ParamSpec, declare_parameters, finite_vector, one_of
from ..ros.qos import input_qos, output_publisher
from ..ros.run import guard_exit, publish_all, run_node
from ..ros.worker import LatestOnlyWorker
from ..shared_control.assistance import pose_error
from ..shared_control.estimator import EstimatorConfig, IntentEstimator, goals_at, reachable_goals
from ..wire import topics
from ..wire.diagnostics import ERROR, ESTIMATOR_COMPONENT, KEY_GOALS, OK, WARN
from ..wire.model_document import ModelDocument
from ..wire.robot_state import check_unit_quaternion, joint_positions, pose_msg_to_matrix

__all__ = ['IntentEstimatorNode', 'PARAMETERS', 'main']

_DEFAULTS = EstimatorConfig()
_POSITIVE = (1e-6, 1e6)
PARAMETERS = (
    ParamSpec('rationality', _DEFAULTS.rationality, 'beta, 1/m: log-likelihood per metre of progress toward a goal.',
              range=_POSITIVE),
    ParamSpec('memory', _DEFAULTS.memory, 'L, m of the hand\'s pose motion over which the evidence fades by e.',
              range=_POSITIVE),
    ParamSpec('rotation_length', _DEFAULTS.rotation_length, 'rho, m per rad: the weight of the hand\'s rotation.',
              range=_POSITIVE),
    ParamSpec('position_scale', _DEFAULTS.position_scale, 'delta_p, m: progress toward a goal fades within it.',
              range=_POSITIVE),
    ParamSpec('angle_scale', _DEFAULTS.angle_scale, 'delta_theta, rad: the same for the orientation.',
              range=(1e-6, 3.14159)),
    ParamSpec('w_floor', _DEFAULTS.w_floor, 'w is kept within [w_floor, 1 - w_floor].', range=(1e-6, 0.49)),
    ParamSpec('max_dt', _DEFAULTS.max_dt, 'Longest time one operator twist is taken to act, s.', range=(1e-3, 10.0)),
    ParamSpec('proposal_radius', _DEFAULTS.proposal_radius, 'm: goals within it (and proposal_angle) of the shown '
              'grasp are credited with the progress toward it (0: the shown grasp is ignored).', range=(0.0, 10.0)),
    ParamSpec('proposal_angle', _DEFAULTS.proposal_angle, 'rad: the same for the orientation.', range=(0.0, 3.15)),
    ParamSpec('publish_period', 0.04, 'Time between two w while the operator moves, s.', range=(0.001, 1.0),
              read_only=True),
    ParamSpec('operator_timeout', 0.1, 'Operator twist age (s) after which the operator counts as still (no w '
              'published).', range=(0.001, 10.0)),
    ParamSpec('object_position', (0.3, -0.3, 0.0), 'Object pose until one arrives on object/pose (and whenever '
              'set): position in m1n6s300_link_base, m (as the planner\'s).',
              validator=finite_vector(3, 'x, y, z in m')),
    ParamSpec('object_orientation', (0.0, 0.0, 1.0, 0.0), 'Object orientation: unit quaternion (x, y, z, w).',
              validator=check_unit_quaternion, constraints='unit norm within 1e-3'),
    ParamSpec('object_tolerance', 0.01, 'An object that moves farther (m) restarts the estimate with new goals.',
              range=(0.0, 1.0)),
    ParamSpec('angle_tolerance', 0.05, 'An object that turns farther (rad) restarts the estimate with new goals.',
              range=(0.0, 3.2)),
    ParamSpec('workspace_radius', 1.5, 'Largest distance (m) of an object position from the base origin.',
              range=(0.1, 100.0)),
    ParamSpec('ik_restarts', 2, 'Random IK restarts when a goal is checked for reachability.', range=(0, 100)),
    ParamSpec('operator_message_type', 'TwistStamped', 'Type on operator/twist: TwistStamped or Twist.',
              validator=one_of(('TwistStamped', 'Twist')), read_only=True),
    ParamSpec('operator_frame', BASE_FRAME, 'Frame of a plain Twist or of a TwistStamped with an empty frame_id.',
              validator=one_of((BASE_FRAME, EE_FRAME))),
    ParamSpec('urdf_path', '', "MICO URDF; '' means the package's config/mico_3f.urdf.", read_only=True),
    TASK_NAMES,
)
_CONFIG_FIELDS = tuple(f.name for f in dataclasses.fields(EstimatorConfig))


@dataclass(frozen=True)
class _Scene:
    """What the goals are made of: the model and the object pose (and the joints to seed IK from)."""

    model: ModelDocument | None = None
    base_T_obj: NDArray[np.float64] | None = None
    q_arm: NDArray[np.float64] | None = None


class IntentEstimatorNode(Node):
    """Estimates w from the operator's twist and the hand's pose. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'intent_estimator', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, ESTIMATOR_COMPONENT)
        self._params = declare_parameters(self, PARAMETERS, on_change=self._configure, check=self._check)
        try:
            self._kin = MicoKinematics(self._params['urdf_path'] or None)
        except FileNotFoundError as exc:
            raise ParameterError(f'urdf_path: {exc}') from None
        self._config = EstimatorConfig(**{name: self._params[name] for name in _CONFIG_FIELDS})
        self._estimator: IntentEstimator | None = None
        """The estimate over the current scene's goals; None while they are prepared."""
        self._proposal: NDArray[np.float64] | None = None
        """The latest grasp on ``grasp/pose`` (base frame): what the operator is shown."""
        self._proposal_lock = threading.Lock()
        """Orders a new estimate (the goal thread) and a new proposal (the executor): the newest is used."""
        self._q: NDArray[np.float64] | None = None
        self._base_T_ee: NDArray[np.float64] | None = None
        self._last_twist: float | None = None  # node-clock time of the last operator twist
        self._last_stamp: float | None = None  # its header stamp (s), None when unset
        self._published = self._restarts = 0
        self._pub = output_publisher(self, Float64MultiArray, topics.INTENT_W)
        self._diag.set_state(OK, f'waiting for {topics.MODEL_ACTIVE}')
        base_T_obj = pose_to_matrix(self._params['object_position'], self._params['object_orientation'])
        self._scenes = LatestOnlyWorker(_Scene(base_T_obj=base_T_obj),
                                        self._diag.guard(self._prepare, counts_received=False),
                                        ready=lambda scene: scene.model is not None, name=f'{node_name}_goals')
        self.context.on_shutdown(self._scenes.stop_soon)
        self._models = ModelFollower(self, self._diag, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: served_models(self._params['task_names']))
        plain = self._params['operator_message_type'] == 'Twist'
        subscribe_input(self, topics.OPERATOR_TWIST, self._on_operator, input_qos(depth=10), self._diag,
                        count_dropped=True, msg_type=Twist if plain else None)
        subscribe_input(self, topics.JOINT_STATES, self._on_joint_state, input_qos(), self._diag)
        subscribe_input(self, topics.OBJECT_POSE, self._on_object_pose, input_qos(depth=1), self._diag)
        subscribe_input(self, topics.GRASP_POSE, self._on_grasp, input_qos(depth=1), self._diag)
        self.create_timer(float(self._params['publish_period']), self._on_timer)

    def destroy_node(self) -> None:
        """Stop the model and goal threads (after their current work), then destroy the node."""
        self._models.stop()
        self._scenes.stop()
        super().destroy_node()

    def _check(self, values: Mapping[str, Any]) -> None:
        EstimatorConfig(**{name: values[name] for name in _CONFIG_FIELDS})
        check_workspace(values['object_position'], values['workspace_radius'], what='object_position')

    def _configure(self, changed: Mapping[str, Any]) -> None:
        self._config = EstimatorConfig(**{name: self._params[name] for name in _CONFIG_FIELDS})
        if (estimator := self._estimator) is not None:
            estimator.config = self._config
        if 'task_names' in changed:
            self._models.recheck()
        if {'object_position', 'object_orientation'} & set(changed):
            self._move_object(pose_to_matrix(self._params['object_position'], self._params['object_orientation']))

    # -- the scene: model and object -> goals, in the goal thread --------------------------------------------

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread
        if doc is not None:
            check_mico_model(doc.model, doc.name)
        self._scenes.update(lambda scene: replace(scene, model=doc, q_arm=self._q))
        if doc is None:
            self._estimator = None
            self._diag.set_state(ERROR, f'cannot serve: {self._models.refused}')

    def _on_object_pose(self, msg: PoseStamped) -> None:
        base_T_obj = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
        check_workspace(base_T_obj[:3, 3], self._params['workspace_radius'])
        self._move_object(base_T_obj)

    def _move_object(self, base_T_obj: NDArray[np.float64]) -> None:
        """A new object pose: new goals when it moved beyond the tolerances, else nothing changes."""
        current = self._scenes.latest.base_T_obj
        if current is not None:
            error = pose_error(current, base_T_obj)
            if (float(np.linalg.norm(error[:3])) <= self._params['object_tolerance']
                    and float(np.linalg.norm(error[3:])) <= self._params['angle_tolerance']):
                return
        self._scenes.update(lambda scene: replace(scene, base_T_obj=base_T_obj, q_arm=self._q))

    def _prepare(self, scene: _Scene) -> None:  # in the goal thread
        assert scene.model is not None and scene.base_T_obj is not None
        self._estimator = None  # the old goals no longer hold
        model = scene.model.model
        self._diag.set_state(OK, f'preparing the goals of {scene.model.name} ({model.demo_x.shape[0]} demonstrations)')
        start = time.perf_counter()
        keep = reachable_goals(model, scene.base_T_obj, self._kin, q_seed=scene.q_arm,
                               restarts=int(self._params['ik_restarts']), stopping=lambda: self._scenes.stopping)
        if self._scenes.stopping:
            return
        try:
            goals = goals_at(model, scene.base_T_obj, keep)
        except GraspIntentError as exc:
            self._diag.set_state(ERROR, f'no goal for {scene.model.name} at this object pose: {exc}')
            raise
        estimator = IntentEstimator(goals, self._config)
        with self._proposal_lock:
            estimator.set_proposal(self._proposal)
            self._estimator = estimator
        self._restarts += 1
        self._diag.set_state(OK, '')
        self._diag.set_values({'model': scene.model.name, KEY_GOALS: f'{len(goals)} of {model.demo_x.shape[0]} '
                               'reachable', 'goals prepared in [ms]': f'{1e3 * (time.perf_counter() - start):.0f}',
                               'restarts': self._restarts})
        self._publish(self._estimator)  # the prior: the planner has an intent before the first motion

    # -- the stream: joint states and operator twists, on the executor ---------------------------------------

    def _on_joint_state(self, msg: JointState) -> None:
        if (q := joint_positions(msg, ARM_JOINTS)) is not None:
            self._kin.check_limits(q, margin=JOINT_LIMIT_MARGIN, what='joint state')
            self._q, self._base_T_ee = q, self._kin.fk(q)

    def _on_grasp(self, msg: PoseStamped) -> None:
        pose = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
        with self._proposal_lock:
            if (estimator := self._estimator) is not None:
                estimator.set_proposal(pose)
            self._proposal = pose

    def _on_operator(self, msg: TwistStamped | Twist) -> None:
        twist, frame = (msg, '') if isinstance(msg, Twist) else (msg.twist, msg.header.frame_id)
        cmd = check_twist([twist.linear.x, twist.linear.y, twist.linear.z],
                          [twist.angular.x, twist.angular.y, twist.angular.z], frame,
                          default_frame=self._params['operator_frame'])
        now = self.get_clock().now().nanoseconds * 1e-9
        stamp = None if isinstance(msg, Twist) else msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        stamp = stamp or None  # an unset stamp (0) says nothing
        if stamp is not None and self._last_stamp is not None:
            dt = stamp - self._last_stamp  # the operator's own timing, whatever the delivery's
        else:
            dt = self._config.max_dt if self._last_twist is None else now - self._last_twist
        self._last_twist, self._last_stamp = now, stamp
        estimator, hand = self._estimator, self._base_T_ee
        if estimator is None or hand is None:
            self._diag.note('operator twist not used: ' + ('no joint state yet' if hand is None else 'no goals yet'))
            return
        xi = np.concatenate([cmd.linear, cmd.angular])
        if cmd.frame == EE_FRAME:
            xi = np.concatenate([hand[:3, :3] @ cmd.linear, hand[:3, :3] @ cmd.angular])
        start = time.perf_counter()
        estimator.update(hand, xi, dt)
        self._diag.processed(time.perf_counter() - start)

    def _on_timer(self) -> None:
        try:
            now = self.get_clock().now().nanoseconds * 1e-9
            moving = self._last_twist is not None and now - self._last_twist <= self._params['operator_timeout']
            if moving and (estimator := self._estimator) is not None:
                self._publish(estimator)
            others = self.count_publishers(topics.INTENT_W) - 1
            if others > 0:
                self._diag.set_state(WARN, f'{others} other publisher(s) on {topics.INTENT_W}: the interpreter '
                                     'answers each w in arrival order, so the plan follows whichever spoke last')
            elif self._estimator is not None:
                self._diag.set_state(OK, '')
        except Exception as exc:  # noqa: BLE001 - an exception escaping a timer kills the node
            self._diag.rejected(f'internal error: {type(exc).__name__}: {exc}', level=ERROR)

    def _publish(self, estimator: IntentEstimator) -> None:
        w = estimator.w
        publish_all(self, {topics.INTENT_W: self._pub}, {topics.INTENT_W: Float64MultiArray(data=w.tolist())})
        self._published += 1
        names = self._params['task_names']
        top = sorted(estimator.set_posterior().items(), key=lambda item: -item[1])[:3]
        self._diag.set_values({'w': ', '.join(f'{v:.3f}' for v in w), 'w published': self._published,
                               'updates': estimator.updates,
                               'likely task sets': ', '.join(f'{zone_label(s, names)}: {p:.2f}' for s, p in top)})


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(IntentEstimatorNode, args)
    guard_exit()


if __name__ == '__main__':
    main()
