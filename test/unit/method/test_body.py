"""Object bodies: signed distances with the right sign and gradient, push-out, documents."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import ModelFormatError
from grasp_intent_ros.kernels import feasible
from grasp_intent_ros.method.body import Box, Cylinder, ObjectBody
from grasp_intent_ros.objects.demos import CUP, FLASHLIGHT

CUP_BODY = CUP.body()
LYING = Cylinder(centre=np.array([0.0, 0.0, 0.02]), axis=np.array([1.0, 0.0, 0.0]), radius=0.02, length=0.2)
BOX = Box(centre=np.array([0.1, 0.0, 0.05]), half_extents=np.array([0.02, 0.03, 0.05]))

points = st.lists(st.floats(-0.3, 0.3, allow_nan=False), min_size=3, max_size=3).map(np.array)


def test_cylinder_distances_at_known_points() -> None:
    cyl = CUP_BODY.primitives[0]
    p = np.array([[0.10, 0.0, 0.05],    # 6 cm beside the wall
                  [0.0, 0.0, 0.13],     # 3 cm above the top
                  [0.07, 0.0, 0.14],    # beyond the rim's edge: 3 cm out, 4 cm up
                  [0.0, 0.0, 0.05],     # on the axis, mid-height: 4 cm deep (the wall is nearest)
                  [0.0, 0.0, 0.095]])   # 5 mm under the top
    sd, grad = cyl.distance(p)
    assert_allclose(sd, [0.06, 0.03, 0.05, -0.04, -0.005], atol=1e-12)
    assert_allclose(grad[0], [1.0, 0.0, 0.0], atol=1e-12)
    assert_allclose(grad[1], [0.0, 0.0, 1.0], atol=1e-12)
    assert_allclose(grad[2], [0.6, 0.0, 0.8], atol=1e-12)
    assert_allclose(grad[4], [0.0, 0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize('prim', [CUP_BODY.primitives[0], LYING, BOX], ids=['upright', 'lying', 'box'])
@settings(max_examples=200, deadline=None)
@given(p=points)
def test_gradient_is_a_unit_normal_matching_finite_differences(prim: Cylinder | Box, p: np.ndarray) -> None:
    sd, grad = prim.distance(p[None, :])
    assert np.linalg.norm(grad[0]) == pytest.approx(1.0, abs=1e-9)
    h = 1e-7
    forward = np.array([(prim.distance((p + h * e)[None, :])[0][0] - sd[0]) / h for e in np.eye(3)])
    backward = np.array([(sd[0] - prim.distance((p - h * e)[None, :])[0][0]) / h for e in np.eye(3)])
    # the distance is differentiable away from edges and the medial surface: there both sides agree
    if np.allclose(forward, backward, atol=1e-4):
        assert_allclose(grad[0], 0.5 * (forward + backward), atol=1e-4)


def test_inside_and_outside_agree_with_the_demonstration_rules() -> None:
    rng = np.random.default_rng(0)
    palms = rng.uniform([-0.1, -0.1, -0.02], [0.1, 0.1, 0.15], size=(500, 3))
    x = np.zeros((500, 10))
    x[:, :3] = palms
    for obj in (CUP, FLASHLIGHT):
        # the rules measure the palm against the main cylinder; the handle and the switch are further parts
        sd = ObjectBody(obj.body().primitives[:1]).distance(palms)[0]
        rule = np.array([obj.palm_to_body(row) for row in x])
        assert_allclose(np.maximum(sd, 0.0), rule, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(p=points)
def test_push_out_reaches_the_margin_and_leaves_clear_points(p: np.ndarray) -> None:
    body = ObjectBody((CUP_BODY.primitives[0], BOX), margin=0.002)
    out = body.push_out(p[None, :])
    assert body.distance(out)[0][0] >= body.margin - 1e-12
    if body.distance(p[None, :])[0][0] >= body.margin:
        assert_allclose(out[0], p)


@settings(max_examples=200, deadline=None)
@given(p=points)
def test_the_planners_compiled_projection_pushes_out_like_push_out(p: np.ndarray) -> None:
    """kernel_arrays carry the body to the compiled kernels: the same push-out as ObjectBody's own."""
    body = ObjectBody((CUP_BODY.primitives[0], BOX), margin=0.002)
    x = np.concatenate([p, [0.0, 0.0, 1.0], np.zeros(4)])[None, :]
    out = feasible(x, np.full(10, -1.0), np.full(10, 1.0), 3, 6, body.kernel_arrays)
    assert_allclose(out[0, :3], body.push_out(p[None, :])[0], atol=1e-12)
    assert_allclose(out[0, 3:], x[0, 3:])


def test_document_round_trip_and_errors() -> None:
    body = ObjectBody((CUP_BODY.primitives[0], BOX), margin=0.003)
    again = ObjectBody.from_document(body.to_document())
    assert again.margin == 0.003
    probe = np.array([[0.05, 0.01, 0.02], [0.2, 0.2, 0.2]])
    assert_allclose(again.distance(probe)[0], body.distance(probe)[0])
    with pytest.raises(ModelFormatError, match="type must be 'cylinder' or 'box'"):
        ObjectBody.from_document({'primitives': [{'type': 'sphere'}]})
    with pytest.raises(ModelFormatError, match='lacks field'):
        ObjectBody.from_document({'primitives': [{'type': 'box', 'centre': [0, 0, 0]}]})
    with pytest.raises(ModelFormatError, match='radius must be positive'):
        ObjectBody.from_document({'primitives': [{'type': 'cylinder', 'centre': [0, 0, 0], 'axis': [0, 0, 1],
                                                  'radius': -1, 'length': 1}]})
    with pytest.raises(ModelFormatError, match='at least one primitive'):
        ObjectBody(())
    with pytest.raises(ModelFormatError, match='margin'):
        ObjectBody((BOX,), margin=float('nan'))


@pytest.mark.parametrize(('prim', 'span'), [
    (Cylinder(np.array([0.01, -0.02, 0.05]), np.array([0.3, 0.2, 1.0]), 0.04, 0.1), 0.08),
    (Box(np.array([0.06, 0.0, 0.05]), np.array([0.01, 0.005, 0.025])), 0.03)])
def test_the_bounding_radius_holds_the_primitive_and_is_reached(prim: Cylinder | Box, span: float) -> None:
    # every point inside the primitive (sampled in a cube of half-side span about it, which holds it) lies within
    # bounding_radius of its centre (1e-9 m), and the farthest sampled come within 5 % of it
    rng = np.random.default_rng(3)
    points = prim.centre + rng.uniform(-span, span, (200_000, 3))
    inside = points[prim.distance(points)[0] <= 0.0]
    reach = np.linalg.norm(inside - prim.centre, axis=1)
    assert inside.shape[0] > 100 and reach.max() <= prim.bounding_radius + 1e-9
    assert reach.max() >= 0.95 * prim.bounding_radius
