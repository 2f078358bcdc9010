"""Thin command lines on the library and on a running suite.

Modules
-------
send_intent
    Send one intent and print the grasp.
paper_tables, ambiguity_report
    The paper's tables and Table V from the library alone.
user_errors
    The command lines' common error handling (a user's mistake is one line on stderr, exit code 2).

Each command runs as ``python -m grasp_intent_ros <name>`` (the table: :mod:`grasp_intent_ros.commands`);
the suite, the demo and the session commands live with their feature (:mod:`~grasp_intent_ros.launch`,
:mod:`~grasp_intent_ros.sessions`).
"""
