"""The objects: their rules and prototypes, which generate the data and judge the benchmarks.

What judges a grasp (the paper's Table I features, as tested predicates) lives here and nowhere else: the
method, the planners, the estimator and the nodes never import this package (test/unit/test_static.py).

Modules
-------
demos
    Each object's rules and body, and a sampler of demonstrations.
judge
    The judge: the tasks a grasp serves by its object's rules, from a hand pose and finger closures.
train
    ``python -m grasp_intent_ros train``: fit a model from a demonstrations CSV.
generate_data
    ``python -m grasp_intent_ros generate_data``: regenerate config/data and config/models.
"""
