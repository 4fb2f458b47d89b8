"""
Tests of the profile-likelihood intervals of w and T (estimation/intervals.py).

Data come from the independent generator ``test/wear_testing/independent_robot.py`` (model (8)
written without the package): levels = model(v, load ~ N(0.5, 0.1), T ~ U[30, 50], w) +
N(0, sigma).  Reference log-likelihoods are computed here from that model and scipy, not from
the package.

The cutoff of the likelihood-ratio statistic is calibrated by the package's own simulation of
(9) (``calibrate_cutoffs``); the coverage is checked here on the independent generator.

Coverage of the chi2_1 cutoff (Wilks), 4000 experiments per case (seed 7), 95 %:

    N     w = 0    w = 5    w = 35   w = 60
    4     99.4     99.2     96.5     96.8
    2     99.4     99.4     97.4     97.7
    1     97.0     97.6     95.5     95.2

Near w = 0 the wear profile (7) is invisible (|tilde tau_f| < 1e-4 = 0.02 sigma for w < 9 at
28-42 rad/s) and w = 0 is a bound: the likelihood-ratio statistic at the truth is then mostly 0,
so the chi2_1 interval over-covers there; at w = 35, 60 the temperature bounds make it
over-cover a little.  The calibrated cutoff (about 1.2-1.9 near w = 0 for N = 2, 4) brings every
case into 93-98 %.
"""

import numpy as np
import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.estimation.intervals import (calibrate_cutoffs, profile_log_likelihood,
                                                     wear_intervals, WearInterval, WearIntervals)
from robot_wear_monitor.estimation.profile_likelihood import wear_grid, WEAR_GRID_MAX
from robot_wear_monitor.model.params import load_parameter_set
from scipy import integrate, optimize, stats
from wear_testing import independent_robot as robot

PARAMS = load_parameter_set()
SPEEDS = {4: (2.1, 28.5, 35.1, 41.7), 2: (35.1, 41.7), 1: (35.1,)}
WEARS = (0.0, 5.0, 35.0, 60.0)
RUNS = 1500  # experiments per (N, w); Monte Carlo std of a coverage near 97 %: 0.44 %
Q95 = stats.chi2.ppf(0.95, 1)


def _experiments(n_levels, wear, runs, seed):
    """Friction levels (runs, N) and true temperatures from the independent model."""
    rng = np.random.default_rng(seed)
    v = np.asarray(SPEEDS[n_levels])
    temps = rng.uniform(30.0, 50.0, runs)
    loads = rng.normal(0.5, 0.1, runs)
    y = np.array([robot.friction_model(v, load, t, wear) for load, t in zip(loads, temps)])
    return y + rng.normal(0.0, PARAMS.sigma, y.shape), temps


def _reference_covariance(speeds):
    """Sigma(Phi) of (14) from the independent model (it is linear in the load)."""
    v = np.asarray(speeds)
    m = robot.friction_model(v, 1.0, 40.0, 10.0) - robot.friction_model(v, 0.0, 40.0, 10.0)
    return PARAMS.sigma ** 2 * np.eye(v.size) + PARAMS.load_std ** 2 * np.outer(m, m)


def _reference_profile(speeds, y, wear):
    """Return the max over T in [30, 50] of log N(y; model(v, 0.5, T, w), Sigma), by scipy."""
    v = np.asarray(speeds)
    cov = _reference_covariance(v)
    inv = np.linalg.inv(cov)
    const = -0.5 * np.log(np.linalg.det(2.0 * np.pi * cov))

    def cost(t):
        r = y - robot.friction_model(v, PARAMS.load_mean, t, wear)
        return float(r @ inv @ r)

    temps = np.linspace(30.0, 50.0, 201)
    k = int(np.argmin([cost(t) for t in temps]))
    fit = optimize.minimize_scalar(cost, bounds=(temps[max(k - 1, 0)], temps[min(k + 1, 200)]),
                                   method='bounded', options={'xatol': 1e-9})
    return const - 0.5 * min(fit.fun, cost(temps[k]))


def _reference_marginal(speed, y, wear):
    """Return log p(y | w) of (17) by scipy quad: T uniform on [30, 50], load Gaussian."""
    m = robot.friction_model(speed, 1.0, 40.0, 0.0) - robot.friction_model(speed, 0.0, 40.0, 0.0)
    s = float(np.hypot(PARAMS.sigma, PARAMS.load_std * m))

    def density(t):
        mean = float(robot.friction_model(speed, PARAMS.load_mean, t, wear))
        return stats.norm.pdf(y, mean, s) / 20.0

    value, _ = integrate.quad(density, 30.0, 50.0, epsabs=0.0, epsrel=1e-11, limit=200)
    return np.log(value)


@pytest.fixture(scope='module')
def monte_carlo():
    """Return the data, intervals and estimates for every (N, w) of the coverage study."""
    results = {}
    for n_levels in SPEEDS:
        for i, wear in enumerate(WEARS):
            y, temps = _experiments(n_levels, wear, RUNS, seed=100 * n_levels + i)
            est = estimate_wear(SPEEDS[n_levels], y, params=PARAMS)
            iv = wear_intervals(SPEEDS[n_levels], y, params=PARAMS, estimates=est)
            results[n_levels, wear] = (y, temps, est, iv)
    return results


def _coverage(iv, wear):
    return float(np.mean((iv.wear_low <= wear) & (wear <= iv.wear_high)))


# --------------------------------------------------------------------------- the grid

def test_wear_grid_starts_at_zero_is_fine_near_zero_and_ends_at_the_maximum():
    grid = wear_grid()
    assert grid[0] == 0.0 and grid[-1] == WEAR_GRID_MAX == PARAMS.wear_max
    steps = np.diff(grid)
    assert np.all(steps > 0)
    assert np.max(steps[grid[1:] <= 10.0]) <= 0.25 + 1e-12
    assert np.max(steps) <= 0.5 + 1e-12
    assert wear_grid(40.0, step=2.0)[-1] == 40.0


@pytest.mark.parametrize('wear_max,fine_step,fine_until,step', [
    (150.0, 0.25, 10.0, 0.5), (10.0, 0.25, 10.0, 0.5), (7.3, 0.1, 10.0, 0.07),
    (150.0, 1.0, 0.0, 5.0), (150.0, 3.0, -1.0, 1000.0), (1e-3, 0.25, 0.3, 0.5)])
def test_wear_grid_is_both_parts_sorted_without_the_shared_point(
        wear_max, fine_step, fine_until, step):
    grid = wear_grid(wear_max, fine_step=fine_step, fine_until=fine_until, step=step)
    edge = min(max(fine_until, 0.0), wear_max)
    fine = np.linspace(0.0, edge, int(np.ceil(edge / fine_step - 1e-9)) + 1)
    coarse = np.linspace(edge, wear_max, int(np.ceil((wear_max - edge) / step - 1e-9)) + 1)
    expected = np.unique(np.concatenate([fine, coarse]))
    assert grid.tobytes() == expected.tobytes()
    assert grid[0] == 0.0 and grid[-1] == wear_max and np.all(np.diff(grid) > 0)


# --------------------------------------------------------------------------- the likelihood rows

@pytest.mark.parametrize('n_levels', [4, 2])
def test_profile_log_likelihood_is_the_true_profile_of_eq_15(n_levels):
    y, _ = _experiments(n_levels, 35.0, 6, seed=1)
    grid = wear_grid()
    rows = profile_log_likelihood(SPEEDS[n_levels], y, params=PARAMS, wear_grid=grid)
    assert rows.shape == (6, grid.size)
    for b in range(6):
        for g in range(0, grid.size, 40):
            ref = _reference_profile(SPEEDS[n_levels], y[b], grid[g])
            assert rows[b, g] == pytest.approx(ref, abs=1e-3)


def test_profile_log_likelihood_of_one_level_is_the_marginal_likelihood_17():
    y, _ = _experiments(1, 20.0, 5, seed=2)
    grid = np.array([0.0, 3.0, 10.0, 20.0, 35.0, 70.0, 140.0])
    rows = profile_log_likelihood(SPEEDS[1], y, params=PARAMS, wear_grid=grid)
    for b in range(5):
        for g, wear in enumerate(grid):
            assert rows[b, g] == pytest.approx(_reference_marginal(35.1, y[b, 0], wear),
                                               abs=1e-4)


def test_profile_log_likelihood_rejects_a_bad_grid():
    with pytest.raises(InputError):
        profile_log_likelihood(SPEEDS[2], [0.08, 0.08], params=PARAMS, wear_grid=[0.0, 1.0])
    with pytest.raises(InputError):
        profile_log_likelihood(SPEEDS[2], [0.08, 0.08], params=PARAMS,
                               wear_grid=[0.0, 2.0, 1.0])
    with pytest.raises(InputError):
        profile_log_likelihood(SPEEDS[2], [0.08, 0.08, 0.08], params=PARAMS, wear_grid=[0, 1, 2])


# --------------------------------------------------------------------------- coverage

@pytest.mark.parametrize('n_levels', [4, 2, 1])
def test_wear_coverage_is_nominal_at_every_wear_including_zero(monte_carlo, n_levels):
    cover = {w: _coverage(monte_carlo[n_levels, w][3], w) for w in WEARS}
    for wear in WEARS:
        assert 0.93 <= cover[wear] <= 0.98, cover
    assert 0.94 <= np.mean(list(cover.values())) <= 0.965, cover


def test_chi2_cutoff_over_covers_at_the_bound_which_the_calibration_corrects(monte_carlo):
    y, _, est, calibrated = monte_carlo[2, 0.0]
    wilks = wear_intervals(SPEEDS[2], y, params=PARAMS, estimates=est, cutoff='chi2')
    assert _coverage(wilks, 0.0) >= 0.985
    assert _coverage(calibrated, 0.0) <= 0.98
    # the calibrated interval is the narrower one there (the upper limit of a new joint)
    assert np.median(calibrated.wear_high) < np.median(wilks.wear_high) - 1.0
    with pytest.raises(InputError):
        wear_intervals(SPEEDS[2], y[:2], params=PARAMS, cutoff='wilks')


def test_calibration_is_reproducible_and_tends_to_chi2_for_one_level():
    first = calibrate_cutoffs(SPEEDS[1], params=PARAMS)
    again = calibrate_cutoffs([35.1 + 0.004], params=PARAMS)  # a measured speed: same design
    assert again is first and first.wear[0] == 0.0
    assert first.wear[-1] == PARAMS.wear_max
    # one level, w well inside the range: the model is regular there and Wilks holds
    large = first.cutoff[first.wear >= 35.0]
    assert np.all(np.abs(large - Q95) < 0.5), large
    # another seed gives cutoffs within the Monte Carlo error of a 95 % quantile
    other = calibrate_cutoffs(SPEEDS[2], params=PARAMS, seed=99, runs=800)
    base = calibrate_cutoffs(SPEEDS[2], params=PARAMS)
    assert np.all(np.abs(other.cutoff - base.cutoff) < 0.8), (other.cutoff, base.cutoff)
    with pytest.raises(InputError):
        calibrate_cutoffs(SPEEDS[2], params=PARAMS, runs=10)


def test_temperature_coverage_of_four_levels(monte_carlo):
    for wear in WEARS:
        _, temps, _, iv = monte_carlo[4, wear]
        cover = np.mean((iv.temperature_low <= temps) & (temps <= iv.temperature_high))
        assert 0.93 <= cover <= 0.99, (wear, cover)
        assert np.median(iv.temperature_high - iv.temperature_low) < 19.0


def test_temperature_intervals_stay_in_bounds_and_contain_the_estimate(monte_carlo):
    for (n_levels, _), (_, _, est, iv) in monte_carlo.items():
        assert np.all(iv.temperature_low >= 30.0) and np.all(iv.temperature_high <= 50.0)
        assert np.all(iv.temperature_low <= iv.temperature_high)
        if n_levels > 1:
            assert np.all(iv.temperature_low <= est.temperature_degc + 1e-9)
            assert np.all(est.temperature_degc <= iv.temperature_high + 1e-9)


# --------------------------------------------------------------------------- shape of intervals

def test_intervals_contain_the_ml_estimate_and_are_finite(monte_carlo):
    for (_, _), (_, _, est, iv) in monte_carlo.items():
        assert np.all(np.isfinite(iv.wear_low) & np.isfinite(iv.wear_high))
        assert np.all(iv.wear_low >= 0.0)
        assert np.all(iv.wear_low <= est.wear) and np.all(est.wear <= iv.wear_high)
        assert np.all(iv.wear_low[est.wear == 0.0] == 0.0)
        assert not np.any(iv.wear_high_at_grid_end)


def test_width_bound(monte_carlo):
    # measured on 4000 experiments per case (N, w): max width 32.7 (N = 4), 31.6 (N = 2),
    # 35.7 (N = 1); 1st percentile 8.9, 11.0, 13.9; minimum 4.2 (N = 4, w = 0: a level well
    # below the nominal friction, which only a new joint explains)
    for (n_levels, wear), (_, _, _, iv) in monte_carlo.items():
        bound = 35.0 if n_levels > 1 else 38.0
        assert np.max(iv.wear_width) <= bound, (n_levels, wear)
        assert np.percentile(iv.wear_width, 1) >= 8.0, (n_levels, wear)
        assert np.min(iv.wear_width) >= 3.0, (n_levels, wear)  # never a spuriously tight one


def test_lower_end_is_zero_for_a_new_joint(monte_carlo):
    for n_levels in SPEEDS:
        iv = monte_carlo[n_levels, 0.0][3]
        assert np.mean(iv.wear_low == 0.0) >= 0.93, n_levels
    # and a clearly worn joint is never compatible with a new one
    for n_levels in (4, 2):
        assert np.all(monte_carlo[n_levels, 60.0][3].wear_low > 20.0), n_levels


@pytest.mark.parametrize('n_levels', [4, 2, 1])
def test_end_points_are_refined_to_the_threshold(monte_carlo, n_levels):
    y, _, est, iv = monte_carlo[n_levels, 35.0]
    speeds = SPEEDS[n_levels]
    cutoff = calibrate_cutoffs(speeds, params=PARAMS)
    for b in range(8):
        at_hat = profile_log_likelihood(speeds, y[b], params=PARAMS,
                                        wear_grid=[0.0, est.wear[b] + 1e-9, 200.0])[0, 1]
        ends = [iv.wear_high[b]] + ([iv.wear_low[b]] if iv.wear_low[b] > 0 else [])
        for end in ends:
            grid = [0.0, end, 200.0] if end > 0 else [0.0, 1.0, 2.0]
            value = profile_log_likelihood(speeds, y[b], params=PARAMS, wear_grid=grid)[0, 1]
            # the statistic at an end point is the cutoff there (not the grid step's value)
            assert 2.0 * (at_hat - value) == pytest.approx(float(cutoff.at(end)), abs=0.01)
        if iv.wear_low[b] == 0.0:
            at_zero = profile_log_likelihood(speeds, y[b], params=PARAMS,
                                             wear_grid=[0.0, 1.0, 2.0])[0, 0]
            assert 2.0 * (at_hat - at_zero) <= float(cutoff.at(0.0)) + 0.01


def test_upper_end_at_the_grid_end_is_reported_as_at_least():
    y, _ = _experiments(2, 120.0, 20, seed=3)
    grid = wear_grid(60.0)
    est = estimate_wear(SPEEDS[2], y, params=PARAMS)
    iv = wear_intervals(SPEEDS[2], y, params=PARAMS, wear_grid_values=grid, estimates=est)
    assert np.all(np.isfinite(iv.wear_high))
    assert np.all(iv.wear_high_at_grid_end == (iv.wear_high >= 60.0))
    assert np.mean(iv.wear_high_at_grid_end) > 0.9
    # an estimate beyond the grid end: the interval still contains it ("at least" w-hat)
    assert np.all((iv.wear_low <= est.wear) & (est.wear <= iv.wear_high))
    # and T is still profiled over the w that explain the data (not a degenerate interval)
    assert np.all(iv.temperature_high - iv.temperature_low > 5.0)


def test_lower_level_gives_a_narrower_interval():
    y, _ = _experiments(4, 35.0, 50, seed=4)
    wide = wear_intervals(SPEEDS[4], y, params=PARAMS, level=0.95)
    narrow = wear_intervals(SPEEDS[4], y, params=PARAMS, level=0.68)
    assert np.all(narrow.wear_low >= wide.wear_low - 1e-9)
    assert np.all(narrow.wear_high <= wide.wear_high + 1e-9)
    assert np.all(narrow.wear_width < wide.wear_width)
    assert narrow.level == 0.68


def test_batch_container():
    y, _ = _experiments(2, 35.0, 3, seed=5)
    iv = wear_intervals(SPEEDS[2], y, params=PARAMS)
    single = wear_intervals(SPEEDS[2], y[1], params=PARAMS)
    assert isinstance(iv, WearIntervals) and len(iv) == 3 and len(single) == 1
    assert isinstance(iv[1], WearInterval)
    assert iv[1].wear_low == pytest.approx(single[0].wear_low, abs=1e-9)
    assert iv[-1].wear_high == iv.wear_high[2]
    assert [i.level for i in iv] == [0.95] * 3


def test_bad_input_is_rejected():
    with pytest.raises(InputError):
        wear_intervals(SPEEDS[2], [0.08, 0.08], params=PARAMS, level=1.0)
    with pytest.raises(InputError):
        wear_intervals(SPEEDS[2], [0.08, np.nan], params=PARAMS)
    est = estimate_wear(SPEEDS[2], [[0.08, 0.08]] * 2, params=PARAMS)
    with pytest.raises(InputError):
        wear_intervals(SPEEDS[2], [0.08, 0.08], params=PARAMS, estimates=est)
