"""The posterior's two computations agree: GraspModel's (numpy, BLAS) and the kernels' fixed-order reference.

And the kernels' shortcut from known posteriors (fit_and_distance) gives score's bits.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.kernels import fit_and_distance, log_joints, score
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


@pytest.mark.parametrize('name', MODELS)
def test_the_fit_and_distance_of_known_posteriors_are_score_s_bits(name: str) -> None:
    """log_joints' posteriors are score's, and f and the distance from them are score's, bit for bit.

    What lets the task ranking keep the demonstrations' posteriors per model and score only v and the reference.
    """
    model = GraspModel.load(config_dir() / 'models' / f'{name}.yaml')
    rng = np.random.default_rng(11)
    width = model.upper - model.lower
    xs = np.concatenate([model.demo_x, rng.uniform(model.lower - width, model.upper + width,
                                                   size=(100, model.features.dim))])
    post = log_joints(xs, model.means, model.precisions, model.log_norm)[1]
    post.setflags(write=False)  # as the ranking keeps them
    for v in rng.dirichlet(np.ones(len(model.zones)), size=5):
        x_ref = xs[int(rng.integers(xs.shape[0]))]
        expected = score(xs, v, model.means, model.precisions, model.log_norm, x_ref, model.feature_scale)
        assert np.array_equal(post, expected[0])
        f, dist = fit_and_distance(post, v, xs, x_ref, model.feature_scale)
        assert np.array_equal(f, expected[1]) and np.array_equal(dist, expected[2])
