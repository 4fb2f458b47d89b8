"""Plausibility checks: valid levels pass, each kind of wrong level fails with its reason."""

from __future__ import annotations

import numpy as np
import pytest
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.estimation.plausibility import check_levels, friction_range
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import load_parameter_set

PARAMS = load_parameter_set()
SPEEDS = np.array([2.1, 28.5, 35.1, 41.7])


def _levels(rng: np.random.Generator, *, wear: float, temperature: float, load: float
            ) -> np.ndarray:
    model = friction(SPEEDS, load, temperature, wear, PARAMS.model)
    return np.asarray(model, dtype=float) + rng.normal(0.0, PARAMS.sigma, SPEEDS.size)


def _check(levels: np.ndarray, speeds: np.ndarray = SPEEDS, **options):
    estimate = estimate_wear(speeds, levels, params=PARAMS)[0]
    return check_levels(speeds_rad_s=speeds, frictions=levels, params=PARAMS,
                        estimate=estimate, **options)


def test_levels_of_the_model_pass_at_the_rate_the_p_value_cutoff_allows():
    rng = np.random.default_rng(3)
    verdicts = [_check(_levels(rng, wear=rng.uniform(0, 80), temperature=rng.uniform(30, 50),
                               load=rng.normal(0.5, 0.1)))
                for _ in range(300)]
    assert sum(not v.valid for v in verdicts) <= 2  # 1e-4 cutoff, a wide friction range


def test_the_friction_range_contains_the_model_at_its_corners():
    low, high = friction_range(SPEEDS, params=PARAMS)
    for wear in (0.0, PARAMS.wear_max):
        for temperature in (PARAMS.temperature_min_degc, PARAMS.temperature_max_degc):
            model = friction(SPEEDS, PARAMS.load_mean, temperature, wear, PARAMS.model)
            assert np.all(low < model) and np.all(model < high)


@pytest.mark.parametrize('factor', [0.1, 8.0])
def test_levels_scaled_by_a_wrong_torque_scale_name_the_torque_scale(factor):
    rng = np.random.default_rng(5)
    levels = _levels(rng, wear=40.0, temperature=40.0, load=0.5) * factor
    verdict = _check(levels)
    assert not verdict.valid and 'friction_range' in verdict.failed
    assert 'torque scale' in verdict.likely_cause
    # the factor that fits is the inverse of the mistake, within the grid's steps
    shown = float(verdict.likely_cause.split('levels x ')[1].split()[0])
    assert shown == pytest.approx(1 / factor, rel=0.35)  # wear and T trade with the scale


def test_speeds_scaled_by_a_wrong_gear_ratio_name_the_gear_ratio_and_its_factor():
    rng = np.random.default_rng(6)
    levels = _levels(rng, wear=10.0, temperature=40.0, load=0.5)
    verdict = _check(levels, speeds=SPEEDS * 0.5, expected_speeds_rad_s=tuple(SPEEDS))
    assert not verdict.valid and 'speeds_configured' in verdict.failed
    assert 'gear ratio' in verdict.likely_cause and '0.5 times' in verdict.likely_cause
    outside = _check(levels[:1], speeds=SPEEDS[:1] / 150.0)
    assert 'speed_range' in outside.failed and 'gear ratio' in outside.likely_cause


def test_a_fit_that_fails_or_a_wear_beyond_the_set_is_invalid():
    same = _check(np.full(4, 0.5))
    assert {'model_check', 'wear_range', 'friction_range'} <= set(same.failed)
    assert 'saturated' in same.likely_cause
    zero = _check(np.zeros(4))
    assert not zero.valid and 'friction_range' in zero.failed
    assert zero.to_json()['valid'] is False and zero.to_json()['invalid_reasons']
