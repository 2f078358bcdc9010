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

With the ``objects`` parameter (a list of object names, ``suite --object ... --with intent_estimator``) it estimates
over the goals of several objects from the suite's namespace, each object's inputs and ``intent/w`` in the object's
namespace, P(o) on ``intent/objects`` (:mod:`.estimator_scene`, docs/several_objects.md); without,
it serves one object in its own namespace.

Parameters: :data:`grasp_intent_ros.shared_control.parameters.ESTIMATOR`, ``config/intent_estimator.yaml``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from ..mico.kinematics import JOINT_LIMIT_MARGIN, MicoKinematics
from ..mico.mock_arm import TwistCommand
from ..ros.clock import now_seconds
from ..ros.diagnostics import NodeDiagnostics
from ..ros.inputs import subscribe_arm, subscribe_operator
from ..ros.params import declare_parameters
from ..ros.qos import STREAM_DEPTH, input_qos, output_publisher
from ..ros.run import guard_exit, publish_all, run_node
from ..shared_control.estimator import IntentEstimator, TwistTiming
from ..shared_control.parameters import ESTIMATOR, check_estimator, estimator_config
from ..shared_control.stamped_inputs import StampedInputs
from ..wire import topics
from ..wire.diagnostics import ESTIMATOR_COMPONENT, OK, WARN
from ..wire.joint_states import JointReading
from ..wire.robot_state import stamp_nanoseconds, stamp_seconds, twist_command
from .estimator_goals import ObjectGoals
from .estimator_scene import SceneIntent

__all__ = ['IntentEstimatorNode', 'main']


def _check(values: Mapping[str, Any]) -> None:
    """The rules over the parameters: :func:`check_estimator`'s, and the object names a namespace each."""
    check_estimator(values)
    topics.check_object_names(values['objects'])


class IntentEstimatorNode(Node):
    """Estimates w from the operator's twist and the hand's pose. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'intent_estimator', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._diag = NodeDiagnostics(self, ESTIMATOR_COMPONENT)
        self._params = declare_parameters(self, ESTIMATOR, on_change=self._configure, check=_check)
        self._kin = self._params.build('urdf_path', lambda path: MicoKinematics(path or None))
        self._config = estimator_config(self._params, None)  # the settings every object shares (max_dt)
        self._q: NDArray[np.float64] | None = None
        self._inputs: StampedInputs[tuple[TwistCommand, float | None]] = StampedInputs(self._config.max_dt)
        """Operator twists (their command and stamp, s) paired with the hand and the grasps shown at their stamps."""
        self._fresh = False  # a twist was taken since the last w published (one object)
        self._timing = TwistTiming()  # on the node's clock
        self._published = 0
        self._diag.set_state(OK, f'waiting for {topics.MODEL_ACTIVE}')
        subscribe_operator(self, self._on_operator, input_qos(STREAM_DEPTH), self._diag,
                           self._params['operator_message_type'])
        subscribe_arm(self, self._on_arm, input_qos(STREAM_DEPTH), self._diag)
        self._scene: SceneIntent | None = None
        """The estimate over several objects (the ``objects`` parameter), else None: one object, ``_object``."""
        self._object: ObjectGoals | None = None
        self._pub = None
        if self._params['objects']:
            self._scene = SceneIntent(self, self._diag, self._params, self._kin, self._inputs, arm=lambda: self._q,
                                      names=self._params['objects'])
        else:
            self._object = ObjectGoals(self, self._diag, self._params, self._kin, self._inputs, arm=lambda: self._q,
                                       ready=self._ready, refresh=self._refresh, report=self._diag.set_state)
            self._pub = output_publisher(self, Float64MultiArray, topics.INTENT_W)
        self.create_timer(float(self._params['publish_period']), self._diag.guard_timer(self._on_timer))

    @property
    def _estimator(self) -> IntentEstimator | None:
        """The one object's estimate; None while its goals are prepared (or with several objects)."""
        return None if self._object is None else self._object.estimator

    @property
    def _served_scene(self) -> SceneIntent:
        assert self._scene is not None  # with no one object
        return self._scene

    def destroy_node(self) -> None:
        """Stop the model and goal threads (their current work waited for at most FINISH_WAIT s), then destroy."""
        (self._object or self._served_scene).stop()
        super().destroy_node()

    def _configure(self, changed: Mapping[str, Any]) -> None:
        self._config = estimator_config(self._params, None)
        self._inputs.wait = self._config.max_dt
        (self._object or self._served_scene).configure(changed)

    def _ready(self, estimator: IntentEstimator | None) -> None:  # in the goal thread
        if estimator is not None:
            self._publish(estimator)  # the prior: the planner has an intent before the first motion

    def _refresh(self) -> None:
        self._fresh = True

    # -- the stream: joint states and operator twists, on the executor ---------------------------------------

    def _on_arm(self, arm: JointReading) -> None:
        self._kin.check_limits(arm.positions, margin=JOINT_LIMIT_MARGIN, what='joint state')
        self._q = arm.positions
        self._inputs.hand(arm.stamp_ns, self._kin.fk(arm.positions))
        self._take_twists()

    def _on_operator(self, msg: Any) -> None:
        cmd = twist_command(msg, default_frame=self._params['operator_frame'])
        self._inputs.twist(stamp_nanoseconds(msg), now_seconds(self), (cmd, stamp_seconds(msg)))
        self._take_twists()

    def _take_twists(self) -> None:
        """Update the estimate with every twist whose hand is known (:mod:`~.shared_control.stamped_inputs`)."""
        for paired in self._inputs.due(now_seconds(self)):
            (cmd, stamp), hand = paired.command, paired.hand
            dt = self._timing.duration(stamp, paired.arrival, self._config.max_dt)
            if hand is None:
                self._diag.note('operator twist not used: no joint state yet')
                continue
            start = time.perf_counter()
            if self._scene is not None:
                if not self._scene.take(hand, cmd.in_base(hand), dt, paired.proposals):
                    self._diag.note('operator twist not used: no goals yet')
                    continue
            elif (estimator := self._estimator) is None:
                self._diag.note('operator twist not used: no goals yet')
                continue
            else:
                assert self._object is not None
                self._object.show(estimator, paired.proposal)
                estimator.update(hand, cmd.in_base(hand), dt)
                self._fresh = True
            self._diag.processed(time.perf_counter() - start)

    def _on_timer(self) -> None:
        self._take_twists()  # a twist whose joint state is late waits at most max_dt
        now = now_seconds(self)
        last = self._timing.arrival
        moving = last is not None and now - last <= self._params['operator_timeout']
        if self._scene is not None:
            if moving or self._scene.fresh:
                self._scene.publish()
            self._scene.check_publishers()
            return
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
        assert self._pub is not None
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
