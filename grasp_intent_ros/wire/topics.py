"""The suite's topics, their message types, and the caps on what an input may carry.

ROS-free (plain strings and numbers); every node, session tool and test names a topic through this module.

Topics
------
:data:`MSGTYPES` maps every topic of the suite (relative names; ``/diagnostics`` is absolute) to its
message type; :data:`LATCHED_TOPICS` are those it publishes latched (:data:`MODEL_LATCHED_TOPICS` the model
server's). :data:`INPUT_TOPICS` are the inputs a
replay publishes again, :data:`PLAN_TOPICS` the outputs of one plan (one stamp), :data:`OUTPUT_TOPICS` the
outputs a replay compares. One service is named
here too, the assistance's switch :data:`ASSISTANCE_ENABLE`.

Input caps
----------
:data:`MAX_MESSAGE_BYTES` caps the serialized size of a message on each input topic (checked before the
message is decoded, :func:`check_message_size`); :data:`MAX_JOINTS` and :data:`MAX_NAME_LENGTH` bound a
joint state's names (:func:`check_names`), :data:`MAX_FEATURES` a feature vector.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Final

from ..errors import GraspIntentError
from ..method.safe_yaml import MAX_DOCUMENT_CHARS

__all__ = [
    'INTENT_W', 'INTENT_OBJECTS', 'INTENT_PRIOR', 'INTENT_V', 'INTENT_CLARIFICATION', 'MODEL_ACTIVE', 'MODEL_AMBIGUITY',
    'MODEL_AMBIGUITY_SYMMETRIC', 'MODEL_AMBIGUITY_PINSKER', 'MODEL_QUERY', 'MODEL_POSTERIOR',
    'OBJECT_POSE', 'JOINT_STATES', 'GRASP_POSE', 'GRASP_JOINT_TARGETS', 'GRASP_TRAJECTORY',
    'GRASP_POSTERIOR', 'GRASP_FEATURES', 'GRASP_MARKERS', 'OPERATOR_TWIST', 'OPERATOR_GRASP_TASKS', 'ASSISTANCE_TWIST',
    'ASSISTANCE_ALPHA', 'ASSISTANCE_OBJECT', 'ARM_TRAJECTORY_COMMAND', 'ARM_TWIST_COMMAND', 'DIAGNOSTICS',
    'ASSISTANCE_ENABLE',
    'MSGTYPES', 'TOPIC_FOLDERS', 'MODEL_LATCHED_TOPICS', 'LATCHED_TOPICS', 'INPUT_TOPICS',
    'PLAN_TOPICS',
    'OUTPUT_TOPICS', 'MAX_FEATURES', 'MAX_NAME_LENGTH', 'MAX_JOINTS', 'MAX_MESSAGE_BYTES', 'check_message_size',
    'check_names', 'OBJECT_NAME', 'object_name_problem', 'check_object_names',
]

INTENT_W: Final = 'intent/w'
INTENT_OBJECTS: Final = 'intent/objects'
"""P(o): the probability of each object of a scene that the operator wants it, one dimension labelled with the
objects' names (the intent estimator over several objects, docs/several_objects.md)."""
INTENT_PRIOR: Final = 'intent/prior'
"""Task probabilities from another source (e.g. per-task classifiers), the intent estimator's prior."""
INTENT_V: Final = 'intent/v'
INTENT_CLARIFICATION: Final = 'intent/clarification'
MODEL_ACTIVE: Final = 'model/active'
MODEL_AMBIGUITY: Final = 'model/ambiguity'
MODEL_AMBIGUITY_SYMMETRIC: Final = 'model/ambiguity/symmetric'
MODEL_AMBIGUITY_PINSKER: Final = 'model/ambiguity/pinsker'
MODEL_QUERY: Final = 'model/query'
MODEL_POSTERIOR: Final = 'model/posterior'
OBJECT_POSE: Final = 'object/pose'
JOINT_STATES: Final = 'joint_states'
GRASP_POSE: Final = 'grasp/pose'
GRASP_JOINT_TARGETS: Final = 'grasp/joint_targets'
GRASP_TRAJECTORY: Final = 'grasp/trajectory'
GRASP_POSTERIOR: Final = 'grasp/posterior'
GRASP_FEATURES: Final = 'grasp/features'
GRASP_MARKERS: Final = 'grasp/markers'
DIAGNOSTICS: Final = '/diagnostics'
OPERATOR_TWIST: Final = 'operator/twist'
"""The operator's twist (e.g. a spacemouse or joystick teleop), the assistance node's input."""
OPERATOR_GRASP_TASKS: Final = 'operator/grasp_tasks'
"""A demonstrator's label of the next close (comma-separated task names), read from a session bag by the
``demonstrations`` command (:mod:`grasp_intent_ros.sessions.demonstrations`); no node subscribes to it."""
ASSISTANCE_TWIST: Final = 'assistance/twist'
"""The blended twist, for a servo (remap it to e.g. ``/servo_node/delta_twist_cmds``)."""
ASSISTANCE_ALPHA: Final = 'assistance/alpha'
"""The arbitration weight of each blended twist."""
ASSISTANCE_OBJECT: Final = 'assistance/object'
"""The object whose grasp the assistance over several objects follows (std_msgs/String, its name), latched: a state,
published at each change, that a late subscriber (the mock arm's ``grasp/close``) needs at once
(docs/several_objects.md)."""
ARM_TRAJECTORY_COMMAND: Final = 'arm_controller/joint_trajectory'
"""The mock arm's trajectory input (a joint_trajectory_controller's topic); the suite remaps it to grasp/trajectory."""
ARM_TWIST_COMMAND: Final = 'servo/delta_twist_cmds'
"""The mock arm's twist input (MoveIt Servo's topic); the suite remaps it to assistance/twist."""
ASSISTANCE_ENABLE: Final = 'assistance/enable'
"""Not a topic: the assistance node's switch, a service (std_srvs/SetBool; off, its output is the operator's twist)."""

_F64MA, _STRING = 'std_msgs/msg/Float64MultiArray', 'std_msgs/msg/String'
MSGTYPES: Final[Mapping[str, str]] = {
    INTENT_W: _F64MA,
    INTENT_OBJECTS: _F64MA,
    INTENT_PRIOR: _F64MA,
    INTENT_V: _F64MA,
    INTENT_CLARIFICATION: _STRING,
    MODEL_ACTIVE: _STRING,
    MODEL_AMBIGUITY: _F64MA,
    MODEL_AMBIGUITY_SYMMETRIC: _F64MA,
    MODEL_AMBIGUITY_PINSKER: _F64MA,
    MODEL_QUERY: _F64MA,
    MODEL_POSTERIOR: _F64MA,
    OBJECT_POSE: 'geometry_msgs/msg/PoseStamped',
    JOINT_STATES: 'sensor_msgs/msg/JointState',
    GRASP_POSE: 'geometry_msgs/msg/PoseStamped',
    GRASP_JOINT_TARGETS: 'sensor_msgs/msg/JointState',
    GRASP_TRAJECTORY: 'trajectory_msgs/msg/JointTrajectory',
    GRASP_POSTERIOR: _F64MA,
    GRASP_FEATURES: _F64MA,
    GRASP_MARKERS: 'visualization_msgs/msg/MarkerArray',
    DIAGNOSTICS: 'diagnostic_msgs/msg/DiagnosticArray',
    OPERATOR_TWIST: 'geometry_msgs/msg/TwistStamped',
    OPERATOR_GRASP_TASKS: _STRING,
    ASSISTANCE_TWIST: 'geometry_msgs/msg/TwistStamped',
    ASSISTANCE_ALPHA: 'std_msgs/msg/Float64',
    ASSISTANCE_OBJECT: _STRING,
    ARM_TRAJECTORY_COMMAND: 'trajectory_msgs/msg/JointTrajectory',
    ARM_TWIST_COMMAND: 'geometry_msgs/msg/TwistStamped',
}
"""Message type of every topic of the suite, by relative name (``/diagnostics`` is absolute)."""

TOPIC_FOLDERS: Final = frozenset(
    '/'.join(parts[:i]) for parts in (t.split('/')[:-1] for t in MSGTYPES if not t.startswith('/'))
    for i in range(1, len(parts) + 1))
"""Every folder of the relative names of :data:`MSGTYPES` ('intent', 'model', 'model/ambiguity', ...): a
recorder's topic prefix that ends in one selects topics of a namespace, any other prefix names a namespace
(:class:`~grasp_intent_ros.ros.recording.TopicSelection`), so no object of a scene may be named after one."""

MODEL_LATCHED_TOPICS: Final = (MODEL_ACTIVE, MODEL_AMBIGUITY, MODEL_AMBIGUITY_SYMMETRIC, MODEL_AMBIGUITY_PINSKER)
"""The model server's latched topics: the active model and its ambiguity."""
LATCHED_TOPICS: Final = (*MODEL_LATCHED_TOPICS, ASSISTANCE_OBJECT)
"""Topics the suite publishes latched (transient local, keep-last 1): a late subscriber gets the last message
(a recorder too: it subscribes to these transient local, ``ros.recording.declared_qos``)."""

INPUT_TOPICS: Final = (INTENT_W, OBJECT_POSE, JOINT_STATES)
"""Inputs a replay publishes again (relative names)."""
PLAN_TOPICS: Final = (GRASP_POSE, GRASP_JOINT_TARGETS, GRASP_TRAJECTORY, GRASP_POSTERIOR, GRASP_FEATURES)
"""The outputs of one plan (all carry the same stamp)."""
OUTPUT_TOPICS: Final = (INTENT_V, INTENT_CLARIFICATION, *PLAN_TOPICS)
"""Outputs compared by a replay (relative names), besides ``model/active`` and rejections."""
OBJECT_NAME: Final = re.compile(r'[A-Za-z][A-Za-z0-9_]*')
"""An object's name in a scene of several (its chain's namespace token): one ROS name token (letters, digits,
underscores, a letter first). A leading underscore, which ROS allows, is refused: it would hide the chain's topics
from ``ros2 topic list``."""


def object_name_problem(name: str) -> str:
    """Why ``name`` cannot name an object of a scene ('' if it can).

    Not :data:`OBJECT_NAME`, or a folder of the suite's topics (:data:`TOPIC_FOLDERS`: a recorder's
    ``--topics grasp/`` would select those, not the chain's).
    """
    if not OBJECT_NAME.fullmatch(name):
        return f'object name {name!r} is not a ROS name token (letters, digits and underscores, a letter first)'
    if name in TOPIC_FOLDERS:
        return (f'object name {name!r} is a folder of the suite\'s topics ({name}/...): a recorder\'s --topics '
                f'{name}/ would select those, not the chain\'s')
    return ''


def check_object_names(names: Sequence[str]) -> None:
    """Object names of a scene: each one that :func:`object_name_problem` accepts, none twice.

    Raises
    ------
    GraspIntentError
        Naming every bad one.
    """
    problems = [problem for name in names if (problem := object_name_problem(name))]
    problems += [f'object {name!r} is named twice' for name in sorted(set(names)) if list(names).count(name) > 1]
    if problems:
        raise GraspIntentError('; '.join(problems))


# ------------------------------------------------------------------------------------------ input caps
MAX_NAME_LENGTH: Final = 256
"""Longest accepted name (characters): a joint name, a frame id."""
MAX_JOINTS: Final = 64
"""Most joints accepted in one ``joint_states`` message."""
MAX_FEATURES: Final = 1024
"""Largest feature vector accepted on ``model/query`` (values)."""

MAX_MESSAGE_BYTES: Final[Mapping[str, int]] = {
    INTENT_W: 16 << 10,        # 10 tasks; labels of up to 10 task names
    INTENT_PRIOR: 16 << 10,    # as INTENT_W
    INTENT_OBJECTS: 16 << 10,  # a value and a name per object
    ASSISTANCE_OBJECT: 1 << 10,  # an object's name (a ROS name token)
    INTENT_V: 64 << 10,        # 1023 zones and their labels
    MODEL_QUERY: 64 << 10,     # MAX_FEATURES values and their labels
    OBJECT_POSE: 4 << 10,      # a pose and a frame id of MAX_NAME_LENGTH
    JOINT_STATES: 64 << 10,    # MAX_JOINTS names of MAX_NAME_LENGTH, positions, velocities, efforts
    MODEL_ACTIVE: 4 * MAX_DOCUMENT_CHARS + 64,  # a document of at most MAX_DOCUMENT_CHARS UTF-8 characters
    INTENT_CLARIFICATION: 64 << 10,  # a reason naming a model's zones
    GRASP_POSE: 4 << 10,       # as OBJECT_POSE
    GRASP_POSTERIOR: 64 << 10,  # 1023 zones, 10 tasks and their labels
    GRASP_FEATURES: 64 << 10,  # MAX_FEATURES values, their labels and a stamp label
    GRASP_JOINT_TARGETS: 64 << 10,  # as JOINT_STATES
    GRASP_TRAJECTORY: 1 << 20,  # as ARM_TRAJECTORY_COMMAND
    OPERATOR_TWIST: 4 << 10,   # a twist and a frame id of MAX_NAME_LENGTH
    ASSISTANCE_TWIST: 4 << 10,  # as OPERATOR_TWIST (the viewer's input)
    ASSISTANCE_ALPHA: 1 << 10,  # one float (the viewer's input)
    DIAGNOSTICS: 1 << 20,      # one publisher's statuses (the suite's texts capped at 1 kB; the viewer's input)
    ARM_TWIST_COMMAND: 4 << 10,
    ARM_TRAJECTORY_COMMAND: 1 << 20,  # e.g. 4,000 points of 9 joints with positions, velocities, accelerations
}
"""Largest serialized (CDR) message accepted on each input topic, bytes.

A node reads its inputs serialized and rejects a larger message before decoding it (so an oversized
message never becomes Python objects); each cap leaves ample room for the largest valid message.
"""


def check_message_size(topic: str, size: int, *, name: str = '') -> None:
    """Reject a serialized message of ``size`` bytes larger than the cap of ``topic`` (read as ``name``, if given).

    Raises
    ------
    GraspIntentError
        If ``size`` exceeds :data:`MAX_MESSAGE_BYTES` ``[topic]``.
    KeyError
        For a topic without a cap (not an input of the suite).
    """
    cap = MAX_MESSAGE_BYTES[topic]
    if size > cap:
        raise GraspIntentError(f'{name or topic}: oversized message of {size} bytes, the limit is {cap} bytes')


def check_names(names: Sequence[str], *, max_count: int, what: str) -> None:
    """At most ``max_count`` names of at most :data:`MAX_NAME_LENGTH` characters each.

    Raises
    ------
    GraspIntentError
        Naming the count or the first name that is too long (abbreviated).
    """
    if len(names) > max_count:
        raise GraspIntentError(f'{what}: {len(names)} names, the limit is {max_count}')
    for i, name in enumerate(names):
        if len(name) > MAX_NAME_LENGTH:
            raise GraspIntentError(f'{what}: name {i} has {len(name)} characters, the limit is '
                                   f'{MAX_NAME_LENGTH} ({name[:40]!r}...)')
