"""Planning a grasp for a target v on a model: the planners and the ranking of demonstrations.

Robot-free: a robot's constraint (the MICO's reachability) comes in as a callable.

Modules
-------
planner
    :func:`~grasp_intent_ros.planning.planner.plan`, every method ('task', 'lm', the scipy references).
ranking
    The demonstrations ranked by the tasks they serve (the default method 'task').

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method` and
:mod:`~grasp_intent_ros.kernels` only.
"""
