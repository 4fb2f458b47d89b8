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


def _design_rows(params, rng, count, n):
    """Return (speeds (count, n), frictions (count, n)): measured speeds, wear 0 .. 140."""
    design = np.sort(rng.uniform(1.0, 60.0, n))
    speeds = design + rng.uniform(-0.004, 0.004, (count, n))
    wear = rng.uniform(0.0, 140.0, (count, 1))
    temperature = rng.uniform(params.temperature_min_degc, params.temperature_max_degc,
                              (count, 1))
    level = core.fm.friction(speeds, params.load_mean, temperature, wear, params.model)
    return speeds, level + rng.normal(0.0, params.sigma, (count, n))


@pytest.mark.parametrize('n', [2, 4, 9, 20])
def test_stacked_start_grids_equal_each_rows_own(n):
    """The start points of rows at their own speeds equal each row's grid_starts, bit for bit."""
    from robot_wear_monitor.estimation import batch
    params = load_parameter_set(None)
    speeds, frictions = _design_rows(params, np.random.default_rng(n), 21, n)
    # some rows far off: start grids of other sizes in the same batch
    speeds[::5] *= np.linspace(0.2, 1.8, n)
    whiten, _ = batch.whitening_rows(speeds, params)
    data_w = np.einsum('bn,bmn->bm', frictions, whiten)
    t0, w0 = batch._grid_starts_rows(speeds, whiten, data_w, params)
    sizes = set()
    for i in range(speeds.shape[0]):
        problem = core._WhitenedProblem(speeds[i].copy(), params)
        assert problem.whiten.tobytes() == whiten[i].tobytes()
        t_alone, w_alone = problem.grid_starts(data_w[i:i + 1])
        assert t_alone.tobytes() == t0[i:i + 1].tobytes()
        assert w_alone.tobytes() == w0[i:i + 1].tobytes()
        sizes.add(problem._grid()[2:4])
    assert len(sizes) >= 2  # rows of different start-grid sizes, grouped


@pytest.mark.parametrize('n', [2, 4, 9, 20])
def test_stacked_profiles_equal_each_rows_own(n):
    """The stacked interval profiles hold each row's Profile arrays, bit for bit."""
    from robot_wear_monitor.estimation import batch_intervals, profile_likelihood
    params = load_parameter_set(None)
    speeds, _ = _design_rows(params, np.random.default_rng(n), 9, n)
    grid = profile_likelihood.wear_grid(params.wear_max)
    stacked = batch_intervals._StackedProfile.build(speeds, params, grid)
    assert stacked.t_grid.shape == (profile_likelihood.T_POINTS,)
    for i in range(speeds.shape[0]):
        alone = profile_likelihood.Profile(speeds[i].copy(), params, grid.copy())
        for name in ('whiten', 'nom', 'wear', 'nom2', 'wear2'):
            assert getattr(alone, name).tobytes() == \
                np.ascontiguousarray(getattr(stacked, name)[i]).tobytes(), name
        assert alone.cross.tobytes() == stacked.cross(slice(i, i + 1))[0].tobytes()
        assert np.float64(alone.const).tobytes() == stacked.const[i].tobytes()
        assert alone.t_grid.tobytes() == stacked.t_grid.tobytes()


def test_a_trend_grid_equal_to_a_rows_extended_grid_gets_the_whole_trend_row(rows):
    """A row whose interval profile runs on the trend grid itself, extended: its full row."""
    from robot_wear_monitor.estimation import profile_likelihood
    from robot_wear_monitor.estimation.batch_intervals import _extended_grid
    params, speeds, frictions = rows
    values = [np.asarray(f)[None, :] for f in frictions]
    estimates = estimate_wear_rows(speeds, values, params=params)
    base = profile_likelihood.wear_grid(params.wear_max)
    i = next(i for i, (s, e) in enumerate(zip(speeds, estimates))
             if s.size > 1 and 1.5 * e.wear[0] > base[-1])
    grid = _extended_grid(base, float(estimates[i].wear[0]))
    assert grid.size > base.size
    _, trend_rows = wear_intervals_rows([speeds[i]], [values[i]], [estimates[i]],
                                        params=params, trend_grid=grid)
    expected = profile_log_likelihood(speeds[i], values[i], params=params, wear_grid=grid)
    assert expected.shape == (1, grid.size)
    assert trend_rows[0].shape == expected.shape and np.array_equal(trend_rows[0], expected)
