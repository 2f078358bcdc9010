"""Several objects in one scene: ``suite --object cup=... --object flashlight=...`` as a user runs it.

One planning chain per object under ``/<object>/``, each with its own model and ``object/pose``, all reading
the arm's one ``joint_states`` at the root (docs/several_objects.md); the command's readiness and its clean
stop cover every chain. Only the process group this test started is signalled.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

from geometry_msgs.msg import PoseStamped, TwistStamped
from processes import alive, ctrl_c, suite_command
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger

from grasp_intent_ros.launch.suite import SUITE_NODES
from grasp_intent_ros.mico.frames import pose_to_matrix
from grasp_intent_ros.mico.kinematics import ARM_JOINTS, BASE_FRAME, HOME_Q
from grasp_intent_ros.ros.conversions import model_from_msg
from grasp_intent_ros.ros.qos import latched_qos
from grasp_intent_ros.ros.robot import matrix_to_pose_msg
from grasp_intent_ros.wire.arrays import msg_labels

UP = 90.0
"""Seconds for six node processes to start and log that they are ready (two planners load their compiled kernels
at once) on a loaded 2-core machine."""
SHARED_UP = 150.0
"""Seconds for nine node processes (two chains, the mock arm, the assistance with its path search's process, the
estimator) to start on a loaded 2-core machine."""
ANSWER = 30.0
"""Seconds for a chain to answer a w (discovery of the test's publishers, one plan)."""
STOP = 30.0
"""Seconds for the command to stop six nodes, one at a time, after Ctrl-C."""
MODELS = {'cup': 'cup_7zone', 'flashlight': 'flashlight_7zone'}
W = {'cup': Float64MultiArray(data=[0.1, 0.9, 0.9]), 'flashlight': Float64MultiArray(data=[0.9, 0.9, 0.1])}
"""Each chain's w, different, so that a v tells which w it came from."""


def test_one_chain_per_object_each_with_its_model_and_pose_sharing_the_arms_joint_states(
        ros, domain_id: int, tmp_path: Path) -> None:
    out = tmp_path / 'suite.out'
    objects = [arg for name, model in MODELS.items() for arg in ('--object', f'{name}={model}')]
    args = ['--domain-id', str(domain_id), *objects, '--log-dir', str(tmp_path / 'logs')]
    with suite_command(args, cwd=tmp_path, out=out) as suite:
        active = {name: ros.subscribe(String, f'/{name}/model/active', latched_qos()) for name in MODELS}
        grasps = {name: ros.subscribe(PoseStamped, f'/{name}/grasp/pose') for name in MODELS}
        w_pubs = {name: ros.publisher(Float64MultiArray, f'/{name}/intent/w') for name in MODELS}
        v_msgs = {name: ros.subscribe(Float64MultiArray, f'/{name}/intent/v') for name in MODELS}
        joints_pub = ros.publisher(JointState, '/joint_states')
        flashlight_pose_pub = ros.publisher(PoseStamped, '/flashlight/object/pose')
        assert ros.wait_for(lambda: 'suite: up' in out.read_text() or suite.poll() is not None, UP), out.read_text()
        assert suite.poll() is None, out.read_text()

        # each chain's model is its own
        assert ros.wait_for(lambda: all(active.values()), ANSWER)
        assert {name: model_from_msg(msgs[-1]).name for name, msgs in active.items()} == MODELS

        # the arm's joint_states is one, at the root: each planner reads it, no chain has one of its own
        def planner_inputs(name: str) -> set[str]:  # empty until the probe has discovered the planner
            if ('grasp_planner', f'/{name}') not in ros.node.get_node_names_and_namespaces():
                return set()
            return {topic for topic, _ in ros.node.get_subscriber_names_and_types_by_node('grasp_planner', f'/{name}')}

        def own_inputs(name: str) -> set[str]:
            return {'/joint_states', f'/{name}/intent/v', f'/{name}/model/active', f'/{name}/object/pose'}
        assert ros.wait_for(lambda: all(own_inputs(name) <= planner_inputs(name) for name in MODELS), ANSWER), \
            {name: planner_inputs(name) for name in MODELS}
        assert [sorted(t for t in planner_inputs(name) if t != '/joint_states' and not t.startswith(f'/{name}/'))
                for name in MODELS] == [[], []], 'a chain reads a topic outside its namespace besides the arm\'s'
        assert [ros.node.count_subscribers(f'/{name}/joint_states') for name in MODELS] == [0, 0]

        # the flashlight on the other side of the arm (its own object/pose); the cup at the default pose (y -0.3)
        home = JointState(name=list(ARM_JOINTS), position=[float(q) for q in HOME_Q])
        flashlight_pose = matrix_to_pose_msg(pose_to_matrix((0.3, 0.3, 0.0), (0.0, 0.0, 1.0, 0.0)),
                                             frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())

        def publish_until(name: str, predicate, *more: tuple[object, object]) -> bool:
            deadline = time.monotonic() + ANSWER
            while time.monotonic() < deadline:
                joints_pub.publish(home)
                for publisher, msg in more:
                    publisher.publish(msg)
                w_pubs[name].publish(W[name])
                if ros.wait_for(predicate, 0.5):
                    return True
            return False

        assert publish_until('flashlight', lambda: v_msgs['flashlight'] and any(g.pose.position.y > 0.0
                                                                              for g in grasps['flashlight']),
                             (flashlight_pose_pub, flashlight_pose)), out.read_text()
        assert grasps['cup'] == [] and v_msgs['cup'] == [], 'a w on /flashlight/intent/w reached the cup\'s chain'

        # a flashlight v still in flight may be planned after this; a v of the cup's w never reaches the flashlight
        # (v and the grasp come on topics of their own: the probe may take the grasp first)
        assert publish_until('cup', lambda: grasps['cup'] and v_msgs['cup']), out.read_text()
        assert all(g.pose.position.y < 0.0 for g in grasps['cup']), 'the cup was planned at the flashlight\'s pose'
        vs = {name: {tuple(m.data) for m in msgs} for name, msgs in v_msgs.items()}
        assert len(vs['cup']) == 1 and len(vs['flashlight']) == 1, f'a w reached the other object\'s chain: {vs}'
        assert vs['cup'] != vs['flashlight'], vs  # (else the test above could not tell the two w apart)

        assert ctrl_c(suite, STOP) == 0, out.read_text()
    text = out.read_text()
    first, lines = text.splitlines()[0], text.splitlines()
    assert first.startswith(f'suite: ROS_DOMAIN_ID={domain_id}, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, namespace /; '
                            'object cup (cup_7zone) in /cup; object flashlight (flashlight_7zone) in /flashlight; '
                            'started cup/intent_interpreter (pid '), first
    pids = {name: int(pid) for name, pid in re.findall(r'([\w/]+) \(pid (\d+)\)', first)}
    chain = [f'{name}/{module}' for name in MODELS for module in SUITE_NODES]
    assert list(pids) == chain, first
    up = next(i for i, line in enumerate(lines) if line.startswith('suite: up after'))
    assert {m for m in re.findall(r'^\[([\w/]+)\] .*\]: ready', '\n'.join(lines[:up]), re.MULTILINE)} == set(chain)
    assert text.rstrip().endswith('suite: stopped cleanly'), text
    assert 'Traceback' not in text, text
    assert not [name for name, pid in pids.items() if alive(pid)], 'a node outlived the suite command'
    assert sorted(p.name for p in (tmp_path / 'logs').iterdir()) == sorted(
        f'{name.replace("/", ".")}.{ext}' for name in chain for ext in ('out', 'err'))


def test_the_intent_estimator_over_both_chains_publishes_each_w_and_p_of_the_objects(
        ros, domain_id: int, tmp_path: Path) -> None:
    """``suite --object ... --with intent_estimator``: one estimator at the root; twists give both w and P(o)."""
    out = tmp_path / 'suite.out'
    objects = [arg for name, model in MODELS.items() for arg in ('--object', f'{name}={model}')]
    args = ['--domain-id', str(domain_id), *objects, '--with', 'intent_estimator']
    with suite_command(args, cwd=tmp_path, out=out) as suite:
        w_msgs = {name: ros.subscribe(Float64MultiArray, f'/{name}/intent/w') for name in MODELS}
        p_msgs = ros.subscribe(Float64MultiArray, '/intent/objects')
        joints_pub = ros.publisher(JointState, '/joint_states')
        twist_pub = ros.publisher(TwistStamped, '/operator/twist')
        assert ros.wait_for(lambda: 'suite: up' in out.read_text() or suite.poll() is not None, UP), out.read_text()
        assert suite.poll() is None, out.read_text()
        # each object's prior w once its goals are ready (both at the default pose until an object/pose comes)
        assert ros.wait_for(lambda: all(w_msgs.values()) and p_msgs and len(p_msgs[-1].data) == 2, ANSWER), \
            out.read_text()
        counts = {name: len(msgs) for name, msgs in w_msgs.items()}
        twist = TwistStamped()
        twist.header.frame_id = BASE_FRAME
        twist.twist.linear.x = 0.05
        home = JointState(name=list(ARM_JOINTS), position=[float(q) for q in HOME_Q])

        def streamed() -> bool:
            return all(len(w_msgs[name]) > counts[name] + 3 for name in MODELS)
        deadline = time.monotonic() + ANSWER
        while time.monotonic() < deadline:
            stamp = ros.node.get_clock().now().to_msg()
            home.header.stamp = twist.header.stamp = stamp
            joints_pub.publish(home)
            twist_pub.publish(twist)
            if ros.wait_for(streamed, 0.02):  # at most the operator's device period
                break
        assert streamed(), out.read_text()
        (labels,) = msg_labels(p_msgs[-1])
        assert labels == tuple(MODELS) and abs(sum(p_msgs[-1].data) - 1.0) < 1e-12, p_msgs[-1]
        assert all(0.0 < v < 1.0 for msgs in w_msgs.values() for m in msgs for v in m.data)
        assert all(0.0 < v <= 1.0 for m in p_msgs for v in m.data)  # 1 while one object alone is ready
        assert ctrl_c(suite, STOP) == 0, out.read_text()
    text = out.read_text()
    assert re.search(r'started cup/intent_interpreter .* intent_estimator \(pid \d+\)', text.splitlines()[0]), text
    assert text.rstrip().endswith('suite: stopped cleanly') and 'Traceback' not in text, text


def test_the_shared_control_loop_follows_one_object_and_closes_to_its_plan(ros, domain_id: int, tmp_path: Path) -> None:
    """``suite --object ... --shared-control --with intent_estimator``: one loop over both chains.

    The assistance at the root streams and publishes the object it follows; the mock arm's ``grasp/close`` closes
    to that object's plan.
    """
    out = tmp_path / 'suite.out'
    objects = [arg for name, model in MODELS.items() for arg in ('--object', f'{name}={model}')]
    args = ['--domain-id', str(domain_id), *objects, '--shared-control', '--with', 'intent_estimator']
    with suite_command(args, cwd=tmp_path, out=out) as suite:
        twists = ros.subscribe(TwistStamped, '/assistance/twist')
        followed = ros.subscribe(String, '/assistance/object', latched_qos())
        plans = {name: ros.subscribe(JointState, f'/{name}/grasp/joint_targets') for name in MODELS}
        states = ros.subscribe(JointState, '/joint_states')
        twist_pub = ros.publisher(TwistStamped, '/operator/twist')
        assert ros.wait_for(lambda: 'suite: up' in out.read_text() or suite.poll() is not None, SHARED_UP), \
            out.read_text()
        assert suite.poll() is None, out.read_text()
        twist = TwistStamped()
        twist.header.frame_id = BASE_FRAME
        twist.twist.linear.z = -0.02  # down, slowly: the estimator's prior w plans both objects meanwhile

        def ready() -> bool:
            return bool(len(twists) > 10 and followed and plans[followed[-1].data])
        deadline = time.monotonic() + ANSWER
        while time.monotonic() < deadline:
            twist.header.stamp = ros.node.get_clock().now().to_msg()
            twist_pub.publish(twist)
            if ros.wait_for(ready, 0.02):
                break
        assert ready(), out.read_text()
        name = followed[-1].data
        assert name in MODELS
        client = ros.node.create_client(Trigger, '/grasp/close')
        assert client.wait_for_service(timeout_sec=ANSWER)

        def close() -> Trigger.Response | None:  # refused until the arm has the plan and the object followed too
            future = client.call_async(Trigger.Request())
            return future.result() if ros.wait_for(future.done, ANSWER) else None
        deadline = time.monotonic() + ANSWER
        while (answer := close()) is not None and not answer.success and time.monotonic() < deadline:
            pass  # each call a round trip: asked again at once
        assert answer is not None and answer.success, answer
        message = answer.message
        assert f"({name}'s plan)" in message, message
        executed = [float(c) for c in re.findall(r'-?\d+\.\d+', message.split(' rad')[0])]
        plan = list(plans[name][-1].position)[-3:]  # the fingers, last in the planner's joint targets
        assert all(abs(e - p) < 0.25 for e, p in zip(executed, plan, strict=True)), (executed, plan)  # 5 sigma
        assert ros.wait_for(lambda: all(abs(q - e) < 1e-3 for q, e in zip(list(states[-1].position)[-3:], executed,
                                                                         strict=True)), ANSWER)
        assert ctrl_c(suite, STOP) == 0, out.read_text()
    text = out.read_text()
    assert re.search(r'mock_arm \(pid \d+\).* assistance \(pid \d+\).* intent_estimator \(pid \d+\)',
                     text.splitlines()[0]), text
    assert text.rstrip().endswith('suite: stopped cleanly') and 'Traceback' not in text, text


REACH = 180.0
"""Seconds for the scripted operator, started once the others are up, to reach for the cup and close (its own grasp
planned, the estimator's w planned by the cup's chain, the reach at 0.12 m/s, the execute) on a loaded machine."""


def test_a_scripted_operator_reaching_for_the_cup_is_followed_and_the_hand_closes_on_the_cups_plan(
        ros, domain_id: int, tmp_path: Path) -> None:
    """The researcher's command, without the viewer (it needs the viewer extra).

    ``suite --object cup=... --object flashlight=... --shared-control --with intent_estimator --with
    scripted_operator``.

    The operator reaches for the cup (the first object: ``--operator-object`` by default), the flashlight on the
    other side of the arm; P(cup) rises, the assistance follows the cup and the hand closes to the cup's plan.
    """
    out = tmp_path / 'suite.out'
    objects = [arg for name, model in MODELS.items() for arg in ('--object', f'{name}={model}')]
    args = ['--domain-id', str(domain_id), *objects, '--shared-control', '--with', 'intent_estimator', '--with',
            'scripted_operator', '--log-dir', str(tmp_path / 'logs')]
    with suite_command(args, cwd=tmp_path, out=out) as suite:
        followed = ros.subscribe(String, '/assistance/object', latched_qos())
        p_msgs = ros.subscribe(Float64MultiArray, '/intent/objects')
        plans = {name: ros.subscribe(JointState, f'/{name}/grasp/joint_targets') for name in MODELS}
        states = ros.subscribe(JointState, '/joint_states')
        flashlight_pose_pub = ros.publisher(PoseStamped, '/flashlight/object/pose')
        flashlight_pose = matrix_to_pose_msg(pose_to_matrix((0.3, 0.3, 0.0), (0.0, 0.0, 1.0, 0.0)),
                                             frame_id=BASE_FRAME, stamp=ros.node.get_clock().now().to_msg())

        def track() -> None:  # the flashlight's tracker, 10 Hz; the cup at every node's default pose (y -0.3)
            flashlight_pose.header.stamp = ros.node.get_clock().now().to_msg()
            flashlight_pose_pub.publish(flashlight_pose)
        ros.node.create_timer(0.1, track)  # spun whenever the test waits

        def closed() -> str:  # the operator's log line of the mock arm's answer to its grasp/close
            return next((line for line in out.read_text().splitlines()
                         if '[scripted_operator]' in line and 'grasp/close: ' in line), '')
        assert ros.wait_for(lambda: closed() or suite.poll() is not None, SHARED_UP + REACH), out.read_text()[-3000:]
        message = closed()
        assert "closing to" in message and "(cup's plan)" in message, message
        assert followed and followed[-1].data == 'cup', [m.data for m in followed]
        # an execute (on the cup's shown grasp; on its own grasp, when the estimated w's grasp lies farther, it closes
        # where the hand is) ran the cup chain's trajectory, never another's
        executes = [line for line in out.read_text().splitlines()
                    if '[scripted_operator]' in line and 'grasp/execute: following' in line]
        assert all("(cup's plan)" in line for line in executes), executes
        executed = [float(c) for c in re.findall(r'-?\d+\.\d+', message.split('closing to')[1].split(' rad')[0])]
        # the fingers, last in the planner's joint targets: a cup plan within 5 sigma of the closure error (the
        # planner may plan again after the close, on the estimator's newer w: not necessarily the last plan)
        fingers = [list(m.position)[-3:] for m in plans['cup']]
        assert any(all(abs(e - p) < 0.25 for e, p in zip(executed, plan, strict=True)) for plan in fingers), \
            (executed, fingers[-3:])
        assert ros.wait_for(lambda: all(abs(q - e) < 1e-3 for q, e in zip(list(states[-1].position)[-3:], executed,
                                                                         strict=True)), ANSWER)
        # P(cup) while both objects are in the estimate (an object whose goals are not ready is not): up from the
        # prior's 0.5 (the flashlight's goals restart from the prior when its tracked pose first comes)
        p_cup = [m.data[0] for m in p_msgs if msg_labels(m) == (tuple(MODELS),)]
        assert p_cup and p_cup[-1] > 0.9, (p_cup[:3], p_cup[-3:])
        assert ctrl_c(suite, STOP) == 0, out.read_text()[-3000:]
    text = out.read_text()
    assert re.search(r'suite: started scripted_operator \(pid \d+\)', text), text[-3000:]
    assert text.rstrip().endswith('suite: stopped cleanly') and 'Traceback' not in text, text[-3000:]
