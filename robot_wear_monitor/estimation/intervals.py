"""
Profile-likelihood confidence intervals of wear w and temperature T.

The standard deviation of :func:`~robot_wear_monitor.estimation.estimator.estimate_wear` is the
inverse Fisher information at the estimate; it is meaningless where the wear profile (7)
collapses (w near 0, where phi_s,w w -> 0) or on a bound.  This module replaces it by the
profile-likelihood interval

    {w >= 0 : 2 (l_max - l_p(w)) <= c(w)},

with l_p(w) the log-likelihood maximised over the nuisance parameter (N >= 2) or integrated over
it (N = 1), and likewise for T.  The cutoff c(w) is calibrated by simulation for the speeds and
the parameter set (:func:`calibrate_cutoffs`): Wilks' chi2_1 quantile over-covers near w = 0,
where w is on a bound and the wear term is nearly invisible.

Log-likelihoods, natural log, true values (no per-row constant dropped):

* N >= 2, eq. (15): l(T, w) = log N(y; f(v, mu_tl, T, w), Sigma(Phi)), Sigma of (14) (the load
  enters (8) linearly, so marginalising the Gaussian load into Sigma is exact, not an
  approximation).  The profile l_p(w) = max over T in [T_min, T_max] of l(T, w).
* N = 1, eq. (17): l(w) = log p(y | w) = log g(y - tilde tau_f(v, w)) with T integrated out
  under its uniform prior (:class:`~robot_wear_monitor.estimation.single_level.MarginalModel`).

Numerical method.  The model (8) is additive, f = tau_f0(v, mu, T) + tilde tau_f(v, w), and
Sigma does not depend on (T, w), so after whitening by the Cholesky factor of Sigma the cost of
row b at (T_k, w_g) is |d_b|^2 + |a_k|^2 + |c_g|^2 - 2 d_b.a_k - 2 d_b.c_g + 2 a_k.c_g, with
a_k, c_g the whitened nominal and wear parts on a T grid and on the wear grid.  The products
a_k.c_g are tabulated once per call; each row then costs one (G, K) addition and a minimum over
the T grid (41 points, 0.5 degC apart), refined by a parabola through the best grid point and its
neighbours (the cost is nearly quadratic in T on that scale; error far below 1e-3 nats, see the
tests).  Interval end points are refined by a batched Illinois (regula falsi) root search on the
same profile evaluated at arbitrary w or T, so they do not depend on the grid step.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
import os
from pathlib import Path
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.calibration_store import (
    CACHE_ENV, calibration_cache_dir, calibration_key, CALIBRATION_RUNS, CALIBRATION_SEED,
    calibration_to_json, CALIBRATION_VERSION, CALIBRATION_WEAR, CutoffCalibration,
    rounded_speeds as _rounded_speeds, SHIPPED_CALIBRATIONS, SHIPPED_DESIGNS,
    store_calibration as _store_calibration, stored_calibration as _stored_calibration,
    write_calibration_table)
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.estimation.profile_likelihood import (cached_profile, cached_single_level,
                                                              validate_grid, wear_grid,
                                                              WearLikelihood)
from robot_wear_monitor.estimation.special_functions import chi2_quantile_one_dof
from robot_wear_monitor.estimation.wear_estimates import (validate_levels, validate_speeds,
                                                          WearEstimates)
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import load_parameter_set, ParameterSet

# The calibration store (keys, the shipped table, the cache) is calibration_store's; its names
# stay importable from here, as before the store had a module of its own.
__all__ = ['CACHE_ENV', 'calibrate_cutoffs', 'calibration_cache_dir', 'calibration_key',
           'CALIBRATION_RUNS', 'CALIBRATION_SEED', 'calibration_to_json', 'CALIBRATION_VERSION',
           'CALIBRATION_WEAR', 'CutoffCalibration', 'profile_log_likelihood',
           'SHIPPED_CALIBRATIONS', 'SHIPPED_DESIGNS', 'simulate_cutoffs', 'wear_intervals',
           'WearInterval', 'WearIntervals', 'write_shipped_calibrations']


#: Illinois iterations of the end-point search, and its tolerance on the bracket width.
_ROOT_ITERATIONS = 40
_ROOT_TOL = 1e-7


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class WearInterval:
    """One profile-likelihood interval of w and of T (see :class:`WearIntervals`)."""

    wear_low: float
    wear_high: float
    temperature_low: float
    temperature_high: float
    wear_high_at_grid_end: bool
    level: float


@dataclass(frozen=True)
class WearIntervals:
    """
    A batch of B profile-likelihood intervals at confidence ``level``.

    :ivar wear_low: lower end of the wear interval [-], shape (B,); exactly 0 when the interval
        reaches the bound w = 0.
    :ivar wear_high: upper end of the wear interval [-], shape (B,).  Where
        ``wear_high_at_grid_end`` is set the likelihood did not fall below the threshold
        inside the wear grid: the true upper end is *at least* this value (the grid end).
    :ivar temperature_low: lower end of the temperature interval [degC], shape (B,).
    :ivar temperature_high: upper end of the temperature interval [degC], shape (B,).
    :ivar wear_high_at_grid_end: shape (B,), bool, see ``wear_high``.
    :ivar level: confidence level, e.g. 0.95.

    """

    wear_low: FloatArray
    wear_high: FloatArray
    temperature_low: FloatArray
    temperature_high: FloatArray
    wear_high_at_grid_end: NDArray[np.bool_]
    level: float

    def __len__(self) -> int:
        """Return the batch size B."""
        return int(self.wear_low.shape[0])

    def __getitem__(self, index: int) -> WearInterval:
        """Return interval ``index`` (negative indices count from the end)."""
        i = range(len(self))[index]
        return WearInterval(wear_low=float(self.wear_low[i]), wear_high=float(self.wear_high[i]),
                            temperature_low=float(self.temperature_low[i]),
                            temperature_high=float(self.temperature_high[i]),
                            wear_high_at_grid_end=bool(self.wear_high_at_grid_end[i]),
                            level=self.level)

    def __iter__(self) -> Iterator[WearInterval]:
        """Iterate over the intervals of the batch."""
        return (self[i] for i in range(len(self)))

    @property
    def wear_width(self) -> FloatArray:
        """Width of the wear intervals [-], shape (B,)."""
        return self.wear_high - self.wear_low


# --------------------------------------------------------------------------- calibration

#: Smallest cutoff [-] (a set of measure zero would not contain w-hat).
_MIN_CUTOFF = 0.05


def calibrate_cutoffs(speeds_rad_s: ArrayLike, *, params: ParameterSet, level: float = 0.95,
                      runs: int = CALIBRATION_RUNS, seed: int = CALIBRATION_SEED
                      ) -> CutoffCalibration:
    """
    Calibrate the likelihood-ratio cutoff at each wear value by simulation (Neyman).

    Wilks' chi2_1 cutoff assumes a regular model with the truth inside the parameter space.
    Here neither holds near w = 0: w = 0 is a bound, and the wear profile (7) is nearly
    invisible for small w (phi_s,w w -> 0), so the statistic at the truth is mostly close to 0
    and the chi2 interval over-covers (98.7-99.5 % instead of 95 %); the temperature bounds
    make it over-cover a little at large w too.  This function simulates ``runs`` experiments
    at each wear value of :data:`CALIBRATION_WEAR` with the data model (9) of the parameter set
    (T uniform on [T_min, T_max], load Gaussian (mu_tl, sigma_tl), noise sigma; exact through
    the covariance (14)), computes the statistic at the true wear with the same likelihood as
    :func:`wear_intervals`, and returns its ``level`` quantile.  The interval then covers the
    truth at the stated level on average over the temperature range (the Neyman construction
    with the likelihood-ratio ordering, Feldman and Cousins 1998, the nuisance T averaged).

    The speeds are rounded to 0.1 rad/s, and results are kept per (rounded speeds, parameter
    set values, level, runs, seed), so the measured speeds of repeated experiments of one design
    share a calibration.  One calibration takes about 1-2 s (18 000 experiments on 2 cores); it
    is kept in the process, stored in the cache folder (:func:`calibration_cache_dir`, one JSON
    file per calibration, written atomically) for the next process, and the packaged parameter
    set's calibration at the default design ships with the package
    (:data:`SHIPPED_CALIBRATIONS`, rebuilt by :func:`write_shipped_calibrations`).

    :param speeds_rad_s: motor-side speeds [rad/s], shape (N,), all > 0.
    :param params: the parameter set (the data model).
    :param level: confidence level in (0, 1).
    :param runs: simulated experiments per wear value, >= 100.
    :param seed: random seed.

    :return: The :class:`CutoffCalibration`.

    """
    speeds = validate_speeds(speeds_rad_s)
    if not 0.0 < float(level) < 1.0:
        raise InputError(f'level: must be in (0, 1), got {level}')
    if int(runs) < 100:
        raise InputError(f'runs: must be >= 100, got {runs}')
    return _calibrate(_rounded_speeds(speeds), params, float(level), int(runs), int(seed))


@lru_cache(maxsize=32)
def _calibrate(speeds_t: tuple, params: ParameterSet, level: float, runs: int,
               seed: int) -> CutoffCalibration:
    key = calibration_key(speeds_t, params, level, runs, seed)
    stored = _stored_calibration(key)
    if stored is not None:
        return stored
    calibration = simulate_cutoffs(speeds_t, params=params, level=level, runs=runs, seed=seed)
    _store_calibration(key, calibration)
    return calibration


def write_shipped_calibrations(path: str | os.PathLike = SHIPPED_CALIBRATIONS) -> Path:
    """
    Calibrate the packaged parameter set at the default design and write the shipped table.

    Rebuild after a change of the calibration or the packaged parameter set:
    ``python3 -c "from robot_wear_monitor.estimation.intervals import
    write_shipped_calibrations as w; w()"`` (a test checks that the table is current).
    """
    params = load_parameter_set(None)
    entries = []
    for speeds in SHIPPED_DESIGNS:
        rounded = _rounded_speeds(validate_speeds(speeds))
        entries.append((rounded, params, simulate_cutoffs(
            rounded, params=params, level=0.95, runs=CALIBRATION_RUNS, seed=CALIBRATION_SEED)))
    return write_calibration_table(path, entries)


def simulate_cutoffs(speeds_t: tuple, *, params: ParameterSet, level: float, runs: int,
                     seed: int) -> CutoffCalibration:
    """Run the calibration of :func:`calibrate_cutoffs` (no cache; speeds already rounded)."""
    speeds = np.asarray(speeds_t)
    wear = np.asarray([w for w in CALIBRATION_WEAR if w <= params.wear_max] + [params.wear_max])
    wear = np.unique(wear)
    rng = np.random.default_rng(seed)
    factor = np.linalg.cholesky(fm.marginal_covariance(speeds, sigma=params.sigma,
                                                       load_std=params.load_std,
                                                       model=params.model))
    grid = wear_grid(params.wear_max)
    cutoff = np.empty(wear.size)
    for i, true_wear in enumerate(wear):
        temps = rng.uniform(params.temperature_min_degc, params.temperature_max_degc, runs)
        mean = fm.friction(speeds[None, :], params.load_mean, temps[:, None], true_wear,
                           params.model)
        values = mean + rng.standard_normal(mean.shape) @ factor.T
        est = estimate_wear(speeds, values, params=params)
        like = WearLikelihood(speeds, values, params, grid, np.asarray(est.wear, dtype=float),
                              est.temperature_degc, want_t=False)
        statistic = 2.0 * (like.l_max - like.at_wear(np.full(runs, true_wear),
                                                     np.arange(runs)))
        cutoff[i] = np.quantile(np.maximum(statistic, 0.0), level)
    return CutoffCalibration(wear=wear, cutoff=np.maximum(cutoff, _MIN_CUTOFF),
                             chi2_cutoff=chi2_quantile_one_dof(level), level=level,
                             runs=runs)


# --------------------------------------------------------------------------- public functions

def profile_log_likelihood(speeds_rad_s: ArrayLike, friction: ArrayLike, *,
                           params: ParameterSet, wear_grid: ArrayLike) -> FloatArray:
    """
    Return the profile (N >= 2) or marginal (N = 1) log-likelihood of w on a wear grid.

    N >= 2: l_p(w) = max over T in [T_min, T_max] of the Gaussian log-likelihood (15),
    log N(y; f(v, mu_tl, T, w), Sigma(Phi)) with Sigma of (14) (load marginalised; exact, the
    model is linear in the load).  The maximum over T is taken on a 41-point T grid refined by a
    parabola (error below 1e-3 nats in the tests).
    N = 1: the marginal log-likelihood (17), log p(y | w) with T integrated out under its uniform
    prior, from a table of log g (step s/64; within 1e-4 nats of the quadrature of
    :class:`~robot_wear_monitor.estimation.single_level.MarginalModel`).

    Both are true log-likelihoods (natural log, all normalising constants included), so rows of
    experiments at different speeds can be added on a common wear grid.

    :param speeds_rad_s: motor-side speeds [rad/s], shape (N,), all > 0.
    :param friction: friction levels (normalised), shape (N,) or (B, N).
    :param params: the parameter set.
    :param wear_grid: wear values w >= 0 [-], strictly increasing, shape (G,), G >= 3; e.g.
        :func:`wear_grid`.

    :return: Log-likelihood [nats], shape (B, G).

    :raises InputError: bad speeds, friction or grid.

    """
    speeds, values = validate_levels(speeds_rad_s, friction)
    grid = validate_grid(wear_grid)
    if speeds.size == 1:
        return cached_single_level(float(speeds[0]), params).rows(values[:, 0], grid)
    profile = cached_profile(speeds, params, grid)
    cost, _ = profile.grid_profiles(profile.whitened(values), want_t=False)
    return profile.const - 0.5 * cost


def _illinois(func, x_in: FloatArray, f_in: FloatArray, x_out: FloatArray,
              f_out: FloatArray) -> FloatArray:
    """Batched Illinois root search of func(x, rows) between x_in (f >= 0) and x_out (f < 0)."""
    a, fa, b, fb = x_in.copy(), f_in.copy(), x_out.copy(), f_out.copy()
    side = np.zeros(a.shape, dtype=int)
    active = np.flatnonzero(np.abs(b - a) > _ROOT_TOL * (1.0 + np.abs(a)))
    for _ in range(_ROOT_ITERATIONS):
        if active.size == 0:
            break
        aa, fa_, bb, fb_ = a[active], fa[active], b[active], fb[active]
        x = bb - fb_ * (bb - aa) / (fb_ - fa_)
        x = np.where(np.isfinite(x) & ((x - aa) * (x - bb) <= 0), x, 0.5 * (aa + bb))
        fx = func(x, active)
        inside = fx >= 0
        # replace the end point of the same sign; halve the kept one's value if it is kept twice
        a[active] = np.where(inside, x, aa)
        fa[active] = np.where(inside, fx, np.where(side[active] == -1, 0.5 * fa_, fa_))
        b[active] = np.where(inside, bb, x)
        fb[active] = np.where(inside, np.where(side[active] == 1, 0.5 * fb_, fb_), fx)
        side[active] = np.where(inside, 1, -1)
        done = np.abs(b[active] - a[active]) <= _ROOT_TOL * (1.0 + np.abs(a[active]))
        active = active[~done]
    # the end point: interpolate inside the last bracket
    with np.errstate(divide='ignore', invalid='ignore'):
        x = b - fb * (b - a) / (fb - fa)
    return np.where(np.isfinite(x) & ((x - a) * (x - b) <= 0), x, a)


def _hull(values: FloatArray, nodes: FloatArray, threshold: FloatArray, x_hat: FloatArray,
          f_hat: FloatArray, func, *, together: bool = False) -> tuple:
    """
    Return the ends (low, high) of {x : values >= threshold} joined with x_hat, refined.

    ``values`` (B, M) at ``nodes`` (M,); x_hat (B,) is a point known to be inside (its
    log-likelihood f_hat).  An end on the first/last node stays there (flag returned).
    ``together``: both ends in one root search, for a ``func`` whose value for a row does not
    depend on the other rows evaluated with it (the batched rows: one product per row; one
    experiment's profile evaluates its rows by one matrix product, whose rows BLAS may round
    differently by how many rows it has, so its ends are searched one after the other).
    """
    b, m = values.shape
    inside = values >= threshold[:, None]
    any_in = inside.any(axis=1)
    first = np.where(any_in, np.argmax(inside, axis=1), m)
    last = np.where(any_in, m - 1 - np.argmax(inside[:, ::-1], axis=1), -1)
    rows = np.arange(b)
    lo_in = np.where(any_in, np.minimum(nodes[np.minimum(first, m - 1)], x_hat), x_hat)
    hi_in = np.where(any_in, np.maximum(nodes[np.maximum(last, 0)], x_hat), x_hat)
    f_lo_in = np.where(any_in & (nodes[np.minimum(first, m - 1)] <= x_hat),
                       values[rows, np.minimum(first, m - 1)], f_hat) - threshold
    f_hi_in = np.where(any_in & (nodes[np.maximum(last, 0)] >= x_hat),
                       values[rows, np.maximum(last, 0)], f_hat) - threshold
    # outside neighbours: the largest node below lo_in, the smallest above hi_in
    lo_out_idx = np.searchsorted(nodes, lo_in, side='left') - 1
    hi_out_idx = np.searchsorted(nodes, hi_in, side='right')
    low, high = lo_in.copy(), hi_in.copy()
    at_low_end = lo_out_idx < 0
    at_high_end = hi_out_idx >= m
    r_low, r_high = np.flatnonzero(~at_low_end), np.flatnonzero(~at_high_end)

    def search(r: NDArray[np.intp], x_in: FloatArray, f_in: FloatArray,
               out_idx: NDArray[np.intp]) -> FloatArray:
        return _illinois(lambda x, act: func(x, r[act]) - threshold[r[act]], x_in, f_in,
                         nodes[out_idx], values[r, out_idx] - threshold[r])
    if together and r_low.size + r_high.size:
        ends = search(np.concatenate([r_low, r_high]),
                      np.concatenate([lo_in[r_low], hi_in[r_high]]),
                      np.concatenate([f_lo_in[r_low], f_hi_in[r_high]]),
                      np.concatenate([lo_out_idx[r_low], hi_out_idx[r_high]]))
        low[r_low], high[r_high] = ends[:r_low.size], ends[r_low.size:]
    elif not together:
        if r_low.size:
            low[r_low] = search(r_low, lo_in[r_low], f_lo_in[r_low], lo_out_idx[r_low])
        if r_high.size:
            high[r_high] = search(r_high, hi_in[r_high], f_hi_in[r_high], hi_out_idx[r_high])
    low[at_low_end] = np.minimum(nodes[0], lo_in[at_low_end])
    high[at_high_end] = np.maximum(nodes[-1], hi_in[at_high_end])
    return low, high, at_high_end


def wear_intervals(speeds_rad_s: ArrayLike, friction: ArrayLike, *, params: ParameterSet,
                   level: float = 0.95, wear_grid_values: ArrayLike | None = None,
                   estimates: WearEstimates | None = None,
                   cutoff: str = 'calibrated') -> WearIntervals:
    """
    Return profile-likelihood confidence intervals of w and T for a batch of experiments.

    Wear: {w >= 0 : 2 (l_max - l_p(w)) <= c(w)} with l_p of
    :func:`profile_log_likelihood` (N >= 2: T profiled out within its bounds; N = 1: T
    integrated out, eq. (17)) and c(w) the cutoff: by default calibrated by simulation for
    these speeds and parameters (:func:`calibrate_cutoffs`; exact coverage on average over the
    temperature range, also at w = 0, where chi2 over-covers), or chi2_1^-1(level) with
    ``cutoff='chi2'`` (Wilks).  l_max is the log-likelihood at the ML estimate of
    :func:`~robot_wear_monitor.estimation.estimator.estimate_wear` (or the grid maximum if that
    is higher), so the interval always contains w-hat.  Where the set is not connected its hull
    is returned.  At the bound: when l_p(0) is above the threshold the interval starts at exactly
    0.  End points are found by root search on the profile (not the grid step).  If the
    likelihood stays above the threshold up to the end of the wear grid, ``wear_high`` is the
    grid end and ``wear_high_at_grid_end`` is set: the true upper end is *at least* that (never
    inf).

    Temperature: the profile-likelihood interval of T within [T_min, T_max], l_p(T) = max over
    w of the joint Gaussian log-likelihood (15), for every N (w on the wear grid, extended to
    1.5 max w-hat when an estimate lies beyond its end).  For N = 1 this
    is the profile of the joint likelihood of (T, w) (not a posterior of T): one level does not
    separate T from w, and the interval is the set of temperatures at which some w >= 0 explains
    the level.  Wear can only add friction (above a dip of about -1e-4), so T is bounded on one
    side at most, and in practice the interval is nearly always the whole range [T_min, T_max]
    (honest: one level carries no information on T).  An end at a temperature bound is that
    bound.

    :param speeds_rad_s: motor-side speeds [rad/s], shape (N,), all > 0.
    :param friction: friction levels (normalised), shape (N,) or (B, N).
    :param params: the parameter set.
    :param level: confidence level in (0, 1).
    :param wear_grid_values: wear grid (G,) of the profile; default :func:`wear_grid` with
        ``params.wear_max``.
    :param estimates: the result of ``estimate_wear`` for the same data, if already computed.
    :param cutoff: ``'calibrated'`` (default) or ``'chi2'``, see above.  The temperature interval
        always uses chi2_1^-1(level).

    :return: A :class:`WearIntervals` batch of length B.

    :raises InputError: bad speeds, friction, grid or level.

    """
    if not 0.0 < float(level) < 1.0:
        raise InputError(f'level: must be in (0, 1), got {level}')
    if cutoff not in ('calibrated', 'chi2'):
        raise InputError(f"cutoff: must be 'calibrated' or 'chi2', got {cutoff!r}")
    speeds, values = validate_levels(speeds_rad_s, friction)
    grid = validate_grid(wear_grid(params.wear_max) if wear_grid_values is None
                         else wear_grid_values)
    est = estimates if estimates is not None else estimate_wear(speeds, values, params=params)
    if len(est) != values.shape[0]:
        raise InputError('estimates: batch size does not match friction')
    half_q = 0.5 * chi2_quantile_one_dof(level)
    w_hat = np.asarray(est.wear, dtype=float)
    like = WearLikelihood(speeds, values, params, grid, w_hat, est.temperature_degc,
                          want_t=True)
    if cutoff == 'calibrated':
        calibration = calibrate_cutoffs(speeds, params=params, level=level)
        half_c = 0.5 * calibration.at(grid)

        def wear_func(w: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
            return like.at_wear(w, rows) + 0.5 * calibration.at(w)
        wear_low, wear_high, open_end = _hull(like.rows + half_c[None, :], grid, like.l_max,
                                              w_hat, like.l_hat + 0.5 * calibration.at(w_hat),
                                              wear_func)
    else:
        wear_low, wear_high, open_end = _hull(like.rows, grid, like.l_max - half_q, w_hat,
                                              like.l_hat, like.at_wear)
    wear_low = np.maximum(wear_low, 0.0)
    profile, data = like.profile, like.data
    joint_t = profile.const - 0.5 * like.cost_t                  # (B, K)
    if speeds.size == 1:
        # T: the joint profile; its maximum is on the grid (T-hat of the joint fit)
        jt = np.argmax(joint_t, axis=1)
        t_hat = profile.t_grid[jt]
        lt_hat = joint_t[np.arange(values.shape[0]), jt]
    else:
        t_hat = np.asarray(est.temperature_degc, dtype=float)
        lt_hat = like.l_hat

    def temp_func(t: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        return profile.const - 0.5 * profile.cost_at_temperature(data[rows], t)
    lt_max = np.maximum(lt_hat, joint_t.max(axis=1))
    t_low, t_high, _ = _hull(joint_t, profile.t_grid, lt_max - half_q, t_hat, lt_hat, temp_func)
    return WearIntervals(wear_low=wear_low, wear_high=wear_high,
                         temperature_low=np.clip(t_low, profile.t_min, profile.t_max),
                         temperature_high=np.clip(t_high, profile.t_min, profile.t_max),
                         wear_high_at_grid_end=open_end, level=float(level))
