"""
The wear trend's configuration and its batched grid filter: p(r, w) on the rate x wear grid.

:class:`TrendConfig` holds the filter's parameters; :class:`GridFilter` is the Bayes filter of
monotone wear of :mod:`robot_wear_monitor.estimation.trend` (which describes the model) for a
batch of B independent trends: predict by the elapsed experiments, update by a likelihood row,
and the posterior's summaries.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import NamedTuple, Optional

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.estimation.profile_likelihood import wear_grid
from robot_wear_monitor.estimation.special_functions import erf
from robot_wear_monitor.setting_fields import (at_least, check_settings, fraction, in_range,
                                               positive, setting, shared_setting)

_LOG_FLOOR = -1e30  # stands for log 0 (-inf) in the interpolation of the rows
#: rate transition tables kept per filter, one per distinct elapsed value (18 kB each)
TRANSITIONS_KEPT = 16


@dataclass(frozen=True)
class TrendConfig:
    """
    Parameters of the trend filter (rates are in w per experiment).

    ``wear_grid``: strictly increasing wear grid starting at >= 0, shape (G,), G >= 3; the
    likelihood rows must be given on it (default: ``profile_likelihood.wear_grid()``, 0 .. 150,
    321 points).  Every other field is a declared setting (default, unit, description, check:
    :mod:`robot_wear_monitor.setting_fields`); a bad value is an
    :class:`~robot_wear_monitor.errors.InputError` ``trend: <name>: <range>, got <value>``.
    ``threshold`` is the alarm policy's (:class:`~robot_wear_monitor.estimation.alarm.
    AlarmPolicy`, the paper's 35) and must lie inside the wear grid.
    """

    wear_grid: FloatArray = field(default_factory=wear_grid)
    threshold: float = shared_setting(
        AlarmPolicy, 'threshold',
        description="alarm level of the wear w that the trend's probability and forecast are "
                    'about (inside the wear grid)')
    initial_wear_scale: float = setting(
        4.0, unit='-', check=positive,
        description='scale of the half-normal new-joint prior of the wear w')
    initial_rate_mean: float = setting(
        0.02, unit='w/experiment', check=positive,
        description='mean of the exponential new-joint prior of the wear rate')
    rate_offset: float = setting(
        0.02, unit='w/experiment', check=positive,
        description='r0 of the log-rate random walk u = log(r + r0)')
    rate_step: float = setting(
        0.15, unit='-', check=positive,
        description='sd of the usual log-rate change per experiment')
    rate_jump_step: float = setting(
        2.5, unit='-', check=positive,
        description='sd of the rare large log-rate change per experiment')
    rate_jump_probability: float = setting(
        0.1, unit='-', check=fraction,
        description='probability of a large log-rate change per experiment')
    rate_max: float = setting(40.0, unit='w/experiment', check=positive,
                              description='largest rate of the rate grid')
    rate_points: int = setting(
        48, check=at_least(3),
        description='points of the rate grid (0 and a geometric grid up to the largest rate)')
    outlier_probability: float = setting(
        1e-3, unit='-', check=fraction,
        description='eps of the likelihood mixture (1 - eps) L + eps max L')
    likelihood_power: float = setting(
        0.5, unit='-', check=in_range(0.0, 1.0, low_open=True),
        description='power a of the tempered likelihood rows, L^a, before the mixture')
    filter_wear_step: float = setting(
        0.5, unit='-', check=positive,
        description="step of the filter's equidistant wear grid over the range of the wear "
                    'grid (the rows are interpolated onto it, linearly in log L)')
    experiment_interval_s: Optional[float] = setting(
        None, unit='s', check=positive,
        description='time of one experiment for the dynamics; unset: the median of the '
                    'last spacing_window time differences')
    spacing_window: int = setting(
        8, check=at_least(1),
        description='recent time differences whose median is the experiment spacing')
    forecast_horizon: int = setting(
        200, unit='experiments', check=at_least(1),
        description='experiments the forecast looks ahead (beyond it: inf)')

    def __post_init__(self) -> None:
        """Validate the grid and the declared settings (InputError naming the field)."""
        grid = np.asarray(self.wear_grid, dtype=float)
        object.__setattr__(self, 'wear_grid', grid)
        if grid.ndim != 1 or grid.size < 3 or not np.all(np.isfinite(grid)):
            raise InputError(f'trend: wear_grid must be 1-D, finite, >= 3 points, got shape '
                             f'{grid.shape}')
        if grid[0] < 0 or np.any(np.diff(grid) <= 0):
            raise InputError('trend: wear_grid must be strictly increasing and start >= 0')
        check_settings(self, prefix='trend: ')
        if not grid[0] < self.threshold < grid[-1]:
            raise InputError(f'trend: threshold {self.threshold} must lie inside the wear grid '
                             f'[{grid[0]}, {grid[-1]}]')

    @property
    def rate_grid(self) -> FloatArray:
        """Rate grid [w/experiment], shape (R,): 0 and a geometric grid up to ``rate_max``."""
        low = min(0.1 * self.rate_offset, self.rate_max / 10.0)
        return np.concatenate(([0.0], np.geomspace(low, self.rate_max, self.rate_points - 1)))


class ForecastTables(NamedTuple):
    """A configuration's rows b_n, (H+1, K); max_n b_n, (K,); max b_j - b_n, j < n (rounding)."""

    basis: FloatArray
    ceiling: FloatArray
    excess: float


class GridFilter:
    """p(r, w) on the rate x wear grid for a batch of B independent trends, shape (B, R, G)."""

    def __init__(self, config: TrendConfig, batch: int) -> None:
        self.config = config
        self.rates = config.rate_grid
        self.log_rates = np.log(self.rates + config.rate_offset)
        edges = 0.5 * (self.log_rates[1:] + self.log_rates[:-1])
        self.log_rate_edges = np.concatenate(([-np.inf], edges, [np.inf]))
        rows_grid = config.wear_grid
        count = int(np.ceil((rows_grid[-1] - rows_grid[0]) / config.filter_wear_step - 1e-9))
        grid = np.linspace(rows_grid[0], rows_grid[-1], count + 1)
        self.step = float(grid[1] - grid[0])
        self.grid = grid
        self.wear_edges = np.concatenate(([grid[0]], 0.5 * (grid[1:] + grid[:-1]), [grid[-1]]))
        # linear interpolation of the rows (on config.wear_grid) onto the filter's grid
        cell = np.clip(np.searchsorted(rows_grid, grid, side='right') - 1, 0,
                       rows_grid.size - 2)
        self.row_index = cell
        self.row_frac = np.clip((grid - rows_grid[cell]) / np.diff(rows_grid)[cell], 0.0, 1.0)
        self.wear_prior = self._wear_prior()
        self.rate_prior = self._rate_prior()
        self.prob = np.empty((batch, self.rates.size, grid.size))
        self.reset(np.ones(batch, dtype=bool))
        self._transitions: dict[float, FloatArray] = {}
        self._moves: dict[float, tuple[NDArray[np.int64], FloatArray]] = {}
        self._above: dict[float, FloatArray] = {}  # probability_above's cell parts, last one
        #: the forecast's tables, once looked up (forecast_tables)
        self.forecast_tables: Optional[ForecastTables] = None

    def _wear_prior(self) -> FloatArray:
        cdf = erf(self.wear_edges / (math.sqrt(2.0) * self.config.initial_wear_scale))
        mass = np.maximum(np.diff(cdf), 0.0)
        return mass / mass.sum()

    def _rate_prior(self) -> FloatArray:
        edges = np.concatenate(([0.0], 0.5 * (self.rates[1:] + self.rates[:-1]), [np.inf]))
        mass = np.diff(-np.exp(-edges / self.config.initial_rate_mean))
        return mass / mass.sum()

    def reset(self, rows: NDArray[np.bool_]) -> None:
        """Put the new-joint prior into the selected rows, shape (B,) bool."""
        self.prob[rows] = self.rate_prior[:, None] * self.wear_prior[None, :]

    def rate_transition(self, elapsed: FloatArray) -> FloatArray:
        """
        Return P(r' = j | r = i) over ``elapsed`` experiments, shape (B, R, R).

        Each distinct elapsed value's table is computed once and kept (up to
        :data:`TRANSITIONS_KEPT`, the oldest dropped first): experiments at a regular interval
        share one.  A table costs some 3,000 error functions (0.15 ms).
        """
        values = np.maximum(np.asarray(elapsed, dtype=float), 0.0).ravel().tolist()
        tables = {value: self._transition_of(value) for value in values}
        return np.stack([tables[value] for value in values])

    def _transition_of(self, elapsed: float) -> FloatArray:
        """Return the (R, R) transition over ``elapsed`` >= 0 experiments (kept, read-only)."""
        kept = self._transitions.get(elapsed)
        if kept is not None:
            return kept
        cfg = self.config
        e = np.full((1, 1), elapsed)  # numpy's power and sqrt, as for a batch of rows
        delta = self.log_rate_edges[None, :] - self.log_rates[:, None]
        jump = 1.0 - (1.0 - cfg.rate_jump_probability) ** e
        out = np.zeros((self.rates.size, self.rates.size))
        for weight, step in ((1.0 - jump, cfg.rate_step), (jump, cfg.rate_jump_step)):
            scale = np.maximum(step * np.sqrt(e), 1e-12) * math.sqrt(2.0)
            cdf = 0.5 * (1.0 + erf(delta / scale))
            out += weight * np.diff(cdf, axis=-1)
        out.flags.writeable = False
        if len(self._transitions) >= TRANSITIONS_KEPT:
            self._transitions.pop(next(iter(self._transitions)))
        self._transitions[elapsed] = out
        return out

    def predict(self, elapsed: FloatArray) -> None:
        """Propagate every row over its ``elapsed`` experiments, shape (B,) (0: no change)."""
        e = np.asarray(elapsed, dtype=float)
        moving = e > 0
        if not np.any(moving):
            return
        if np.all(moving):
            self.prob = self._shift(self.prob, e)
        else:
            self.prob[moving] = self._shift(self.prob[moving], e[moving])

    def _shift(self, p: FloatArray, elapsed: FloatArray) -> FloatArray:
        """
        Mix the rates, then move the wear of rate row j by r_j e (linear split, top absorbs).

        The product is numpy's einsum('bij,big->bjg', optimize=True), (p^T P)^T, laid out
        (g, j) in a buffer with a zero after the cells, for one gather of both cells of the
        split (the sums over g follow that layout, as they followed the einsum's).
        """
        b, r, g = p.shape
        cells = r * g
        source = np.empty((b, cells + 1))  # every filter's cells (g, j), then a zero
        source[:, cells] = 0.0
        mixed = source[:, :cells].reshape(b, g, r)
        np.matmul(p.transpose(0, 2, 1), self.rate_transition(elapsed), out=mixed)
        mixed = mixed.transpose(0, 2, 1)  # new p(j) = sum_i P(j | i) p(i), (b, r, g)
        moves = [self._move_of(value) for value in elapsed.tolist()]
        offsets = np.arange(b)[:, None, None] * (cells + 1)
        moved = np.take(source.reshape(-1), np.stack([m[0] for m in moves]) + offsets)
        frac = np.stack([m[1] for m in moves])
        # moved[j, c] = p[j, c - 1 - whole_j] (0 below): low = moved[1:], high = moved[:-1]
        low = moved[:, :, 1:]
        out = moved[:, :, :-1] - low
        out *= frac
        out += low  # low + frac (high - low)
        out[:, :, -1] += mixed.sum(axis=2) - out.sum(axis=2)  # what moved past the top
        return out

    def _move_of(self, elapsed: float) -> tuple[NDArray[np.int64], FloatArray]:
        """
        Return the gather index (R, G+1) and frac (R, 1) of a shift over ``elapsed`` (kept).

        Row j moves s_j = r_j e / step cells, whole_j = floor(s_j) (at most G), frac_j = s_j -
        floor(s_j); at c the index takes cell c - 1 - whole_j of row j from the cells laid out
        (g, j), or the zero after them below the grid.
        """
        kept = self._moves.get(elapsed)
        if kept is not None:
            return kept
        r, g = self.rates.size, self.grid.size
        shift = self.rates * elapsed / self.step
        whole = np.minimum(np.floor(shift), g).astype(np.int64)
        frac = (shift - np.floor(shift))[:, None]
        source = np.arange(g + 1)[None, :] - 1 - whole[:, None]
        index = np.where(source >= 0, source * r + np.arange(r)[:, None], r * g)
        if len(self._moves) >= TRANSITIONS_KEPT:
            self._moves.pop(next(iter(self._moves)))
        self._moves[elapsed] = (index, frac)
        return index, frac

    def update(self, log_likelihood: FloatArray) -> None:
        """Multiply by the likelihood rows (B, G) (outlier mixture) and renormalise."""
        rows = np.maximum(log_likelihood - np.max(log_likelihood, axis=-1, keepdims=True),
                          _LOG_FLOOR)
        low = rows[:, self.row_index]
        high = rows[:, self.row_index + 1]
        ll = self.config.likelihood_power * (low + self.row_frac * (high - low))
        eps = self.config.outlier_probability
        like = (1.0 - eps) * np.exp(ll) + eps
        p = self.prob * like[:, None, :]
        p /= p.sum(axis=(1, 2), keepdims=True)
        self.prob = p

    # ----------------------------------------------------------------- summaries

    def wear_marginal(self) -> FloatArray:
        """Return p(w) per row, shape (B, G)."""
        return self.prob.sum(axis=1)

    def wear_quantiles(self, levels: ArrayLike, mass: Optional[FloatArray] = None
                       ) -> FloatArray:
        """Return quantiles (Q,) of w, (B, Q), mass uniform in a cell (``mass``: wear_marginal)."""
        mass = self.wear_marginal() if mass is None else mass
        cdf = np.cumsum(mass, axis=1)
        cdf /= cdf[:, -1:]
        q = np.asarray(levels, dtype=float)[None, :]  # (1, Q)
        cell = np.minimum(np.sum(cdf[:, None, :] < q[:, :, None], axis=2), cdf.shape[1] - 1)
        upper = np.take_along_axis(cdf, cell, axis=1)
        lower = upper - np.take_along_axis(mass, cell, axis=1) / np.sum(mass, axis=1)[:, None]
        frac = np.clip((q - lower) / np.maximum(upper - lower, 1e-300), 0.0, 1.0)
        edges = self.wear_edges
        return edges[cell] + frac * (edges[cell + 1] - edges[cell])

    def probability_above(self, threshold: float, mass: Optional[FloatArray] = None
                          ) -> FloatArray:
        """Return P(w >= threshold) per row, shape (B,) (``mass``: :meth:`wear_marginal`)."""
        mass = self.wear_marginal() if mass is None else mass
        frac = self._above.get(threshold)
        if frac is None:  # the part of every cell above the threshold
            lo, hi = self.wear_edges[:-1], self.wear_edges[1:]
            frac = np.clip((hi - threshold) / np.maximum(hi - lo, 1e-300), 0.0, 1.0)
            self._above = {threshold: frac}
        return np.clip(mass @ frac, 0.0, 1.0)

    def rate_median(self) -> FloatArray:
        """Return the posterior median rate per row [w/experiment], shape (B,)."""
        cdf = np.cumsum(self.prob.sum(axis=2), axis=1)
        index = np.argmax(cdf >= 0.5 * cdf[:, -1:], axis=1)
        return self.rates[index]
