"""The closed loop with the intent estimator as the only source of w, as real processes over loopback.

The test side is the operator: it steers the hand toward a usage-only demonstration of the cup (a twist
proportional to the pose error, read from the joint states) and never publishes ``intent/w``. The
demonstration is the reachable one farthest in pose from every other task set's: the motion can only tell
apart goals that differ in pose (docs/intent_estimation.md), and at a usage goal with handover goals a few
millimetres off, the w the hand ends with depends on the path of its last decimetre, which the assistance's
pull toward the shown grasp changes with the planner's choice. The estimator
must publish the prior, so that the suite plans, then raise w_usage as the hand heads for the usage grasp. Before
the reach, a classifier that doubts usage speaks on ``intent/prior``: w must follow it at once, and the motion must
still win over it.
Nothing sleeps: every wait polls with a deadline.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, TwistStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import features_to_obj_T_ee, pose_error, pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.estimator import EstimatorConfig
from grasp_intent_ros.shared_control.limits import clip_norm
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.robot_state import joint_positions

STARTUP = 90.0
"""Seconds for six processes to start, discover each other, prepare the goals and plan on a loaded machine."""
REACH = 30.0
"""Seconds for w_usage to rise while the operator heads for the usage grasp (about 0.4 m at 0.1 m/s)."""
PRIOR = 4 / 7


def test_the_estimator_alone_drives_intent_w_from_the_operators_reach(ros: Any, launch: Any) -> None:
    kin = MicoKinematics()
    model = ModelFiles(config_dir() / 'models').load('cup_7zone')
    base_T_obj = pose_to_matrix((0.3, -0.3, 0.0), (0.0, 0.0, 1.0, 0.0))  # the planner's and estimator's default
    poses = [base_T_obj @ features_to_obj_T_ee(x) for x in model.demo_x]
    rho = EstimatorConfig().rotation_length

    def separation(n: int) -> float:  # pose distance (m) to the nearest demonstration of another task set
        return min(float(np.linalg.norm(e[:3]) + rho * np.linalg.norm(e[3:]))
                   for e in (pose_error(poses[n], poses[m]) for m in range(len(poses))
                             if model.demo_sets[m] != model.demo_sets[n]))

    usage = sorted((n for n, s in enumerate(model.demo_sets) if s == 1), key=separation, reverse=True)
    goal = next(poses[n] for n in usage if kin.ik(poses[n], HOME_Q, restarts=2).success)
    # subscribed before the nodes start: the estimator's prior w goes out once, when its goals are ready, which
    # can come before a subscription made after the start has matched
    ws = ros.subscribe(Float64MultiArray, topics.INTENT_W)
    grasps = ros.subscribe(PoseStamped, topics.GRASP_POSE)
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    operator = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)
    launch.start_nodes(model='cup_7zone', shared_control=True, extra=('intent_estimator',))

    def steer() -> None:
        msg = TwistStamped()
        msg.header.frame_id = BASE_FRAME
        if states and (q := joint_positions(states[-1], ARM_JOINTS)) is not None:
            error = pose_error(kin.fk(q), goal)
            t = msg.twist
            t.linear.x, t.linear.y, t.linear.z = clip_norm(1.5 * error[:3], 0.1).tolist()
            t.angular.x, t.angular.y, t.angular.z = clip_norm(1.5 * error[3:], 0.5).tolist()
        operator.publish(msg)

    assert ros.wait_for(lambda: ws and states, STARTUP), launch.died() or 'no prior w or joint state'
    np.testing.assert_allclose(ws[0].data, [PRIOR] * 3, rtol=1e-9)
    classifier = ros.publisher(Float64MultiArray, topics.INTENT_PRIOR)
    assert ros.publish_until(classifier, Float64MultiArray(data=[0.1, 0.9, 0.9]), lambda: ws[-1].data[0] < 0.2,
                             STARTUP), launch.died() or f'w stayed at {list(ws[-1].data)} after the classifier\'s w'
    ros.node.create_timer(0.01, steer)  # spun whenever the test waits
    assert ros.wait_for(lambda: grasps, STARTUP), launch.died() or 'no grasp planned from the estimated w'
    assert ros.wait_for(lambda: ws[-1].data[0] > 0.8, REACH), \
        launch.died() or f'w stayed at {list(ws[-1].data)} while the operator headed for a usage grasp'
    assert all(0.0 < v < 1.0 for msg in ws for v in msg.data)
