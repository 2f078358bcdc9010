"""Recorded sessions: bags written, read and repaired; sessions replayed, compared, reported and played back.

ROS-free (numpy and rosbags; never rclpy) but the live replay (``replay``, ``replay_client``, ``replayers``) and the
fixture recording (``fixtures``), which run the nodes and talk to them.

Modules
-------
bag
    rosbag2 MCAP bags, generic: writer, queued writer, reader, repair, offered QoS, types.
outputs
    Messages read into comparable values (:class:`~.outputs.Output`); rejections from ``/diagnostics``
    (:class:`~.outputs.RejectionTracker`); :class:`~.outputs.SessionError`.
pairing
    A session bag split into inputs and the outputs each caused (:class:`~.pairing.PairedSession` of
    :class:`~.pairing.Step` s, :func:`~.pairing.load_paired_session`); compaction of a recorded bag.
scenes
    A session of several objects (one planning chain per object, the arm's joint states above them) paired
    chain by chain (:func:`~.scenes.load_paired_scene`).
compare
    A step's recorded outputs against live ones at the replay's tolerances.
closed_loop
    A shared-control session replayed by its outcome (the grasp reached, the pose offset).
report_data, report_summary, report
    What the report draws, by role and receive time; its summary.md (a scene's too); its figures and command line.
replay_client, replayers, replay
    The replay's rclpy client and engine; its command line (``--check``).
playback
    A session bag in the viewer's page, with a time slider (the ``viewer`` extra).
reindex
    The command line of the bag repair (:func:`grasp_intent_ros.sessions.bag.reindex`).
demonstrations
    Grasps demonstrated on an arm (closes of the hand in ``joint_states``, against ``object/pose``, labelled)
    as rows of the training CSV; the ``demonstrations`` command.
fixtures
    The session bags of bags/ recorded from real runs of the suite (``scripts/record_sessions.py``), and
    the recording both kinds of fixture share (the closed-loop ones are recorded by
    ``benchmarks/bench_shared_control.py --record``).

The recorder itself is a node (:mod:`grasp_intent_ros.nodes.recorder`).
"""
