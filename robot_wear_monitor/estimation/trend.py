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

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.trend_filter import GridFilter, TrendConfig
from robot_wear_monitor.estimation.trend_forecast import forecast_tables, ForecastSeries
from robot_wear_monitor.json_values import finite_or_none

__all__ = ['filter_batch', 'TrendBatch', 'TrendConfig', 'TrendEstimate', 'WearTrend']


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
        self._filter = GridFilter(self.config, 1)
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
        the threshold indicator; the rows (M^T)^n a (:func:`forecast_basis`) are computed once.
        The quantile q of the crossing is where the running maximum of P_n first reaches q
        (linear in between; ``inf`` beyond the horizon).  Only the rows that decide it are
        multiplied (:class:`ForecastSeries`), first around the last forecast's crossings.
        """
        series = ForecastSeries(forecast_tables(self._filter), self._filter.prob[0].ravel())
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
    flt = GridFilter(cfg, b)
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
