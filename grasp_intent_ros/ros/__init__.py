"""The rclpy layer: the one place that knows both ROS messages and :mod:`grasp_intent_ros.core`.

Modules
-------
run
    ``run_node``: the Jazzy init / spin / shutdown idiom, written once (SIGINT and SIGTERM exit 0).
qos
    QoS profiles: input (compatible with ``ros2 topic pub``), output, latched.
params
    Parameters declared from a table of :class:`~grasp_intent_ros.ros.params.ParamSpec`, validated
    together on every change and never half-applied.
conversions
    Float64MultiArray <-> numpy with labelled dimensions (validated, raising the core's errors);
    the versioned model document carried by std_msgs/String.
diagnostics
    ``NodeDiagnostics``: counters, last error and timing of a node, published on ``/diagnostics``,
    and ``guard`` for subscription callbacks that must never raise.

Importing this package imports rclpy; :mod:`grasp_intent_ros.core` never does.
"""

__all__ = ['conversions', 'diagnostics', 'params', 'qos', 'run']
