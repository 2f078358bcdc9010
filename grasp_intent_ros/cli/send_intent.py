"""Send one intent w to the node chain and print the grasp it answers with (a ``ros2 topic pub`` stand-in).

Run: ``python -m grasp_intent_ros send_intent 0.9 0.9 0.1 [--timeout 10] [-w N] [--ros-args -r __ns:=/robot1]``

Publishes w on ``intent/w``, again every 0.5 s until answered (the first message after discovery can be
lost), and waits for the chain's answer: ``grasp/pose``, ``grasp/joint_targets`` and ``grasp/posterior``
of one plan (equal stamps) stamped after the first send, or a message on ``intent/clarification``.
Prints w, v (the last ``intent/v`` seen), P, the reconstructed w, the end-effector pose and the joint
targets (:func:`format_grasp`, reusable by other tools) and exits 0. Exits 1 with the reason on stderr on
a clarification request or a timeout (the message then names what was and was not heard, and the last
warning of the grasp planner's diagnostics), 2 for bad arguments.

Before it leaves, it waits up to :data:`ACK_TIMEOUT` for every matched subscription to acknowledge its w
(a subscription whose side of the match came late gets it resent). A subscriber that discovery finds after the
interpreter answered gets no w: a recorder started before ``send_intent`` records its w for sure only with
``-w 2`` (``--wait-matching-subscriptions``, as ``ros2 topic pub`` has it), which holds the first w until
two subscriptions, the interpreter's and the recorder's, have matched (within ``--timeout``). Matched is not
ordered: the recorder may receive the w after the interpreter's answer to it (the w reaches each subscription in
turn); a session is paired by send times (:func:`~grasp_intent_ros.sessions.pairing.send_order`), not by that.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from numpy.typing import ArrayLike, NDArray
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from ..errors import GraspIntentError
from ..method.intent import validate_w
from ..ros.conversions import posterior_from_msg
from ..ros.qos import input_qos, output_qos
from ..wire.arrays import Posterior, msg_labels, msg_to_array

__all__ = ['GraspAnswer', 'NoGrasp', 'IntentSender', 'format_grasp', 'main', 'ACK_TIMEOUT']

ACK_TIMEOUT = 1.0
"""Seconds ``send_intent`` waits at most, before it leaves, for its w to be acknowledged by every subscription."""


class NoGrasp(RuntimeError):
    """The chain asked for clarification, or did not answer in time; the message says which and why."""


@dataclass(frozen=True)
class GraspAnswer:
    """The chain's answer to one w.

    Attributes
    ----------
    w : ndarray, shape (m,)
        The intent that was sent.
    v_labels, v : tuple of str and ndarray, or None
        The last target vector seen on ``intent/v`` (None if none was seen).
    posterior : Posterior
    pose : geometry_msgs/PoseStamped
        End-effector pose.
    joints : sensor_msgs/JointState
        Joint targets.
    """

    w: NDArray[np.float64]
    v_labels: tuple[str, ...] | None
    v: NDArray[np.float64] | None
    posterior: Posterior[Time]
    pose: PoseStamped
    joints: JointState


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


def _row(names: Sequence[str], values: ArrayLike) -> str:
    return '  '.join(f'{n} {float(v):.3f}' for n, v in zip(names, np.asarray(values, dtype=np.float64)))


def format_grasp(answer: GraspAnswer) -> str:
    """A plain-text table of an answer: w, v, P, reconstructed w, EE pose, joint targets (rad and deg)."""
    post, p, o = answer.posterior, answer.pose.pose.position, answer.pose.pose.orientation
    lines = [
        f'{"w (sent)":<18}{_row(post.task_names, answer.w)}',
        f'{"v (intent/v)":<18}' + (_row(answer.v_labels or (), answer.v) if answer.v is not None
                                   else '(not seen)'),
        f'{"P (grasp)":<18}{_row(post.zone_labels, post.p)}',
        f'{"w (reconstructed)":<18}{_row(post.task_names, post.w)}',
        f'{"end effector":<18}position [m]  x {p.x:+.4f}  y {p.y:+.4f}  z {p.z:+.4f}  '
        f'(frame {answer.pose.header.frame_id})',
        f'{"":<18}orientation   x {o.x:+.4f}  y {o.y:+.4f}  z {o.z:+.4f}  w {o.w:+.4f}',
        f'{"joint targets":<18}' + ('\n' + ' ' * 18).join(
            f'{name:<26}{q:+9.4f} rad {math.degrees(q):+9.2f} deg'
            for name, q in zip(answer.joints.name, answer.joints.position)),
    ]
    return '\n'.join(lines)


class IntentSender(Node):
    """Publishes w on ``intent/w`` and collects the chain's answer. ``kwargs`` go to ``rclpy.node.Node``."""

    def __init__(self, node_name: str = 'send_intent', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        # the matched event only wakes the executor: a first w waiting for its subscribers goes out at once
        self._w_pub = self.create_publisher(Float64MultiArray, 'intent/w', output_qos(),
                                            event_callbacks=PublisherEventCallbacks(matched=lambda _status: None))
        self._v: list[Float64MultiArray] = []
        self._clarifications: list[String] = []
        self._poses: dict[int, PoseStamped] = {}
        self._joints: dict[int, JointState] = {}
        self._posteriors: dict[int, Posterior[Time]] = {}
        self._planner_warning = ''
        qos = input_qos()
        self.create_subscription(Float64MultiArray, 'intent/v', self._v.append, qos)
        self.create_subscription(String, 'intent/clarification', self._clarifications.append, qos)
        self.create_subscription(PoseStamped, 'grasp/pose',
                                 lambda m: self._poses.setdefault(_ns(m.header.stamp), m), qos)
        self.create_subscription(JointState, 'grasp/joint_targets',
                                 lambda m: self._joints.setdefault(_ns(m.header.stamp), m), qos)
        self.create_subscription(Float64MultiArray, 'grasp/posterior', self._on_posterior, qos)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 50)

    @property
    def clarifications(self) -> tuple[str, ...]:
        """Every clarification request received so far (the reasons), oldest first."""
        return tuple(m.data for m in self._clarifications)

    def _on_posterior(self, msg: Float64MultiArray) -> None:
        try:
            posterior = posterior_from_msg(msg)
        except GraspIntentError as exc:
            self.get_logger().warning(f'ignored a malformed grasp/posterior: {exc}')
            return
        self._posteriors.setdefault(_ns(posterior.stamp), posterior)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if 'grasp_planner' in status.name and status.level != DiagnosticStatus.OK:
                self._planner_warning = f'{status.name}: {status.message}'

    def _answer(self, after: int) -> int | None:
        stamps = sorted(s for s in self._posteriors if s > after and s in self._poses and s in self._joints)
        return stamps[0] if stamps else None

    def send(self, w: ArrayLike, executor: Executor, *, timeout: float = 10.0, period: float = 0.5,
             subscribers: int = 0) -> GraspAnswer:
        """Publish w until the chain answers; spin ``executor`` (which must hold this node) meanwhile.

        The first w goes out once ``subscribers`` subscriptions of ``intent/w`` have matched this publisher
        (at once for 0).

        The answer: the first plan stamped after the send, once an ``intent/v`` has been heard since (w is sent
        again every ``period``, so a v missed while the subscriptions were still matching comes again).

        Raises
        ------
        InvalidIntentError
            For a w that is not a vector of 1..10 probabilities.
        NoGrasp
            On a clarification request, or when no answer arrives within ``timeout`` seconds (the first w
            included).
        """
        w_arr = validate_w(w)
        msg = Float64MultiArray(data=[float(v) for v in w_arr])
        sent_after = _ns(self.get_clock().now().to_msg())
        n_v, n_clarifications = len(self._v), len(self._clarifications)
        deadline = time.monotonic() + timeout
        next_send = 0.0
        waiting = self._w_pub.get_subscription_count() < subscribers
        while (stamp := self._answer(sent_after)) is None or len(self._v) == n_v:  # the plan and a v heard
            now = time.monotonic()
            if len(self._clarifications) > n_clarifications:
                raise NoGrasp(f'the chain asks for clarification: {self._clarifications[-1].data}')
            if now >= deadline:
                raise NoGrasp(self._timeout_reason(timeout, heard_v=len(self._v) > n_v,
                                                   subscribers=subscribers if waiting else 0))
            waiting = waiting and self._w_pub.get_subscription_count() < subscribers
            if now >= next_send and not waiting:
                self._w_pub.publish(msg)
                next_send = now + period
            executor.spin_once(timeout_sec=max(0.0, (deadline if waiting else min(next_send, deadline))
                                               - time.monotonic()))
        v_msg = self._v[-1] if len(self._v) > n_v else None
        return GraspAnswer(w=w_arr, v_labels=msg_labels(v_msg)[0] if v_msg and v_msg.layout.dim else None,
                           v=msg_to_array(v_msg) if v_msg is not None else None,
                           posterior=self._posteriors[stamp], pose=self._poses[stamp], joints=self._joints[stamp])

    def wait_for_acks(self, timeout: float) -> bool:
        """Wait up to ``timeout`` seconds until every matched subscription has acknowledged every w sent.

        A reliable subscription that received a w before its side of the match was complete asks for it again:
        the w reaches it only while this publisher exists. Returns whether all were acknowledged in time.
        """
        return self._w_pub.wait_for_all_acked(Duration(seconds=timeout))

    def _timeout_reason(self, timeout: float, *, heard_v: bool, subscribers: int) -> str:
        if subscribers:
            where = (f'no w was sent: {self._w_pub.get_subscription_count()} of the {subscribers} subscriptions of '
                     'intent/w waited for matched')
        elif self._w_pub.get_subscription_count() == 0:
            where = 'nobody subscribes to intent/w (is intent_interpreter running, on this ROS_DOMAIN_ID?)'
        elif not heard_v:
            where = 'no intent/v came back (does the interpreter expect this many tasks?)'
        else:
            where = 'intent/v came back but no complete grasp (is grasp_planner running, with a model?)'
        hint = f'; grasp planner: {self._planner_warning}' if self._planner_warning else ''
        return f'no grasp within {timeout:g} s: {where}{hint}'


def main(args: Sequence[str] | None = None) -> None:
    """Entry point: send one w, print the grasp, exit 0 (1 on clarification or timeout)."""
    argv = list(sys.argv if args is None else ['send_intent', *args])
    parser = argparse.ArgumentParser(description='Publish one intent w on intent/w and print the grasp.')
    parser.add_argument('w', type=float, nargs='+', help='probability of each task, in [0, 1]')
    parser.add_argument('--timeout', type=float, default=10.0, help='seconds to wait for the answer')
    parser.add_argument('-w', '--wait-matching-subscriptions', type=int, default=0, metavar='N', dest='subscribers',
                        help='send the first w once N subscriptions of intent/w have matched (2: the interpreter '
                             'and a recorder, so that the recorder gets it for sure); default 0, at once')
    options = parser.parse_args(remove_ros_args(argv)[1:])
    try:
        w = validate_w(options.w)
    except GraspIntentError as exc:
        parser.error(str(exc))
    if not options.timeout > 0.0:
        parser.error('--timeout must be positive')
    if options.subscribers < 0:
        parser.error('--wait-matching-subscriptions must not be negative')
    rclpy.init(args=argv)
    node: IntentSender | None = None
    code = 1
    try:
        node = IntentSender()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        print(format_grasp(node.send(w, executor, timeout=options.timeout, subscribers=options.subscribers)))
        code = 0
    except NoGrasp as exc:
        print(f'send_intent: {exc}', file=sys.stderr)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.wait_for_acks(ACK_TIMEOUT)
            node.destroy_node()
        rclpy.try_shutdown()
    raise SystemExit(code)


if __name__ == '__main__':
    main()
