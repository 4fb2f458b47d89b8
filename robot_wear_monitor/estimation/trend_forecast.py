"""
The wear trend's forecast: the adjoint rows of the no-data propagation, once per configuration.

Since w is monotone, P(crossed within n experiments) = P(w_{k+n} >= threshold) =
<p, (M^T)^n a>; :func:`forecast_tables` computes the rows (M^T)^n a of a configuration once
(kept for four configurations) and :class:`ForecastSeries` multiplies a posterior by only the
rows that decide a quantile of the crossing (for
:meth:`robot_wear_monitor.estimation.trend.WearTrend.update`).
"""

from __future__ import annotations

from dataclasses import fields
import math

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation.trend_filter import ForecastTables, GridFilter, TrendConfig


class ForecastSeries:
    """
    The forecast series s_n = <p, b_n> of one posterior p, its rows multiplied on demand.

    Rows are multiplied in one product of four consecutive rows or, for the last (H+1 mod 4)
    rows, which the kernels treat apart, of those and the four before.  A row has then the
    bits of one product of the whole basis: OpenBLAS's dgemv forms each row's dot product on
    its own, a row of a group of four with one kernel, the last (rows mod 4) with others, over
    the same splits of the cells (``test_trend.py``, one BLAS thread as the CLI and nodes run).

    Rows not multiplied are bounded.  p, b_n >= 0: a product of K = R G terms in any order is
    within a relative 2 K u of the exact one (u the unit roundoff), so s_n <= <p, max_n b_n> m
    (m = 1 + 4 K u, at least 1 + 1e-9) and, the rows not decreasing but by e = ``excess``,
    s_j <= s_i m + 4 e sum(p) for j <= i.  A crossing found in a run of rows i .. is the first
    one, and its running maximum the run's, when that bound of the rows before i is below the
    run's maximum before the crossing; otherwise the run grows down.
    """

    def __init__(self, tables: ForecastTables, p: FloatArray) -> None:
        self.basis = tables.basis
        self.margin = 1.0 + max(1e-9, 4.0 * p.size * 2.0 ** -53)
        self.p = p
        self.rows = self.basis.shape[0]
        self.whole = self.rows - self.rows % 4  # rows in groups of four
        self.values = np.full(self.rows, np.nan)  # NaN: not multiplied
        self.slack = 4.0 * tables.excess * float(p.sum()) + 1e-300  # 1e-300: underflows
        self.bound = float(tables.ceiling @ p) * self.margin + self.slack

    def _multiply(self, first: int) -> tuple[int, int]:
        """Multiply rows first .. first + 3 (or the last group and the rest); return the range."""
        first = max(first, 0)
        end = first + 4
        if end > self.whole:
            first, end = max(self.whole - 4, 0), self.rows
        if np.isnan(self.values[first:end]).any():
            self.values[first:end] = self.basis[first:end] @ self.p
        return first, end

    def crossing(self, level: float, row: int) -> tuple[float, int]:
        """
        Return (n, its row): where the running maximum of clip(s_n, 0, 1) first reaches level.

        n is linear in between, 0 if s_0 does, ``inf`` if none; ``row``: where to look first.
        """
        if level > self.bound:
            return math.inf, row
        low, high = self._multiply(min(max(row, 0), self.rows - 1) - 2)
        while True:
            values = self.values[low:high]
            above = np.flatnonzero(values >= level)
            if above.size:
                n = low + int(above[0])
                if n == 0:
                    return 0.0, 0
                before = values[:n - low]
                if n > low and (low == 0 or values[0] * self.margin + self.slack
                                < before.max()):
                    p0 = np.clip(before.max(), 0.0, 1.0)
                    p1 = np.clip(values[n - low], 0.0, 1.0)
                    return n - 1 + (level - p0) / max(p1 - p0, 1e-300), n
            elif high < self.rows:
                high = self._multiply(high)[1]
                continue
            elif low == 0 or values[0] * self.margin + self.slack < level:
                return math.inf, self.rows - 1
            low = min(low, self._multiply(low - 4)[0])


#: per configuration: the forecast basis and its bounds
_FORECAST_TABLES: dict[tuple, ForecastTables] = {}


def _config_key(config: TrendConfig) -> tuple:
    """Return a hashable key of every field of ``config`` (arrays by their bytes)."""
    key = []
    for item in fields(config):
        value = getattr(config, item.name)
        if isinstance(value, np.ndarray):
            value = (value.shape, value.tobytes())
        key.append((item.name, value))
    return tuple(key)


def forecast_tables(flt: GridFilter) -> ForecastTables:
    """Return the forecast basis and its bounds, once per configuration (kept on the filter)."""
    if flt.forecast_tables is not None:
        return flt.forecast_tables
    key = _config_key(flt.config)
    tables = _FORECAST_TABLES.get(key)
    if tables is None:
        basis = forecast_basis(flt)
        size = basis.shape[1]
        ceiling, drop = basis[0].copy(), np.empty(size)
        excess = 0.0
        for row in basis[1:]:  # the largest b_j - b_n, j < n, and the largest b_n of a cell
            np.subtract(ceiling, row, out=drop)
            excess = max(excess, float(drop.max()))
            np.maximum(ceiling, row, out=ceiling)
        tables = ForecastTables(basis, ceiling, excess)
        if len(_FORECAST_TABLES) >= 4:  # 23 MB each at the default grid
            _FORECAST_TABLES.clear()
        _FORECAST_TABLES[key] = tables
    flt.forecast_tables = tables
    return tables


def forecast_basis(flt: GridFilter) -> FloatArray:
    """
    Return the rows (M^T)^n a, n = 0 .. horizon, shape (H+1, R*G) (:func:`forecast_tables`).

    M is one experiment ahead without data: the rate transition of one experiment, then every
    rate row shifted by its rate (the linear split between two cells of :meth:`GridFilter._shift`,
    mass past the top kept in the top cell).  a is the P(w >= threshold) weight of every cell.
    """
    cfg = flt.config
    r, g = flt.rates.size, flt.grid.size
    transition = flt.rate_transition(np.ones(1))[0]  # (R, R): new p = transition.T @ p
    shift = flt.rates / flt.step
    whole = np.minimum(np.floor(shift), g).astype(np.int64)
    frac = (shift - np.floor(shift))[:, None]
    cells = np.arange(g)[None, :]
    first = np.arange(r)[:, None] * g  # the flat index of each rate row's first cell
    low = (first + np.minimum(cells + whole[:, None], g - 1)).ravel()
    high = (first + np.minimum(cells + whole[:, None] + 1, g - 1)).ravel()
    keep = np.broadcast_to(1.0 - frac, (r, g)).ravel()  # the weights of low and high
    move = np.broadcast_to(frac, (r, g)).ravel()
    lo, hi = flt.wear_edges[:-1], flt.wear_edges[1:]
    above = np.clip((hi - cfg.threshold) / np.maximum(hi - lo, 1e-300), 0.0, 1.0)
    basis = np.empty((cfg.forecast_horizon + 1, r * g))
    basis[0] = np.tile(above, r)
    moved, upper = np.empty(r * g), np.empty(r * g)
    for n in range(cfg.forecast_horizon):  # moved = keep v[low] + move v[high], in place
        np.take(basis[n], low, out=moved)
        np.take(basis[n], high, out=upper)
        moved *= keep
        upper *= move
        moved += upper
        np.matmul(transition, moved.reshape(r, g), out=basis[n + 1].reshape(r, g))
    return basis
