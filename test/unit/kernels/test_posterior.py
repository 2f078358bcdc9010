"""The posterior's two computations agree: GraspModel's (numpy, BLAS) and the kernels' fixed-order reference."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.kernels import log_joints
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.resources import config_dir

MODELS = ('cup_7zone', 'cup_5zone', 'cup_4zone', 'flashlight_7zone')


@pytest.mark.parametrize('name', MODELS)
def test_the_fixed_order_reference_agrees_with_the_models_posterior(name: str) -> None:
    """At the demonstrations, the zone means and random points in the bounds (up to twice their width out).

    Tolerances: log joints within 1e-9 relative (their magnitude reaches 1e3 far out, and the two sum in
    different orders), posteriors within 1e-12 absolute (each a softmax of those).
    """
    model = GraspModel.load(config_dir() / 'models' / f'{name}.yaml')
    rng = np.random.default_rng(7)
    width = model.upper - model.lower
    xs = np.concatenate([model.demo_x, model.means,
                         rng.uniform(model.lower - width, model.upper + width, size=(200, model.features.dim))])
    lj, post = log_joints(xs, model.means, model.precisions, model.log_norm)
    assert_allclose(lj, model.log_joint(xs), rtol=1e-9, atol=1e-9)
    assert_allclose(post, model.posterior(xs), rtol=0, atol=1e-12)
    assert_allclose(post.sum(axis=1), 1.0, rtol=0, atol=1e-12)
