"""Tools around the nodes.

The node suite as processes, the demo, sending intents, recording, replaying and reporting sessions, the
paper's tables.

Modules
-------
suite
    :class:`~grasp_intent_ros.tools.suite.NodeSuite`: the nodes as processes on one loopback-only domain.
session, compare
    ROS-free: a session bag split into inputs and their outputs; recorded vs live answers compared.
replay_client, replay
    The replay's rclpy client and engine; its command line.
report_data, report
    A session bag loaded for the report (ROS-free); the figures and summary, and the command line.
playback
    A session bag in the viewer's page, with a time slider (the ``viewer`` extra).
recorder, send_intent, demo
    Record a session bag; send one intent and print the grasp; the README's demo.
paper_tables, ambiguity_report, cli
    The paper's tables and Table V from the library alone; the shared command-line error handler.

Each command runs as ``python -m grasp_intent_ros.<name>`` (a thin alias module at the package top).
"""
