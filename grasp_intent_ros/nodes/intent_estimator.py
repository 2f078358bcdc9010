"""Intent estimator node: the operator's reach -> task probabilities w on ``intent/w`` (docs/intent_estimation.md).

Run: ``python -m grasp_intent_ros intent_estimator [--ros-args --params-file config/intent_estimator.yaml]``
(in the suite: ``python -m grasp_intent_ros suite --shared-control --with intent_estimator``)

Topics, diagnostics, restarts and timing: docs/intent_estimation.md (its interface table is this node's contract);
the maths: :mod:`grasp_intent_ros.shared_control.estimator`. Each operator twist (before blending) updates the
estimate on the executor, and each grasp on ``grasp/pose`` is the grasp shown. Task probabilities from another
source on ``intent/prior`` (e.g. per-task classifiers) become the estimate's prior, kept across restarts, and the
posterior goes out at the next tick. ``intent/w`` goes out every ``publish_period`` while the operator moves, and
once at each restart (the prior). The goals are prepared in a
thread of their own whenever the model changes or the object moves beyond the tolerances; meanwhile no w is
published and twists are not used.

Parameters: :data:`grasp_intent_ros.shared_control.parameters.ESTIMATOR`, ``config/intent_estimator.yaml``.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..errors import GraspIntentError, InvalidIntentError
from ..method.intent import MAX_TASKS
from ..mico.grasp import check_mico_model
from ..mico.kinematics import BASE_FRAME, JOINT_LIMIT_MARGIN, MicoKinematics
from ..mico.mock_arm import TwistCommand
from ..mico.parameters import object_pose
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_arm, subscribe_input, subscribe_operator
from ..ros.model_follower import ModelFollower, served_models
from ..ros.params import declare_parameters
from ..ros.qos import STREAM_DEPTH, input_qos, output_publisher
from ..ros.run import guard_exit, publish_all, run_node
from ..ros.worker import LatestOnlyWorker
from ..shared_control.assistance import offset
from ..shared_control.estimator import IntentEstimator, TwistTiming
from ..shared_control.goals import goals_at, reachable_goals
from ..shared_control.parameters import ESTIMATOR, check_estimator, estimator_config
from ..shared_control.stamped_inputs import StampedInputs
from ..shared_control.task_prior import check_task_prior
from ..wire import topics
from ..wire.arrays import msg_to_array
from ..wire.diagnostics import ERROR, ESTIMATOR_COMPONENT, KEY_GOALS, OK, WARN
from ..wire.joint_states import JointReading
from ..wire.model_document import ModelDocument
from ..wire.robot_state import (
    object_pose_msg,
    pose_msg_to_matrix,
    stamp_nanoseconds,
    stamp_seconds,
    twist_command,
)

__all__ = ['IntentEstimatorNode', 'main']


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
        self._params = declare_parameters(self, ESTIMATOR, on_change=self._configure, check=check_estimator)
        self._kin = self._params.build('urdf_path', lambda path: MicoKinematics(path or None))
        self._config = estimator_config(self._params, None)
        self._estimator: IntentEstimator | None = None
        """The estimate over the current scene's goals; None while they are prepared."""
        self._proposal: NDArray[np.float64] | None = None  # the newest grasp/pose (base frame): the grasp shown
        self._task_prior: NDArray[np.float64] | None = None  # the newest intent/prior, for every estimator
        self._prior_lock = threading.Lock()  # the prior and the estimator it was set on, one at a time
        self._q: NDArray[np.float64] | None = None
        self._inputs: StampedInputs[tuple[TwistCommand, float | None]] = StampedInputs(self._config.max_dt)
        """Operator twists (their command and stamp, s) paired with the hand and the grasp shown at their stamps."""
        self._shown: NDArray[np.float64] | None = None  # the proposal the estimator holds
        self._fresh = False  # a twist was taken since the last w published
        self._timing = TwistTiming()  # on the node's clock
        self._published = self._restarts = 0
        self._pub = output_publisher(self, Float64MultiArray, topics.INTENT_W)
        self._diag.set_state(OK, f'waiting for {topics.MODEL_ACTIVE}')
        self._scenes = LatestOnlyWorker(_Scene(base_T_obj=object_pose(self._params)),
                                        self._diag.guard(self._prepare, counts_received=False),
                                        ready=lambda scene: scene.model is not None, name=f'{node_name}_goals')
        self.context.on_shutdown(self._scenes.stop_soon)
        self._models = ModelFollower(self, self._diag, self._use_model, name=f'{node_name}_model',
                                     requires=lambda: served_models(self._params['task_names']))
        subscribe_operator(self, self._on_operator, input_qos(STREAM_DEPTH), self._diag,
                           self._params['operator_message_type'])
        subscribe_arm(self, self._on_arm, input_qos(STREAM_DEPTH), self._diag)
        subscribe_input(self, topics.OBJECT_POSE, self._on_object_pose, input_qos(depth=1), self._diag)
        subscribe_input(self, topics.GRASP_POSE, self._on_grasp, input_qos(), self._diag)
        subscribe_input(self, topics.INTENT_PRIOR, self._on_prior, input_qos(), self._diag)
        self.create_timer(float(self._params['publish_period']), self._diag.guard_timer(self._on_timer))

    def destroy_node(self) -> None:
        """Stop the model and goal threads (their current work waited for at most FINISH_WAIT s), then destroy."""
        self._models.stop()
        self._scenes.stop()
        super().destroy_node()

    def _configure(self, changed: Mapping[str, Any]) -> None:
        model = self._scenes.latest.model
        self._config = estimator_config(self._params, None if model is None else model.name)
        self._inputs.wait = self._config.max_dt
        if (estimator := self._estimator) is not None:
            estimator.config = self._config
        if 'task_names' in changed:
            self._models.recheck()
        if {'object_position', 'object_orientation'} & set(changed):
            self._move_object(object_pose(self._params))

    # -- the scene: model and object -> goals, in the goal thread --------------------------------------------

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread
        if doc is not None:
            check_mico_model(doc.model, doc.name)
        self._scenes.update(lambda scene: replace(scene, model=doc, q_arm=self._q))
        if doc is None:
            self._estimator = None
            self._diag.set_state(ERROR, f'cannot serve: {self._models.refused}')

    def _on_object_pose(self, msg: PoseStamped) -> None:
        self._move_object(object_pose_msg(msg, self._params['workspace_radius']))

    def _move_object(self, base_T_obj: NDArray[np.float64]) -> None:
        """A new object pose: new goals when it moved beyond the tolerances, else nothing changes."""
        current = self._scenes.latest.base_T_obj
        if current is not None:
            distance, angle = offset(current, base_T_obj)
            if distance <= self._params['object_tolerance'] and angle <= self._params['angle_tolerance']:
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
        self._shown = self._proposal
        self._config = config = estimator_config(self._params, scene.model.name)  # its calibration map
        estimator = IntentEstimator(goals, config, proposal=self._proposal)
        with self._prior_lock:
            prior = self._task_prior
            if prior is not None and prior.size == goals.n_tasks:
                estimator.set_task_prior(prior)
            self._estimator = estimator
        self._restarts += 1
        self._diag.set_state(OK, '')
        self._show_prior(estimator)
        self._diag.set_values({'model': scene.model.name, KEY_GOALS: f'{len(goals)} of {model.demo_x.shape[0]} '
                               'reachable', 'goals prepared in [ms]': f'{1e3 * (time.perf_counter() - start):.0f}',
                               'calibration (a, b)': f'{config.calibration_slope:g}, {config.calibration_offset:g}',
                               'restarts': self._restarts})
        self._publish(estimator)  # the prior: the planner has an intent before the first motion

    # -- the stream: joint states and operator twists, on the executor ---------------------------------------

    def _on_arm(self, arm: JointReading) -> None:
        self._kin.check_limits(arm.positions, margin=JOINT_LIMIT_MARGIN, what='joint state')
        self._q = arm.positions
        self._inputs.hand(arm.stamp_ns, self._kin.fk(arm.positions))
        self._take_twists()

    def _on_grasp(self, msg: PoseStamped) -> None:
        self._proposal = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
        self._inputs.proposal(stamp_nanoseconds(msg), self._proposal)

    def _on_prior(self, msg: Float64MultiArray) -> None:
        w = check_task_prior(msg_to_array(msg, max_size=MAX_TASKS, error=InvalidIntentError, what='task prior'))
        with self._prior_lock:
            if (estimator := self._estimator) is not None:
                estimator.set_task_prior(w)  # its length checked against the model's tasks: kept only if it fits
            self._task_prior = w
        self._fresh = True  # the posterior on the new prior goes out at the next tick
        if estimator is not None:
            self._show_prior(estimator)

    def _show_prior(self, estimator: IntentEstimator) -> None:
        used = estimator.task_prior  # None also when intent/prior's length is not this model's number of tasks
        self._diag.set_values({'task prior in use (intent/prior)': 'none (uniform over the served task sets)'
                               if used is None else ', '.join(f'{v:.3f}' for v in used)})

    def _on_operator(self, msg: Any) -> None:
        cmd = twist_command(msg, default_frame=self._params['operator_frame'])
        self._inputs.twist(stamp_nanoseconds(msg), self._now(), (cmd, stamp_seconds(msg)))
        self._take_twists()

    def _now(self) -> float:
        return float(self.get_clock().now().nanoseconds * 1e-9)

    def _take_twists(self) -> None:
        """Update the estimate with every twist whose hand is known (:mod:`~.shared_control.stamped_inputs`)."""
        for paired in self._inputs.due(self._now()):
            (cmd, stamp), hand = paired.command, paired.hand
            dt = self._timing.duration(stamp, paired.arrival, self._config.max_dt)
            estimator = self._estimator
            if estimator is None or hand is None:
                self._diag.note(f'operator twist not used: no {"joint state" if hand is None else "goals"} yet')
                continue
            start = time.perf_counter()
            if paired.proposal is not self._shown:
                estimator.set_proposal(paired.proposal)
                self._shown = paired.proposal
            estimator.update(hand, cmd.in_base(hand), dt)
            self._fresh = True
            self._diag.processed(time.perf_counter() - start)

    def _on_timer(self) -> None:
        self._take_twists()  # a twist whose joint state is late waits at most max_dt
        now = self._now()
        last = self._timing.arrival
        moving = last is not None and now - last <= self._params['operator_timeout']
        if (moving or self._fresh) and (estimator := self._estimator) is not None:
            self._publish(estimator)
        others = self.count_publishers(topics.INTENT_W) - 1
        if others > 0:
            self._diag.set_state(WARN, f'{others} other publisher(s) on {topics.INTENT_W}: the interpreter '
                                 'answers each w in arrival order, so the plan follows whichever spoke last')
        elif self._estimator is not None:
            self._diag.set_state(OK, '')

    def _publish(self, estimator: IntentEstimator) -> None:
        w = estimator.w
        self._fresh = False
        publish_all(self, {topics.INTENT_W: self._pub}, {topics.INTENT_W: Float64MultiArray(data=w.tolist())})
        self._published += 1
        self._diag.set_values({'w': ', '.join(f'{v:.3f}' for v in w), 'w published': self._published,
                               'updates': estimator.updates,
                               'likely task sets': estimator.likely_sets(self._params['task_names'])})


def main(args: list[str] | None = None) -> None:
    """Entry point: run the node until SIGINT/SIGTERM."""
    run_node(IntentEstimatorNode, args)
    guard_exit()


if __name__ == '__main__':
    main()
