"""The rclpy layer: the one place that knows both ROS messages and :mod:`grasp_intent_ros.method`.

The wire formats themselves are defined ROS-free in :mod:`grasp_intent_ros.wire`; this layer builds and
reads the rclpy objects.

Modules
-------
run
    ``run_node``: the Jazzy init / spin / shutdown idiom, written once (SIGINT and SIGTERM exit 0).
startup
    A node process tuned for a fast start and quick answers (``run``: no cyclic garbage collection until its
    code is loaded, OpenBLAS single-threaded, a short GIL switch interval; ``KernelWarmUp``: the compiled
    kernels loaded ahead); imports neither rclpy nor numpy.
realtime
    ``apply_thread_priority``: a node process's threads at Linux's ``SCHED_FIFO`` (opt-in; a warning, never a
    crash, without the privilege), reset on fork; ``thread_policies`` of a process, read from /proc.
qos
    QoS profiles: input (compatible with ``ros2 topic pub``), output, latched.
params
    ``declare_parameters``: a node's table of :class:`~grasp_intent_ros.parameters.ParamSpec` declared with
    ParameterDescriptors, validated together on every change and never half-applied.
diagnostics
    ``NodeDiagnostics``: counters, last error and timing of a node, published on ``/diagnostics``,
    and ``guard`` for subscription callbacks that must never raise.
inputs
    ``subscribe_input``: every input subscription; a message over its topic's size cap is rejected before
    it is decoded.
worker
    ``LatestOnlyWorker``: callbacks store the newest inputs, one thread handles the newest snapshot (and
    can take a subscription's messages itself, off the executor); ``InputThread``: a thread that takes an
    input's every message off the executor.
conversions
    Labelled and stamped Float64MultiArray, the grasp posterior, the model document on std_msgs/String,
    the message class of a suite topic.
robot
    PoseStamped <-> 4x4 transforms, joint states, joint trajectories.
clock
    ``now_seconds``: a node's clock (ROS time) in the float seconds the core takes.
model_follower
    ``ModelFollower``: a node's copy of the active model, read from ``model/active`` in a thread of its own.
clarification
    ``ClarificationRequests``: a node's requests for clarification on ``intent/clarification``, counted.
grasp_messages
    A plan's way out, in one module: ``GraspOutputs``, the planner's output stage (the checks, the messages
    of one planned grasp with its RViz markers, all or none, else a clarification request; the plan's
    diagnostics).
recording
    The recorder's plumbing: ``TopicSelection``, the offered QoS read from discovery, ``TopicRecorder`` (the
    selected topics subscribed as they appear, their messages put into a bag serialized), its command line.
compat
    Every workaround of rclpy internals, each naming the rclpy it works around (a test fails when rclpy
    changes, so that they are checked again).

Importing this package imports no submodule; each submodule but ``startup`` imports rclpy or the message
packages, and :mod:`grasp_intent_ros.method` never does.
"""
