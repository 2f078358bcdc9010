"""The closed loop as real processes: interpreter, model server, planner, mock arm and assistance over loopback.

The test side steers toward the planned grasp (six axes, as a spacemouse) and sends a certain intent; the hand
must reach the planned grasp with the assistance's help. Then the suite with the scripted operator node as the
only operator and source of w: it must reach the shown grasp, have the suite execute it (the hand then at the
planned grasp, not the reach tolerance short of it) and close the hand. Nothing sleeps: every wait polls with a
deadline.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from geometry_msgs.msg import PoseStamped, TwistStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from grasp_intent_ros.mico.frames import offset
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, FINGER_JOINTS, MicoKinematics
from grasp_intent_ros.ros.realtime import thread_policies
from grasp_intent_ros.wire import topics
from grasp_intent_ros.wire.diagnostics import OPERATOR_COMPONENT, WARN
from grasp_intent_ros.wire.robot_state import joint_positions, pose_msg_to_matrix

STARTUP = 60.0
"""Seconds for five processes to start, discover each other and plan on a loaded 2-core machine."""
CONVERGE = 30.0
"""Seconds for the hand to reach the grasp: about 0.5 m at the robot's 0.15 m/s, and the pre-grasp first."""


def test_the_assistance_brings_the_hand_to_the_planned_grasp(ros: Any, launch: Any) -> None:
    launch.start_nodes(shared_control=True)
    kin = MicoKinematics()
    grasps = ros.subscribe(PoseStamped, topics.GRASP_POSE)
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    alphas = ros.subscribe(Float64, topics.ASSISTANCE_ALPHA)
    operator = ros.publisher(TwistStamped, topics.OPERATOR_TWIST)

    def errors() -> tuple[float, float]:
        q = joint_positions(states[-1], ARM_JOINTS)
        assert q is not None
        hand, grasp = kin.fk(q), pose_msg_to_matrix(grasps[-1], frame_id=BASE_FRAME)
        return (float(np.linalg.norm(hand[:3, 3] - grasp[:3, 3])),
                float(np.linalg.norm(pin.log3(grasp[:3, :3] @ hand[:3, :3].T))))

    def steer() -> None:  # the operator: proportional toward the planned grasp, six axes (zero before a grasp)
        msg = TwistStamped()
        msg.header.frame_id = BASE_FRAME
        q = joint_positions(states[-1], ARM_JOINTS) if states else None
        if q is not None and grasps:
            hand, grasp = kin.fk(q), pose_msg_to_matrix(grasps[-1], frame_id=BASE_FRAME)
            error = np.r_[grasp[:3, 3] - hand[:3, 3], pin.log3(grasp[:3, :3] @ hand[:3, :3].T)]
            linear, angular = 1.5 * error[:3], 1.5 * error[3:]
            linear *= min(1.0, 0.05 / max(float(np.linalg.norm(linear)), 1e-12))
            angular *= min(1.0, 0.3 / max(float(np.linalg.norm(angular)), 1e-12))
            (msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z) = linear.tolist()
            (msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z) = angular.tolist()
        operator.publish(msg)

    ros.node.create_timer(0.01, steer)  # spun whenever the test waits
    assert ros.wait_for(lambda: states and alphas, STARTUP), launch.died() or 'no joint states or alpha'
    w = ros.publisher(Float64MultiArray, topics.INTENT_W)
    assert ros.publish_until(w, Float64MultiArray(data=[0.95, 0.05, 0.05]), lambda: grasps, STARTUP, period=1.0), \
        launch.died() or 'no grasp'

    start = errors()
    assert start[0] > 0.1  # Home is far from the cup
    assert ros.wait_for(lambda: errors()[0] < 0.01 and errors()[1] < 0.1, CONVERGE), \
        launch.died() or f'hand {errors()} (m, rad) from the grasp, started {start} away'
    assert max(a.data for a in alphas) > 0.5


OPERATOR_PARAMS = """/**/scripted_operator:
  ros__parameters:
    task_set: [usage, transfer]
    intent: held
    w: [0.9, 0.9, 0.1]
    hold: 0.0
"""
"""The scripted operator of the ambiguous case: w held at (0.9, 0.9, 0.1), the operator wanting usage and transfer."""


def test_the_suite_with_a_scripted_operator_reaches_executes_and_closes_on_the_shown_grasp(
        ros: Any, launch: Any, tmp_path: Any) -> None:
    params = tmp_path / 'operator.yaml'
    params.write_text(OPERATOR_PARAMS)
    launch.start_nodes(shared_control=True, extra=('scripted_operator',), params_files=[params])
    kin = MicoKinematics()
    grasps = ros.subscribe(PoseStamped, topics.GRASP_POSE)
    states = ros.subscribe(JointState, topics.JOINT_STATES)
    statuses = ros.diagnostics()

    def closed() -> bool:  # the fingers closed to the plan's closures (about 1 rad each), executed or by grasp/close
        fingers = joint_positions(states[-1], FINGER_JOINTS) if states else None
        return fingers is not None and bool(np.all(fingers > 0.5))

    def operator() -> list[str]:  # the scripted operator's status messages
        return [s.message for s in statuses if s.name.endswith(OPERATOR_COMPONENT)]

    assert ros.wait_for(lambda: grasps and closed(), STARTUP + CONVERGE), launch.died() or \
        f'the hand did not close; the operator: {operator()[-1:]}'
    assert ros.wait_for(lambda: any('done: episode 1' in m for m in operator()), 10.0), operator()[-1:]
    q = joint_positions(states[-1], ARM_JOINTS)  # after the close, the execution over
    assert q is not None
    hand, shown = kin.fk(q), pose_msg_to_matrix(grasps[-1], frame_id=BASE_FRAME)
    distance, angle = offset(hand, shown)
    # executed: the arm followed the plan's trajectory to the shown grasp (closed where it stood, the hand sat about
    # 5 mm and 0.03 rad short of it: within the reach tolerance the operator closes at, outside this one)
    assert distance < 0.001 and angle < 0.01, (distance, angle)
    assert any('done: episode 1 reached the shown grasp' in m and m.endswith('(executed)') for m in operator()), \
        operator()[-1:]


def _children(pid: int) -> list[int]:
    """The ids of the processes whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir('/proc'):
        try:
            stat = Path(f'/proc/{entry}/stat').read_text() if entry.isdigit() else ''
        except OSError:
            continue  # ended meanwhile
        if stat and int(stat.rpartition(')')[2].split()[1]) == pid:
            found.append(int(entry))
    return found


def _fifo_permitted() -> bool:
    """Whether a process started from here may set SCHED_FIFO (tried in a child: this process stays as it is)."""
    code = 'import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))'
    return subprocess.run([sys.executable, '-c', code], check=False).returncode == 0


def test_thread_priority_raises_the_node_process_and_not_its_path_search(ros: Any, launch: Any,
                                                                        status_finder: Any) -> None:
    # thread_priority 50: once the node is warmed up, every thread of its process at SCHED_FIFO 50, its path search's
    # process (started before) at the normal policy; where the privilege is missing, a WARN and the node serves on
    statuses = ros.diagnostics()
    alphas = ros.subscribe(Float64, topics.ASSISTANCE_ALPHA)
    node = launch.start('assistance', '-p', 'thread_priority:=50')
    pid = node.popen.pid

    def reported(value: str) -> bool:
        status = status_finder(statuses, ': assistance')
        return status is not None and any(v.key == 'thread_priority' and v.value == value for v in status.values)

    if _fifo_permitted():
        assert ros.wait_for(lambda: reported('SCHED_FIFO 50'), STARTUP)
        policies = thread_policies(pid)
        assert len(policies) > 1 and set(policies.values()) == {os.SCHED_FIFO}, policies
        assert os.sched_getparam(pid).sched_priority == 50
        assert os.sched_getscheduler(pid) & os.SCHED_RESET_ON_FORK
    else:
        assert ros.wait_for(lambda: status_finder(statuses, ': assistance', level=bytes([WARN]),
                                                  text='thread_priority 50 not set') and reported('normal'), STARTUP)
        assert os.SCHED_FIFO not in thread_policies(pid).values()
    searches = [child for child in _children(pid) if 'path_search' in Path(f'/proc/{child}/cmdline').read_text()]
    assert len(searches) == 1, _children(pid)
    assert set(thread_policies(searches[0]).values()) == {os.SCHED_OTHER}
    count = len(alphas)
    assert ros.wait_for(lambda: len(alphas) > count + 10, 10.0)  # serving
