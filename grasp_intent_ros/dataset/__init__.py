"""The data-set side: demonstrations from documented rules, training, the shipped data and models.

Not the method (:mod:`grasp_intent_ros.core` never imports this package).

Modules
-------
demos
    The paper's Table I subtle features as tested predicates, and a sampler of demonstrations.
train
    ``python -m grasp_intent_ros train``: fit a model from a demonstrations CSV.
generate_data
    ``python -m grasp_intent_ros generate_data``: regenerate config/data and config/models.
"""
