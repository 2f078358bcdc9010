"""Starting the suite: the nodes as processes on one loopback-only domain, and the README's demo.

Modules
-------
suite
    :class:`~grasp_intent_ros.launch.suite.NodeSuite`: the nodes as processes, their environment.
process
    :class:`~grasp_intent_ros.launch.process.NodeProcess`: one node process, its logs, its stop and its judgement.
parent_death
    :func:`~grasp_intent_ros.launch.parent_death.ended_with_this_process`: a node process ends with its launcher.
objects
    :func:`~grasp_intent_ros.launch.objects.parse_objects`: several objects in one scene, one planning chain each.
suite_command
    ``python -m grasp_intent_ros suite``: the suite started, its output echoed, stopped on a signal.
demo
    ``python -m grasp_intent_ros demo``: the paper's intent cases sent to a running suite, then its closed loop.
demo_loop
    The demo's closed loop: the scripted operator helped by the assistance on the mock MICO, then without it.
"""
