"""The paper's method, free of the robot and of ROS: intent (w -> u -> v), the grasp model, ambiguity.

Nothing here knows the MICO's joints, a planner's search or a message: a model is Gaussians over a feature
space, fitted to labelled demonstrations, with a posterior over its zones.

Modules
-------
intent
    Paper eqs. 3-4: task probabilities w -> joint task events u -> the target v over zones; clarification.
model
    The multi-task grasp model (one Gaussian per zone, inclusive labelling) and its posterior P(zone | x);
    its document (YAML).
ambiguity
    Paper eqs. 5-8: KL-divergence matrices between the tasks' grasp distributions.
data
    Labelled demonstrations (CSV).
features
    The feature space a model is over (names, units, bounds); the MICO's 3-finger layout is the default.
body
    The object's solid body, a field of the model document: where the palm may not go.
log_space
    Probabilities kept as logarithms: log-sum-exp and softmax, shifted by the largest value.
registry
    The models of a directory, loaded on demand, a few kept.
safe_yaml
    YAML documents read and written safely (size caps, no aliases).
parameters (ROS-free tables)
    The intent interpreter node's and the model server node's parameter tables; ``task_names``.

Imports of the package: :mod:`grasp_intent_ros.errors`, :mod:`grasp_intent_ros.resources`,
:mod:`grasp_intent_ros.parameters` and the compiled
posterior (:mod:`grasp_intent_ros.kernels`) only (test/unit/test_static.py).
"""
