"""The suite's wire formats, once each, ROS-free (messages are read by their fields only).

Modules
-------
protocol
    Topics and their types, input size caps, labelled and stamped arrays (and the CDR fast path), the
    model document, diagnostics keys and levels, robot-side messages read as values.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method` and
:mod:`~grasp_intent_ros.mico`.
"""
