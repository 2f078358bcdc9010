"""Tools around the nodes.

The node suite as processes, the demo, sending intents, recording, replaying and reporting sessions, the
paper's tables. The ROS-free session analysis they use is :mod:`grasp_intent_ros.sessions`.

Modules
-------
suite
    :class:`~grasp_intent_ros.tools.suite.NodeSuite`: the nodes as processes on one loopback-only domain.
replay_client, replay
    The replay's rclpy client and engine; its command line.
report
    The session report's figures and summary, and its command line.
playback
    A session bag in the viewer's page, with a time slider (the ``viewer`` extra).
reindex
    The command line of the bag repair (:func:`grasp_intent_ros.bag.reindex`).
recorder, send_intent, demo
    Record a session bag; send one intent and print the grasp; the README's demo.
paper_tables, ambiguity_report, cli
    The paper's tables and Table V from the library alone; the shared command-line error handler.

Each command runs as ``python -m grasp_intent_ros <name>`` (the table: :mod:`grasp_intent_ros.commands`).
"""
