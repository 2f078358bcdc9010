"""Recorded sessions paired, compared and summarised, ROS-free (numpy and rosbags; never rclpy).

A session is a rosbag2 bag of the node suite's topics (:mod:`grasp_intent_ros.bag` reads and writes it);
this package reads it as the method's values. The command lines that use it (replay, report) are in
:mod:`grasp_intent_ros.tools`.

Modules
-------
outputs
    Messages read into comparable values (:class:`~.outputs.Output`); rejections from ``/diagnostics``
    (:class:`~.outputs.RejectionTracker`); :class:`~.outputs.SessionError`.
pairing
    A session bag split into inputs and the outputs each caused (:class:`~.pairing.PairedSession` of
    :class:`~.pairing.Step` s, :func:`~.pairing.load_paired_session`); compaction of a recorded bag.
compare
    A step's recorded outputs against live ones at the replay's tolerances.
report_data
    What the report draws, by role and receive time (:class:`~.report_data.ReportData`,
    :func:`~.report_data.load_report_data`).

Imports: :mod:`~grasp_intent_ros.core`, :mod:`~grasp_intent_ros.bag` and :mod:`~grasp_intent_ros.protocol`
only (test/unit/test_static.py).
"""
