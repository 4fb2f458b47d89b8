"""
Experiment design: which N speeds make the wear estimate most accurate, eqs. (22)-(25).

N >= 2: the Fisher information (22) of theta = (T, w) with the load marginalised into Sigma(Phi)
of (14), the cost [F^-1]_22 of (23) (the Cramer-Rao bound of w), and its minimum over the speeds
within the design bounds and with the minimum separation of (24), continuous (Table IV) or over
the combinations of a speed grid (Table V).  N = 1: the exact Fisher information of w from the
marginal likelihood (17), T integrated out under its uniform prior (25), by deterministic
quadrature (see :func:`.estimation.marginal_fisher_information`).

Units: speeds motor side [rad/s], temperature [degC], cost in w^2 (a variance of w-hat).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.single_level import marginal_fisher_information
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet
from scipy import optimize


_MAX_COMBINATIONS = 5_000_000
_CONTINUOUS_STARTS = 6


@dataclass(frozen=True)
class DesignResult:
    """
    An experiment design: the speeds, their cost and N.

    :ivar speeds_rad_s: the N speed levels [rad/s], ascending, shape (N,).
    :ivar cost: [F^-1]_22 of (23) (N >= 2) or 1/F of (25) (N = 1) at the design point [w^2].
    :ivar n: number of levels N.

    """

    speeds_rad_s: FloatArray
    cost: float
    n: int


def fisher_information(*, speeds_rad_s: ArrayLike, params: ParameterSet,
                       temperature_degc: ArrayLike | None = None,
                       wear: ArrayLike | None = None) -> FloatArray:
    """
    Return the Fisher information (22) of (T, w) for batches of speed sets.

    F = grad tau_f^T Sigma(Phi)^-1 grad tau_f with Sigma(Phi) = sigma^2 I + sigma_tl^2 M M^T,
    inverted in closed form (Sherman-Morrison).

    :param speeds_rad_s: speed sets [rad/s], shape (..., N), > 0.
    :param params: the parameter set.
    :param temperature_degc: operating point T [degC] (default: params.design_temperature_degc),
        broadcast against the leading shape (...).
    :param wear: operating point w (default: params.design_wear), broadcast like T.

    :return: F, shape (..., 2, 2), in the order (T, w).

    """
    params.require('wear', purpose='designing the experiment (22)-(25)')
    speeds = np.asarray(speeds_rad_s, dtype=float)
    t = params.design_temperature_degc if temperature_degc is None else temperature_degc
    w = params.design_wear if wear is None else wear
    t = np.asarray(t, dtype=float)[..., None]
    w = np.asarray(w, dtype=float)[..., None]
    grad = fm.friction_with_gradients(speeds, params.load_mean, t, w, params.model)
    jac = np.stack(np.broadcast_arrays(grad.d_temperature, grad.d_wear), axis=-1)  # (..., N, 2)
    m = np.broadcast_to(grad.d_load, jac.shape[:-1])
    return _information_from_sums(np.einsum('...ni,...nj->...ij', jac, jac),
                                  np.einsum('...ni,...n->...i', jac, m),
                                  np.einsum('...n,...n->...', m, m), params)


def _information_from_sums(jtj: FloatArray, jtm: FloatArray, mtm: FloatArray,
                           params: ParameterSet) -> FloatArray:
    """F from the sums over levels J^T J, J^T m and m^T m (they add up over speed levels)."""
    var_load = params.load_std ** 2
    c = var_load / (params.sigma ** 2 + var_load * mtm)
    return (jtj - c[..., None, None] * jtm[..., :, None] * jtm[..., None, :]) / params.sigma ** 2


def wear_variance_bound(information: ArrayLike) -> FloatArray:
    """
    Return [F^-1]_22 = F11 / (F11 F22 - F12^2) of (23), shape (...) from F (..., 2, 2).

    Singular information gives +inf (w not identifiable from those speeds).
    """
    f = np.asarray(information, dtype=float)
    det = f[..., 0, 0] * f[..., 1, 1] - f[..., 0, 1] * f[..., 1, 0]
    scale = f[..., 0, 0] * f[..., 1, 1]
    with np.errstate(divide='ignore', invalid='ignore'):
        bound = f[..., 0, 0] / det
    return np.where(det > 1e-12 * np.abs(scale), bound, np.inf)


def design_cost(*, speeds_rad_s: ArrayLike, params: ParameterSet,
                temperature_degc: float | None = None, wear: float | None = None) -> FloatArray:
    """
    Return the design cost for speed sets of shape (..., N), shape (...).

    N >= 2: [F^-1]_22 of (23) at (T, w).  N = 1: 1/F of (25), the exact marginal information
    of w (T integrated out, so ``temperature_degc`` is not used).
    """
    speeds = np.asarray(speeds_rad_s, dtype=float)
    w = params.design_wear if wear is None else wear
    if speeds.shape[-1] == 1:
        info = marginal_fisher_information(speeds_rad_s=speeds[..., 0], wear=w, params=params)
        with np.errstate(divide='ignore'):
            return np.where(info > 0, 1.0 / info, np.inf)
    return wear_variance_bound(fisher_information(speeds_rad_s=speeds, params=params,
                                                  temperature_degc=temperature_degc, wear=w))


def _check_n(n: int) -> None:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f'n: the number of speed levels must be an integer >= 1, got {n!r}')


def _level_sums(speeds: FloatArray, params: ParameterSet, temperature_degc: float,
                wear: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per-speed contributions to J^T J (K, 2, 2), J^T m (K, 2) and m^T m (K,)."""
    grad = fm.friction_with_gradients(speeds, params.load_mean, temperature_degc, wear,
                                      params.model)
    jac = np.stack([grad.d_temperature, grad.d_wear], axis=-1)
    m = grad.d_load
    return jac[:, :, None] * jac[:, None, :], jac * m[:, None], m * m


def _combination_costs(index: NDArray[np.int64], sums: tuple, params: ParameterSet
                       ) -> FloatArray:
    jtj, jtm, mtm = (s[index].sum(axis=1) for s in sums)
    return wear_variance_bound(_information_from_sums(jtj, jtm, mtm, params))


def _combinations(count: int, n: int) -> NDArray[np.int64]:
    if comb(count, n) > _MAX_COMBINATIONS:
        raise InputError(f'grid: {comb(count, n)} combinations of {n} of {count} speeds are too '
                         f'many (at most {_MAX_COMBINATIONS}); use a coarser grid')
    flat = np.fromiter((i for c in combinations(range(count), n) for i in c), dtype=np.int64,
                       count=comb(count, n) * n)
    return flat.reshape(-1, n)


def best_grid_design(*, n: int, grid_rad_s: ArrayLike, params: ParameterSet,
                     temperature_degc: float | None = None, wear: float | None = None,
                     min_separation_rad_s: float | None = None) -> DesignResult:
    """
    Return the best combination of n speeds from a grid, exhaustively (Table V).

    :param n: number of levels N >= 1.
    :param grid_rad_s: the available speeds [rad/s], > 0 (duplicates are ignored).
    :param params: the parameter set.
    :param temperature_degc: design temperature [degC] (default from params; unused for N = 1).
    :param wear: design wear (default from params).
    :param min_separation_rad_s: minimum distance between chosen speeds (default
        params.speed_separation_rad_s).

    :raises InputError: n < 1, a non-positive or non-finite grid speed, n larger than the grid, or
        no combination that respects the separation.

    """
    _check_n(n)
    grid = np.unique(np.asarray(grid_rad_s, dtype=float))
    if grid.size == 0 or not np.all(np.isfinite(grid)) or np.any(grid <= 0):
        raise InputError(f'grid: speeds must be finite and > 0 rad/s, got {grid.tolist()}')
    if n > grid.size:
        raise InputError(f'n = {n} is larger than the {grid.size} distinct grid speeds')
    t = params.design_temperature_degc if temperature_degc is None else temperature_degc
    w = params.design_wear if wear is None else wear
    if n == 1:
        costs = design_cost(speeds_rad_s=grid[:, None], params=params, wear=w)
        best = int(np.argmin(costs))
        return DesignResult(speeds_rad_s=grid[[best]], cost=float(costs[best]), n=1)
    separation = (params.speed_separation_rad_s if min_separation_rad_s is None
                  else min_separation_rad_s)
    index = _combinations(grid.size, n)
    index = index[np.all(np.diff(grid[index], axis=1) >= separation - 1e-12, axis=1)]
    if index.shape[0] == 0:
        raise InputError(f'grid: no {n} speeds of the grid are {separation} rad/s apart')
    costs = _combination_costs(index, _level_sums(grid, params, t, w), params)
    best = int(np.argmin(costs))
    return DesignResult(speeds_rad_s=grid[index[best]], cost=float(costs[best]), n=n)


def optimal_design(*, n: int, params: ParameterSet, temperature_degc: float | None = None,
                   wear: float | None = None) -> DesignResult:
    """
    Return the continuous optimal design of (24) (N >= 2) or (25) (N = 1), Table IV.

    The speeds lie within [params.speed_min_rad_s, params.speed_max_rad_s] and, for N >= 2, are
    at least params.speed_separation_rad_s apart.  A coarse exhaustive search over a speed grid
    (spacing = the separation) gives the starts of SLSQP with the linear separation constraints;
    N = 1 uses a 1 rad/s grid and a bounded scalar minimisation.

    :param n: number of levels N >= 1.
    :param params: the parameter set (design bounds and default operating point).
    :param temperature_degc: design temperature [degC] (default from params; unused for N = 1).
    :param wear: design wear (default from params).

    :raises InputError: n < 1, or n levels do not fit between the bounds with the separation.

    """
    _check_n(n)
    lo, hi = params.speed_min_rad_s, params.speed_max_rad_s
    t = params.design_temperature_degc if temperature_degc is None else temperature_degc
    w = params.design_wear if wear is None else wear
    if n == 1:
        grid = np.linspace(lo, hi, int(np.ceil(hi - lo)) + 1)
        costs = np.concatenate([design_cost(speeds_rad_s=chunk[:, None], params=params, wear=w)
                                for chunk in np.array_split(grid, max(1, grid.size // 32))])
        best = int(np.argmin(costs))
        a, b = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
        result = optimize.minimize_scalar(
            lambda v: float(design_cost(speeds_rad_s=[v], params=params, wear=w)),
            bounds=(a, b), method='bounded', options={'xatol': 1e-4})
        speed, cost = (float(result.x), float(result.fun)) if result.fun <= costs[best] else (
            float(grid[best]), float(costs[best]))
        return DesignResult(speeds_rad_s=np.array([speed]), cost=cost, n=1)
    separation = params.speed_separation_rad_s
    if (n - 1) * separation > hi - lo:
        raise InputError(f'n = {n} levels {separation} rad/s apart do not fit in '
                         f'[{lo}, {hi}] rad/s')
    step = max(separation, (hi - lo) / 400.0)
    grid = np.arange(lo, hi + 1e-9, step)
    while comb(grid.size, n) > 1_000_000:
        step *= 1.5
        grid = np.arange(lo, hi + 1e-9, step)
    index = _combinations(grid.size, n)
    index = index[np.all(np.diff(grid[index], axis=1) >= separation - 1e-12, axis=1)]
    costs = _combination_costs(index, _level_sums(grid, params, t, w), params)
    order = np.argsort(costs)[:_CONTINUOUS_STARTS]

    def objective(v: FloatArray) -> float:
        value = float(design_cost(speeds_rad_s=v, params=params, temperature_degc=t, wear=w))
        return value if np.isfinite(value) else 1e300

    difference = np.eye(n, k=1)[:-1] - np.eye(n)[:-1]  # rows: v[i+1] - v[i]
    constraint = optimize.LinearConstraint(difference, separation, np.inf)
    best_speeds, best_cost = grid[index[order[0]]], float(costs[order[0]])
    for start in order:
        result = optimize.minimize(objective, grid[index[start]], method='SLSQP',
                                   bounds=[(lo, hi)] * n, constraints=[constraint],
                                   options={'ftol': 1e-12, 'maxiter': 500})
        v = np.clip(np.sort(result.x), lo, hi)
        if np.all(np.diff(v) >= separation - 1e-6):
            cost = objective(v)
            if cost < best_cost:
                best_speeds, best_cost = v, cost
    return DesignResult(speeds_rad_s=np.asarray(best_speeds, dtype=float), cost=best_cost, n=n)
