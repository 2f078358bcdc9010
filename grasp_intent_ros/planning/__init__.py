"""Planning a grasp for a target v on a model: the planners and the ranking of demonstrations.

Robot-free: a robot's constraint (the MICO's reachability) comes in as a callable.

Modules
-------
planner
    :func:`~grasp_intent_ros.planning.planner.plan`, every method ('task', 'lm', the scipy references).
options
    The methods and their typed options (one class per method; an option a method does not use is an error).
ranking
    The demonstrations ranked by the tasks they serve (the default method 'task').
robustness
    The execution noise (where the arm lands around a plan) and the estimate of success as executed.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method` and
:mod:`~grasp_intent_ros.kernels` only.
"""
