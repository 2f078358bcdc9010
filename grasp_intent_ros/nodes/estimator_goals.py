"""One object's goals for the intent estimator node: its model and pose followed, its estimator made off the executor.

A part of :mod:`.intent_estimator` (rules: docs/intent_estimation.md, "Restarts"). :class:`ObjectGoals` follows an
object's ``model/active`` (:class:`~grasp_intent_ros.ros.model_follower.ModelFollower`) and ``object/pose``; when the
model changes or the object moves beyond ``object_tolerance`` or ``angle_tolerance`` it prepares the object's goals
(its reachable demonstrations at its pose) in a thread of its own, then hands the node a new
:class:`~grasp_intent_ros.shared_control.estimator.IntentEstimator`, starting from the prior. It also reads the
object's ``grasp/pose`` (the grasp shown) and ``intent/prior`` (kept across restarts). One per object, in its
namespace (``cup/...``, diagnostics values named ``<object>: <key>``); the one-object node's in its own.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..errors import GraspIntentError, InvalidIntentError
from ..method.intent import MAX_TASKS
from ..mico.frames import offset
from ..mico.grasp import check_mico_model
from ..mico.kinematics import BASE_FRAME, MicoKinematics
from ..mico.parameters import object_pose
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_input
from ..ros.model_follower import ModelFollower, served_models
from ..ros.qos import input_qos
from ..ros.worker import LatestOnlyWorker
from ..shared_control.estimator import IntentEstimator
from ..shared_control.goals import goals_at, reachable_goals
from ..shared_control.parameters import estimator_config
from ..shared_control.stamped_inputs import StampedInputs
from ..shared_control.task_prior import check_task_prior
from ..wire.arrays import msg_to_array
from ..wire.diagnostics import ERROR, KEY_GOALS, OK
from ..wire.model_document import ModelDocument
from ..wire.robot_state import object_pose_msg, pose_msg_to_matrix, stamp_nanoseconds
from ..wire.topics import GRASP_POSE, INTENT_PRIOR, OBJECT_POSE

__all__ = ['ObjectGoals']


@dataclass(frozen=True)
class _Scene:
    """What the goals are made of: the model and the object pose (and the joints to seed IK from)."""

    model: ModelDocument | None = None
    base_T_obj: NDArray[np.float64] | None = None
    q_arm: NDArray[np.float64] | None = None


class ObjectGoals:
    """One object's estimator, renewed on a new model or pose (module docstring).

    ``node``, ``diagnostics`` and ``params`` are the node's (its ``ESTIMATOR`` values, read when used), ``kin`` its
    kinematics, ``inputs`` its stamped inputs (the object's ``grasp/pose`` goes into stream ``namespace``). ``arm()``
    gives the arm's newest joints (or None) to seed IK. From the goal thread, ``ready(estimator)`` hands over a new
    estimator, or None when the object's goals are dropped (being prepared again, or no model served);
    ``refresh()`` says the estimate changed without motion (a new ``intent/prior``); ``report(level, message)`` is
    the object's standing condition (the node's state, for one object). ``namespace``: '' for the node's own
    topics, else the object's relative namespace (``'cup'``).
    """

    def __init__(self, node: Node, diagnostics: NodeDiagnostics, params: Mapping[str, Any], kin: MicoKinematics,
                 inputs: StampedInputs[Any], *, arm: Callable[[], NDArray[np.float64] | None],
                 ready: Callable[[IntentEstimator | None], object], refresh: Callable[[], object],
                 report: Callable[[int, str], object], namespace: str = '') -> None:
        self._diag, self._params, self._kin, self._inputs = diagnostics, params, kin, inputs
        self._arm, self._ready, self._refresh, self._report = arm, ready, refresh, report
        self.namespace = namespace
        self._prefix = f'{namespace}: ' if namespace else ''
        self.estimator: IntentEstimator | None = None
        """The estimate over the object's current goals; None while they are prepared or no model is served."""
        self.restarts = 0  # estimators made (the first one included)
        self.proposal: NDArray[np.float64] | None = None  # the newest grasp/pose (base frame): the grasp shown
        self.shown: NDArray[np.float64] | None = None  # the proposal the estimator holds (show)
        self._task_prior: NDArray[np.float64] | None = None  # the newest intent/prior, for every estimator
        self._prior_lock = threading.Lock()  # the prior and the estimator it was set on, one at a time
        thread = node.get_name() + (f'_{namespace}' if namespace else '')
        self._scenes = LatestOnlyWorker(_Scene(base_T_obj=object_pose(params)),
                                        diagnostics.guard(self._prepare, counts_received=False),
                                        ready=lambda scene: scene.model is not None, name=f'{thread}_goals')
        node.context.on_shutdown(self._scenes.stop_soon)
        self.models = ModelFollower(node, diagnostics, self._use_model, name=f'{thread}_model', namespace=namespace,
                                    requires=lambda: served_models(params['task_names']))
        subscribe_input(node, OBJECT_POSE, self._on_object_pose, input_qos(depth=1), diagnostics, namespace=namespace)
        subscribe_input(node, GRASP_POSE, self._on_grasp, input_qos(), diagnostics, namespace=namespace)
        subscribe_input(node, INTENT_PRIOR, self._on_prior, input_qos(), diagnostics, namespace=namespace)

    @property
    def base_T_obj(self) -> NDArray[np.float64] | None:
        """The object pose of the newest goals asked for."""
        return self._scenes.latest.base_T_obj

    def stop(self) -> None:
        """Stop the model and goal threads (their current work waited for at most FINISH_WAIT s)."""
        self.models.stop()
        self._scenes.stop()

    def configure(self, changed: Mapping[str, Any]) -> None:
        """The node's parameters changed (accepted, ``changed`` by name): settings, the models served, the pose.

        A new ``object_position`` or ``object_orientation`` moves the object there (:meth:`move`).
        """
        model = self._scenes.latest.model
        if (estimator := self.estimator) is not None:
            estimator.config = estimator_config(self._params, None if model is None else model.name)
        if 'task_names' in changed:
            self.models.recheck()
        if {'object_position', 'object_orientation'} & set(changed):
            self.move(object_pose(self._params))

    def _use_model(self, doc: ModelDocument | None) -> None:  # in the model follower's thread
        if doc is not None:
            check_mico_model(doc.model, doc.name)
        self._scenes.update(lambda scene: replace(scene, model=doc, q_arm=self._arm()))
        if doc is None:
            self.estimator = None
            self._ready(None)
            self._report(ERROR, f'cannot serve: {self.models.refused}')

    def _on_object_pose(self, msg: PoseStamped) -> None:
        self.move(object_pose_msg(msg, self._params['workspace_radius']))

    def move(self, base_T_obj: NDArray[np.float64]) -> None:
        """A new object pose: new goals when it moved beyond the tolerances, else nothing changes."""
        current = self._scenes.latest.base_T_obj
        if current is not None:
            distance, angle = offset(current, base_T_obj)
            if distance <= self._params['object_tolerance'] and angle <= self._params['angle_tolerance']:
                return
        self._scenes.update(lambda scene: replace(scene, base_T_obj=base_T_obj, q_arm=self._arm()))

    def _prepare(self, scene: _Scene) -> None:  # in the goal thread
        assert scene.model is not None and scene.base_T_obj is not None
        self.estimator = None  # the old goals no longer hold
        self._ready(None)
        model = scene.model.model
        self._report(OK, f'preparing the goals of {scene.model.name} ({model.demo_x.shape[0]} demonstrations)')
        start = time.perf_counter()
        keep = reachable_goals(model, scene.base_T_obj, self._kin, q_seed=scene.q_arm,
                               restarts=int(self._params['ik_restarts']), stopping=lambda: self._scenes.stopping)
        if self._scenes.stopping:
            return
        try:
            goals = goals_at(model, scene.base_T_obj, keep)
        except GraspIntentError as exc:
            self._report(ERROR, f'no goal for {scene.model.name} at this object pose: {exc}')
            raise
        self.shown = self.proposal
        config = estimator_config(self._params, scene.model.name)  # its calibration map
        estimator = IntentEstimator(goals, config, proposal=self.proposal)
        with self._prior_lock:
            prior = self._task_prior
            if prior is not None and prior.size == goals.n_tasks:
                estimator.set_task_prior(prior)
            self.estimator = estimator
        self.restarts += 1
        self._report(OK, '')
        self._show_prior(estimator)
        prefix = self._prefix
        self._diag.set_values({f'{prefix}model': scene.model.name,
                               f'{prefix}{KEY_GOALS}': f'{len(goals)} of {model.demo_x.shape[0]} reachable',
                               f'{prefix}goals prepared in [ms]': f'{1e3 * (time.perf_counter() - start):.0f}',
                               f'{prefix}calibration (a, b)': f'{config.calibration_slope:g}, '
                               f'{config.calibration_offset:g}', f'{prefix}restarts': self.restarts})
        self._ready(estimator)  # the node publishes the prior: the planner has an intent before the first motion

    def _on_grasp(self, msg: PoseStamped) -> None:
        self.proposal = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)
        self._inputs.proposal(stamp_nanoseconds(msg), self.proposal, stream=self.namespace)

    def show(self, estimator: IntentEstimator, proposal: NDArray[np.float64] | None) -> None:
        """Give ``estimator`` (this object's) the grasp shown at a twist's stamp, if it is not the one it holds."""
        if proposal is not self.shown:
            estimator.set_proposal(proposal)
            self.shown = proposal

    def _on_prior(self, msg: Float64MultiArray) -> None:
        w = check_task_prior(msg_to_array(msg, max_size=MAX_TASKS, error=InvalidIntentError, what='task prior'))
        with self._prior_lock:
            if (estimator := self.estimator) is not None:
                estimator.set_task_prior(w)  # its length checked against the model's tasks: kept only if it fits
            self._task_prior = w
        self._refresh()  # the posterior on the new prior goes out at the next tick
        if estimator is not None:
            self._show_prior(estimator)

    def _show_prior(self, estimator: IntentEstimator) -> None:
        used = estimator.task_prior  # None also when intent/prior's length is not this model's number of tasks
        self._diag.set_values({f'{self._prefix}task prior in use (intent/prior)': 'none (uniform over the served '
                               'task sets)' if used is None else ', '.join(f'{v:.3f}' for v in used)})
