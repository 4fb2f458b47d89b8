"""
Wear trend: a Bayes filter that fuses per-experiment wear likelihoods into a monotone trend.

Each friction experiment k gives a log-likelihood row l_k(w) of the wear level on a common wear
grid (:func:`robot_wear_monitor.estimation.intervals.profile_log_likelihood`: T profiled out,
N = 1 marginal).  Between maintenance actions the wear is modelled as a monotone process with a
growth rate, and the filter computes p(w_k, r_k | l_1 .. l_k) on a 2-D grid (wear x rate).

State-space model (time in *experiments*, see below):

* the rate r >= 0 [w per experiment] follows a random walk in u = log(r + r0) with a
  heavy-tailed increment, a two-component Gaussian mixture: sd ``rate_step`` sqrt(e) with
  probability 1 - ``rate_jump_probability`` and sd ``rate_jump_step`` sqrt(e) otherwise, over
  e elapsed experiments.  The small component gives smooth, gradually accelerating wear (an
  exponential rise like the paper's Sec. V is a slow drift of log r); the wide one lets the
  filter follow the sudden steep rises of accelerated wear tests within one or two experiments
  without making the quiet phase noisy;
* the wear grows by the new rate over the elapsed time, w' = w + r' e.  Increments are >= 0, so
  wear never decreases within a segment (wear is a degradation; the "random variations" of the
  paper's wear profile data are measurement noise, which the likelihood carries);
* a maintenance action (:meth:`WearTrend.reset`) starts a new segment from the new-joint prior:
  w half-normal with scale ``initial_wear_scale``, r exponential with ``initial_rate_mean``;
* each likelihood row enters tempered and as an outlier mixture, (1 - eps) L(w)^a + eps (L
  scaled to max 1).  The power a = ``likelihood_power`` (0.5) is there because a profile
  likelihood overstates what many experiments with their own nuisance temperatures say
  together (the Neyman-Scott effect): pooled over the quiet phase of a simulated test, the
  N = 4 profile rows put w near the dip of the wear profile (7) at 4-5 while the truth is 1.
  With a = 1 the 95 % interval covered the truth in 72-97 % of the experiments of
  ``bench/bench_alarm.py``; with a = 0.5 it covers 86-99 %.  eps = ``outlier_probability``
  (1e-3) keeps one experiment that does not fit the model (a disturbed pass) from erasing the
  posterior on its own.

Why a grid filter rather than a Kalman filter on w-hat: the per-experiment likelihood of w is
far from Gaussian (the profile (7) is almost flat in w at small w, so the likelihood is broad
and skewed below w = 20, and with N = 2 it can be bimodal); w is bounded below; the increments
are one-sided; and the alarm needs a tail probability P(w >= 35).  The grid handles all of
these exactly, at O(R G) per update (R = 48 rates x G = 301 wear cells of 0.5: the rows are
interpolated onto the filter's equidistant grid, linearly in log L).  The state is a pure
function of the (time, row) sequence, so a restarted service rebuilds it by replaying its stored
rows (:class:`WearTrend` and the batched :func:`filter_batch` give identical numbers).

Time: the dynamics count *experiments*.  The elapsed number of experiments between two updates
is dt / s, with s = ``experiment_interval_s`` when configured, otherwise the median of the last
``spacing_window`` time differences (the recent experiment spacing).  Time stamps [s] with an
irregular cadence work, and so does the experiment index used as time (s = 1); with a regular
cadence both give the same trend.

Forecast: the posterior is propagated without data for up to ``forecast_horizon`` experiments.
Since w is monotone, P(crossed within n experiments) = P(w_{k+n} >= threshold); the
propagation is linear, so the adjoint rows (M^T)^n a are computed once per configuration and a
forecast multiplies p by the rows that decide its quantiles (about 0.1 ms).  Its quantiles
give the remaining experiments (median and 95 % interval, ``inf`` beyond the horizon) and, at the
recent spacing, the crossing time [s].

Alarm: the trend's P(w >= threshold) feeds the ``trend`` rule of
:mod:`robot_wear_monitor.estimation.alarm` (which also holds the threshold's default).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
import math
from typing import NamedTuple, Optional

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import WEAR_THRESHOLD
from robot_wear_monitor.estimation.intervals import wear_grid
from robot_wear_monitor.estimation.special_functions import erf
from robot_wear_monitor.json_values import finite_or_none


_LOG_FLOOR = -1e30  # stands for log 0 (-inf) in the interpolation of the rows
#: rate transition tables kept per filter, one per distinct elapsed value (18 kB each)
_TRANSITIONS_KEPT = 16


@dataclass(frozen=True)
class TrendConfig:
    """
    Parameters of the trend filter (rates are in w per experiment).

    :ivar wear_grid: strictly increasing wear grid starting at >= 0, shape (G,), G >= 3; the
        likelihood rows must be given on it (default: ``intervals.wear_grid()``, 0 .. 150,
        321 points).
    :ivar threshold: alarm threshold of w (default: the paper's 35, ``alarm.WEAR_THRESHOLD``).
    :ivar initial_wear_scale: scale of the half-normal new-joint prior of w [w].
    :ivar initial_rate_mean: mean of the (exponential) new-joint prior of the rate [w/experiment].
    :ivar rate_offset: r0 of the log-rate random walk u = log(r + r0) [w/experiment].
    :ivar rate_step: sd of the usual log-rate change per experiment.
    :ivar rate_jump_step: sd of the rare large log-rate change per experiment.
    :ivar rate_jump_probability: probability of a large log-rate change per experiment.
    :ivar rate_max: largest rate of the grid [w/experiment].
    :ivar rate_points: number R of rate grid points (0 and a geometric grid up to ``rate_max``).
    :ivar outlier_probability: eps of the likelihood mixture (1 - eps) L + eps max L.
    :ivar likelihood_power: the rows are tempered, L^a (0 < a <= 1), before the mixture.
    :ivar filter_wear_step: step of the filter's own equidistant wear grid over the range of
        ``wear_grid`` [w]; the rows are interpolated onto it (linearly in log L).
    :ivar experiment_interval_s: the time of one experiment [s] for the dynamics; None: the median
        of the last ``spacing_window`` time differences.
    :ivar spacing_window: number of recent time differences whose median is the spacing.
    :ivar forecast_horizon: experiments the forecast looks ahead.

    """

    wear_grid: FloatArray = field(default_factory=wear_grid)
    threshold: float = WEAR_THRESHOLD
    initial_wear_scale: float = 4.0
    initial_rate_mean: float = 0.02
    rate_offset: float = 0.02
    rate_step: float = 0.15
    rate_jump_step: float = 2.5
    rate_jump_probability: float = 0.1
    rate_max: float = 40.0
    rate_points: int = 48
    outlier_probability: float = 1e-3
    likelihood_power: float = 0.5
    filter_wear_step: float = 0.5
    experiment_interval_s: Optional[float] = None
    spacing_window: int = 8
    forecast_horizon: int = 200

    def __post_init__(self) -> None:
        """Validate the grid and the scalars (InputError naming the field)."""
        grid = np.asarray(self.wear_grid, dtype=float)
        object.__setattr__(self, 'wear_grid', grid)
        if grid.ndim != 1 or grid.size < 3 or not np.all(np.isfinite(grid)):
            raise InputError(f'trend: wear_grid must be 1-D, finite, >= 3 points, got shape '
                             f'{grid.shape}')
        if grid[0] < 0 or np.any(np.diff(grid) <= 0):
            raise InputError('trend: wear_grid must be strictly increasing and start >= 0')
        if not grid[0] < self.threshold < grid[-1]:
            raise InputError(f'trend: threshold {self.threshold} must lie inside the wear grid '
                             f'[{grid[0]}, {grid[-1]}]')
        positive = ('filter_wear_step', 'initial_wear_scale', 'initial_rate_mean',
                    'rate_offset', 'rate_step', 'rate_jump_step', 'rate_max')
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f'trend: {name} must be > 0, got {value}')
        if not 0 < self.likelihood_power <= 1:
            raise InputError(f'trend: likelihood_power must be in (0, 1], got '
                             f'{self.likelihood_power}')
        for name in ('rate_jump_probability', 'outlier_probability'):
            value = getattr(self, name)
            if not 0 <= value < 1:
                raise InputError(f'trend: {name} must be in [0, 1), got {value}')
        if self.rate_points < 3 or self.spacing_window < 1 or self.forecast_horizon < 1:
            raise InputError('trend: rate_points >= 3, spacing_window >= 1 and '
                             'forecast_horizon >= 1 are required')
        interval = self.experiment_interval_s
        if interval is not None and not (math.isfinite(interval) and interval > 0):
            raise InputError(f'trend: experiment_interval_s must be > 0, got {interval}')

    @property
    def rate_grid(self) -> FloatArray:
        """Rate grid [w/experiment], shape (R,): 0 and a geometric grid up to ``rate_max``."""
        low = min(0.1 * self.rate_offset, self.rate_max / 10.0)
        return np.concatenate(([0.0], np.geomspace(low, self.rate_max, self.rate_points - 1)))


@dataclass(frozen=True)
class TrendEstimate:
    """
    The filtered wear trend after one experiment.

    :ivar time_s: time of the experiment [s] (or its index, if the index is used as time).
    :ivar segment: number of maintenance resets before this estimate (0 for the first joint).
    :ivar experiments: experiments in the current segment, including this one.
    :ivar wear: posterior median of w [-].
    :ivar wear_low: 2.5 % posterior quantile of w [-].
    :ivar wear_high: 97.5 % posterior quantile of w [-].
    :ivar rate: posterior median of the growth rate [w per experiment].
    :ivar threshold: the alarm threshold of w.
    :ivar probability_above_threshold: posterior P(w >= threshold).
    :ivar remaining_experiments: median number of experiments until w >= threshold (0 when the
        median wear is already above; ``inf`` beyond the forecast horizon; NaN when the
        update asked for no forecast).
    :ivar remaining_experiments_low: 2.5 % quantile of it.
    :ivar remaining_experiments_high: 97.5 % quantile of it.
    :ivar experiment_spacing_s: the spacing the forecast assumes [s]; NaN while unknown.
    :ivar crossing_time_s: time of the median crossing, time_s + remaining x spacing [s];
        ``inf`` beyond the horizon, NaN while the spacing is unknown.
    :ivar crossing_time_low_s: 2.5 % quantile of the crossing time [s].
    :ivar crossing_time_high_s: 97.5 % quantile of the crossing time [s].

    """

    time_s: float
    segment: int
    experiments: int
    wear: float
    wear_low: float
    wear_high: float
    rate: float
    threshold: float
    probability_above_threshold: float
    remaining_experiments: float
    remaining_experiments_low: float
    remaining_experiments_high: float
    experiment_spacing_s: float
    crossing_time_s: float
    crossing_time_low_s: float
    crossing_time_high_s: float

    def to_json(self) -> dict:
        """Return the fields as a JSON-safe dict (NaN and infinity become None)."""
        out: dict = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            out[name] = value if isinstance(value, int) else finite_or_none(value)
        return out


# --------------------------------------------------------------------------- batched grid filter

class _GridFilter:
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
        #: the forecast's tables, once looked up (_forecast_tables)
        self.forecast_tables: Optional[_ForecastTables] = None

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
        :data:`_TRANSITIONS_KEPT`, the oldest dropped first): experiments at a regular interval
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
        if len(self._transitions) >= _TRANSITIONS_KEPT:
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
        if len(self._moves) >= _TRANSITIONS_KEPT:
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


def _crossing_time(time_s: float, remaining: float, spacing_s: float) -> float:
    """Return time_s + remaining x spacing [s]: inf beyond the horizon, NaN if spacing unknown."""
    if remaining == 0:
        return time_s
    if not math.isfinite(remaining):
        return math.inf
    return time_s + remaining * spacing_s if math.isfinite(spacing_s) else math.nan


class _Spacing:
    """Recent experiment spacing: the median of the last time differences [s]."""

    def __init__(self, window: int) -> None:
        self.window = window
        self.intervals: list[float] = []
        self._value = math.nan

    def add(self, interval: float) -> None:
        if interval > 0:
            self.intervals = (self.intervals + [interval])[-self.window:]
            # numpy's median: the middle value, or the mean of the middle two (a + b) / 2
            ordered = sorted(self.intervals)
            middle = len(ordered) // 2
            self._value = (ordered[middle] if len(ordered) % 2
                           else (ordered[middle - 1] + ordered[middle]) / 2.0)

    def value(self) -> float:
        return self._value


# --------------------------------------------------------------------------- public classes

class WearTrend:
    """
    A monotone wear trend with a growth rate, filtered from per-experiment likelihood rows.

    The state is a pure function of the sequence of :meth:`update` and :meth:`reset` calls, so a
    restarted service rebuilds it by replaying its stored rows in order.

    :param config: filter parameters (default :class:`TrendConfig`).

    """

    def __init__(self, config: TrendConfig | None = None) -> None:
        """Start a new joint (the new-joint prior) with no experiment yet."""
        self.config = config if config is not None else TrendConfig()
        self._filter = _GridFilter(self.config, 1)
        self._spacing = _Spacing(self.config.spacing_window)
        self._last_time: Optional[float] = None
        self._segment_start: Optional[float] = None
        self.segment = 0
        self.experiments = 0
        self.last_estimate: Optional[TrendEstimate] = None
        #: the row of each quantile's last crossing: where the next forecast looks first
        self._forecast_rows: dict[float, int] = {}

    @property
    def wear_grid(self) -> FloatArray:
        """Return the wear grid the likelihood rows must be given on, shape (G,)."""
        return self.config.wear_grid

    def _elapsed(self, interval: float) -> float:
        if self.config.experiment_interval_s is not None:
            return interval / self.config.experiment_interval_s
        spacing = self._spacing.value()
        return interval / spacing if spacing > 0 else 1.0

    def _spacing_s(self) -> float:
        if self.config.experiment_interval_s is not None:
            return float(self.config.experiment_interval_s)
        return self._spacing.value()

    def update(self, *, time_s: float, log_likelihood: ArrayLike,
               forecast: bool = True) -> TrendEstimate:
        """
        Add one experiment and return the filtered trend.

        :param time_s: time of the experiment [s] (or the experiment index), not before the last
            experiment or reset.
        :param log_likelihood: log-likelihood of w on ``wear_grid`` (any additive constant; -inf
            allowed), shape (G,).
        :param forecast: compute the crossing forecast (about 0.1 ms once the first forecast of the
            configuration built its rows); False leaves its fields NaN, e.g. when replaying
            a history (the state does not depend on it).

        :raises InputError: time going backwards or not finite, a row of the wrong shape, NaN, +inf
            or no finite value.

        """
        time_s = float(time_s)
        if not math.isfinite(time_s):
            raise InputError(f'trend: time must be finite, got {time_s}')
        row = np.asarray(log_likelihood, dtype=float)
        if row.shape != self.wear_grid.shape:
            raise InputError(f'trend: log_likelihood must have shape {self.wear_grid.shape}, '
                             f'got {row.shape}')
        if not np.all(np.isfinite(row)) and (np.any(np.isnan(row)) or np.any(row == np.inf)
                                             or not np.any(np.isfinite(row))):
            raise InputError('trend: log_likelihood must be finite or -inf (not NaN, +inf, '
                             'nor all -inf)')
        known = [t for t in (self._last_time, self._segment_start) if t is not None]
        reference = max(known) if known else None
        if reference is not None and time_s < reference:
            raise InputError(f'trend: time goes backwards ({time_s} < {reference})')
        if self._last_time is not None:
            self._spacing.add(time_s - self._last_time)
        if self.experiments > 0 and reference is not None:
            self._filter.predict(np.array([self._elapsed(time_s - reference)]))
        self._filter.update(row[None, :])
        self._last_time = time_s
        self.experiments += 1
        self.last_estimate = self._estimate(time_s, forecast)
        return self.last_estimate

    def reset(self, *, time_s: Optional[float] = None) -> None:
        """
        Start a new segment (maintenance): back to the new-joint prior.

        :param time_s: time of the maintenance [s] on the experiments' clock, not before the last
            experiment; None: at the last experiment (when the reset comes from another
            clock than the experiments' stamps, e.g. a node's clock during a bag replay).

        """
        if time_s is not None:
            time_s = float(time_s)
            if not math.isfinite(time_s):
                raise InputError(f'trend: time must be finite, got {time_s}')
            if self._last_time is not None and time_s < self._last_time:
                raise InputError(f'trend: reset time goes backwards ({time_s} < '
                                 f'{self._last_time})')
        else:
            time_s = self._last_time
        self._filter.reset(np.ones(1, dtype=bool))
        self._segment_start = time_s
        self.segment += 1
        self.experiments = 0
        self.last_estimate = None

    def _estimate(self, time_s: float, forecast: bool) -> TrendEstimate:
        flt, cfg = self._filter, self.config
        mass = flt.wear_marginal()
        low, median, high = flt.wear_quantiles(_WEAR_LEVELS, mass)[0]
        spacing = self._spacing_s()
        if forecast:
            remaining = self._forecast()
            times = [_crossing_time(time_s, n, spacing) for n in remaining]
        else:
            remaining = times = [math.nan] * 3
        return TrendEstimate(
            time_s=time_s, segment=self.segment, experiments=self.experiments,
            wear=float(median), wear_low=float(low), wear_high=float(high),
            rate=float(flt.rate_median()[0]), threshold=cfg.threshold,
            probability_above_threshold=float(flt.probability_above(cfg.threshold, mass)[0]),
            remaining_experiments=remaining[0], remaining_experiments_low=remaining[1],
            remaining_experiments_high=remaining[2], experiment_spacing_s=spacing,
            crossing_time_s=times[0], crossing_time_low_s=times[1],
            crossing_time_high_s=times[2])

    def _forecast(self) -> list[float]:
        """
        Return the experiments until w >= threshold at the quantiles of :data:`_FORECAST_LEVELS`.

        Without data, one experiment ahead is the same linear map M of p(r, w) every step, so
        P_n = P(w >= threshold after n more experiments) = <M^n p, a> = <p, (M^T)^n a> with a
        the threshold indicator; the rows (M^T)^n a (:func:`_forecast_basis`) are computed once.
        The quantile q of the crossing is where the running maximum of P_n first reaches q
        (linear in between; ``inf`` beyond the horizon).  Only the rows that decide it are
        multiplied (:class:`_ForecastSeries`), first around the last forecast's crossings.
        """
        series = _ForecastSeries(_forecast_tables(self._filter), self._filter.prob[0].ravel())
        remaining = []
        for level in _FORECAST_LEVELS:
            value, row = series.crossing(level, self._forecast_rows.get(level, 0))
            self._forecast_rows[level] = row
            remaining.append(value)
        return remaining


#: the quantiles of w of an estimate (wear_low, wear, wear_high)
_WEAR_LEVELS = np.array([0.025, 0.5, 0.975])
#: the quantiles of the crossing the estimate reads from the forecast (in the order of the
#: estimate's remaining_experiments, _low, _high)
_FORECAST_LEVELS = (0.5, 0.025, 0.975)


class _ForecastTables(NamedTuple):
    """A configuration's rows b_n, (H+1, K); max_n b_n, (K,); max b_j - b_n, j < n (rounding)."""

    basis: FloatArray
    ceiling: FloatArray
    excess: float


class _ForecastSeries:
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

    def __init__(self, tables: _ForecastTables, p: FloatArray) -> None:
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
_FORECAST_TABLES: dict[tuple, _ForecastTables] = {}


def _config_key(config: TrendConfig) -> tuple:
    """Return a hashable key of every field of ``config`` (arrays by their bytes)."""
    key = []
    for item in fields(config):
        value = getattr(config, item.name)
        if isinstance(value, np.ndarray):
            value = (value.shape, value.tobytes())
        key.append((item.name, value))
    return tuple(key)


def _forecast_tables(flt: _GridFilter) -> _ForecastTables:
    """Return the forecast basis and its bounds, once per configuration (kept on the filter)."""
    if flt.forecast_tables is not None:
        return flt.forecast_tables
    key = _config_key(flt.config)
    tables = _FORECAST_TABLES.get(key)
    if tables is None:
        basis = _forecast_basis(flt)
        size = basis.shape[1]
        ceiling, drop = basis[0].copy(), np.empty(size)
        excess = 0.0
        for row in basis[1:]:  # the largest b_j - b_n, j < n, and the largest b_n of a cell
            np.subtract(ceiling, row, out=drop)
            excess = max(excess, float(drop.max()))
            np.maximum(ceiling, row, out=ceiling)
        tables = _ForecastTables(basis, ceiling, excess)
        if len(_FORECAST_TABLES) >= 4:  # 23 MB each at the default grid
            _FORECAST_TABLES.clear()
        _FORECAST_TABLES[key] = tables
    flt.forecast_tables = tables
    return tables


def _forecast_basis(flt: _GridFilter) -> FloatArray:
    """
    Return the rows (M^T)^n a, n = 0 .. horizon, shape (H+1, R*G) (:func:`_forecast_tables`).

    M is one experiment ahead without data: the rate transition of one experiment, then every
    rate row shifted by its rate (the linear split between two cells of :meth:`_GridFilter._shift`,
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


@dataclass(frozen=True)
class TrendBatch:
    """
    Filtered trends of B independent experiment series of K experiments each.

    :ivar wear: posterior median of w, shape (B, K).
    :ivar wear_low: 2.5 % quantile, shape (B, K).
    :ivar wear_high: 97.5 % quantile, shape (B, K).
    :ivar probability_above_threshold: P(w >= threshold), shape (B, K).

    """

    wear: FloatArray
    wear_low: FloatArray
    wear_high: FloatArray
    probability_above_threshold: FloatArray


def filter_batch(*, times_s: ArrayLike, log_likelihood: ArrayLike,
                 config: TrendConfig | None = None) -> TrendBatch:
    """
    Run B independent trends (one segment each) over K experiments, without forecasts.

    The same filter as :class:`WearTrend` (identical numbers), vectorised over the batch, for
    Monte Carlo studies.

    :param times_s: experiment times [s] (or indices), shape (B, K), non-decreasing along K.
    :param log_likelihood: rows on ``config.wear_grid``, shape (B, K, G).
    :param config: filter parameters (default :class:`TrendConfig`).

    """
    cfg = config if config is not None else TrendConfig()
    times = np.asarray(times_s, dtype=float)
    rows = np.asarray(log_likelihood, dtype=float)
    if times.ndim != 2 or rows.shape != times.shape + cfg.wear_grid.shape:
        raise InputError(f'trend: expected times (B, K) and rows (B, K, {cfg.wear_grid.size}), '
                         f'got {times.shape} and {rows.shape}')
    if np.any(np.diff(times, axis=1) < 0):
        raise InputError('trend: times go backwards')
    b, k = times.shape
    flt = _GridFilter(cfg, b)
    spacing = [_Spacing(cfg.spacing_window) for _ in range(b)]
    out = np.empty((4, b, k))
    for j in range(k):
        if j > 0:
            dt = times[:, j] - times[:, j - 1]
            elapsed = np.empty(b)
            for i in range(b):
                spacing[i].add(float(dt[i]))
                unit = (cfg.experiment_interval_s if cfg.experiment_interval_s is not None
                        else spacing[i].value())
                elapsed[i] = dt[i] / unit if unit > 0 else 1.0
            flt.predict(elapsed)
        flt.update(rows[:, j])
        out[:3, :, j] = flt.wear_quantiles([0.5, 0.025, 0.975]).T
        out[3, :, j] = flt.probability_above(cfg.threshold)
    return TrendBatch(wear=out[0], wear_low=out[1], wear_high=out[2],
                      probability_above_threshold=out[3])
