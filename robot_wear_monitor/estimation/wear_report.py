"""
The wear estimate of one experiment as a report: estimate, intervals, alarm, JSON.

:func:`wear_report` runs the estimator (16)-(19) and the profile-likelihood intervals on one
set of friction levels and returns a :class:`WearReport`; :meth:`WearReport.to_dict` is the
JSON object of ``robot-wear-monitor estimate --json`` (NaN and inf as null).
:func:`meaningful_std` decides whether the inverse-Fisher standard deviation of w-hat describes
its uncertainty or only the interval does (the monitoring services use it too, through
:mod:`robot_wear_monitor.monitoring.diagnostics`).  Importing this module loads no scipy.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Sequence, TYPE_CHECKING

import numpy as np
from robot_wear_monitor.estimation.plausibility import check_levels, Plausibility, VALID
from robot_wear_monitor.json_values import finite_or_none

if TYPE_CHECKING:  # the estimator and intervals: imported where used (numpy work at import)
    from robot_wear_monitor.estimation.intervals import WearInterval
    from robot_wear_monitor.estimation.wear_estimates import WearEstimate
    from robot_wear_monitor.model.params import ParameterSet


def meaningful_std(*, std: float, value: float, low: float, high: float,
                   open_above: bool = False) -> float:
    """
    Return ``std`` when it describes the uncertainty of ``value``, else NaN.

    The standard deviation (inverse Fisher information) is kept when the 95 % profile-likelihood
    interval [low, high] is interior (low > 0, a finite upper end inside the grid) and the Wald
    interval value +- 1.96 std agrees with it: each half-width within a factor 1.5.  Near w = 0,
    where the wear term's speed scale collapses, or at a bound, it is not (0.3 +- 4317) and only
    the interval is reported.
    """
    if not (math.isfinite(std) and std > 0 and math.isfinite(low) and math.isfinite(high)):
        return math.nan
    if open_above or low <= 0 or not low <= value <= high:
        return math.nan
    for half in (value - low, high - value):
        if not (half > 0 and 1 / 1.5 <= 1.96 * std / half <= 1.5):
            return math.nan
    return std


@dataclass(frozen=True)
class WearReport:
    """
    The estimate of one experiment with its 95 % intervals and the alarm decision.

    :ivar estimate: the ML estimate of (T [degC], w [-]) with covariance and chi2 test.
    :ivar interval: the profile-likelihood intervals of w [-] and T [degC].
    :ivar wear_std: standard deviation of w-hat [-], NaN where it is not meaningful
        (see :func:`meaningful_std`).
    :ivar alarm: w-hat >= the parameter set's wear threshold.
    :ivar warning: w-hat >= the parameter set's warning level.
    :ivar wear_threshold: the alarm threshold of the parameter set [-].
    :ivar plausibility: the verdict of the plausibility checks; when invalid the wear cannot be
        judged from these levels and ``alarm`` means nothing (JSON ``alarm`` null).
    :ivar wear_determined: False for a set without a wear model (``identify
        --no-wear-model``): w-hat is not determined (JSON ``wear`` null), there is no alarm
        (``alarm`` null) and ``interval`` holds T's interval only.

    """

    estimate: WearEstimate
    interval: WearInterval
    wear_std: float
    alarm: bool
    warning: bool
    wear_threshold: float
    plausibility: Plausibility = VALID
    #: False with a set without a wear model: T-hat only, w-hat not determined, no alarm
    wear_determined: bool = True

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON object of ``estimate --json`` (keys stable; None for NaN/inf)."""
        est, interval = self.estimate, self.interval
        return {
            'temperature': float(est.temperature_degc), 'wear': finite_or_none(est.wear),
            'covariance': [[finite_or_none(x) for x in row] for row in est.covariance],
            'wear_std': finite_or_none(self.wear_std),
            'temperature_std': finite_or_none(est.temperature_std_degc),
            'wear_interval': [finite_or_none(interval.wear_low),
                              finite_or_none(interval.wear_high)],
            'wear_interval_open_above': interval.wear_high_at_grid_end,
            'temperature_interval': [finite_or_none(interval.temperature_low),
                                     finite_or_none(interval.temperature_high)],
            'alarm': self.alarm if self.plausibility.valid and self.wear_determined else None,
            'wear_determined': self.wear_determined,
            'warning': self.warning,
            'chi2': float(est.chi2), 'dof': int(est.dof), 'p_value': finite_or_none(est.p_value),
            'temperature_at_bound': est.temperature_at_bound,
            'wear_at_bound': est.wear_at_bound, 'n_levels': est.n_levels,
            'speeds': [float(v) for v in est.speeds_rad_s],
            'wear_threshold': self.wear_threshold, **self.plausibility.to_json()}


def wear_report(*, speeds_rad_s: Sequence[float], frictions: Sequence[float],
                params: ParameterSet) -> WearReport:
    """
    Estimate (T, w) from one experiment's friction levels and decide the alarm.

    :param speeds_rad_s: motor-side speed levels [rad/s].
    :param frictions: friction levels, normalised torque, one per speed.
    :param params: the parameter set (model, bounds, thresholds); a set without a wear model
        gives T-hat with its interval only (``wear_determined`` False).

    """
    # deferred import: start-up time (estimator, intervals: not every importer needs them)
    from robot_wear_monitor.estimation.estimator import estimate_wear
    from robot_wear_monitor.estimation.intervals import wear_intervals, WearInterval
    from robot_wear_monitor.estimation.wear_estimates import validate_speeds
    params.require_estimator(purpose='estimating wear (16)')
    estimates = estimate_wear(speeds_rad_s, frictions, params=params)
    est = estimates[0]
    if not params.estimates_wear:  # no wear model: T-hat and its interval only
        # deferred import: start-up time (temperature_only: sets without a wear model only)
        from robot_wear_monitor.estimation.temperature_only import estimate_temperature
        speeds = validate_speeds(speeds_rad_s)
        t_only = estimate_temperature(speeds, np.asarray(frictions, dtype=float)[None, :],
                                      params)
        interval = WearInterval(wear_low=math.nan, wear_high=math.nan,
                                temperature_low=float(t_only.temperature_low[0]),
                                temperature_high=float(t_only.temperature_high[0]),
                                wear_high_at_grid_end=False, level=0.95)
        return WearReport(estimate=est, interval=interval, wear_std=math.nan, alarm=False,
                          warning=False, wear_threshold=params.wear_threshold,
                          plausibility=check_levels(speeds_rad_s=speeds_rad_s,
                                                    frictions=frictions, params=params,
                                                    estimate=est),
                          wear_determined=False)
    interval = wear_intervals(speeds_rad_s, frictions, params=params, estimates=estimates)[0]
    wear_std = meaningful_std(std=float(est.wear_std), value=float(est.wear),
                              low=interval.wear_low, high=interval.wear_high,
                              open_above=interval.wear_high_at_grid_end)
    return WearReport(estimate=est, interval=interval, wear_std=wear_std,
                      alarm=bool(est.wear >= params.wear_threshold),
                      warning=bool(est.wear >= params.wear_warning),
                      wear_threshold=params.wear_threshold,
                      plausibility=check_levels(speeds_rad_s=speeds_rad_s, frictions=frictions,
                                                params=params, estimate=est))
