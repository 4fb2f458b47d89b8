"""The ROS-agnostic monitoring service that both nodes and the bag replay drive.

Pipeline: joint states -> :class:`FrictionExperimentService` (segmentation into friction levels
and experiments) -> ``friction_levels`` -> :class:`WearEstimatorService` (estimate (T, w),
alarm latch with reset, diagnostics status and key-values, SQLite history).

Alarm rule (documented in ``docs/service.md``).  The paper's rule is a threshold on each
estimate: w-hat >= 35.  The latch implements it and, optionally, asks for accumulated evidence
as well: a one-sided CUSUM of the Gaussian log-likelihood ratio between the threshold ``w1``
(35) and the healthy level ``w0`` (25), each estimate weighted by its own variance,

    llr_k = (w1 - w0) * (w-hat_k - (w0 + w1) / 2) / std_k^2,    S_k = max(0, S_(k-1) + llr_k)

and the alarm is raised at the first estimate with ``w-hat_k >= w1`` and ``S_k >= h`` (h =
``alarm_evidence``).  h = 0 (default) is the paper's rule: a Monte Carlo of the N = 4 design over
wear trends like the paper's Sec. V scenarios, T in 30..50 degC and the load uncertainty gives a
false alarm while w < 25 in 0-4 % of the runs and an alarm within two experiments of w crossing
35 in 96-100 %; h = 2 gives a little fewer false alarms for a little later detection.  The alarm
stays latched until reset (``~/reset_alarm``), which also clears the evidence.
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass, field
import math
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.monitoring.history import AlarmEvent, HistoryRecord, WearHistory
from robot_wear_monitor.experiment.levels import FrictionExperiment, FrictionLevel
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.recordings.messages import (DIAGNOSTIC_ERROR, DIAGNOSTIC_OK,
                                                    DIAGNOSTIC_WARN, FrictionLevelsMessage,
                                                    MessageError, MessageKit)
from robot_wear_monitor.model.params import load_parameter_set, ParameterSet

#: Topics of the nodes (relative names resolve to /<name> in the root namespace).
FRICTION_LEVELS_TOPIC = 'friction_levels'
TEMPERATURE_TOPIC = 'temperature'
WEAR_TOPIC = 'wear'
ALARM_TOPIC = 'wear_alarm'
DIAGNOSTICS_TOPIC = '/diagnostics'
TREND_TOPIC = 'wear_trend'
RESET_SERVICE = '~/reset_alarm'

#: Topic -> ROS type of every output of the two nodes.
OUTPUT_TOPICS: dict[str, str] = {
    FRICTION_LEVELS_TOPIC: messages.FRICTION_LEVELS_TYPE,
    TEMPERATURE_TOPIC: messages.TEMPERATURE_TYPE,
    WEAR_TOPIC: messages.WEAR_TYPE,
    ALARM_TOPIC: messages.ALARM_TYPE,
    DIAGNOSTICS_TOPIC: messages.DIAGNOSTICS_TYPE,
    TREND_TOPIC: messages.TREND_TYPE,
}

#: Alarm rules: ``trend`` raises when the trend's P(w >= threshold) reaches ``probability``
#: (the default, chosen by ``bench/bench_alarm.py``); ``estimate`` is the paper's rule, one
#: estimate w-hat >= threshold (with the optional CUSUM evidence).
ALARM_RULES = ('trend', 'estimate')


# --------------------------------------------------------------------------- alarm latch

@dataclass(frozen=True)
class AlarmPolicy:
    """Parameters of the alarm test: threshold w1, healthy level w0 and evidence h."""

    threshold: float = 35.0
    healthy: float = 25.0
    evidence_to_raise: float = 0.0
    rule: str = 'estimate'
    probability: float = 0.5

    def __post_init__(self) -> None:
        """Reject a policy whose healthy level is not below the threshold, or a bad rule."""
        if not (self.healthy < self.threshold and self.evidence_to_raise >= 0):
            raise InputError(f'alarm policy: need healthy < threshold and evidence >= 0, got '
                             f'healthy={self.healthy}, threshold={self.threshold}, '
                             f'evidence={self.evidence_to_raise}')
        if self.rule not in ALARM_RULES or not 0.0 < self.probability < 1.0:
            raise InputError(f'alarm policy: rule must be one of {", ".join(ALARM_RULES)} and '
                             f'0 < probability < 1, got {self.rule!r}, {self.probability}')

    def log_likelihood_ratio(self, *, wear: float, wear_std: float) -> float:
        """Return llr of one estimate, 0 when its standard deviation is unknown or infinite."""
        if not (math.isfinite(wear) and math.isfinite(wear_std) and wear_std > 0):
            return 0.0
        midpoint = 0.5 * (self.threshold + self.healthy)
        return (self.threshold - self.healthy) * (wear - midpoint) / wear_std ** 2


class AlarmLatch:
    """A latched wear alarm fed by the CUSUM of the estimates' log-likelihood ratios."""

    def __init__(self, policy: AlarmPolicy, *, active: bool = False,
                 evidence: float = 0.0) -> None:
        """Start in the given (restored) state."""
        self.policy = policy
        self.active = bool(active)
        self.evidence = max(0.0, float(evidence))

    def update(self, *, wear: float, wear_std: float,
               probability_above_threshold: float = math.nan) -> bool:
        """Add one estimate; return True when this estimate raises the alarm.

        Rule ``estimate``: w-hat >= threshold (and the CUSUM evidence >= ``evidence_to_raise``).
        Rule ``trend``: the trend's posterior P(w >= threshold) >= ``probability``.
        """
        llr = self.policy.log_likelihood_ratio(wear=wear, wear_std=wear_std)
        self.evidence = max(0.0, self.evidence + llr)
        if self.active:
            return False
        if self.policy.rule == 'trend':
            raise_now = probability_above_threshold >= self.policy.probability
        else:
            raise_now = (wear >= self.policy.threshold
                         and self.evidence >= self.policy.evidence_to_raise)
        if raise_now:
            self.active = True
            return True
        return False

    def reset(self) -> bool:
        """Clear the alarm and the evidence; return whether it was active."""
        was_active = self.active
        self.active = False
        self.evidence = 0.0
        return was_active


# --------------------------------------------------------------------------- estimator service

@dataclass(frozen=True)
class EstimatorConfig:
    """Configuration of :class:`WearEstimatorService` (from the node parameters)."""

    joint: str
    params: ParameterSet
    alarm: AlarmPolicy = AlarmPolicy()
    wear_warning: float = 28.0
    min_fit_p_value: float = 0.01
    experiment_speeds_rad_s: tuple[float, ...] = ()
    speed_tolerance_rad_s: float = 1.0

    @classmethod
    def from_node_parameters(cls, values: Mapping[str, Any], *,
                             params: ParameterSet | None = None) -> 'EstimatorConfig':
        """Build from validated ``wear_estimator_node`` parameters (see node_config)."""
        if params is None:
            params = load_parameter_set(values.get('parameter_set_file') or None)
        return cls(joint=values['joint'], params=params,
                   alarm=AlarmPolicy(threshold=values['wear_threshold'],
                                     healthy=values['wear_healthy'],
                                     evidence_to_raise=values['alarm_evidence'],
                                     rule=values.get('alarm_rule', 'trend'),
                                     probability=values.get('alarm_probability', 0.15)),
                   wear_warning=values['wear_warning'],
                   min_fit_p_value=values['min_fit_p_value'],
                   experiment_speeds_rad_s=tuple(values['experiment_speeds_rad_s']))


@dataclass(frozen=True)
class DiagnosticReport:
    """One DiagnosticStatus: level (0 OK, 1 WARN, 2 ERROR), message and key-values."""

    level: int
    message: str
    values: tuple[tuple[str, str], ...]

    def value(self, key: str) -> str:
        """Return the value of ``key`` (KeyError when absent)."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)


@dataclass(frozen=True)
class WearUpdate:
    """The result of one experiment: inputs, estimate, alarm state and diagnostics."""

    index: int
    stamp_s: float
    joint: str
    speeds_rad_s: tuple[float, ...]
    frictions: tuple[float, ...]
    estimate: Any
    alarm_active: bool
    alarm_raised: bool
    alarm_evidence: float
    status: DiagnosticReport
    interval: Any = None
    trend: Any = None

    @property
    def wear(self) -> float:
        """Return w-hat."""
        return float(self.estimate.wear)

    @property
    def wear_std(self) -> float:
        """Return the standard deviation of w-hat where it means something, else NaN.

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
            'temperature_degc': json_number(self.temperature_degc),
            'temperature_std_degc': json_number(self.temperature_std_degc),
            'wear': json_number(self.wear), 'wear_std': json_number(self.wear_std),
            'wear_interval': [json_number(v) for v in self.wear_interval],
            'wear_interval_open_above': self.wear_interval_open_above,
            'temperature_interval': [json_number(v) for v in self.temperature_interval],
            'trend': None if self.trend is None else self.trend.to_json(),
            'fit_p_value': json_number(self.estimate.p_value),
            'chi2': json_number(self.estimate.chi2), 'dof': int(self.estimate.dof),
            'temperature_at_bound': bool(self.estimate.temperature_at_bound),
            'wear_at_bound': bool(self.estimate.wear_at_bound),
            'alarm': self.alarm_active, 'alarm_raised': self.alarm_raised,
            'alarm_evidence': json_number(self.alarm_evidence),
            'status': messages.LEVEL_NAMES[self.status.level], 'message': self.status.message,
        }


def meaningful_std(*, std: float, value: float, low: float, high: float,
                   open_above: bool = False) -> float:
    """Return ``std`` when it describes the uncertainty of ``value``, else NaN.

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


def json_number(value: float) -> Optional[float]:
    """Return ``value`` as float, or None when it is NaN or infinite (valid JSON)."""
    value = float(value)
    return value if math.isfinite(value) else None


def _fmt(value: float, digits: int = 4) -> str:
    value = float(value)
    return f'{value:.{digits}g}' if math.isfinite(value) else 'nan'


#: Rejections that the friction experiment itself produces (ramps too short to be a pass, a
#: pass without its partner, a pause in the stream, an experiment the runner aborted or a
#: recording cut), and messages without the joint (another publisher on /joint_states, e.g. a
#: gripper): logged as info, not as input defects.
ROUTINE_REJECTIONS = frozenset({'pass_too_short', 'pass_unpaired', 'pass_no_common_window',
                                'time_gap', 'aborted_experiment', 'already_in_history',
                                'joint_missing', 'experiment_cut'})


#: A standstill at least this long [s] is a pause between experiments, not a turn inside one
#: (the planned experiment dwells 0.1-0.2 s at its turns); used at the cut of a recording.
_PAUSE_S = 0.5


class RejectionLog:
    """Rate-limited log text of the inputs rejected since the last report, by reason.

    A node calls :meth:`report` whenever its rejection count grows and from its periodic
    diagnostics timer; the text says how many inputs of each reason were rejected since the
    last report, at most once per ``period_s``, so a flood of bad messages gives one line per
    period and none is left unreported.
    """

    def __init__(self, *, what: str, period_s: float = 10.0) -> None:
        """Name the rejected inputs ``what`` (e.g. ``joint_states``) in the text."""
        self.what = what
        self.period_s = float(period_s)
        self._reported: Counter[str] = Counter()
        self._last_s = -math.inf

    def report(self, counts: Mapping[str, int], *, now_s: float, detail: str = ''
               ) -> Optional[tuple[str, bool]]:
        """Return (text, defective) of the rejections not yet reported, or None.

        None when nothing is new or the last report is less than ``period_s`` old;
        ``defective`` is True when a reason other than :data:`ROUTINE_REJECTIONS` is new
        (a reason may be prefixed by its joint, ``"<joint>: <reason>"``).
        """
        if now_s - self._last_s < self.period_s:
            return None
        new = Counter(counts)
        new.subtract(self._reported)
        new = +new
        if not new:
            return None
        self._last_s = now_s
        self._reported = Counter(counts)
        by_reason = ', '.join(f'{reason} {count}' for reason, count in sorted(new.items()))
        text = (f'rejected {sum(new.values())} {self.what} ({by_reason}); '
                f'{sum(counts.values())} since start')
        # a node of several joints names each reason "<joint>: <reason>"
        defective = any(reason.rpartition(': ')[2] not in ROUTINE_REJECTIONS for reason in new)
        return (f'{text}; last: {detail}' if detail and defective else text), defective


EstimateFunction = Callable[..., Any]


def _default_estimate(speeds_rad_s: np.ndarray, frictions: np.ndarray, *,
                      params: ParameterSet) -> Any:
    return _estimate_batch(speeds_rad_s, frictions, params=params)[0]


def _estimate_batch(speeds_rad_s: np.ndarray, frictions: np.ndarray, *,
                    params: ParameterSet) -> Any:
    from robot_wear_monitor.estimation.estimator import estimate_wear
    return estimate_wear(speeds_rad_s, frictions, params=params)


class WearEstimatorService:
    """Estimate (T, w) per experiment, latch the alarm, report diagnostics, keep the history.

    Args:
        config: the estimator configuration.
        history: the SQLite history (``WearHistory(':memory:')`` when None); the trend, the
            latched alarm and the evidence are restored from it.
        estimate: ``f(speeds, frictions, *, params) -> WearEstimate`` (the core estimator by
            default; tests may pass a fake).
        trend_length: estimates kept in memory for the trend (all stored ones are restored
            up to this many).

    """

    def __init__(self, config: EstimatorConfig, *, history: WearHistory | None = None,
                 estimate: EstimateFunction | None = None, trend_length: int = 1000) -> None:
        """Restore the state of ``config.joint`` from ``history``."""
        self.config = config
        self.history = history if history is not None else WearHistory(':memory:')
        self._estimate = estimate or _default_estimate
        restored = self.history.restore(joint=config.joint, trend_length=trend_length)
        self.trend: deque[HistoryRecord] = deque(restored.records, maxlen=trend_length)
        self.wear_trend = self._rebuild_trend(restored.records)
        self.latch = AlarmLatch(config.alarm, active=restored.alarm_active,
                                evidence=restored.alarm_evidence)
        self.restored_estimates = len(restored.records)
        self.experiments = len(restored.records)
        self.rejections: Counter[str] = Counter()
        self.last_update: Optional[WearUpdate] = None
        self.last_rejection = ''

    def _new_trend(self) -> Any:
        from robot_wear_monitor.estimation.trend import TrendConfig, WearTrend
        return WearTrend(TrendConfig(threshold=self.config.alarm.threshold))

    def _likelihood_rows(self, speeds: np.ndarray, frictions: np.ndarray) -> np.ndarray:
        """Return the profile log-likelihood rows of w on the trend's grid, (B, G)."""
        from robot_wear_monitor.estimation.intervals import profile_log_likelihood
        return profile_log_likelihood(speeds, frictions, params=self.config.params,
                                      wear_grid=self.wear_trend.wear_grid)

    def _rebuild_trend(self, records: Sequence[HistoryRecord]) -> Any:
        """Rebuild the trend filter from the stored estimates and maintenance resets.

        The filter's state is a pure function of its rows, so replaying the stored friction
        levels (grouped by speed set, one batched likelihood call per set) and the ``reset``
        events in their order gives the trend the service had before the restart.
        """
        self.wear_trend = self._new_trend()
        if not records:
            return self.wear_trend
        rows: list[Any] = [None] * len(records)
        groups: dict[tuple[float, ...], list[int]] = {}
        for i, record in enumerate(records):
            groups.setdefault(tuple(record.speeds_rad_s), []).append(i)
        for speeds, indices in groups.items():
            try:
                batch = self._likelihood_rows(np.asarray(speeds), np.asarray(
                    [records[i].frictions for i in indices], dtype=float))
            except (InputError, ValueError):
                continue
            for i, row in zip(indices, batch):
                rows[i] = row
        resets = [e for e in self.history.events(joint=self.config.joint)
                  if e.event == 'reset']
        for record, row in zip(records, rows):
            for event in [e for e in resets if e.estimate_id is not None
                          and e.estimate_id < (record.id or 0)]:
                self._reset_trend()
                resets.remove(event)
            if row is not None:
                try:
                    self.wear_trend.update(time_s=record.stamp_s, log_likelihood=row,
                                           forecast=False)
                except InputError:
                    continue
        for event in resets:
            if records and event.estimate_id is not None and event.estimate_id >= (
                    records[-1].id or 0):
                self._reset_trend()
        return self.wear_trend

    def _reset_trend(self) -> None:
        # The reset is stamped by this process's clock, the experiments by their recordings'
        # stamps (a replayed bag, simulated time): the new segment starts at the last experiment
        # so that the two clocks never meet on the trend's time line.
        self.wear_trend.reset()

    def warm_up(self) -> None:
        """Run the estimator once on model friction levels (nothing is stored or published).

        The first estimate of a process pays for imports and caches (about 0.5 s here), and the
        first interval of a design for the calibration of its cutoffs (about 2 s, see
        :func:`~robot_wear_monitor.estimation.intervals.calibrate_cutoffs`); a node pays both at
        start for its configured speeds, not at its first experiment while /joint_states keeps
        arriving.
        """
        from robot_wear_monitor.estimation.intervals import calibrate_cutoffs
        from robot_wear_monitor.model.friction import friction
        configured = self.config.experiment_speeds_rad_s
        speeds = np.asarray(configured or (30.0, 40.0), dtype=float)
        levels = np.asarray(friction(speeds, 0.5, 40.0, 10.0, self.config.params.model),
                            dtype=float)
        self._estimate(speeds, levels, params=self.config.params)
        if configured:
            calibrate_cutoffs(speeds, params=self.config.params)

    # ----------------------------------------------------------------- inputs

    def reject(self, reason: str, detail: str = '') -> None:
        """Count an unusable input by ``reason`` (shown in the diagnostics key-values)."""
        self.rejections[reason] += 1
        self.last_rejection = f'{reason}: {detail}' if detail else reason

    def handle_friction_levels(self, msg: Any) -> Optional[WearUpdate]:
        """Process a ``friction_levels`` JointState (rclpy or rosbags); None if rejected."""
        try:
            levels = messages.friction_levels_from_msg(msg)
        except MessageError as error:
            self.reject(error.reason, error.detail)
            return None
        return self.process_levels(levels)

    def process_experiment(self, experiment: FrictionExperiment) -> Optional[WearUpdate]:
        """Process a completed experiment directly (no message in between)."""
        return self.process_levels(FrictionLevelsMessage(
            stamp_s=experiment.end_time_s, joint=self.config.joint,
            speeds_rad_s=tuple(float(v) for v in experiment.speeds_rad_s),
            frictions=tuple(float(f) for f in experiment.frictions)))

    def process_levels(self, levels: FrictionLevelsMessage) -> Optional[WearUpdate]:
        """Estimate, update the alarm, store the history; None if the estimate fails."""
        if levels.joint and levels.joint != self.config.joint:
            self.reject('other_joint', f'levels of joint {levels.joint!r}, this estimator '
                                       f'monitors {self.config.joint!r}')
            return None
        speeds = np.asarray(levels.speeds_rad_s, dtype=float)
        frictions = np.asarray(levels.frictions, dtype=float)
        if speeds.size < 1 or speeds.shape != frictions.shape:
            self.reject('length_mismatch', f'{speeds.size} speeds, {frictions.size} frictions')
            return None
        if not (np.all(np.isfinite(speeds)) and np.all(np.isfinite(frictions))):
            self.reject('not_finite', 'a speed or friction level is NaN or infinite')
            return None
        known = self.history.find_estimate(joint=self.config.joint, stamp_s=levels.stamp_s)
        if known is not None:
            # the same experiment again (a re-run of a recording into the same history, a
            # replayed message): its estimate is stored and in the trend; never twice
            self.reject('already_in_history', f'the experiment ending at {levels.stamp_s:.6f} '
                                              f's is estimate {known} of the history; skipped')
            return None
        batch = None
        try:
            if self._estimate is _default_estimate:  # keep the batch for the interval
                batch = _estimate_batch(speeds, frictions, params=self.config.params)
                estimate = batch[0]
            else:
                estimate = self._estimate(speeds, frictions, params=self.config.params)
        except (InputError, ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            self.reject('estimation_failed', str(error).splitlines()[0] if str(error) else '')
            return None
        wear = float(estimate.wear)
        wear_std = float(estimate.wear_std)
        interval, trend = self._interval_and_trend(speeds, frictions, stamp_s=levels.stamp_s,
                                                   estimates=batch)
        raised = self.latch.update(
            wear=wear, wear_std=wear_std,
            probability_above_threshold=(math.nan if trend is None
                                         else trend.probability_above_threshold))
        self.experiments += 1
        update_std = meaningful_std(
            std=wear_std, value=wear,
            low=math.nan if interval is None else interval.wear_low,
            high=math.nan if interval is None else interval.wear_high,
            open_above=bool(interval is not None and interval.wear_high_at_grid_end))
        status = self._status(estimate=estimate, speeds=levels.speeds_rad_s,
                              interval=interval, trend=trend, wear_std=update_std)
        record = HistoryRecord(
            joint=self.config.joint, stamp_s=levels.stamp_s, speeds_rad_s=levels.speeds_rad_s,
            frictions=levels.frictions, temperature_degc=float(estimate.temperature_degc),
            temperature_std_degc=float(estimate.temperature_std_degc), wear=wear,
            wear_std=wear_std, chi2=float(estimate.chi2), dof=int(estimate.dof),
            p_value=float(estimate.p_value),
            temperature_at_bound=bool(estimate.temperature_at_bound),
            wear_at_bound=bool(estimate.wear_at_bound), alarm_active=self.latch.active,
            alarm_evidence=self.latch.evidence, status_level=status.level,
            parameter_set=self.config.params.name, **_interval_columns(interval, trend))
        events = [AlarmEvent(joint=self.config.joint, stamp_s=levels.stamp_s, event='raised',
                             wear=wear, note=self._raise_note(wear, trend))] if raised else []
        record_id = self.history.append(record, events=events)
        if record_id is None:  # another writer stored this experiment meanwhile
            self.reject('already_in_history', f'the experiment ending at {levels.stamp_s:.6f} '
                                              f's was stored by another writer; skipped')
            return None
        self.trend.append(HistoryRecord(**{**record.__dict__, 'id': record_id}))
        self.last_update = WearUpdate(
            index=self.experiments, stamp_s=levels.stamp_s, joint=self.config.joint,
            speeds_rad_s=levels.speeds_rad_s, frictions=levels.frictions, estimate=estimate,
            alarm_active=self.latch.active, alarm_raised=raised,
            alarm_evidence=self.latch.evidence, status=status, interval=interval, trend=trend)
        return self.last_update

    def _raise_note(self, wear: float, trend: Any) -> str:
        """Say which evidence raised the alarm (the history's ``alarm_events.note``)."""
        policy = self.config.alarm
        if policy.rule == 'trend' and trend is not None:
            return (f'trend P(w >= {_fmt(policy.threshold)}) = '
                    f'{_fmt(trend.probability_above_threshold, 3)} >= '
                    f'{_fmt(policy.probability, 3)}; trend w {_fmt(trend.wear)} '
                    f'[{_fmt(trend.wear_low)}, {_fmt(trend.wear_high)}], w-hat {_fmt(wear)}')
        return (f'w-hat {_fmt(wear)} >= {_fmt(policy.threshold)}, evidence '
                f'{_fmt(self.latch.evidence, 3)}')

    def _interval_and_trend(self, speeds: np.ndarray, frictions: np.ndarray, *,
                            stamp_s: float, estimates: Any = None) -> tuple[Any, Any]:
        """Return the 95 % intervals of (w, T) and the updated trend (None where they fail).

        ``estimates``: the estimator's batch result for these levels, if the default estimator
        made it (the interval needs the ML estimate; it is not computed twice).
        """
        from robot_wear_monitor.estimation.intervals import wear_intervals
        interval = trend = None
        try:
            interval = wear_intervals(speeds, frictions, params=self.config.params,
                                      estimates=estimates)[0]
        except (InputError, ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            self.reject('interval_failed', str(error).splitlines()[0] if str(error) else '')
        try:
            row = self._likelihood_rows(speeds, frictions)[0]
            trend = self.wear_trend.update(time_s=stamp_s, log_likelihood=row)
        except (InputError, ValueError, FloatingPointError) as error:
            self.reject('trend_failed', str(error).splitlines()[0] if str(error) else '')
        return interval, trend

    def reset_alarm(self, *, stamp_s: float, note: str = 'reset after maintenance'
                    ) -> tuple[bool, str]:
        """Clear the latched alarm (``~/reset_alarm``); return (success, message).

        A reset follows maintenance: the wear trend starts a new segment from the new-joint prior.
        """
        was_active = self.latch.reset()
        self._reset_trend()
        last_id = self.trend[-1].id if self.trend else None
        self.history.record_event(AlarmEvent(joint=self.config.joint, stamp_s=stamp_s,
                                             event='reset', wear=None, note=note,
                                             estimate_id=last_id))
        if was_active:
            return True, 'wear alarm cleared; evidence and trend reset'
        return True, 'no wear alarm was active; evidence and trend reset'

    # ----------------------------------------------------------------- diagnostics

    def _status(self, *, estimate: Any, speeds: Sequence[float], interval: Any = None,
                trend: Any = None, wear_std: float = math.nan) -> DiagnosticReport:
        config = self.config
        wear = float(estimate.wear)
        p_value = float(estimate.p_value)
        summary = (f'w = {_fmt(wear, 3)}{_interval_text(interval)}, '
                   f'T = {_fmt(estimate.temperature_degc, 3)} degC')
        if trend is not None:
            summary += (f'; trend {_fmt(trend.wear, 3)} ({_fmt(trend.wear_low, 3)}-'
                        f'{_fmt(trend.wear_high, 3)}), P(w >= '
                        f'{_fmt(config.alarm.threshold)}) {trend.probability_above_threshold:.0%}'
                        f'{_forecast_text(trend)}')
        warnings = []
        if wear >= config.wear_warning and not self.latch.active:
            warnings.append(f'wear near the alarm level {_fmt(config.alarm.threshold)}')
        if math.isfinite(p_value) and p_value < config.min_fit_p_value:
            warnings.append(f'the friction levels do not fit the model (p = {p_value:.2g})')
        if bool(estimate.temperature_at_bound):
            warnings.append('temperature estimate on its bound')
        if config.experiment_speeds_rad_s and not _same_speeds(
                speeds, config.experiment_speeds_rad_s, config.speed_tolerance_rad_s):
            warnings.append('speeds differ from the configured experiment')
        if self.latch.active:
            level = DIAGNOSTIC_ERROR
            message = f'WEAR ALARM (latched, reset after maintenance): {summary}'
        elif warnings:
            level = DIAGNOSTIC_WARN
            message = f'{summary}; ' + '; '.join(warnings)
        else:
            level = DIAGNOSTIC_OK
            message = summary
        values = [
            ('joint', config.joint),
            ('wear', _fmt(wear, 6)), ('wear_std', _fmt(wear_std, 6)),
            ('wear_low', _fmt(math.nan if interval is None else interval.wear_low, 6)),
            ('wear_high', _fmt(math.nan if interval is None else interval.wear_high, 6)),
            ('temperature_degc', _fmt(estimate.temperature_degc, 6)),
            ('temperature_std_degc', _fmt(estimate.temperature_std_degc, 6)),
            ('temperature_low_degc',
             _fmt(math.nan if interval is None else interval.temperature_low, 6)),
            ('temperature_high_degc',
             _fmt(math.nan if interval is None else interval.temperature_high, 6)),
            ('speeds_rad_s', ','.join(_fmt(v, 6) for v in speeds)),
            ('n_levels', str(int(estimate.n_levels))),
            ('fit_p_value', _fmt(p_value, 4)), ('chi2', _fmt(estimate.chi2, 4)),
            ('dof', str(int(estimate.dof))),
            ('temperature_at_bound', str(bool(estimate.temperature_at_bound)).lower()),
            ('wear_at_bound', str(bool(estimate.wear_at_bound)).lower()),
            ('alarm', str(self.latch.active).lower()),
            ('alarm_evidence', _fmt(self.latch.evidence, 4)),
            ('alarm_rule', config.alarm.rule),
            ('wear_threshold', _fmt(config.alarm.threshold)),
            ('wear_warning', _fmt(config.wear_warning)),
            ('experiments', str(self.experiments)),
            ('parameter_set', config.params.name),
        ]
        values += _trend_values(trend)
        values += self._rejection_values()
        return DiagnosticReport(level=level, message=message, values=tuple(values))

    def _rejection_values(self) -> list[tuple[str, str]]:
        values = [('rejected_total', str(sum(self.rejections.values())))]
        values += [(f'rejected_{reason}', str(count))
                   for reason, count in sorted(self.rejections.items())]
        if self.last_rejection:
            values.append(('last_rejection', self.last_rejection))
        return values

    def current_status(self) -> DiagnosticReport:
        """Return the status to publish now (periodic diagnostics, before any estimate)."""
        if self.last_update is not None:
            status = self.last_update.status
            values = [kv for kv in status.values if not kv[0].startswith(
                ('rejected_', 'last_rejection', 'alarm'))]
            values += [('alarm', str(self.latch.active).lower()),
                       ('alarm_evidence', _fmt(self.latch.evidence, 4))]
            level = status.level
            message = status.message
            if not self.latch.active and level == DIAGNOSTIC_ERROR:
                level, message = DIAGNOSTIC_OK, 'wear alarm reset; waiting for the next experiment'
            return DiagnosticReport(level=level, message=message,
                                    values=tuple(values + self._rejection_values()))
        values = [('joint', self.config.joint), ('alarm', str(self.latch.active).lower()),
                  ('alarm_evidence', _fmt(self.latch.evidence, 4)),
                  ('experiments', str(self.experiments))]
        if self.trend:
            last = self.trend[-1]
            values += [('wear', _fmt(last.wear, 6)), ('wear_std', _fmt(last.wear_std, 6)),
                       ('temperature_degc', _fmt(last.temperature_degc, 6))]
        values += self._rejection_values()
        if self.latch.active:
            return DiagnosticReport(DIAGNOSTIC_ERROR, 'WEAR ALARM (latched, restored from the '
                                    'history; reset after maintenance)', tuple(values))
        message = ('restored from the history; waiting for the next experiment' if self.trend
                   else 'waiting for the first friction experiment')
        return DiagnosticReport(DIAGNOSTIC_OK, message, tuple(values))

    # ----------------------------------------------------------------- outputs

    def diagnostic_name(self) -> str:
        """Return the DiagnosticStatus name: ``wear_monitor: <joint>``."""
        return f'wear_monitor: {self.config.joint}'

    def output_messages(self, kit: MessageKit, update: WearUpdate
                        ) -> list[tuple[str, Any]]:
        """Return (topic, message) of the estimator's outputs for one update, in order."""
        return [
            (TEMPERATURE_TOPIC, messages.temperature_to_msg(
                kit, stamp_s=update.stamp_s, frame_id=self.config.joint,
                temperature_degc=update.temperature_degc,
                variance_degc2=update.temperature_std_degc ** 2)),
            (WEAR_TOPIC, messages.wear_to_msg(kit, wear=update.wear)),
            (ALARM_TOPIC, messages.alarm_to_msg(kit, active=update.alarm_active)),
            *([] if update.trend is None else [(TREND_TOPIC, messages.trend_to_msg(
                kit, stamp_s=update.stamp_s, joint=self.config.joint, trend=update.trend))]),
            (DIAGNOSTICS_TOPIC, self.diagnostics_message(kit, stamp_s=update.stamp_s,
                                                         status=update.status)),
        ]

    def diagnostics_message(self, kit: MessageKit, *, stamp_s: float,
                            status: DiagnosticReport | None = None) -> Any:
        """Return the DiagnosticArray of ``status`` (the current status when None)."""
        status = status or self.current_status()
        return messages.diagnostics_to_msg(
            kit, stamp_s=stamp_s, name=self.diagnostic_name(), hardware_id=self.config.joint,
            level=status.level, message=status.message, values=status.values)


def _interval_text(interval: Any) -> str:
    if interval is None:
        return ''
    above = '+' if interval.wear_high_at_grid_end else ''
    return (f' (95 %: {_fmt(interval.wear_low, 3)}-{_fmt(interval.wear_high, 3)}'
            f'{above})')


def _forecast_text(trend: Any) -> str:
    remaining = float(trend.remaining_experiments)
    if trend.probability_above_threshold >= 0.5 or not math.isfinite(remaining):
        return ''
    return (f', crossing in {remaining:.0f} experiments '
            f'({_fmt(trend.remaining_experiments_low, 3)}-'
            f'{_fmt(trend.remaining_experiments_high, 3)})')


#: Diagnostics key-values of the trend (trend attribute names, with their keys).
_TREND_KEYS = (('trend_wear', 'wear'), ('trend_low', 'wear_low'), ('trend_high', 'wear_high'),
               ('trend_rate_per_experiment', 'rate'),
               ('probability_above_threshold', 'probability_above_threshold'),
               ('remaining_experiments', 'remaining_experiments'),
               ('remaining_experiments_low', 'remaining_experiments_low'),
               ('remaining_experiments_high', 'remaining_experiments_high'),
               ('crossing_time_s', 'crossing_time_s'),
               ('crossing_time_low_s', 'crossing_time_low_s'),
               ('crossing_time_high_s', 'crossing_time_high_s'))


def _trend_values(trend: Any) -> list[tuple[str, str]]:
    if trend is None:
        return []
    return [(key, _fmt(getattr(trend, name), 15 if 'time' in key else 6))
            for key, name in _TREND_KEYS]


def _interval_columns(interval: Any, trend: Any) -> dict[str, float]:
    """Return the history's interval and trend columns of one estimate (NaN when absent)."""
    nan = math.nan
    return {
        'wear_low': nan if interval is None else float(interval.wear_low),
        'wear_high': nan if interval is None else float(interval.wear_high),
        'temperature_low_degc': nan if interval is None else float(interval.temperature_low),
        'temperature_high_degc': nan if interval is None else float(interval.temperature_high),
        'trend_wear': nan if trend is None else float(trend.wear),
        'trend_low': nan if trend is None else float(trend.wear_low),
        'trend_high': nan if trend is None else float(trend.wear_high),
        'crossing_experiments': nan if trend is None else float(trend.remaining_experiments),
        'crossing_time_s': nan if trend is None else float(trend.crossing_time_s),
    }


def _same_speeds(speeds: Sequence[float], expected: Sequence[float], tolerance: float) -> bool:
    if len(speeds) != len(expected):
        return False
    return all(abs(a - b) <= tolerance for a, b in zip(sorted(speeds), sorted(expected)))


# --------------------------------------------------------------------------- experiment service

@dataclass
class _EventExperiment:
    """An experiment opened by a runner ``start`` event: its window [start_s, end_s] [s]."""

    start: messages.ExperimentEvent
    start_s: float
    end_s: float = math.inf
    levels: list[FrictionLevel] = field(default_factory=list)


@dataclass
class FrictionExperimentService:
    """Segment joint states of one joint into friction levels and completed experiments.

    Wraps the streaming segmenter and the experiment assembler of ``segmentation.py``; the
    node feeds it every /joint_states message, the replay every recorded one.

    Experiment boundaries.  Without events an experiment is complete when every configured
    speed has a level, and an idle gap abandons an incomplete one (the assembler).  The
    friction_experiment_runner's events (:meth:`add_experiment_event`, streaming path only)
    say exactly which levels form an experiment: a ``start`` for this joint closes any open
    experiment (emitted if it has levels; the assembler's is flushed) and opens one at the
    event's stamp S; every level completed from then on goes to it, not to the assembler, when
    its passes lie in [S, E] (E = the ``end`` stamp, open until it comes; levels outside are
    counted); an ``end`` with the same experiment id closes it as soon as a sample stamped E or
    later has been added (at once when one already has: the segmentation has then seen every
    sample up to E), and it is emitted with one merged level per planned speed of the event
    (``speeds_rad_s``; the configured speeds when the event has none), in the planned order,
    even if a speed is missing (counted as incomplete); ``aborted`` drops the open experiment's
    levels (rejection ``aborted_experiment``).  Events of other joints, and an ``end`` or
    ``aborted`` of no open experiment, are counted and ignored.  Events and JointStates must be
    stamped by the same clock.
    """

    segmenter_config: Any
    experiment_speeds_rad_s: tuple[float, ...] = ()
    speed_tolerance_rad_s: float = 1.0
    idle_gap_s: float = 30.0
    rejections: Counter = field(default_factory=Counter)
    levels: list[FrictionLevel] = field(default_factory=list)

    def __post_init__(self) -> None:
        """Build the segmenter and the assembler."""
        from robot_wear_monitor.experiment.segmentation import (ExperimentAssembler,
                                                                StreamingSegmenter)
        self.messages = 0
        self.experiments = 0
        self.last_experiment: Optional[FrictionExperiment] = None
        self.last_error = ''
        self._status_total = 0
        self._segmenter = StreamingSegmenter(self.segmenter_config)
        self._chunks = None
        self._last_pause_end_s = -math.inf
        from robot_wear_monitor.experiment.segmentation import SpeedTally
        self._speed_tally = SpeedTally(self.speed_tolerance_rad_s)
        self._assembler = ExperimentAssembler(
            speeds_rad_s=list(self.experiment_speeds_rad_s) or None,
            speed_tolerance_rad_s=self.speed_tolerance_rad_s, idle_gap_s=self.idle_gap_s)
        self.event_counts: Counter = Counter()
        self.experiments_from_events = 0
        self.experiments_incomplete = 0
        self.levels_outside_experiment = 0
        self._event_ignored = 0
        self._open: Optional[_EventExperiment] = None
        self._latest_stamp_s = -math.inf

    @classmethod
    def from_node_parameters(cls, values: Mapping[str, Any]) -> 'FrictionExperimentService':
        """Build from validated ``friction_experiment_node`` parameters (see node_config)."""
        from robot_wear_monitor.monitoring.node_config import SEGMENTER_FIELDS
        from robot_wear_monitor.experiment.segmentation import SegmenterConfig
        config = SegmenterConfig(**{name: values[name] for name in SEGMENTER_FIELDS})
        return cls(segmenter_config=config,
                   experiment_speeds_rad_s=tuple(values['experiment_speeds_rad_s']),
                   speed_tolerance_rad_s=values['experiment_speed_tolerance_rad_s'],
                   idle_gap_s=values['idle_gap_s'])

    @property
    def joint(self) -> str:
        """Return the segmented joint."""
        return self.segmenter_config.joint

    def all_rejections(self) -> Counter:
        """Return the rejections of the segmenter and of this service, by reason."""
        total = Counter(self._segmenter.rejections)
        total.update(self.rejections)
        return total

    @property
    def rejected_total(self) -> int:
        """Return the number of rejections so far (cheap: for a per-message check)."""
        return self._segmenter.rejections.total() + self.rejections.total()

    def add_joint_state(self, *, stamp_s: float, name: Sequence[str], position: Sequence[float],
                        velocity: Sequence[float], effort: Sequence[float]
                        ) -> list[FrictionExperiment]:
        """Add one JointState; return the experiments it completes (usually none)."""
        self.messages += 1
        try:
            new_levels = self._segmenter.add_joint_state(stamp_s=stamp_s, name=name,
                                                         position=position, velocity=velocity,
                                                         effort=effort)
        except (InputError, ValueError, TypeError) as error:
            self.rejections['malformed_joint_state'] += 1
            self.last_error = str(error)
            return []
        return self._after_sample(stamp_s, self._assemble(new_levels))

    def add_sample(self, *, time_s: float, position_rad: float, velocity_rad_s: float,
                   effort: float) -> list[FrictionExperiment]:
        """Add one sample of the joint already picked from its JointState (the replay)."""
        return self._after_sample(time_s, self._assemble(self._segmenter.add_sample(
            time_s=time_s, position_rad=position_rad, velocity_rad_s=velocity_rad_s,
            effort=effort)))

    def add_recording(self, *, time_s: Sequence[float], position_rad: Sequence[float],
                      velocity_rad_s: Sequence[float], effort: Sequence[float]
                      ) -> list[FrictionExperiment]:
        """Segment a chunk of a recording of the joint at once (the replay) and assemble it.

        Chunks are the consecutive parts of one recording (a whole recording is one chunk);
        the chunked batch segmenter gives the same levels and rejection counts as the
        streaming one that ``add_sample`` feeds (tested), at numpy speed, and keeps only the
        move in progress between chunks; the levels then go through the same experiment
        assembler as on the robot.  Use it on a fresh service (not mixed with ``add_sample``
        or ``add_joint_state``), then ``finish()``.  Arrays: shape (n,), time [s], joint
        position [rad], joint speed [rad/s], effort.
        """
        from robot_wear_monitor.experiment.segmentation import ChunkSegmenter
        if self._chunks is None:
            self._chunks = ChunkSegmenter(self.segmenter_config)
            self._segmenter = self._chunks
        self.messages += len(time_s)
        motion_before = self._chunks.last_motion_s
        experiments = self._assemble(self._chunks.add(
            time_s=time_s, position_rad=position_rad, velocity_rad_s=velocity_rad_s,
            effort=effort))
        # a standstill of idle_gap_s inside the chunk closes the experiment as the live node
        # does sample by sample (the levels before it are in; a level after it would close
        # it anyway)
        ends, lengths = self._rests(time_s, velocity_rad_s, motion_before)
        for rest_end_s in ends[lengths > self.idle_gap_s]:
            if self._open is None:
                experiments += self._completed(self._assembler.idle(now_s=float(rest_end_s)))
        pauses = ends[lengths > _PAUSE_S]
        if pauses.size:
            self._last_pause_end_s = float(pauses[-1])
        if len(time_s):
            experiments += self._idle(float(time_s[-1]))
        return experiments

    def _rests(self, time_s: Sequence[float], velocity_rad_s: Sequence[float],
               motion_before_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the end times [s] and lengths [s] of the standstills between moving samples.

        A standstill ends at a moving sample; it starts at the moving sample before it (or at
        ``motion_before_s``, the last motion of the previous chunk).
        """
        t = np.asarray(time_s, dtype=float)
        speed = np.abs(np.asarray(velocity_rad_s, dtype=float)) * self.segmenter_config.gear_ratio
        moving = t[np.isfinite(t) & (speed > self.segmenter_config.standstill_speed_rad_s)]
        if moving.size == 0:
            return moving, moving
        starts = np.concatenate(([motion_before_s], moving[:-1]))
        return moving, moving - starts

    def drop_interrupted(self) -> int:
        """At the cut of a recording: drop the experiment the cut interrupts; return its levels.

        The move in progress at the cut is dropped (a cut pass).  The experiment in progress is
        kept when it is complete: the joint paused (0.5 s or more, longer than the turns of one
        experiment) after its last level and was moving again at the cut (the next experiment
        had begun), or it has the speeds of this joint's previous experiment, or the joint
        stood still for ``idle_gap_s`` before the cut (the rule that would have closed it);
        otherwise it is dropped (counted as ``experiment_cut``), since the levels
        that followed are lost.  Chunked path (``add_recording``) only.
        """
        if self._chunks is None or self._open is not None:
            return 0
        self._chunks.discard_move()
        speeds = self._assembler.current_speeds()
        if not speeds:
            return 0
        moving_at_cut = self._chunks.last_time_s - self._chunks.last_motion_s <= _PAUSE_S
        if moving_at_cut and self._last_pause_end_s > self._assembler.last_level_end_s:
            return 0  # the joint paused after these levels, then started the next experiment
        previous = self.last_experiment
        if previous is not None and len(previous.speeds_rad_s) == len(speeds) and all(
                abs(a - b) <= self.speed_tolerance_rad_s
                for a, b in zip(sorted(previous.speeds_rad_s), sorted(speeds))):
            return 0
        if self._chunks.last_time_s - self._chunks.last_motion_s > self.idle_gap_s:
            return 0
        dropped = self._assembler.discard()
        self.rejections['experiment_cut'] += 1
        return dropped

    def close_idle(self) -> list[FrictionExperiment]:
        """Close the assembler's experiment because the stream has stopped (no samples).

        The live node calls it when no JointState has come for ``idle_gap_s`` (wall time): a
        recording or a robot that stops publishing after an experiment must not hold that
        experiment back until the next one.  The segmentation is not flushed (a move in
        progress goes on if the stream comes back).
        """
        if self._open is not None:
            return []
        return self._completed(self._assembler.flush() or [])

    def _idle(self, now_s: float) -> list[FrictionExperiment]:
        """Close the assembler's experiment once the joint has stood still for idle_gap_s.

        Standing still, not merely no new level: a level at a slow speed takes its time.
        """
        if now_s - self._segmenter.last_motion_s <= self.idle_gap_s:
            return []
        return self._completed(self._assembler.idle(now_s=now_s))

    @property
    def fastest_speed_rad_s(self) -> float:
        """Return the fastest motor-side speed of the accepted samples so far [rad/s]."""
        return self._segmenter.fastest_speed_rad_s

    @property
    def passes(self) -> int:
        """Return the constant-speed passes found so far (paired or not)."""
        return self._segmenter.passes

    def levels_per_speed(self) -> dict[float, int]:
        """Return the friction levels found per speed (motor side, the speed's mean to 0.1)."""
        return self._speed_tally.counts()

    @property
    def levels_at_other_speeds(self) -> dict[float, int]:
        """Return the levels at no configured speed, per speed (0.1 rad/s): reported, unused."""
        return self._assembler.ignored_speeds.counts()

    def summary(self) -> dict[str, Any]:
        """Return what the segmentation found, for a report (JSON-ready).

        Keys: ``joint``, ``samples`` (read), ``rejected`` (reason -> count),
        ``passes``, ``levels``, ``levels_per_speed_rad_s`` (speed -> count),
        ``levels_at_other_speeds_rad_s`` (speed -> count), ``experiments``,
        ``experiments_abandoned``, ``speeds_configured_rad_s`` (empty: discovered).
        """
        return {'joint': self.joint, 'samples': self.messages,
                'rejected': dict(sorted(self.all_rejections().items())),
                'passes': self.passes, 'levels': len(self.levels),
                'levels_per_speed_rad_s': {f'{k:g}': v
                                           for k, v in self.levels_per_speed().items()},
                'levels_at_other_speeds_rad_s': {
                    f'{k:g}': v for k, v in self.levels_at_other_speeds.items()},
                'experiments': self.experiments,
                'experiments_abandoned': self._assembler.abandoned,
                'speeds_configured_rad_s': list(self.experiment_speeds_rad_s)}

    def _assemble(self, new_levels: Sequence[FrictionLevel]) -> list[FrictionExperiment]:
        experiments: list[FrictionExperiment] = []
        for level in new_levels:
            self.levels.append(level)
            self._speed_tally.add(level.speed_rad_s)
            if self._open is None:
                experiments.extend(self._assembler.add(level))
            elif self._open.start_s <= level.start_time_s and \
                    level.end_time_s <= self._open.end_s:
                self._open.levels.append(level)
            else:
                self.levels_outside_experiment += 1
        return self._completed(experiments)

    def _completed(self, experiments: list[FrictionExperiment]) -> list[FrictionExperiment]:
        """Count completed experiments and keep the last one; return them."""
        if experiments:
            self.experiments += len(experiments)
            self.last_experiment = experiments[-1]
        return experiments

    def _after_sample(self, stamp_s: float, experiments: list[FrictionExperiment]
                      ) -> list[FrictionExperiment]:
        """Close the event experiment whose ``end`` stamp the samples have reached.

        Also closes the assembler's experiment when the joint has idled for ``idle_gap_s``
        since its last level (with discovered speeds nothing else would close it until the
        next experiment starts).
        """
        stamp_s = float(stamp_s)
        if math.isfinite(stamp_s) and stamp_s > self._latest_stamp_s:
            self._latest_stamp_s = stamp_s
            if self._open is None:
                experiments = experiments + self._idle(stamp_s)
        if self._open is not None and self._latest_stamp_s >= self._open.end_s:
            experiments = experiments + self._completed(self._close_event_experiment())
        return experiments

    # ----------------------------------------------------------------- experiment events

    def handle_experiment_event_msg(self, msg: Any) -> list[FrictionExperiment]:
        """Read one ``friction_experiment/events`` message and apply it (see the class doc).

        A malformed message is counted (rejection ``experiment_event_<reason>``) and ignored.
        """
        try:
            event = messages.experiment_event_from_msg(msg)
        except MessageError as error:
            self.rejections[f'experiment_event_{error.reason}'] += 1
            self.last_error = f'experiment event: {error}'
            return []
        return self.add_experiment_event(event)

    def add_experiment_event(self, event: messages.ExperimentEvent
                             ) -> list[FrictionExperiment]:
        """Apply one runner event; return the experiments it completes (see the class doc)."""
        if event.joint != self.joint:
            self.event_counts['other_joint'] += 1
            return []
        self.event_counts[event.event] += 1
        if event.event == 'start':
            done = self._close_event_experiment()
            done += self._assembler.flush() or []
            self._open = _EventExperiment(start=event, start_s=float(event.stamp_s))
            return self._completed(done)
        if self._open is None or self._open.start.experiment_id != event.experiment_id:
            self.event_counts['unmatched'] += 1
            return []
        if event.event == 'aborted':
            self.rejections['aborted_experiment'] += 1
            self._open = None
            return []
        self._open.end_s = float(event.stamp_s)
        if self._latest_stamp_s >= self._open.end_s:
            return self._completed(self._close_event_experiment())
        return []

    @property
    def open_experiment_id(self) -> Optional[int]:
        """Return the runner's id of the experiment in progress (opened by ``start``), if any."""
        return None if self._open is None else int(self._open.start.experiment_id)

    def _close_event_experiment(self) -> list[FrictionExperiment]:
        """Close the open event experiment; return it when it has levels (not counted yet)."""
        from robot_wear_monitor.experiment.segmentation import merge_levels
        current, self._open = self._open, None
        if current is None:
            return []
        levels = [lv for lv in current.levels if lv.end_time_s <= current.end_s]
        self.levels_outside_experiment += len(current.levels) - len(levels)
        speeds = list(current.start.speeds_rad_s or self.experiment_speeds_rad_s)
        groups: list[list[FrictionLevel]] = [[] for _ in speeds]
        for level in levels:
            if speeds:
                distance = [abs(v - level.speed_rad_s) for v in speeds]
                slot = int(np.argmin(distance))
                if distance[slot] > self.speed_tolerance_rad_s:
                    self._event_ignored += 1
                    continue
            else:
                slot = next((i for i, group in enumerate(groups) if abs(
                    group[0].speed_rad_s - level.speed_rad_s) <= self.speed_tolerance_rad_s),
                    len(groups))
                if slot == len(groups):
                    groups.append([])
            groups[slot].append(level)
        found = [merge_levels(group) for group in groups if group]
        if not found:
            return []
        if len(found) < len(groups):
            self.experiments_incomplete += 1
        self.experiments_from_events += 1
        return [FrictionExperiment(levels=tuple(found))]

    def diagnostic_name(self) -> str:
        """Return the DiagnosticStatus name: ``friction_experiment: <joint>``."""
        return f'friction_experiment: {self.joint}'

    def current_status(self) -> DiagnosticReport:
        """Return the segmentation status: counts, last experiment, rejections by reason.

        WARN while malformed inputs (reasons outside :data:`ROUTINE_REJECTIONS`) were rejected
        since the previous call (the node calls it once per diagnostics period), OK otherwise;
        the counts are totals since start.
        """
        rejections = self.all_rejections()
        total = sum(rejections.values())
        defects = sum(n for r, n in rejections.items() if r not in ROUTINE_REJECTIONS)
        new = defects - self._status_total
        self._status_total = defects
        summary = (f'{self.messages} joint_states, {len(self.levels)} friction levels, '
                   f'{self.experiments} experiments')
        values = [('joint', self.joint), ('joint_states', str(self.messages)),
                  ('passes', str(self.passes)),
                  ('friction_levels', str(len(self.levels))),
                  ('levels_per_speed_rad_s', ','.join(
                      f'{k:g}:{v}' for k, v in self.levels_per_speed().items())),
                  ('experiments', str(self.experiments)),
                  ('speeds_rad_s', ','.join(f'{v:g}' for v in self.experiment_speeds_rad_s)
                   or 'found in the data'),
                  ('levels_at_other_speeds', str(self._assembler.ignored + self._event_ignored)),
                  ('levels_at_other_speeds_rad_s', ','.join(
                      f'{k:g}:{v}' for k, v in self.levels_at_other_speeds.items())),
                  ('experiments_abandoned', str(self._assembler.abandoned))]
        if not self.experiments and self.messages:
            rejected = self.all_rejections()
            values.append(('no_experiment_yet', explain_no_experiment(
                service=self, reader_rejections={},
                seen=rejected.get('joint_missing', 0) < self.messages)))
        if self.event_counts:
            open_id = self.open_experiment_id
            values += [('experiment_events', str(sum(self.event_counts[k] for k in (
                           'start', 'end', 'aborted')))),
                       ('experiment_events_other_joints', str(self.event_counts['other_joint'])),
                       ('experiment_events_unmatched', str(self.event_counts['unmatched'])),
                       ('experiments_from_events', str(self.experiments_from_events)),
                       ('experiments_incomplete', str(self.experiments_incomplete)),
                       ('levels_outside_experiment', str(self.levels_outside_experiment)),
                       ('experiment_open', 'none' if open_id is None else str(open_id))]
        if self.last_experiment is not None:
            values += [('last_experiment_end_s', _fmt(self.last_experiment.end_time_s, 15)),
                       ('last_speeds_rad_s', ','.join(
                           _fmt(v, 6) for v in self.last_experiment.speeds_rad_s)),
                       ('last_frictions', ','.join(
                           _fmt(f, 6) for f in self.last_experiment.frictions))]
        values.append(('rejected_total', str(total)))
        values += [(f'rejected_{reason}', str(count))
                   for reason, count in sorted(rejections.items())]
        if self.last_error:
            values.append(('last_rejection', self.last_error))
        if new > 0:
            reasons = ', '.join(sorted(set(rejections) - ROUTINE_REJECTIONS))
            return DiagnosticReport(DIAGNOSTIC_WARN, f'{summary}; {new} malformed inputs '
                                    f'rejected in the last period ({reasons})', tuple(values))
        return DiagnosticReport(DIAGNOSTIC_OK, summary, tuple(values))

    def diagnostics_message(self, kit: MessageKit, *, stamp_s: float) -> Any:
        """Return the DiagnosticArray of :meth:`current_status`."""
        status = self.current_status()
        return messages.diagnostics_to_msg(
            kit, stamp_s=stamp_s, name=self.diagnostic_name(), hardware_id=self.joint,
            level=status.level, message=status.message, values=status.values)

    def finish(self) -> list[FrictionExperiment]:
        """Flush the segmenter and the assembler at the end of a stream (bag end, shutdown).

        An experiment opened by a ``start`` event and not ended is closed (emitted if it has
        levels).
        """
        experiments = self._assemble(self._segmenter.finish() or [])
        experiments.extend(self._completed(self._close_event_experiment()))
        experiments.extend(self._completed(self._assembler.flush() or []))
        return experiments

    def friction_levels_message(self, kit: MessageKit, experiment: FrictionExperiment) -> Any:
        """Return the ``friction_levels`` JointState of a completed experiment."""
        return messages.friction_levels_to_msg(
            kit, stamp_s=experiment.end_time_s, joint=self.joint,
            speeds_rad_s=experiment.speeds_rad_s, frictions=experiment.frictions)


def explain_no_experiment(*, service: FrictionExperimentService,
                          reader_rejections: Mapping[str, int], seen: bool = True,
                          joints_seen: Optional[list[str]] = None,
                          topic: str = '/joint_states') -> str:
    """Return one sentence on why a recording of the joint gave no friction experiment.

    Checked in order: a joint name that is in no message (the names seen are listed), no
    usable sample of the joint, no motion (motor speed never above the standstill speed), no
    constant-speed plateau (every pass too short), passes found but never paired
    forward/backward over a common window, and levels whose speeds match none of the
    configured experiment speeds (the recorded speeds are listed).
    """
    config = service.segmenter_config
    joint = service.joint
    if not seen and joints_seen is None:
        return f'joint {joint!r} is in no message on {topic}'
    if not seen:
        names = list(joints_seen)
        shown = ', '.join(names[:12]) + (', ...' if len(names) > 12 else '')
        return f'joint {joint!r} is in no message on {topic} (joints seen: {shown or "none"})'
    if service.messages == 0:
        reasons = ', '.join(f'{k} {v}' for k, v in sorted(reader_rejections.items()))
        return f'no usable sample of joint {joint!r} ({reasons or "none"})'
    fastest = service.fastest_speed_rad_s
    if not fastest > config.standstill_speed_rad_s:
        return (f'joint {joint!r} never moves: its motor speed stays at or below '
                f'{fastest:.3g} rad/s (standstill {config.standstill_speed_rad_s:g} rad/s at '
                f'gear ratio {config.gear_ratio:g}); check the joint name and the gear ratio')
    rejections = service.all_rejections()
    if not service.levels:
        if rejections.get('pass_unpaired', 0) or rejections.get('pass_no_common_window', 0):
            return (f'joint {joint!r} has {service.passes} constant-speed passes, but none '
                    f'was paired with a pass the other way over a common position window '
                    f'(unpaired {rejections.get("pass_unpaired", 0)}, no common window '
                    f'{rejections.get("pass_no_common_window", 0)}): eq. (3) needs back-and-'
                    f'forth moves at one speed')
        return (f'joint {joint!r} moves (up to {fastest:.3g} rad/s motor side) but has no '
                f'constant-speed plateau of {config.min_duration_s:g} s or more '
                f'({rejections.get("pass_too_short", 0)} passes too short)')
    found = sorted(service.levels_per_speed())
    shown = ', '.join(f'{v:g}' for v in found[:12]) + (', ...' if len(found) > 12 else '')
    if not service.experiment_speeds_rad_s:
        return (f'{len(service.levels)} friction levels of joint {joint!r} at {shown} rad/s '
                f'formed no experiment')
    configured = ', '.join(f'{v:g}' for v in service.experiment_speeds_rad_s)
    return (f'{len(service.levels)} friction levels of joint {joint!r} at {shown} rad/s, but '
            f'none formed an experiment of the configured speeds [{configured}] rad/s '
            f'(tolerance {service.speed_tolerance_rad_s:g} rad/s): set '
            f'experiment_speeds_rad_s in --config to the recorded speeds, or leave it unset '
            f'to take the speeds found in the recording')
