"""shared_control.limits: the output twist's speed and acceleration limits."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from grasp_intent_ros.shared_control.limits import TwistLimiter


def test_limits_bound_speed_and_acceleration_and_never_pass_a_nan() -> None:
    limiter = TwistLimiter(0.2, 1.0, 1.0, 5.0)
    out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 0.01)
    assert_allclose(out, [0.01, 0, 0, 0, 0, 0.05], atol=1e-15)  # acceleration-limited from rest
    for _ in range(100):
        out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 0.01)
    assert_allclose(out, [0.2, 0, 0, 0, 0, 1.0], atol=1e-15)  # speed-limited
    out = limiter.limit(np.array([1.0, 0, 0, 0, 0, 10.0]), 5.0)  # a gap grants max_dt only
    assert np.all(np.isfinite(limiter.limit(np.full(6, np.nan), 0.01)))
    assert_allclose(limiter.stop(), 0.0, atol=0)
