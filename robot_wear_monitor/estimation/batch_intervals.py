"""
Intervals and likelihood rows of many experiments at once, each at its own measured speeds.

The companion of :mod:`robot_wear_monitor.estimation.batch` for
:func:`~robot_wear_monitor.estimation.intervals.wear_intervals` and
:func:`~robot_wear_monitor.estimation.intervals.profile_log_likelihood`.  Each row keeps its own
profile (whitening, model on the wear and temperature grids: built for all rows at once with
the operations of one experiment's), and the grid profiles and the root searches of the
interval ends run once for all rows, every row with its own matrices.  The products are the
same matrix products as for one experiment (one per row, same shapes and memory layout), so
row ``i`` equals the one-experiment result number for number (tested).

Rows with one level (N = 1), whose likelihood is the marginal (17), go one by one.
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation import intervals as one, profile_likelihood as pl
from robot_wear_monitor.estimation.batch import _levels_last, whitening_rows
from robot_wear_monitor.estimation.special_functions import chi2_quantile_one_dof
from robot_wear_monitor.estimation.wear_estimates import validate_levels, WearEstimates
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet


class _StackedProfile:
    """
    The :class:`~robot_wear_monitor.estimation.profile_likelihood.Profile` of B rows, stacked.

    Built for all rows at once (:meth:`build`), with the operations of one row's profile: the
    model on the grids elementwise (evaluated levels-first, on long rows of memory), then one
    BLAS product and one einsum kernel per row, so row ``i`` holds the arrays of ``Profile(
    speeds[i], params, grid)`` number for number (tested).
    """

    def __init__(self, params: ParameterSet, grid: FloatArray, speeds: FloatArray,
                 whiten: FloatArray, const: FloatArray, nom: FloatArray, wear: FloatArray,
                 nom2: FloatArray, wear2: FloatArray) -> None:
        self.params, self.grid = params, grid
        self.t_min = float(params.temperature_min_degc)
        self.t_max = float(params.temperature_max_degc)
        self.t_grid = np.linspace(self.t_min, self.t_max, pl.T_POINTS)
        self.speeds = speeds                                           # (B, N)
        self.whiten = whiten                                           # (B, N, N)
        self.const = const                                             # (B,)
        self.nom = nom                                                 # (B, K, N)
        self.wear = wear                                               # (B, G, N)
        self.nom2 = nom2                                               # (B, K)
        self.wear2 = wear2                                             # (B, G)
        self._last_rows: dict[tuple[str, ...], tuple[bytes, list[FloatArray]]] = {}

    @classmethod
    def build(cls, speeds: FloatArray, params: ParameterSet, grid: FloatArray
              ) -> '_StackedProfile':
        """Return the profiles of the rows ``speeds`` (B, N) [rad/s] on the wear ``grid``."""
        whiten, factor = whitening_rows(speeds, params)
        const = (-0.5 * speeds.shape[1] * np.log(2.0 * np.pi)
                 - np.sum(np.log(np.diagonal(factor, axis1=1, axis2=2)), axis=1))
        t_grid = np.linspace(float(params.temperature_min_degc),
                             float(params.temperature_max_degc), pl.T_POINTS)
        levels_first = speeds.T[:, :, None]  # (N, B, 1)
        whiten_t = cls._t(whiten)
        nom = np.matmul(_levels_last(fm.nominal_friction(levels_first, params.load_mean, t_grid,
                                                         params.model)), whiten_t)
        wear = np.matmul(_levels_last(fm.wear_friction(levels_first, grid, params.model)),
                         whiten_t)
        return cls(params, grid, speeds, whiten, const, nom, wear,
                   np.einsum('bkn,bkn->bk', nom, nom), np.einsum('bgn,bgn->bg', wear, wear))

    @staticmethod
    def _t(stack: FloatArray) -> FloatArray:
        """Return every row's matrix transposed (a view: each row as ``matrix.T``)."""
        return np.swapaxes(stack, -1, -2)

    def _times(self, values: FloatArray, stack: FloatArray) -> FloatArray:
        """Return ``values[i] @ stack[i].T`` per row: (R, M, N) x (R, P, N) -> (R, M, P)."""
        return np.matmul(values, self._t(stack))

    def whitened(self, values: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        """Return the rows' values whitened, (R, N) (one (1, N) product per row)."""
        return self._times(values[:, None, :], self.whiten[rows])[:, 0, :]

    def cross(self, part: slice) -> FloatArray:
        """Return the ``Profile.cross`` 2 a_k.c_g of the rows ``part``, (R, G, K)."""
        return np.matmul(2.0 * self.wear[part], self._t(self.nom[part]))

    def grid_profiles(self, data: FloatArray, *, want_t: bool) -> tuple:
        """Return min_T cost (B, G) and (if want_t) min_w cost (B, K), as per row alone."""
        d2 = np.einsum('bn,bn->b', data, data)
        p_t = self.nom2 - self._times(2.0 * data[:, None, :], self.nom)[:, 0, :]
        q_w = self.wear2 - self._times(2.0 * data[:, None, :], self.wear)[:, 0, :]
        b, g, k = data.shape[0], self.wear.shape[1], self.nom.shape[1]
        prof_w = np.empty((b, g))
        prof_t = np.empty((b, k)) if want_t else None
        # a few rows' cost cubes at a time (cache-sized), each made from its rows' products
        chunk = max(1, pl.CHUNK_CELLS // (g * k))
        for s in range(0, b, chunk):
            cube = self.cross(slice(s, s + chunk))
            cube += p_t[s:s + chunk, None, :]
            cube += q_w[s:s + chunk, :, None]
            prof_w[s:s + chunk] = pl.parabola_min(cube, self.t_grid)[0]
            if prof_t is not None:
                # over the wear grid: on a contiguous copy (argmin would copy it anyway)
                prof_t[s:s + chunk] = pl.parabola_min(
                    np.ascontiguousarray(np.swapaxes(cube, 1, 2)), self.grid)[0]
        prof_w += d2[:, None]
        if prof_t is not None:
            prof_t += d2[:, None]
        return prof_w, prof_t

    def _of_rows(self, rows: NDArray[np.intp], *names: str) -> list[FloatArray]:
        """
        Return the arrays ``names`` of the rows ``rows``.

        The last rows' are kept per ``names``: a root search asks for the same rows again and
        again until one of them has converged.
        """
        key = rows.tobytes()
        last = self._last_rows.get(names)
        if last is None or last[0] != key:
            last = self._last_rows[names] = (key, [getattr(self, n)[rows] for n in names])
        return last[1]

    def cost_at_wear(self, data: FloatArray, w: FloatArray,
                     rows: NDArray[np.intp]) -> FloatArray:
        """Return min over T of the cost at one w per row of ``rows``, (R,)."""
        speeds, whiten, nom2, nom = self._of_rows(rows, 'speeds', 'whiten', 'nom2', 'nom')
        c = self._times(fm.wear_friction(speeds, w[:, None], self.params.model)[:, None, :],
                        whiten)[:, 0, :]
        e = data - c
        cost = (np.einsum('bn,bn->b', e, e)[:, None] + nom2
                - self._times(2.0 * e[:, None, :], nom)[:, 0, :])
        return pl.parabola_min(cost, self.t_grid)[0]

    def cost_at_temperature(self, data: FloatArray, t: FloatArray,
                            rows: NDArray[np.intp]) -> FloatArray:
        """Return min over the wear grid of the cost at one T per row of ``rows``, (R,)."""
        speeds, whiten, wear2, wear = self._of_rows(rows, 'speeds', 'whiten', 'wear2', 'wear')
        f0 = fm.nominal_friction(speeds, self.params.load_mean, t[:, None], self.params.model)
        a = self._times(f0[:, None, :], whiten)[:, 0, :]
        e = data - a
        cost = (np.einsum('bn,bn->b', e, e)[:, None] + wear2
                - self._times(2.0 * e[:, None, :], wear)[:, 0, :])
        return pl.parabola_min(cost, self.grid)[0]


def _extended_grid(grid: FloatArray, w_hat: float) -> FloatArray:
    """Return the wear grid of one row's T profile (as ``WearLikelihood`` extends it)."""
    target = 1.5 * max(float(w_hat), 0.0)
    if target > grid[-1]:
        count = int(min(np.ceil((target - grid[-1]) / pl.COARSE_STEP), 200))
        return np.concatenate([grid, np.linspace(grid[-1], target, count + 1)[1:]])
    return grid


def wear_intervals_rows(speeds: Sequence[FloatArray], values: Sequence[FloatArray],
                        estimates: Sequence[WearEstimates], *, params: ParameterSet,
                        trend_grid: Optional[FloatArray] = None, level: float = 0.95
                        ) -> tuple[list[one.WearIntervals], list[Optional[FloatArray]]]:
    """
    Return the intervals of B experiments (one batch of 1 per row) and their trend rows.

    Row ``i`` equals ``wear_intervals(speeds[i], values[i], params=params,
    estimates=estimates[i], level=level)`` (default grid, calibrated cutoff), and its trend
    row ``profile_log_likelihood(speeds[i], values[i], params=params,
    wear_grid=trend_grid)`` (None without ``trend_grid``).  ``values[i]``: shape (1, N).

    :raises InputError: as the one-experiment functions.

    """
    grid = pl.validate_grid(pl.wear_grid(params.wear_max))
    checked = [validate_levels(s, v) for s, v in zip(speeds, values)]
    speeds = [s for s, _ in checked]
    values = [v for _, v in checked]
    out: list[Optional[one.WearIntervals]] = [None] * len(speeds)
    groups: dict[tuple, list[int]] = {}
    calibrations: dict[tuple, object] = {}  # by rounded speeds, the key of a calibration
    for i, (s, v) in enumerate(zip(speeds, values)):
        if s.size == 1 or v.shape[0] != 1 or len(estimates[i]) != 1:
            out[i] = one.wear_intervals(s, v, params=params, level=level,
                                        estimates=estimates[i])
            continue
        rounded = one._rounded_speeds(s)
        calibration = calibrations.get(rounded)
        if calibration is None:
            calibration = calibrations[rounded] = one.calibrate_cutoffs(s, params=params,
                                                                        level=level)
        extended = _extended_grid(grid, float(estimates[i].wear[0]))
        groups.setdefault((s.size, id(calibration), extended.tobytes()), []).append(i)
    trend = None if trend_grid is None else pl.validate_grid(trend_grid)
    trend_rows: list[Optional[FloatArray]] = [None] * len(speeds)
    for (_, _, extended), rows in groups.items():
        results, like_rows = _intervals_stacked(
            [speeds[i] for i in rows], [values[i] for i in rows],
            [estimates[i] for i in rows], params, grid, level)
        # the trend row of a row whose profile is on the trend grid (its extended grid) is its
        # wear profile there (profile_log_likelihood and wear_intervals compute it alike)
        same = trend is not None and extended == trend.tobytes()
        for j, (i, result) in enumerate(zip(rows, results)):
            out[i] = result
            if same:
                trend_rows[i] = like_rows[j:j + 1]
    if trend is not None:
        left = [i for i, row in enumerate(trend_rows) if row is None]
        for i, row in zip(left, _likelihood_rows([speeds[i] for i in left],
                                                 [values[i] for i in left], params, trend)):
            trend_rows[i] = row
    return [r for r in out if r is not None], trend_rows


def _likelihood_rows(speeds: Sequence[FloatArray], values: Sequence[FloatArray],
                     params: ParameterSet, trend_grid: FloatArray
                     ) -> list[Optional[FloatArray]]:
    """Return profile_log_likelihood of every row (N >= 2 rows stacked), shape (1, G) each."""
    grid = pl.validate_grid(trend_grid)
    rows: list[Optional[FloatArray]] = [None] * len(speeds)
    by_size: dict[int, list[int]] = {}
    for i, (s, v) in enumerate(zip(speeds, values)):
        s, v = validate_levels(s, v)
        if s.size == 1 or v.shape[0] != 1:
            rows[i] = one.profile_log_likelihood(s, v, params=params, wear_grid=grid)
        else:
            by_size.setdefault(s.size, []).append(i)
    for group in by_size.values():
        stacked = _StackedProfile.build(np.stack([speeds[i] for i in group]), params, grid)
        index = np.arange(len(group))
        data = stacked.whitened(np.concatenate([np.asarray(values[i], dtype=float)
                                                for i in group]), index)
        cost, _ = stacked.grid_profiles(data, want_t=False)
        like = stacked.const[:, None] - 0.5 * cost
        for j, i in enumerate(group):
            rows[i] = like[j:j + 1]
    return rows


def _intervals_stacked(speeds: list, values: list, estimates: list, params: ParameterSet,
                       grid: FloatArray, level: float
                       ) -> tuple[list[one.WearIntervals], FloatArray]:
    """
    Return :func:`wear_intervals` of rows of equal N, calibration and extended grid.

    Also the rows' profile log-likelihood on their extended grid (:func:`_extended_grid`, the
    same for all), (B, G') (its first G columns: on ``grid``).
    """
    speeds = [np.asarray(s, dtype=float) for s in speeds]
    vals = np.concatenate([np.asarray(v, dtype=float) for v in values])
    w_hat = np.concatenate([np.asarray(e.wear, dtype=float) for e in estimates])
    t_hat = np.concatenate([np.asarray(e.temperature_degc, dtype=float) for e in estimates])
    half_q = 0.5 * chi2_quantile_one_dof(level)
    profile = _StackedProfile.build(np.stack(speeds), params,
                                    _extended_grid(grid, float(w_hat[0])))
    index = np.arange(len(speeds))
    data = profile.whitened(vals, index)
    # WearLikelihood, N >= 2
    cost_w, cost_t = profile.grid_profiles(data, want_t=True)
    profile_rows = profile.const[:, None] - 0.5 * cost_w  # on the extended grid
    like_rows = profile_rows[:, :grid.size]
    model = fm.friction(profile.speeds, params.load_mean, t_hat[:, None], w_hat[:, None],
                        params.model)
    residual = data - profile.whitened(model, index)
    l_hat = profile.const - 0.5 * np.einsum('bn,bn->b', residual, residual)
    l_max = np.maximum(l_hat, like_rows.max(axis=1))

    def at_wear(w: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        return profile.const[rows] - 0.5 * profile.cost_at_wear(data[rows], w, rows)
    # wear_intervals, calibrated cutoff (one calibration for the group)
    calibration = one.calibrate_cutoffs(speeds[0], params=params, level=level)
    half_c = 0.5 * calibration.at(grid)

    def wear_func(w: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        return at_wear(w, rows) + 0.5 * calibration.at(w)
    wear_low, wear_high, open_end = one._hull(like_rows + half_c[None, :], grid, l_max, w_hat,
                                              l_hat + 0.5 * calibration.at(w_hat), wear_func,
                                              together=True)
    wear_low = np.maximum(wear_low, 0.0)
    joint_t = profile.const[:, None] - 0.5 * cost_t

    def temp_func(t: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        return profile.const[rows] - 0.5 * profile.cost_at_temperature(data[rows], t, rows)
    lt_max = np.maximum(l_hat, joint_t.max(axis=1))
    t_low, t_high, _ = one._hull(joint_t, profile.t_grid, lt_max - half_q, t_hat, l_hat,
                                 temp_func, together=True)
    t_low = np.clip(t_low, profile.t_min, profile.t_max)
    t_high = np.clip(t_high, profile.t_min, profile.t_max)
    return [one.WearIntervals(wear_low=wear_low[i:i + 1], wear_high=wear_high[i:i + 1],
                              temperature_low=t_low[i:i + 1], temperature_high=t_high[i:i + 1],
                              wear_high_at_grid_end=open_end[i:i + 1], level=float(level))
            for i in index], profile_rows
