"""
The wear estimator service's configuration and its result for one experiment.

:class:`EstimatorConfig` comes from the ``wear_estimator_node`` parameters; a
:class:`WearUpdate` is what :class:`~robot_wear_monitor.monitoring.estimator_service.
WearEstimatorService` returns per experiment: the inputs, the estimate with its intervals and
trend, the plausibility verdict, the alarm state and the diagnostics status, with its JSON.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Mapping, Optional, TYPE_CHECKING

from robot_wear_monitor.estimation.alarm import (AlarmPolicy, DEFAULT_ALARM_PROBABILITY,
                                                 DEFAULT_ALARM_RULE, WEAR_WARNING)
from robot_wear_monitor.estimation.plausibility import INVALID_P_VALUE, Plausibility, VALID
from robot_wear_monitor.estimation.wear_report import meaningful_std
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.model.params import load_parameter_set, ParameterError, ParameterSet
from robot_wear_monitor.monitoring.diagnostics import DiagnosticReport
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.setting_fields import fraction, non_negative, setting

if TYPE_CHECKING:
    from robot_wear_monitor.estimation.intervals import WearInterval
    from robot_wear_monitor.estimation.trend import TrendEstimate
    from robot_wear_monitor.estimation.wear_estimates import WearEstimate


def node_alarm_levels(values: Mapping[str, Any], params: ParameterSet) -> tuple[float, float]:
    """
    Return (threshold, warning level) [w] a joint is judged by: the node's, else the set's.

    The node parameters ``wear_threshold`` and ``wear_warning`` win (they are what a site
    sets); where one is 0, its default, the parameter set's ``alarm.wear_threshold`` /
    ``alarm.wear_warning`` stands.

    :raises ParameterError: the warning level above the threshold.
    """
    threshold = float(values['wear_threshold']) or params.wear_threshold
    warning = float(values['wear_warning']) or params.wear_warning
    if not warning <= threshold:
        raise ParameterError(f'wear_warning: must be <= wear_threshold, got {warning:g} > '
                             f'{threshold:g} (0: the value of parameter set '
                             f'{params.name[:80]!r})')
    return threshold, warning


@dataclass(frozen=True)
class EstimatorConfig:
    """Configuration of :class:`WearEstimatorService` (from the node parameters)."""

    joint: str
    params: ParameterSet
    alarm: AlarmPolicy = AlarmPolicy()
    wear_warning: float = setting(
        WEAR_WARNING, unit='-', check=non_negative,
        description='diagnostics WARN when the wear estimate reaches this level')
    min_fit_p_value: float = setting(
        0.01, unit='-', check=fraction,
        description='diagnostics WARN when the chi-square fit p-value is below it')
    invalid_fit_p_value: float = setting(
        INVALID_P_VALUE, unit='-', check=fraction,
        description='below this chi-square fit p-value the estimate is invalid: the wear cannot '
                    'be judged from the experiment (reported, stored, never alarm evidence)')
    experiment_speeds_rad_s: tuple[float, ...] = ()
    speed_tolerance_rad_s: float = 1.0
    #: the robot of the joint (``robot_id``; empty: unnamed, the history's ``default``)
    robot: str = ''

    @classmethod
    def from_node_parameters(cls, values: Mapping[str, Any], *,
                             params: ParameterSet | None = None) -> 'EstimatorConfig':
        """Build from validated ``wear_estimator_node`` parameters (see node_config)."""
        if params is None:
            params = load_parameter_set(values.get('parameter_set_file') or None)
        params.require_estimator(purpose='the wear estimator')
        threshold, warning = node_alarm_levels(values, params)
        return cls(joint=values['joint'], params=params,
                   alarm=AlarmPolicy(threshold=threshold,
                                     healthy=values['wear_healthy'],
                                     evidence_to_raise=values['alarm_evidence'],
                                     rule=values.get('alarm_rule', DEFAULT_ALARM_RULE),
                                     probability=values.get('alarm_probability',
                                                            DEFAULT_ALARM_PROBABILITY)),
                   wear_warning=warning,
                   min_fit_p_value=values['min_fit_p_value'],
                   invalid_fit_p_value=values.get('invalid_fit_p_value', INVALID_P_VALUE),
                   experiment_speeds_rad_s=tuple(values['experiment_speeds_rad_s']),
                   robot=str(values.get('robot_id', '') or ''))

    def levels_warning(self) -> str:
        """
        Return the warning to log once when the node's levels are not the parameter set's.

        The node parameters ``wear_threshold`` and ``wear_warning`` win: they are what a site
        sets, what the alarm and the trend use and what is stored with every estimate (and
        shown by the fleet view and the dashboard); the parameter set's ``alarm`` values are
        their defaults (a parameter left at 0).  '' when both agree.
        """
        differ = [f'{name} {node:g} (the set says {stated:g})' for name, node, stated in (
            ('wear_threshold', self.alarm.threshold, self.params.wear_threshold),
            ('wear_warning', self.wear_warning, self.params.wear_warning)) if node != stated]
        if not differ:
            return ''
        where = f'robot {self.robot[:80]!r} ' if self.robot else ''
        return (f'{where}joint {self.joint[:80]!r}: the node parameters differ from parameter '
                f'set {self.params.name[:80]!r}: {", ".join(differ)}; the node\'s values are '
                'used and stored with every estimate')


@dataclass(frozen=True)
class WearUpdate:
    """The result of one experiment: inputs, estimate, alarm state and diagnostics."""

    index: int
    stamp_s: float
    joint: str
    speeds_rad_s: tuple[float, ...]
    frictions: tuple[float, ...]
    estimate: WearEstimate
    alarm_active: bool
    alarm_raised: bool
    alarm_evidence: float
    status: DiagnosticReport
    interval: Optional[WearInterval] = None
    trend: Optional[TrendEstimate] = None
    #: the plausibility verdict: an invalid estimate is reported and stored, never evidence
    plausibility: Plausibility = VALID
    #: False with a set without a wear model: T-hat only, w-hat not determined (NaN), no alarm
    wear_determined: bool = True

    @property
    def valid(self) -> bool:
        """Return True when the levels passed the plausibility checks (the wear is judged)."""
        return self.plausibility.valid

    @property
    def wear(self) -> float:
        """Return w-hat."""
        return float(self.estimate.wear)

    @property
    def wear_std(self) -> float:
        """
        Return the standard deviation of w-hat where it means something, else NaN.

        See :func:`meaningful_std`: near w = 0 or on a bound the inverse Fisher information is
        no measure of the uncertainty and only the interval is reported.
        """
        return meaningful_std(std=float(self.estimate.wear_std), value=self.wear,
                              low=self.wear_interval[0], high=self.wear_interval[1],
                              open_above=self.wear_interval_open_above)

    @property
    def wear_interval(self) -> tuple[float, float]:
        """Return the 95 % profile-likelihood interval of w (NaNs when not computed)."""
        if self.interval is None:
            return (math.nan, math.nan)
        return (float(self.interval.wear_low), float(self.interval.wear_high))

    @property
    def wear_interval_open_above(self) -> bool:
        """Return True when the upper end is only a lower bound (the wear grid's end)."""
        return bool(self.interval is not None and self.interval.wear_high_at_grid_end)

    @property
    def temperature_interval(self) -> tuple[float, float]:
        """Return the 95 % profile-likelihood interval of T [degC] (NaNs when not computed)."""
        if self.interval is None:
            return (math.nan, math.nan)
        return (float(self.interval.temperature_low), float(self.interval.temperature_high))

    @property
    def temperature_degc(self) -> float:
        """Return T-hat [degC]."""
        return float(self.estimate.temperature_degc)

    @property
    def temperature_std_degc(self) -> float:
        """Return the standard deviation of T-hat [degC]."""
        return float(self.estimate.temperature_std_degc)

    def to_json(self) -> dict[str, Any]:
        """Return a JSON-safe summary (NaN and inf become None)."""
        return {
            'index': self.index, 'joint': self.joint, 'stamp_s': self.stamp_s,
            'speeds_rad_s': [float(v) for v in self.speeds_rad_s],
            'frictions': [float(f) for f in self.frictions],
            'temperature_degc': finite_or_none(self.temperature_degc),
            'temperature_std_degc': finite_or_none(self.temperature_std_degc),
            'wear': finite_or_none(self.wear), 'wear_std': finite_or_none(self.wear_std),
            'wear_determined': self.wear_determined,
            'wear_interval': [finite_or_none(v) for v in self.wear_interval],
            'wear_interval_open_above': self.wear_interval_open_above,
            'temperature_interval': [finite_or_none(v) for v in self.temperature_interval],
            'trend': None if self.trend is None else self.trend.to_json(),
            'fit_p_value': finite_or_none(self.estimate.p_value),
            'chi2': finite_or_none(self.estimate.chi2), 'dof': int(self.estimate.dof),
            'temperature_at_bound': bool(self.estimate.temperature_at_bound),
            'wear_at_bound': bool(self.estimate.wear_at_bound),
            'alarm': self.alarm_active, 'alarm_raised': self.alarm_raised,
            'alarm_evidence': finite_or_none(self.alarm_evidence),
            'status': messages.LEVEL_NAMES[self.status.level], 'message': self.status.message,
            **self.plausibility.to_json(),
        }
