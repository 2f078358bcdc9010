"""The package's commands, once: command name -> the module whose ``main`` it runs.

One table serves every way of starting them:

- ``ros2 run grasp_intent_ros <name>`` after a colcon build (setup.py installs one script per name into
  ``lib/grasp_intent_ros``, where ``ros2 run`` looks and no shell's PATH does);
- ``python -m grasp_intent_ros <name>`` and the one pip-installed script ``grasp-intent-ros <name>``
  (:mod:`grasp_intent_ros.__main__`), so that a pip install puts no generic name such as ``demo`` or
  ``train`` into a user's ``bin/``.

The node modules also run as ``python -m grasp_intent_ros.nodes.<node>``. setup.py reads this file without
importing the package, so it imports nothing.
"""

COMMANDS = {
    'intent_interpreter': 'nodes.intent_interpreter',
    'model_server': 'nodes.model_server',
    'grasp_planner': 'nodes.grasp_planner',
    'viewer': 'nodes.viewer',
    'assistance': 'nodes.assistance',
    'mock_arm': 'nodes.mock_arm',
    'intent_estimator': 'nodes.intent_estimator',
    'scripted_operator': 'nodes.scripted_operator',
    'suite': 'launch.suite_command',
    'send_intent': 'cli.send_intent',
    'demo': 'launch.demo',
    'recorder': 'nodes.recorder',
    'reindex': 'sessions.reindex',
    'replay': 'sessions.replay',
    'report': 'sessions.report',
    'playback': 'sessions.playback',
    'demonstrations': 'sessions.demonstrations',
    'paper_tables': 'cli.paper_tables',
    'ambiguity_report': 'cli.ambiguity_report',
    'generate_data': 'objects.generate_data',
    'train': 'objects.train',
}
"""Command name -> module under ``grasp_intent_ros`` with a ``main()`` that reads ``sys.argv``."""

SCRIPT = 'grasp-intent-ros'
"""The one console script a pip install puts on PATH: ``grasp-intent-ros <command> [arguments]``."""
