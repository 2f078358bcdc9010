"""Fuzz: the assistance, the mock arm and the scripted operator, in one process, get malformed twists and joint states.

Hypothesis draws the messages with a fixed seed (derandomize): twists with NaN, infinities, 1e308, -0.0 in
any field and frames that are the base, the hand, unknown or 5,000 characters long (over the input cap),
undecodable bytes, and the joint states of benchmarks/_bench/fuzz_inputs.py. No exception may leave a callback (it would
leave the executor's spin, here in the test's thread), no output may hold a NaN or infinity, the arm must
stay within its limits, and every node must still answer afterwards (the scripted operator, whose twists go
elsewhere, reads the fuzzed joint states).
"""

from __future__ import annotations

import numpy as np
from _bench.fuzz_inputs import joint_cases
from geometry_msgs.msg import TwistStamped
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from grasp_intent_ros.mico.kinematics import BASE_FRAME, EE_FRAME, HOME_Q, MicoKinematics
from grasp_intent_ros.mico.mock_arm import MockArm
from grasp_intent_ros.nodes.assistance import AssistanceNode
from grasp_intent_ros.nodes.mock_arm import MockArmNode
from grasp_intent_ros.nodes.scripted_operator import ScriptedOperatorNode
from grasp_intent_ros.wire import topics

EXAMPLES = 400
ARM_STATES = 'mock/joint_states'
"""The mock arm's output, remapped away from the fuzzed ``joint_states``."""
SCRIPTED = 'scripted/twist'
"""The scripted operator's output, remapped away from the fuzzed ``operator/twist``."""
_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, -0.0, 1e-300]))
_frames = st.sampled_from(['', BASE_FRAME, EE_FRAME, 'map', 'x' * 5000])


def _twist(values: list[float], frame: str) -> TwistStamped:
    msg = TwistStamped()
    msg.header.frame_id = frame
    t = msg.twist
    t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z = values
    return msg


twists = st.one_of(st.builds(_twist, st.lists(_values, min_size=6, max_size=6), _frames),
                   st.binary(min_size=1, max_size=64).map(lambda b: b'\x00\x01\x00\x00' + b[:3]))


def test_fuzzed_twists_and_joint_states_never_crash_a_node(ros) -> None:
    ros.add(AssistanceNode(context=ros.context))
    ros.add(MockArmNode(context=ros.context, cli_args=['--ros-args', '-r', f'joint_states:={ARM_STATES}']))
    ros.add(ScriptedOperatorNode(context=ros.context, cli_args=['--ros-args', '-r',
                                                                f'{topics.OPERATOR_TWIST}:={SCRIPTED}']))
    scripted = ros.subscribe(TwistStamped, SCRIPTED)
    outputs = ros.subscribe(TwistStamped, topics.ASSISTANCE_TWIST)
    alphas = ros.subscribe(Float64, topics.ASSISTANCE_ALPHA)
    states = ros.subscribe(JointState, ARM_STATES)
    pubs = {topic: ros.publisher(type_, topic) for topic, type_ in (
        (topics.OPERATOR_TWIST, TwistStamped), (topics.ARM_TWIST_COMMAND, TwistStamped),
        (topics.JOINT_STATES, JointState))}
    assert ros.wait_for(lambda: outputs and states and all(p.get_subscription_count() for p in pubs.values()), 10.0)

    @settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None,
              phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck))
    @given(case=st.one_of(twists.map(lambda m: (topics.OPERATOR_TWIST, m)),
                          twists.map(lambda m: (topics.ARM_TWIST_COMMAND, m)),
                          joint_cases().map(lambda c: (topics.JOINT_STATES, c.msg))))
    def send(case: tuple[str, object]) -> None:
        topic, msg = case
        pubs[topic].publish(msg)
        ros.wait_for(lambda: False, 0.002)  # the nodes take it; an exception escaping a callback fails here

    send()
    n_out, n_states, n_scripted = len(outputs), len(states), len(scripted)
    assert ros.wait_for(lambda: len(outputs) > n_out + 10 and len(states) > n_states + 10
                        and len(scripted) > n_scripted + 10, 5.0)  # all still serve
    twist_values = np.array([[m.twist.linear.x, m.twist.linear.y, m.twist.linear.z, m.twist.angular.x,
                              m.twist.angular.y, m.twist.angular.z] for m in outputs + scripted])
    assert np.all(np.isfinite(twist_values)) and np.all(np.isfinite([a.data for a in alphas]))
    arm = MockArm(MicoKinematics(), np.r_[HOME_Q, 0.0, 0.0, 0.0])
    positions = np.array([m.position for m in states])
    assert np.all(np.isfinite(positions)) and np.all((positions >= arm.lower) & (positions <= arm.upper))
