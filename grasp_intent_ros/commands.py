"""The package's commands, once: command name -> the module whose ``main`` it runs.

One table serves every way of starting them:

- ``ros2 run grasp_intent_ros <name>`` after a colcon build (setup.py installs one script per name into
  ``lib/grasp_intent_ros``, where ``ros2 run`` looks and no shell's PATH does);
- ``python -m grasp_intent_ros <name>`` and the one pip-installed script ``grasp-intent-ros <name>``
  (:mod:`grasp_intent_ros.__main__`), so that a pip install puts no generic name such as ``demo`` or
  ``train`` into a user's ``bin/``.

The node modules also run as ``python -m grasp_intent_ros.<node>``. setup.py reads this file without
importing the package, so it imports nothing.
"""

COMMANDS = {
    'intent_interpreter': 'intent_interpreter',
    'model_server': 'model_server',
    'grasp_planner': 'grasp_planner',
    'viewer': 'viewer',
    'assistance': 'assistance',
    'mock_arm': 'mock_arm',
    'intent_estimator': 'intent_estimator',
    'suite': 'tools.suite',
    'send_intent': 'tools.send_intent',
    'demo': 'tools.demo',
    'recorder': 'tools.recorder',
    'reindex': 'tools.reindex',
    'replay': 'tools.replay',
    'report': 'tools.report',
    'playback': 'tools.playback',
    'paper_tables': 'tools.paper_tables',
    'ambiguity_report': 'tools.ambiguity_report',
    'generate_data': 'dataset.generate_data',
    'train': 'dataset.train',
}
"""Command name -> module under ``grasp_intent_ros`` with a ``main()`` that reads ``sys.argv``."""

SCRIPT = 'grasp-intent-ros'
"""The one console script a pip install puts on PATH: ``grasp-intent-ros <command> [arguments]``."""
