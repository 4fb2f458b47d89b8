"""
Estimates, intervals and likelihood rows of many experiments at once equal one at a time.

Rows at their own speeds (N = 1 .. 6 levels, at the bounds of T and w, wear beyond the wear
grid's end so that the temperature profile's grid is extended) are compared exactly with
:func:`estimate_wear`, :func:`wear_intervals` and :func:`profile_log_likelihood` row by row.
"""

import numpy as np
import pytest
from robot_wear_monitor.estimation import estimator as core
from robot_wear_monitor.estimation.batch import estimate_wear_rows
from robot_wear_monitor.estimation.batch_intervals import wear_intervals_rows
from robot_wear_monitor.estimation.intervals import profile_log_likelihood, wear_intervals
from robot_wear_monitor.estimation.trend import TrendConfig
from robot_wear_monitor.model.params import load_parameter_set


@pytest.fixture(scope='module')
def rows():
    """Return (params, speeds, frictions): 60 experiments at their own measured speeds."""
    params = load_parameter_set(None)
    rng = np.random.default_rng(3)
    designs = {1: [30.0], 2: [10.0, 40.0], 3: [2.1, 20.0, 41.7], 4: [2.1, 28.5, 35.1, 41.7],
               6: [5.0, 12.0, 20.0, 28.0, 35.0, 42.0]}
    speeds, frictions = [], []
    for i in range(60):
        n = [1, 2, 3, 4, 4, 4, 6][i % 7]
        # measured speeds a few mrad/s off the design's (one calibration per design)
        levels = np.asarray(designs[n]) + rng.uniform(-0.004, 0.004, n)
        wear = [0.0, 5.0, 40.0, 90.0, 140.0][i % 5]
        temperature = [params.temperature_min_degc, 35.0, params.temperature_max_degc][i % 3]
        level = core.fm.friction(levels, params.load_mean, temperature, wear, params.model)
        speeds.append(levels)
        frictions.append(level + rng.normal(0.0, params.sigma, n) * (i % 4))
    return params, speeds, frictions


def _equal(alone, row, names):
    for name in names:
        a, b = np.asarray(getattr(alone, name)), np.asarray(getattr(row, name))
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert np.array_equal(a, b, equal_nan=True), name


def test_estimate_wear_rows_equals_estimate_wear_row_by_row(rows):
    """Each row's estimate is estimate_wear's, number for number."""
    params, speeds, frictions = rows
    batch = estimate_wear_rows(speeds, frictions, params=params)
    assert len(batch) == len(speeds)
    on_bound = 0
    for s, f, row in zip(speeds, frictions, batch):
        alone = core.estimate_wear(s, f, params=params)
        assert row.n_levels == alone.n_levels and len(row) == 1
        _equal(alone, row, ('temperature_degc', 'wear', 'covariance', 'temperature_at_bound',
                            'wear_at_bound', 'chi2', 'dof', 'p_value', 'speeds_rad_s'))
        on_bound += bool(alone.wear_at_bound[0] or alone.temperature_at_bound[0])
    assert on_bound >= 5  # the bounds' held-variable steps are compared too


def test_wear_intervals_rows_equal_wear_intervals_row_by_row(rows):
    """Each row's interval and trend row are wear_intervals' and profile_log_likelihood's."""
    params, speeds, frictions = rows
    values = [np.asarray(f)[None, :] for f in frictions]
    estimates = estimate_wear_rows(speeds, values, params=params)
    grid = TrendConfig(threshold=40.0).wear_grid
    intervals, trend_rows = wear_intervals_rows(speeds, values, estimates, params=params,
                                                trend_grid=grid)
    extended = 0
    for s, v, e, interval, row in zip(speeds, values, estimates, intervals, trend_rows):
        alone = wear_intervals(s, v, params=params, estimates=e)
        _equal(alone, interval, ('wear_low', 'wear_high', 'temperature_low',
                                 'temperature_high', 'wear_high_at_grid_end'))
        assert interval.level == alone.level
        expected = profile_log_likelihood(s, v, params=params, wear_grid=grid)
        assert row.shape == expected.shape and np.array_equal(row, expected)
        extended += bool(s.size > 1 and 1.5 * e.wear[0] > params.wear_max)
    assert extended >= 2  # rows whose temperature profile runs on an extended wear grid
