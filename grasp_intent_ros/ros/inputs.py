"""Input subscriptions that reject oversized messages before decoding them.

Every input of the suite is read serialized (``create_subscription(..., raw=True)`` hands the callback the
CDR bytes): a message larger than its topic's cap (:data:`grasp_intent_ros.wire.topics.MAX_MESSAGE_BYTES`) is
rejected by its size alone and never becomes Python objects; the rest is decoded with
``rclpy.serialization.deserialize_message`` and handed to the node's callback. Both go through the node's
:meth:`~grasp_intent_ros.ros.diagnostics.NodeDiagnostics.guard`, so an oversized message is one counted
rejection (a WARN with the size and the cap) like any other bad input.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any, cast

from geometry_msgs.msg import Twist
from rclpy.callback_groups import CallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

from ..errors import GraspIntentError
from ..mico.kinematics import ARM_JOINTS
from ..wire.diagnostics import WARN
from ..wire.joint_states import JointReading, JointStates
from ..wire.topics import JOINT_STATES, MAX_MESSAGE_BYTES, OPERATOR_TWIST, check_message_size
from .conversions import message_class
from .diagnostics import NodeDiagnostics
from .qos import input_events

__all__ = ['subscribe_input', 'subscribe_operator', 'decode_input', 'subscribe_arm']


def decode_input(topic: str, data: bytes, msg_type: Any = None) -> Any:
    """The message of the suite input ``topic`` serialized in ``data`` (its size already checked).

    ``msg_type`` (default: the topic's, :data:`~grasp_intent_ros.wire.topics.MSGTYPES`) is for an input that
    takes another type by configuration (e.g. a plain Twist for a TwistStamped).

    Raises
    ------
    GraspIntentError
        If rclpy cannot decode it.
    """
    try:
        return deserialize_message(data, message_class(topic) if msg_type is None else msg_type)
    except Exception as exc:  # noqa: BLE001 - a message rclpy cannot decode is bad input
        raise GraspIntentError(f'{topic}: undecodable message: {type(exc).__name__}: {exc}') from None


def subscribe_input(node: Node, topic: str, callback: Callable[[Any], object], qos: QoSProfile,
                    diagnostics: NodeDiagnostics, *, count_dropped: bool = False, serialized: bool = False,
                    callback_group: CallbackGroup | None = None, msg_type: Any = None,
                    namespace: str = '') -> Subscription:
    """Subscribe ``callback`` to the suite input ``topic``, size-checked before decoding and guarded.

    Parameters
    ----------
    node : Node
    topic : str
        A topic of :data:`~grasp_intent_ros.wire.topics.MAX_MESSAGE_BYTES` (relative name).
    callback : callable
        Called with the decoded message (the topic's type, :data:`~grasp_intent_ros.wire.topics.MSGTYPES`).
    qos : QoSProfile
    diagnostics : NodeDiagnostics
        Counts every message received and every rejection (:meth:`NodeDiagnostics.guard`).
    count_dropped : bool
        Also count the messages the node never took (:meth:`NodeDiagnostics.count_dropped`).
    serialized : bool
        Hand ``callback`` the size-checked serialized bytes instead of the decoded message; it decodes
        them itself (e.g. :func:`grasp_intent_ros.wire.arrays.serialized_vector`, else :func:`decode_input`).
    callback_group : CallbackGroup, optional
        The subscription's group (default: the node's), e.g. that of a thread that takes it off the executor
        (:class:`grasp_intent_ros.ros.worker.InputThread`, :meth:`~grasp_intent_ros.ros.worker.
        LatestOnlyWorker.take`; the subscription's callback takes the message and its info).
    msg_type : message class, optional
        Instead of the topic's own type (:func:`decode_input`); the topic's size cap still applies.
    namespace : str
        A relative namespace to read ``topic`` in (e.g. ``'cup'``: ``cup/object/pose``, one object's of a scene),
        with ``topic``'s type and cap; every rejection then names the topic read (``cup/object/pose: ...``).

    Raises
    ------
    KeyError
        For a topic without a cap.
    """
    msg_type = message_class(topic) if msg_type is None else msg_type
    if topic not in MAX_MESSAGE_BYTES:
        raise KeyError(f'{topic!r} is not an input topic with a size cap')

    name = f'{namespace}/{topic}' if namespace else topic

    def on_serialized(data: bytes) -> None:
        check_message_size(topic, len(data), name=name)
        msg = data if serialized else decode_input(name, data, msg_type)
        try:
            callback(msg)
        except GraspIntentError as exc:
            if not namespace:
                raise
            raise GraspIntentError(f'{name}: {exc}') from None

    on_serialized.__name__ = getattr(callback, '__name__', 'on_message')
    guarded = diagnostics.guard(on_serialized)
    # rclpy passes the message info to a callback of two parameters (its annotation names one)
    handle = cast(Callable[[bytes, Mapping[str, Any]], None], diagnostics.count_dropped(guarded)) if count_dropped \
        else (lambda data, _info: guarded(data))
    return node.create_subscription(msg_type, name, cast(Callable[[bytes], None], handle), qos, raw=True,
                                    event_callbacks=input_events(node.get_logger(), name),
                                    callback_group=callback_group)


def subscribe_operator(node: Node, callback: Callable[[Any], object], qos: QoSProfile, diagnostics: NodeDiagnostics,
                       message_type: str) -> Subscription:
    """:func:`subscribe_input` to ``operator/twist``, messages dropped counted: a TwistStamped, or a plain Twist.

    ``message_type`` is the node's ``operator_message_type`` parameter ('TwistStamped' or 'Twist');
    :func:`grasp_intent_ros.wire.robot_state.twist_command` reads either.
    """
    return subscribe_input(node, OPERATOR_TWIST, callback, qos, diagnostics, count_dropped=True,
                           msg_type=Twist if message_type == 'Twist' else None)


def subscribe_arm(node: Node, callback: Callable[[JointReading], object], qos: QoSProfile,
                  diagnostics: NodeDiagnostics) -> Subscription:
    """:func:`subscribe_input` to ``joint_states``, ``callback`` given the arm's reading when a message renews it.

    Each arm joint's latest position from whichever message named it last
    (:class:`~grasp_intent_ros.wire.joint_states.JointStates` of the arm joints, receipts on the monotonic clock):
    the callback runs when a message names an arm joint and every arm joint is known and not stale. A message that
    names none (e.g. the fingers' alone, from another publisher) brings nothing new; one that names some while
    another is unknown or stale is noted (WARN, why: :meth:`~grasp_intent_ros.wire.joint_states.JointStates.missing`);
    a malformed one is a counted rejection that changes nothing.
    """
    joints = JointStates(ARM_JOINTS)

    def on_joint_state(msg: Any) -> None:
        if not joints.add(msg, time.monotonic()):
            return
        if (arm := joints.read()) is None:
            diagnostics.note(f'joint state not used: {joints.missing()}', level=WARN)
        else:
            callback(arm)

    on_joint_state.__name__ = getattr(callback, '__name__', 'on_joint_state')
    return subscribe_input(node, JOINT_STATES, on_joint_state, qos, diagnostics)
