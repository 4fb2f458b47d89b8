"""
T-hat only: the estimate with a parameter set that has no wear model.

A set written by ``identify --no-wear-model`` (``identification.not_identified: [wear]``) has
no wear profile (7): its friction levels are described by the nominal model (5) alone.  The
estimate is then the maximum-likelihood T of (16) with w left out, the load marginalised into
the covariance (11)-(14) as for (T, w), T within the set's bounds; w-hat is *not determined*
(NaN) and nothing reads it as wear.  The same rule holds for N = 1 (one level gives T exactly
where the model reaches it).

Numerical method: the cost (16) along T is evaluated on :data:`GRID_POINTS` equidistant
temperatures over the bounds, refined by a golden-section search between the neighbours of the
best grid point, and a bound is the estimate when its cost is lower.  The 95 % interval of T is
the profile-likelihood one, where the cost is within the chi2(1) quantile 3.84 of its minimum
(linear interpolation between grid points; a bound where it reaches one).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation.special_functions import chi2_survival
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet


#: Temperatures of the start grid over the set's bounds.
GRID_POINTS = 1001
#: chi2(1) quantile of the 95 % profile-likelihood interval of T.
CHI2_1_95 = 3.841458820694124
_GOLDEN_ITERATIONS = 40


@dataclass(frozen=True)
class TemperatureOnly:
    """
    A batch of B temperature-only estimates (w not determined).

    :ivar temperature_degc: T-hat [degC], shape (B,).
    :ivar temperature_var: variance of T-hat [degC^2] (inverse Fisher information), (B,).
    :ivar temperature_at_bound: T-hat on a temperature bound, (B,).
    :ivar chi2: weighted residual sum of squares at T-hat, (B,).
    :ivar dof: N minus 1 (minus 0 on a bound), (B,).
    :ivar p_value: P(chi2_dof >= chi2), NaN where dof = 0, (B,).
    :ivar temperature_low: lower end of the 95 % interval of T [degC], (B,).
    :ivar temperature_high: upper end of the 95 % interval of T [degC], (B,).

    """

    temperature_degc: FloatArray
    temperature_var: FloatArray
    temperature_at_bound: NDArray[np.bool_]
    chi2: FloatArray
    dof: NDArray[np.int64]
    p_value: FloatArray
    temperature_low: FloatArray
    temperature_high: FloatArray


def estimate_temperature(speeds: FloatArray, values: FloatArray,
                         params: ParameterSet) -> TemperatureOnly:
    """
    Return the ML estimates of T for friction vectors ``values`` (B, N) at ``speeds`` (N,).

    The model is (5) at the set's load mean with w = 0 (the set has no wear model); the
    covariance is eq. (14).
    """
    covariance = fm.marginal_covariance(speeds, sigma=params.sigma, load_std=params.load_std,
                                        model=params.model)
    whiten_t = np.linalg.solve(np.linalg.cholesky(covariance), np.eye(speeds.size)).T
    data_w = values @ whiten_t
    t_min, t_max = params.temperature_min_degc, params.temperature_max_degc

    def cost(t: FloatArray) -> FloatArray:
        model = fm.friction(speeds[None, :], params.load_mean, t[:, None], 0.0, params.model)
        residual = data_w - np.asarray(model, dtype=float) @ whiten_t
        return np.einsum('bn,bn->b', residual, residual)

    grid = np.linspace(t_min, t_max, GRID_POINTS)
    model_grid = np.asarray(fm.friction(speeds[None, :], params.load_mean, grid[:, None], 0.0,
                                        params.model), dtype=float) @ whiten_t
    grid_cost = (np.einsum('bn,bn->b', data_w, data_w)[:, None] - 2.0 * data_w @ model_grid.T
                 + np.einsum('kn,kn->k', model_grid, model_grid)[None, :])
    best = np.argmin(grid_cost, axis=1)
    lower = grid[np.maximum(best - 1, 0)]
    upper = grid[np.minimum(best + 1, grid.size - 1)]
    t_hat = _golden_minimise(cost, lower, upper)
    chi2 = cost(t_hat)
    for bound in (t_min, t_max):
        at = np.full_like(t_hat, bound)
        bound_cost = cost(at)
        better = bound_cost <= chi2
        t_hat, chi2 = np.where(better, at, t_hat), np.where(better, bound_cost, chi2)
    at_bound = (t_hat <= t_min) | (t_hat >= t_max)
    gradient = fm.friction_with_gradients(speeds[None, :], params.load_mean, t_hat[:, None], 0.0,
                                          params.model).d_temperature
    slope = np.asarray(gradient, dtype=float) @ whiten_t
    information = np.einsum('bn,bn->b', slope, slope)
    with np.errstate(divide='ignore'):
        variance = np.where(information > 0, 1.0 / information, np.inf)
    dof = (speeds.size - (~at_bound).astype(np.int64)).astype(np.int64)
    with np.errstate(invalid='ignore'):
        p_value = np.where(dof > 0, chi2_survival(chi2, np.maximum(dof, 1)), np.nan)
    low, high = _profile_interval(grid, grid_cost, best, chi2)
    return TemperatureOnly(temperature_degc=t_hat, temperature_var=variance,
                           temperature_at_bound=at_bound, chi2=chi2, dof=dof, p_value=p_value,
                           temperature_low=np.minimum(low, t_hat),
                           temperature_high=np.maximum(high, t_hat))


def _golden_minimise(objective, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Return the batched golden-section minimiser of objective(x) (B,) on [lower, upper]."""
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = lower.astype(float).copy(), upper.astype(float).copy()
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = objective(c), objective(d)
    for _ in range(_GOLDEN_ITERATIONS):
        left = fc <= fd  # the minimiser is in [a, d]
        b, a = np.where(left, d, b), np.where(left, a, c)
        new_c = np.where(left, b - ratio * (b - a), d)
        new_d = np.where(left, c, a + ratio * (b - a))
        f_new = objective(np.where(left, new_c, new_d))
        fc, fd = np.where(left, f_new, fd), np.where(left, fc, f_new)
        c, d = new_c, new_d
    return 0.5 * (a + b)


def _profile_interval(grid: FloatArray, grid_cost: FloatArray, best: NDArray[np.intp],
                      chi2: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return the ends of {T: cost(T) - min <= 3.84} around the best grid point, (B,) each."""
    low, high = np.empty(chi2.shape), np.empty(chi2.shape)
    for row in range(chi2.size):
        excess = grid_cost[row] - chi2[row] - CHI2_1_95
        j = int(best[row])
        outside_below = np.flatnonzero(excess[:j] > 0)
        outside_above = np.flatnonzero(excess[j + 1:] > 0) + j + 1
        low[row] = grid[0] if outside_below.size == 0 else _crossing(
            grid, excess, int(outside_below[-1]))
        high[row] = grid[-1] if outside_above.size == 0 else _crossing(
            grid, excess, int(outside_above[0]) - 1)
    return low, high


def _crossing(grid: FloatArray, excess: FloatArray, k: int) -> float:
    """Return where ``excess`` crosses 0 between grid points k and k + 1 (linear)."""
    e0, e1 = float(excess[k]), float(excess[k + 1])
    share = e0 / (e0 - e1) if e0 != e1 else 0.5
    return float(grid[k] + share * (grid[k + 1] - grid[k]))
