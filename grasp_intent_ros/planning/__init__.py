"""Planning a grasp for a target v on a model: the planners and the ranking of demonstrations.

Robot-free: a robot's constraint (the MICO's reachability) comes in as a callable.

Modules
-------
planner
    :func:`~grasp_intent_ros.planning.planner.plan`, the one entry to every method.
common
    What the methods share: the result types (:class:`~.common.PlanResult`, :class:`~.common.Candidate`),
    the tolerances, the feasible set, Algorithm 1's starts, the choice order, the fitting methods' search.
task
    Method 'task' (the default): the demonstration that serves the likely tasks.
lm
    Method 'lm' (the paper's planner): P matched to v by log-odds projection, else least squares.
scipy_methods
    Methods 'slsqp' and 'trust-constr' (the paper's solvers, scipy) and the multi-start oracle.
options
    The methods and their typed options (one class per method; an option a method does not use is an error).
ranking
    The demonstrations ranked by the tasks they serve (the default method 'task').
robustness
    The execution noise (where the arm lands around a plan) and the estimate of success as executed.

Imports of the package: :mod:`~grasp_intent_ros.errors`, :mod:`~grasp_intent_ros.method` and
:mod:`~grasp_intent_ros.kernels` only.
"""
