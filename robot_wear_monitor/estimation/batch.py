"""
Estimates of many experiments at once, each at its own measured speeds.

A monitor estimates one experiment at a time, and the measured speeds of its experiments differ
by a few mrad/s, so :func:`~robot_wear_monitor.estimation.estimator.estimate_wear` (one design
per call) cannot batch them.  A replay has many completed experiments at hand at once:
:func:`estimate_wear_rows` estimates them together, every row with its own speeds.  Each row's
start grid is its own (it depends on the speeds), but the grids of all rows and the costs on
them are evaluated stacked, and the local refinement of all rows runs as one batched iteration
on a stacked problem (the speeds and whitening matrix of every row), so the numpy calls of a
grid or an iteration are paid once for the batch, not once per experiment.

Every operation is row by row, as alone: elementwise ufuncs, reductions along the same axis,
one LAPACK, BLAS or einsum kernel call per row with the same shapes and memory layout (each row
iterates until it converges), so row ``i`` of the result equals ``estimate_wear(speeds[i],
friction[i])`` number for number (the tests assert it on simulated and foreign recordings).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation import estimator as core, start_grid, wear_estimates
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet


class _StackedProblem(core._WhitenedProblem):
    """The weighted least squares (16) of B rows, each at its own speeds (B, N)."""

    def __init__(self, speeds: FloatArray, whiten: FloatArray, params: ParameterSet) -> None:
        # no super().__init__: the rows' whitening matrices come from their own problems
        self.speeds = speeds
        self.speed_rows = speeds
        self.whiten = whiten
        self.params = params
        self.t_min = params.temperature_min_degc
        self.t_max = params.temperature_max_degc
        self._grid_cache = None

    def apply(self, values: FloatArray) -> FloatArray:
        """Return the whitened values (B, N), every row by its own matrix."""
        return np.einsum('bn,bmn->bm', values, self.whiten)

    def rows(self, index: NDArray[np.intp]) -> '_StackedProblem':
        """Return the problem of the rows ``index``."""
        return _StackedProblem(self.speeds[index], self.whiten[index], self.params)


def estimate_wear_rows(speeds_rad_s: Sequence[ArrayLike], friction: Sequence[ArrayLike], *,
                       params: ParameterSet) -> list[wear_estimates.WearEstimates]:
    """
    Estimate (T, w) of B experiments, each with its own speeds; one batch of 1 per row.

    Row ``i`` of the result equals ``estimate_wear(speeds_rad_s[i], friction[i],
    params=params)``; rows with N >= 2 levels are refined together (rows of equal N), rows
    with one level are estimated one by one.

    :raises InputError: bad speeds or friction in a row (as :func:`estimate_wear`).

    """
    if len(speeds_rad_s) != len(friction):
        raise ValueError('speeds_rad_s and friction: one entry per experiment')
    speeds = [wear_estimates.validate_speeds(s) for s in speeds_rad_s]
    values = [wear_estimates.validate_friction(f, s.size) for s, f in zip(speeds, friction)]
    results: list[wear_estimates.WearEstimates | None] = [None] * len(speeds)
    by_size: dict[int, list[int]] = {}
    for i, (s, v) in enumerate(zip(speeds, values)):
        if s.size == 1 or v.shape[0] != 1:
            results[i] = core.estimate_wear(s, v, params=params)
        else:
            by_size.setdefault(s.size, []).append(i)
    for rows in by_size.values():
        for i, estimates in zip(rows, _estimate_stacked([speeds[i] for i in rows],
                                                        [values[i] for i in rows], params)):
            results[i] = estimates
    return [r for r in results if r is not None]


def whitening_rows(speeds: FloatArray, params: ParameterSet) -> tuple[FloatArray, FloatArray]:
    """
    Return the whitening matrices (B, N, N) and Cholesky factors (B, N, N) of B rows.

    Row ``i`` is the matrix of ``_WhitenedProblem(speeds[i], params)`` (and of an intervals
    profile), number for number: the covariance (14) elementwise, then one LAPACK
    factorisation and solve per row, as alone (numpy's stacked linalg calls them row by row).

    :param speeds: motor-side speeds [rad/s], shape (B, N).
    :raises numpy.linalg.LinAlgError: a covariance that is not positive definite.

    """
    covariance = fm.marginal_covariance(speeds, sigma=params.sigma, load_std=params.load_std,
                                        model=params.model)
    factor = np.asarray(np.linalg.cholesky(covariance), dtype=np.float64)
    whiten = np.asarray(np.linalg.solve(factor, np.eye(speeds.shape[1])), dtype=np.float64)
    return whiten, factor


def _arc_length_grids(points: FloatArray, fine: FloatArray, lower: float, *, spacing: float,
                      max_step: float) -> list[FloatArray]:
    """
    Return :func:`~robot_wear_monitor.estimation.start_grid.arc_length_grid` of every row.

    ``points`` (B, M, N): every row's whitened model curve at the ``fine`` samples (M,).  The
    arc lengths of all rows are one stacked evaluation (the same elementwise operations and
    the same reductions along the last axis as for one row); the grids' sizes differ by row.
    """
    arc = np.cumsum(np.linalg.norm(np.diff(points, axis=1), axis=2), axis=1)
    arc = np.concatenate([np.zeros((arc.shape[0], 1)), arc], axis=1)
    arc = arc + (fine - lower) * (spacing / max_step)  # the parameter step bound
    grids = []
    for row in arc:
        count = min(int(np.ceil(row[-1] / spacing)) + 1, start_grid.GRID_MAX_POINTS)
        grids.append(np.interp(np.linspace(0.0, row[-1], max(count, 2)), row, fine))
    return grids


#: at most this many (row, sample, level) cells in a stacked start-grid array (cache-sized)
_GRID_ROW_CELLS = 1 << 16


def _levels_last(values: FloatArray) -> FloatArray:
    """Return values (N, ...) as a C-contiguous array (..., N) (the layout of one row's model)."""
    return np.ascontiguousarray(np.moveaxis(values, 0, -1))


def _grid_starts_rows(speeds: FloatArray, whiten: FloatArray, data_w: FloatArray,
                      params: ParameterSet) -> tuple[FloatArray, FloatArray]:
    """
    Return the K starting points (T, w) of every row, each of shape (B, K).

    Row ``i`` equals ``_WhitenedProblem(speeds[i], params).grid_starts(data_w[i:i + 1])``
    number for number: the start grid of every row (its own, at its own speeds) and the cost on
    it are computed for many rows at once, with the operations of one row stacked (elementwise
    ufuncs, reductions along the same axis, one BLAS product and one einsum kernel per row).

    :param speeds: motor-side speeds [rad/s], shape (B, N).
    :param whiten: the rows' whitening matrices, shape (B, N, N) (:func:`whitening_rows`).
    :param data_w: the rows' whitened friction levels, shape (B, N).

    """
    count, n = speeds.shape
    t_out = np.empty((count, core._STARTS))
    w_out = np.empty((count, core._STARTS))
    chunk = max(1, _GRID_ROW_CELLS // (start_grid.ARC_SAMPLES * n))
    for start in range(0, count, chunk):
        part = slice(start, start + chunk)
        t_out[part], w_out[part] = _grid_starts_chunk(speeds[part], whiten[part], data_w[part],
                                                      params)
    return t_out, w_out


def _grid_starts_chunk(speeds: FloatArray, whiten: FloatArray, data_w: FloatArray,
                       params: ParameterSet) -> tuple[FloatArray, FloatArray]:
    """Return :func:`_grid_starts_rows` of a few rows (the arrays of ``_grid``, stacked)."""
    model, load = params.model, params.load_mean
    t_min, t_max = params.temperature_min_degc, params.temperature_max_degc
    mid_t = 0.5 * (t_min + t_max)
    whiten_t = np.ascontiguousarray(np.swapaxes(whiten, 1, 2))  # each row's whiten.T
    # the model is evaluated levels-first, (N, B, samples): the same elementwise operations
    # as one row's (samples, N), on long rows of memory
    v = speeds.T[:, :, None]
    fine_t = np.linspace(t_min, t_max, start_grid.ARC_SAMPLES)
    fine_w = np.linspace(0.0, params.wear_max, start_grid.ARC_SAMPLES)
    grids_t = _arc_length_grids(
        np.matmul(_levels_last(fm.friction(v, load, fine_t, 0.0, model)), whiten_t), fine_t,
        t_min, spacing=start_grid.GRID_SPACING_SIGMA, max_step=start_grid.GRID_MAX_STEP_DEGC)
    grids_w = _arc_length_grids(
        np.matmul(_levels_last(fm.friction(v, load, mid_t, fine_w, model)), whiten_t), fine_w,
        0.0, spacing=start_grid.GRID_SPACING_SIGMA, max_step=start_grid.GRID_MAX_STEP_WEAR)
    t0 = np.empty((speeds.shape[0], core._STARTS))
    w0 = np.empty((speeds.shape[0], core._STARTS))
    groups: dict[tuple[int, int], list[int]] = {}
    for i, (grid_t, grid_w) in enumerate(zip(grids_t, grids_w)):
        groups.setdefault((grid_t.size, grid_w.size), []).append(i)
    for (n_t, n_w), rows in groups.items():
        index = np.asarray(rows)
        grid_t, grid_w = np.stack([grids_t[i] for i in rows]), np.stack([grids_w[i] for i in rows])
        # the model (8) on every row's grid, w-major (as _grid), whitened by one product per row
        rows_v = v[:, index, :, None]  # (N, b, 1, 1)
        nominal = fm.nominal_friction(rows_v, load, grid_t[:, None, :], model)  # (N, b, 1, T)
        wear = fm.wear_friction(rows_v, grid_w[:, :, None], model)  # (N, b, w, 1)
        model_w = np.matmul(_levels_last(nominal + wear).reshape(index.size, n_w * n_t, -1),
                            whiten_t[index])
        norm2 = np.einsum('bkn,bkn->bk', model_w, model_w)
        # d.(-2 g) of grid_starts as (-2 d).g: the same products exactly (a factor 2 is exact),
        # the same einsum kernel on the same memory layout, without a -2 g copy of the grid
        score = np.einsum('bn,bnk->bk', -2.0 * data_w[index], np.swapaxes(model_w, 1, 2))
        score += norm2
        score = score.reshape(-1, n_w, n_t)
        # the rest of grid_starts, row by row on the stack
        best_t = np.argmin(score, axis=2)
        profile = np.min(score, axis=2)
        padded = np.pad(profile, ((0, 0), (1, 1)), constant_values=np.inf)
        local = (profile <= padded[:, :-2]) & (profile <= padded[:, 2:])
        ranked = np.where(local, profile, profile + 1e300)
        pick = np.argpartition(ranked, core._STARTS - 1, axis=1)[:, :core._STARTS]
        t0[index] = np.take_along_axis(grid_t, np.take_along_axis(best_t, pick, axis=1),
                                       axis=1)
        w0[index] = np.take_along_axis(grid_w, pick, axis=1)
    return t0, w0


def _estimate_stacked(speeds: list[FloatArray], values: list[FloatArray],
                      params: ParameterSet) -> list[wear_estimates.WearEstimates]:
    """Return the N >= 2 estimates of :func:`estimate_wear` for rows of equal N (one row each)."""
    speed_rows = np.stack(speeds)
    stacked = _StackedProblem(speed_rows, whitening_rows(speed_rows, params)[0], params)
    data_w = stacked.apply(np.concatenate(values))
    t0, w0 = _grid_starts_rows(speed_rows, stacked.whiten, data_w, params)
    count, k = t0.shape
    repeated_rows = np.repeat(np.arange(count), k)
    repeated = data_w[repeated_rows]
    starts_problem = stacked.rows(repeated_rows)
    t, w = core._refine(starts_problem, repeated, t0.ravel(), w0.ravel())
    cost = starts_problem.cost(repeated, t, w).reshape(count, k)
    pick = np.argmin(cost, axis=1)
    rows = np.arange(count)
    t, w = t.reshape(count, k)[rows, pick], w.reshape(count, k)[rows, pick]
    # the end of _estimate_multi_level, row by row on the stack
    residual, jacobian, chi2 = stacked.evaluate(data_w, t, w)
    covariance = core._inverse_2x2(np.einsum('bni,bnj->bij', jacobian, jacobian))
    t_at_bound = (t <= stacked.t_min) | (t >= stacked.t_max)
    w_at_bound = w <= 0.0
    n_levels = speeds[0].size
    dof = (n_levels - (~t_at_bound).astype(np.int64) - (~w_at_bound).astype(np.int64))
    p_value = wear_estimates.fit_p_value(chi2, dof)
    return [wear_estimates.WearEstimates(
        temperature_degc=t[i:i + 1], wear=w[i:i + 1], covariance=covariance[i:i + 1],
        temperature_at_bound=t_at_bound[i:i + 1], wear_at_bound=w_at_bound[i:i + 1],
        chi2=chi2[i:i + 1], dof=dof[i:i + 1], p_value=p_value[i:i + 1], n_levels=n_levels,
        speeds_rad_s=speeds[i].copy()) for i in rows]
