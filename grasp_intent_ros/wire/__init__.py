"""The suite's wire formats, once each, ROS-free (messages are read by their fields only).

Modules
-------
topics
    Every topic and its message type, the topic groups a replay uses, the input size caps.
arrays
    Labelled and stamped Float64MultiArrays, the grasp posterior and features, and the CDR fast path that
    reads a flat vector (or a repeated layout) from its serialized bytes.
model_document
    The model document on ``model/active``: header (name, version, sha256) and YAML, written, read, checked.
diagnostics
    The diagnostics levels, status names and keys (each key defined once).
robot_state
    Robot-side messages read as values: a PoseStamped as a transform, a JointState's positions by name, a twist.
joint_states
    The arm's ``joint_states`` as a real arm's driver publishes them (split, reordered, velocity-less): the
    latest position of each joint and its staleness, the hand, the fingers at rest (from positions).

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method` and
:mod:`~grasp_intent_ros.mico`.
"""
