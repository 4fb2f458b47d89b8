"""
The profile of the likelihood of w (and T) that the intervals are cut from, and the wear grid.

:func:`wear_grid` is the default wear grid of the profile (and of the trend); :class:`Profile`
(N >= 2: T maximised out) and :class:`SingleLevel` (N = 1: T integrated out) evaluate the
log-likelihood of rows of friction levels at any w or T, :class:`WearLikelihood` the profile of
w as :mod:`.intervals` and the trend take it.  The method is described in :mod:`.intervals`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.single_level import MarginalModel
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet

#: Default upper end of the wear grid [-] (the estimator's starting grid ends there too).
WEAR_GRID_MAX = 150.0
#: Default wear grid steps [-]: ``FINE_STEP`` up to ``FINE_UNTIL``, then ``COARSE_STEP``.
FINE_STEP, FINE_UNTIL, COARSE_STEP = 0.25, 10.0, 0.5
#: Points of the T grid of the profile (uniform on [T_min, T_max], refined by a parabola).
T_POINTS = 41
#: Rows per chunk of the (rows, G, K) cost cube (cache-sized).
CHUNK_CELLS = 1 << 18
#: N = 1 table of log g: step s / _TABLE_DENSITY over nominal range +- _TABLE_TAIL s.
_TABLE_DENSITY = 64.0
_TABLE_TAIL = 30.0


def wear_grid(wear_max: float = WEAR_GRID_MAX, *, fine_step: float = FINE_STEP,
              fine_until: float = FINE_UNTIL, step: float = COARSE_STEP) -> FloatArray:
    """
    Return the default wear grid: 0 to ``wear_max``, finer near w = 0.

    Steps of ``fine_step`` on [0, fine_until] and of ``step`` above; the grid starts at exactly
    0 and ends at exactly ``wear_max``.  With the defaults: 0, 0.25, ..., 10, 10.5, ..., 150
    (321 points).

    :param wear_max: upper end [-], > 0.
    :param fine_step: step near 0 [-], > 0.
    :param fine_until: where the fine part ends [-].
    :param step: step above ``fine_until`` [-], > 0.

    :return: Strictly increasing grid, shape (G,).

    """
    if not (wear_max > 0 and fine_step > 0 and step > 0):
        raise InputError('wear grid: wear_max, fine_step and step must be > 0')
    edge = min(max(fine_until, 0.0), wear_max)
    fine = np.linspace(0.0, edge, int(np.ceil(edge / fine_step - 1e-9)) + 1)
    coarse = np.linspace(edge, wear_max, int(np.ceil((wear_max - edge) / step - 1e-9)) + 1)
    return np.concatenate([fine[:-1], coarse])  # the two parts share the point edge


# --------------------------------------------------------------------------- helpers

def validate_grid(grid: ArrayLike) -> FloatArray:
    g = np.asarray(grid, dtype=float)
    if g.ndim != 1 or g.size < 3 or not np.all(np.isfinite(g)):
        raise InputError('wear_grid: expected a finite 1-D grid of >= 3 points')
    if g[0] < 0 or np.any(np.diff(g) <= 0):
        raise InputError('wear_grid: must be strictly increasing and >= 0')
    return g


def take_last(values: FloatArray, index: NDArray[np.intp]) -> FloatArray:
    """
    Return ``np.take_along_axis(values, index, axis=-1)``: index (..., P) into values (..., M).

    C-contiguous values (the profiles' costs and cost cubes) are gathered at once from their
    flat memory, other values by numpy's ``take_along_axis``.
    """
    if not values.flags.c_contiguous:
        return np.take_along_axis(values, index, axis=-1)
    offsets = np.arange(0, values.size, values.shape[-1]).reshape(values.shape[:-1] + (1,))
    return values.reshape(-1)[offsets + index]


def parabola_min(values: FloatArray, nodes: FloatArray) -> tuple[FloatArray, FloatArray]:
    """
    Return the minimum over the last axis refined by a parabola, and where it is.

    ``values`` (..., M) sampled at increasing ``nodes`` (M,), M >= 3.  The parabola through the
    best point and its two neighbours (the two inner neighbours at an end) is minimised on the
    interval between the best point's neighbours; the result is never above the best sample.
    """
    m = nodes.size
    j = np.argmin(values, axis=-1)
    jc = np.minimum(np.maximum(j, 1), m - 2)  # the best point, or the inner neighbour of an end
    # the parabola's three samples and the best one, and the nodes of those and of the best
    # point's neighbours (where the minimum may lie), each in one gather
    index = np.stack([jc - 1, jc, jc + 1, j, np.maximum(j - 1, 0), np.minimum(j + 1, m - 1)],
                     axis=-1)
    picked = take_last(values, index[..., :4])
    y0, y1, y2, best = picked[..., 0], picked[..., 1], picked[..., 2], picked[..., 3]
    at = nodes[index]
    x0, x1, x2, x_best, x_low, x_high = (at[..., i] for i in range(6))
    f01 = (y1 - y0) / (x1 - x0)
    f12 = (y2 - y1) / (x2 - x1)
    a = (f12 - f01) / (x2 - x0)
    with np.errstate(divide='ignore', invalid='ignore'):
        x = 0.5 * (x0 + x1) - f01 / (2.0 * a)
    # no vertex (NaN): the best point; an infinite one is clipped to the interval's end
    x = np.where(np.isnan(x), x_best, x).clip(x_low, x_high)
    value = y0 + f01 * (x - x0) + a * (x - x0) * (x - x1)
    better = (a > 0) & (value < best)
    return np.where(better, value, best), np.where(better, x, x_best)


class Profile:
    """Whitened Gaussian log-likelihood (15) at fixed speeds, profiled on grids."""

    def __init__(self, speeds: FloatArray, params: ParameterSet, grid: FloatArray) -> None:
        self.speeds, self.params, self.grid = speeds, params, grid
        covariance = fm.marginal_covariance(speeds, sigma=params.sigma,
                                            load_std=params.load_std, model=params.model)
        factor = np.linalg.cholesky(covariance)
        self.whiten = np.linalg.solve(factor, np.eye(speeds.size))
        self.const = (-0.5 * speeds.size * np.log(2.0 * np.pi)
                      - float(np.sum(np.log(np.diag(factor)))))
        self.t_min = float(params.temperature_min_degc)
        self.t_max = float(params.temperature_max_degc)
        self.t_grid = np.linspace(self.t_min, self.t_max, T_POINTS)
        self.nom = self._nominal(self.t_grid)            # (K, N)
        self.wear = self._wear(grid)                     # (G, N)
        self.nom2 = np.einsum('kn,kn->k', self.nom, self.nom)
        self.wear2 = np.einsum('gn,gn->g', self.wear, self.wear)
        self.cross = 2.0 * self.wear @ self.nom.T        # (G, K)

    def _nominal(self, t: FloatArray) -> FloatArray:
        f0 = fm.nominal_friction(self.speeds, self.params.load_mean, t[:, None],
                                 self.params.model)
        return f0 @ self.whiten.T

    def _wear(self, w: FloatArray) -> FloatArray:
        return fm.wear_friction(self.speeds, w[:, None], self.params.model) @ self.whiten.T

    def whitened(self, values: FloatArray) -> FloatArray:
        return values @ self.whiten.T

    def grid_profiles(self, data: FloatArray, *, want_t: bool) -> tuple:
        """Return the cost profiles min_T cost (B, G) and (if want_t) min_w cost (B, K)."""
        b = data.shape[0]
        g, k = self.cross.shape
        d2 = np.einsum('bn,bn->b', data, data)
        p_t = self.nom2[None, :] - 2.0 * data @ self.nom.T      # (B, K)
        q_w = self.wear2[None, :] - 2.0 * data @ self.wear.T    # (B, G)
        prof_w = np.empty((b, g))
        prof_t = np.empty((b, k)) if want_t else None
        chunk = max(1, CHUNK_CELLS // (g * k))
        for s in range(0, b, chunk):
            cube = self.cross[None, :, :] + p_t[s:s + chunk, None, :]
            cube += q_w[s:s + chunk, :, None]
            prof_w[s:s + chunk] = parabola_min(cube, self.t_grid)[0]
            if prof_t is not None:
                prof_t[s:s + chunk] = parabola_min(np.swapaxes(cube, 1, 2), self.grid)[0]
        prof_w += d2[:, None]
        if want_t:
            prof_t += d2[:, None]
        return prof_w, prof_t

    def cost_at_wear(self, data: FloatArray, w: FloatArray) -> FloatArray:
        """Return min over T of the cost (16) at one w per row, shape (B,)."""
        c = self._wear(w)
        e = data - c
        cost = (np.einsum('bn,bn->b', e, e)[:, None] + self.nom2[None, :]
                - 2.0 * e @ self.nom.T)
        return parabola_min(cost, self.t_grid)[0]

    def cost_at_temperature(self, data: FloatArray, t: FloatArray) -> FloatArray:
        """Return min over the wear grid of the cost (16) at one T per row, shape (B,)."""
        a = self._nominal(t)
        e = data - a
        cost = (np.einsum('bn,bn->b', e, e)[:, None] + self.wear2[None, :]
                - 2.0 * e @ self.wear.T)
        return parabola_min(cost, self.grid)[0]


_PROFILES: dict[tuple[bytes, int, bytes], Profile] = {}
_PROFILES_KEPT = 4


def cached_profile(speeds: FloatArray, params: ParameterSet, grid: FloatArray) -> Profile:
    """
    Return the profile of these speeds, parameter set and grid, built once and kept.

    Everything in a :class:`Profile` is data-independent (whitening, model on the grids);
    a monitor evaluates experiment after experiment at the same speeds.  Kept per
    parameter-set object; the last ``_PROFILES_KEPT`` are kept.
    """
    key = (speeds.tobytes(), id(params), grid.tobytes())
    profile = _PROFILES.get(key)
    if profile is None or profile.params is not params:
        profile = Profile(speeds.copy(), params, grid.copy())
        if len(_PROFILES) >= _PROFILES_KEPT:
            _PROFILES.pop(next(iter(_PROFILES)))
        _PROFILES[key] = profile
    return profile


class SingleLevel:
    """Marginal log-likelihood (17) of one level, exact and tabulated."""

    def __init__(self, speed: float, params: ParameterSet) -> None:
        self.speed, self.params = speed, params
        self.marginal = MarginalModel.build(speeds_rad_s=speed, params=params)
        s = float(self.marginal.std)
        self.s = s
        lo = float(self.marginal.nominal.min()) - _TABLE_TAIL * s
        hi = float(self.marginal.nominal.max()) + _TABLE_TAIL * s
        self.z = np.arange(lo, hi + s / _TABLE_DENSITY, s / _TABLE_DENSITY)
        self.table = self.marginal.log_density(self.z)

    def tabulated(self, z: FloatArray) -> FloatArray:
        """Return log g(z) by linear interpolation of the table, Gaussian tails beyond it."""
        zc = np.clip(z, self.z[0], self.z[-1])
        return np.interp(zc, self.z, self.table) - 0.5 * ((z - zc) / self.s) ** 2

    def exact(self, y: FloatArray, w: FloatArray) -> FloatArray:
        """Return log p(y | w) by quadrature, y and w of shape (B,)."""
        return self.marginal.log_density(y - fm.wear_friction(self.speed, w, self.params.model))

    def rows(self, y: FloatArray, grid: FloatArray) -> FloatArray:
        """Return log p(y_b | w_g), shape (B, G), from the table."""
        wear = fm.wear_friction(self.speed, grid, self.params.model)
        return self.tabulated(y[:, None] - wear[None, :])


_SINGLE_LEVELS: dict[tuple[float, int], SingleLevel] = {}


def cached_single_level(speed: float, params: ParameterSet) -> SingleLevel:
    """Return the tabulated marginal of one speed and parameter set, built once and kept."""
    key = (speed, id(params))
    single = _SINGLE_LEVELS.get(key)
    if single is None or single.params is not params:
        single = SingleLevel(speed, params)
        if len(_SINGLE_LEVELS) >= _PROFILES_KEPT:
            _SINGLE_LEVELS.pop(next(iter(_SINGLE_LEVELS)))
        _SINGLE_LEVELS[key] = single
    return single


class WearLikelihood:
    """
    The wear log-likelihood of a batch: rows on a grid, the maximum and exact values.

    ``rows`` (B, G): l_p(w) on the wear grid (N >= 2: profile over T; N = 1: marginal (17));
    ``l_hat`` (B,): the log-likelihood at the ML estimate; ``l_max`` (B,): the larger of that and
    the grid maximum; :meth:`at_wear` evaluates l_p at one w per row.  ``cost_t`` (B, K) is the
    joint cost minimised over w on the grid, per T of the T grid (for the T interval).
    """

    def __init__(self, speeds: FloatArray, values: FloatArray, params: ParameterSet,
                 grid: FloatArray, w_hat: FloatArray, t_hat: FloatArray, *,
                 want_t: bool) -> None:
        # the profile in T maximises over w on the wear grid, extended beyond an estimate past
        # its end (the wear profile uses the first grid.size columns only)
        target = 1.5 * float(np.max(w_hat, initial=0.0))
        extended = grid
        if want_t and target > grid[-1]:
            count = int(min(np.ceil((target - grid[-1]) / COARSE_STEP), 200))
            extended = np.concatenate([grid, np.linspace(grid[-1], target, count + 1)[1:]])
        self.profile = profile = cached_profile(speeds, params, extended)
        self.data = data = profile.whitened(values)
        self.single = None
        if speeds.size == 1:
            self.single = cached_single_level(float(speeds[0]), params)
            self.y = values[:, 0]
            cost_w, self.cost_t = (profile.grid_profiles(data, want_t=True) if want_t
                                   else (None, None))
            self.rows = self.single.rows(self.y, grid)
            self.l_hat = self.single.exact(self.y, w_hat)
        else:
            cost_w, self.cost_t = profile.grid_profiles(data, want_t=want_t)
            self.rows = profile.const - 0.5 * cost_w[:, :grid.size]
            residual = data - profile.whitened(
                fm.friction(speeds[None, :], params.load_mean, np.asarray(t_hat)[:, None],
                            w_hat[:, None], params.model))
            self.l_hat = profile.const - 0.5 * np.einsum('bn,bn->b', residual, residual)
        self.l_max = np.maximum(self.l_hat, self.rows.max(axis=1))

    def at_wear(self, w: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        """Return l_p(w_i) of the rows ``rows`` (one w per row)."""
        if self.single is not None:
            return self.single.exact(self.y[rows], w)
        return self.profile.const - 0.5 * self.profile.cost_at_wear(self.data[rows], w)
