"""shared_control.calibration: the logistic map of the marginals and its log-loss fit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from grasp_intent_ros.errors import InvalidIntentError
from grasp_intent_ros.shared_control import parameters
from grasp_intent_ros.shared_control.calibration import calibrate, fit_calibration, model_calibration
from grasp_intent_ros.shared_control.estimator import EstimatorConfig, IntentEstimator
from grasp_intent_ros.shared_control.goals import goals_from_poses
from grasp_intent_ros.shared_control.parameters import ESTIMATOR, default_estimator_config, estimator_config

FLOOR = 0.01


def test_no_map_returns_w_clipped_exactly() -> None:
    w = np.array([0.0, 0.005, 0.2, 0.5, 0.8, 0.999, 1.0])
    assert_array_equal(calibrate(w, 1.0, 0.0, FLOOR), np.clip(w, FLOOR, 1 - FLOOR))  # to the last bit


def test_the_map_is_monotone_finite_and_in_range_for_any_input() -> None:
    w = np.r_[-np.inf, -1.0, np.linspace(0.0, 1.0, 2001), 2.0, np.inf]
    for slope, offset in ((1e-6, 0.0), (0.3, -2.0), (2.5, 0.7), (1e6, -1e6), (1e6, 1e6)):
        out = calibrate(w, slope, offset, FLOOR)
        assert np.all(np.isfinite(out))
        assert np.all((out >= FLOOR) & (out <= 1 - FLOOR))
        assert np.all(np.diff(out) >= 0.0), (slope, offset)


def test_a_slope_above_one_spreads_estimates_away_from_the_offsets_fixed_point() -> None:
    w = np.array([0.3, 0.5, 0.7])
    out = calibrate(w, 2.0, 0.0, FLOOR)
    assert out[0] < 0.3 and out[1] == pytest.approx(0.5, abs=1e-15) and out[2] > 0.7


def test_bad_parameters_and_nan_are_refused() -> None:
    for slope, offset, floor in ((0.0, 0.0, FLOOR), (-1.0, 0.0, FLOOR), (np.nan, 0.0, FLOOR), (1.0, np.inf, FLOOR),
                                 (1.0, 0.0, 0.5), (1.0, 0.0, 0.0)):
        with pytest.raises(InvalidIntentError):
            calibrate([0.5], slope, offset, floor)
    with pytest.raises(InvalidIntentError):
        calibrate([0.5, np.nan], 1.0, 0.0, FLOOR)


def _draws(slope: float, offset: float, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Estimates w in [0.05, 0.95] and outcomes drawn with probability sigmoid(slope logit(w) + offset)."""
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.05, 0.95, n)
    p = 1.0 / (1.0 + np.exp(-(slope * np.log(w / (1 - w)) + offset)))
    return w, (rng.uniform(size=n) < p).astype(np.float64)


def test_fit_to_calibrated_data_is_the_identity() -> None:
    w, y = _draws(1.0, 0.0, 100_000, 0)
    slope, offset = fit_calibration(w, y, FLOOR)
    # standard errors at n = 1e5 about 0.01 (slope) and 0.007 (offset): 4 sigma
    assert slope == pytest.approx(1.0, abs=0.04) and offset == pytest.approx(0.0, abs=0.03)


def test_fit_recovers_an_under_confident_estimators_map() -> None:
    w, y = _draws(2.0, -0.3, 100_000, 1)
    slope, offset = fit_calibration(w, y, FLOOR)
    assert slope == pytest.approx(2.0, abs=0.08) and offset == pytest.approx(-0.3, abs=0.04)
    # the fitted map lowers the mean log loss below the unmapped estimates'
    def log_loss(p: np.ndarray) -> float:
        return float(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))
    assert log_loss(calibrate(w, slope, offset, FLOOR)) < log_loss(w) - 0.01


def test_fit_of_separable_data_stays_finite_and_refuses_reversed_order() -> None:
    w = np.array([0.2, 0.3, 0.7, 0.8])
    slope, offset = fit_calibration(w, np.array([0.0, 0.0, 1.0, 1.0]), FLOOR)
    assert np.isfinite(slope) and np.isfinite(offset) and slope > 1.0
    with pytest.raises(InvalidIntentError):
        fit_calibration(w, np.array([1.0, 1.0, 0.0, 0.0]), FLOOR)
    for bad_w, bad_y in (([], []), ([0.5], [0.5]), ([np.nan], [1.0]), ([0.5, 0.5], [1.0])):
        with pytest.raises(InvalidIntentError):
            fit_calibration(bad_w, bad_y, FLOOR)


def test_the_estimators_w_is_its_marginals_mapped() -> None:
    poses = np.repeat(np.eye(4)[None], 3, axis=0)
    poses[:, :3, 3] = [[0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [-0.3, 0.0, 0.0]]
    goals = goals_from_poses(poses, [1, 2, 4], 3)
    plain = IntentEstimator(goals)
    mapped = IntentEstimator(goals, EstimatorConfig(calibration_slope=2.0, calibration_offset=0.5))
    for est in (plain, mapped):
        est.update(np.eye(4), np.r_[0.12, 0.0, 0.0, 0.0, 0.0, 0.0], 0.002)  # 0.24 mm: w inside its bounds
    assert_allclose(mapped.w, calibrate(plain.w, 2.0, 0.5, FLOOR), rtol=0, atol=1e-12)
    assert 1 / 3 < plain.w[0] < mapped.w[0] < 0.99  # the prior 1/3, raised by the motion, then by the map
    with pytest.raises(InvalidIntentError):
        EstimatorConfig(calibration_slope=0.0)
    with pytest.raises(InvalidIntentError):
        EstimatorConfig(calibration_offset=float('nan'))


def test_each_model_gets_its_listed_map_and_another_model_none() -> None:
    models, slopes, offsets = ['a', 'b'], [1.5, 0.8], [-0.1, 0.2]
    assert model_calibration('b', models, slopes, offsets) == (0.8, 0.2)
    assert model_calibration('c', models, slopes, offsets) == (1.0, 0.0)
    assert model_calibration(None, models, slopes, offsets) == (1.0, 0.0)
    for bad in ((['a'], [1.0, 2.0], [0.0]), (['a', 'a'], [1.0, 1.0], [0.0, 0.0]), (['a'], [0.0], [0.0]),
                (['a'], [1.0], [float('inf')])):
        with pytest.raises(InvalidIntentError):
            model_calibration('a', *bad)


def test_the_node_settings_pick_the_listed_models_map_and_none_by_default() -> None:
    defaults = {spec.name: spec.default for spec in ESTIMATOR}
    plain = estimator_config(defaults, 'cup_7zone')
    assert (plain.calibration_slope, plain.calibration_offset) == (1.0, 0.0)
    listed = {**defaults, 'calibration_models': ['cup_7zone'], 'calibration_slopes': [1.4],
              'calibration_offsets': [-0.1]}
    mapped = estimator_config(listed, 'cup_7zone')
    assert (mapped.calibration_slope, mapped.calibration_offset) == (1.4, -0.1)
    assert estimator_config(listed, 'flashlight_7zone').calibration_slope == 1.0
    with pytest.raises(InvalidIntentError):
        estimator_config({**listed, 'calibration_slopes': [1.0, 2.0]}, 'cup_7zone')


def test_the_default_settings_are_the_nodes_with_the_map_its_defaults_list(monkeypatch: pytest.MonkeyPatch) -> None:
    assert default_estimator_config('cup_7zone') == EstimatorConfig() == default_estimator_config('flashlight_7zone')
    listed = {'calibration_models': ['cup_7zone'], 'calibration_slopes': [1.4], 'calibration_offsets': [-0.1]}
    specs = tuple(replace(spec, default=listed.get(spec.name, spec.default)) for spec in ESTIMATOR)
    monkeypatch.setattr(parameters, 'ESTIMATOR', specs)
    assert default_estimator_config('cup_7zone') == replace(EstimatorConfig(), calibration_slope=1.4,
                                                            calibration_offset=-0.1)
    assert default_estimator_config('flashlight_7zone') == EstimatorConfig()
