"""The ROS-free simulator and the real nodes agree: one operator, one seed, the same hand's path and outcome.

The simulator (:func:`grasp_intent_ros.shared_control.simulator.simulate`) drives the nodes' core functions
on a simulated clock. Here the assistance node and the mock arm node (with the suite's arguments) run
in-process on their wall-clock timers, fed the plan the simulator showed (the planner node's messages of
that grasp, the model on ``model/active``), and the same scripted operator (device, constants, seed) drives
them, ticking on each ``joint_states`` and seeing the hand ``reaction`` s late, as in the simulator.

Tolerances, and why. The node loop differs from the simulated one by the wall clock only: an operator twist
answered up to one period later, the assistance reading the previous tick's joints when the operator's twist
comes first, and on a loaded machine fewer, longer ticks (one executor runs both nodes and the operator, so
the loop falls below 100 Hz; the operator's reaction stays in seconds). So *when* the hand gets somewhere is
not compared (on a loaded machine the node loop closes later), but *where* it goes is: every hand the node
loop's operator saw lies within :data:`PATH_TOL` of the simulated path and every simulated one
within :data:`PATH_TOL` of the node loop's (a curve's drift of a few ticks at the operator's 0.12 m/s is
millimetres); both close the hand on the same goal (the shown grasp), at poses within :data:`CLOSE_POS` /
:data:`CLOSE_ROT` of each other (each is within the 1 cm / 0.1 rad reach threshold of that goal).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import TwistStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from grasp_intent_ros.launch.suite import NodeSuite
from grasp_intent_ros.method.intent import all_zones, default_task_names, interpret, zone_labels
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import offset, pose_to_matrix
from grasp_intent_ros.mico.grasp import Grasp
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, MicoKinematics
from grasp_intent_ros.nodes.assistance import AssistanceNode
from grasp_intent_ros.nodes.mock_arm import MockArmNode
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.ros.conversions import array_to_msg
from grasp_intent_ros.ros.grasp_messages import grasp_messages
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.shared_control.arbitration import grasp_task_set
from grasp_intent_ros.shared_control.operators import OperatorConstants, PersistentIntent, ScriptedOperator
from grasp_intent_ros.shared_control.simulator import Scene, certain_grasps, simulate
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.model_document import model_document, read_model_document
from grasp_intent_ros.wire.robot_state import joint_positions

BASE_T_OBJ = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))
W = (0.9, 0.9, 0.1)
TRUE_SET = 0b011  # usage and transfer: the paper's case, the grasp shown serves it and lies on the way
SEED = 4
TIMEOUT = 15.0
PATH_TOL = 0.02
"""m: the largest distance of a hand on one path from the other path."""
CLOSE_POS, CLOSE_ROT = 0.02, 0.2
"""m, rad: the two closing poses (each within the reach threshold of the same goal)."""


class Recorder(ScriptedOperator):
    """A scripted operator that keeps (t, the hand it saw) at every twist."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.seen: list[tuple[float, np.ndarray]] = []

    def twist(self, now: float, hand: np.ndarray | None, goal: np.ndarray) -> np.ndarray:
        if hand is not None:
            self.seen.append((now, hand[:3, 3].copy()))
        return super().twist(now, hand, goal)


def operator() -> Recorder:
    return Recorder('spacemouse', OperatorConstants(), np.random.default_rng(SEED))


@pytest.fixture(scope='module')
def setup() -> dict[str, Any]:
    kin = MicoKinematics()
    models = ModelFiles(config_dir() / 'models')
    model = models.load('cup_7zone')
    own = {s: (g.base_T_ee, g.positions[6:]) for s, g in certain_grasps(model, BASE_T_OBJ, kin).items()}
    return {'kin': kin, 'model': model, 'own': own}


@pytest.mark.wall_clock
def test_the_simulator_and_the_nodes_agree_on_the_hands_path_and_outcome(ros: Any, setup: dict[str, Any]) -> None:
    kin, model, own = setup['kin'], setup['model'], setup['own']
    intent = PersistentIntent(W, TRUE_SET, noise=0.0)  # no estimator noise: one plan, shown throughout
    cache: dict[bytes, Grasp | None] = {}
    simulated = operator()
    episode = simulate(Scene(model, BASE_T_OBJ, BASE_T_OBJ, kin), 'suite', intent, simulated, own,
                       np.random.default_rng(0), np.random.default_rng(0), ada_goals=[], plan_cache=cache,
                       timeout=TIMEOUT)
    plans = {g.base_T_ee.tobytes(): g for g in cache.values() if g is not None}
    assert episode.closed_at is not None and episode.pursued == 'shown' and len(plans) == 1
    (grasp,) = plans.values()

    # the nodes, fed the plan the simulator showed, as the planner node publishes it
    assistance = ros.add(AssistanceNode(context=ros.context))
    ros.add(MockArmNode(context=ros.context, cli_args=['--ros-args', *NodeSuite.node_args('mock_arm')]))
    text = model_document(model, name='cup_7zone', version=1)
    ros.publisher(String, topics.MODEL_ACTIVE, latched_qos()).publish(String(data=text))
    stamp = ros.node.get_clock().now().to_msg()
    messages = grasp_messages(grasp, read_model_document(text), BASE_T_OBJ, stamp=stamp, object_size=(0.08, 0.1),
                              markers=False)
    v = interpret(np.asarray(W)).v
    messages[topics.INTENT_V] = array_to_msg(v, [zone_labels(all_zones(3), default_task_names(3))])
    pubs = {topic: ros.publisher(type(msg), topic) for topic, msg in messages.items()}
    assist = assistance._assist
    task_set = grasp_task_set(grasp.result.x, model.demo_x, model.demo_sets, model.feature_scale)
    ready = lambda: (assist.base_T_ee is not None and assist._task_set == task_set  # noqa: E731
                     and assist.alpha()[1] != 'no intent')

    def publish_plan() -> None:
        for topic, msg in messages.items():
            pubs[topic].publish(msg)

    assert ros.wait_for(lambda: (publish_plan(), ready())[1], 30.0), 'the assistance has no plan'

    # the operator: one tick per joint_states, the hand seen `reaction` s late, from the first tick on
    live = operator()
    operator_pub = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)
    hands: list[tuple[float, np.ndarray]] = []  # (s from the first tick, the hand's pose)
    result: dict[str, Any] = {}

    def tick(msg: JointState) -> None:
        if result:
            return
        q = joint_positions(msg, ARM_JOINTS)
        assert q is not None
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        now = t - (hands[0][0] if hands else t)
        hands.append((t, kin.fk(q)))
        seen = next(h for s, h in reversed(hands) if s - hands[0][0] <= now - live.c.reaction) \
            if now >= live.c.reaction else hands[0][1]
        goal, pursued = live.choose_goal(grasp.base_T_ee, own[intent.task_set(now)][0])
        if live.at_goal(seen, goal):
            result.update(closed_at=now, pursued=pursued, hand=hands[-1][1])
            return
        out = TwistStamped()
        out.header.frame_id = BASE_FRAME
        (out.twist.linear.x, out.twist.linear.y, out.twist.linear.z,
         out.twist.angular.x, out.twist.angular.y, out.twist.angular.z) = live.twist(now, seen, goal).tolist()
        operator_pub.publish(out)

    ros.node.create_subscription(JointState, topics.JOINT_STATES, tick, 10)
    assert ros.wait_for(lambda: result or (hands and hands[-1][0] - hands[0][0] > TIMEOUT), 4 * TIMEOUT), \
        'the node loop stalled'
    assert result, f'the nodes did not close within {TIMEOUT} s (the simulator closed at {episode.closed_at} s)'

    sim_path = np.array([p for _, p in simulated.seen])
    node_path = np.array([p for _, p in live.seen])
    apart = np.linalg.norm(node_path[:, None, :] - sim_path[None, :, :], axis=2)
    print(f'closed: nodes {result["closed_at"]:.2f} s ({len(node_path)} operator ticks), simulator '
          f'{episode.closed_at:.2f} s; paths apart (node from simulated, simulated from node) '
          f'{1e3 * apart.min(axis=1).max():.1f} / {1e3 * apart.min(axis=0).max():.1f} mm')
    assert apart.min(axis=1).max() <= PATH_TOL and apart.min(axis=0).max() <= PATH_TOL
    assert result['pursued'] == episode.pursued
    assert episode.hand is not None
    distance, angle = offset(result['hand'], episode.hand)
    assert distance <= CLOSE_POS and angle <= CLOSE_ROT, (distance, angle)
