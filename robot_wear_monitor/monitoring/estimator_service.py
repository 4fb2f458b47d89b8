"""
The wear estimator service: one estimate (T, w) per friction experiment, alarm and history.

:class:`WearEstimatorService` is what the ``wear_estimator_node`` (one per joint) and the bag
replay drive: it reads a ``friction_levels`` message (or a completed experiment), estimates
(T, w) with :func:`~robot_wear_monitor.estimation.estimator.estimate_wear`, their 95 %
profile-likelihood intervals and the wear trend (:mod:`robot_wear_monitor.estimation.trend`),
updates the latched alarm (:class:`~robot_wear_monitor.estimation.alarm.AlarmLatch`), stores
the estimate in the SQLite :class:`~robot_wear_monitor.history.WearHistory` (from
which a restarted service restores its trend and latched alarm) and builds the diagnostics
status and the node's output messages.  A reset (``~/reset_alarm``, after maintenance) clears
the alarm and its evidence and starts a new trend segment.  The configuration comes from the
node parameters (:class:`EstimatorConfig`); the result of one experiment is a
:class:`WearUpdate`.
"""

from __future__ import annotations

from collections import Counter, deque
import math
from typing import Any, Callable, Optional, Sequence, TYPE_CHECKING

import numpy as np

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import AlarmLatch
from robot_wear_monitor.estimation.plausibility import check_levels, Plausibility, VALID
from robot_wear_monitor.estimation.wear_report import meaningful_std
from robot_wear_monitor.experiment.levels import FrictionExperiment
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, LatchMoved, WearHistory
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import ParameterSet
from robot_wear_monitor.monitoring.diagnostics import (DiagnosticReport, forecast_text,
                                                       interval_text, trend_values)
from robot_wear_monitor.monitoring.prepared import Prepared, PreparedEstimates
from robot_wear_monitor.monitoring.topics import (ALARM_TOPIC, DIAGNOSTICS_TOPIC,
                                                  TEMPERATURE_TOPIC, TREND_TOPIC, WEAR_TOPIC)
# EstimatorConfig and WearUpdate live in wear_update; imported from here by existing callers
from robot_wear_monitor.monitoring.wear_update import EstimatorConfig, WearUpdate
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.recordings.messages import (DIAGNOSTIC_ERROR, DIAGNOSTIC_OK,
                                                    DIAGNOSTIC_WARN, FrictionLevelsMessage,
                                                    MessageError, MessageKit)
from robot_wear_monitor.text import fmt_number, STD_NOT_REPORTED

if TYPE_CHECKING:
    from robot_wear_monitor.estimation.intervals import WearInterval
    from robot_wear_monitor.estimation.trend import TrendEstimate, WearTrend
    from robot_wear_monitor.estimation.wear_estimates import WearEstimate, WearEstimates


__all__ = ['EstimateFunction', 'EstimatorConfig', 'WearEstimatorService', 'WearUpdate']

#: ``f(speeds, frictions, *, params) -> WearEstimate``: the estimator the service calls.
EstimateFunction = Callable[..., 'WearEstimate']


def _default_estimate(speeds_rad_s: np.ndarray, frictions: np.ndarray, *,
                      params: ParameterSet) -> WearEstimate:
    return _estimate_batch(speeds_rad_s, frictions, params=params)[0]


def _estimate_batch(speeds_rad_s: np.ndarray, frictions: np.ndarray, *,
                    params: ParameterSet) -> WearEstimates:
    # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
    from robot_wear_monitor.estimation.estimator import estimate_wear
    return estimate_wear(speeds_rad_s, frictions, params=params)


class WearEstimatorService:
    """
    Estimate (T, w) per experiment, latch the alarm, report diagnostics, keep the history.

    :param config: the estimator configuration.
    :param history: the SQLite history (``WearHistory(':memory:')`` when None); the trend, the
        latched alarm and the evidence are restored from it.
    :param estimate: ``f(speeds, frictions, *, params) -> WearEstimate`` (the core estimator by
        default; tests may pass a fake).
    :param trend_length: estimates kept in memory for the trend (all stored ones are restored
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
        #: the id of the last raise or reset this estimator knows of (see follow_history_reset)
        self._latch_event_id = (restored.last_event.id if restored.last_event is not None
                                else None)
        self.restored_estimates = len(restored.records)
        self.experiments = len(restored.records)
        self.rejections: Counter[str] = Counter()
        #: estimates of this run the plausibility checks refused (the wear not judged)
        self.invalid_estimates = 0
        self.last_update: Optional[WearUpdate] = None
        self.last_rejection = ''
        #: estimates made ahead by :meth:`prepare` (a replay's experiments at hand)
        self.prepared = PreparedEstimates()

    def _new_trend(self) -> WearTrend:
        # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
        from robot_wear_monitor.estimation.trend import TrendConfig, WearTrend
        return WearTrend(TrendConfig(threshold=self.config.alarm.threshold))

    def _likelihood_rows(self, speeds: np.ndarray, frictions: np.ndarray) -> np.ndarray:
        """Return the profile log-likelihood rows of w on the trend's grid, (B, G)."""
        # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
        from robot_wear_monitor.estimation.intervals import profile_log_likelihood
        return profile_log_likelihood(speeds, frictions, params=self.config.params,
                                      wear_grid=self.wear_trend.wear_grid)

    def _rebuild_trend(self, records: Sequence[HistoryRecord]) -> WearTrend:
        """
        Rebuild the trend filter from the stored estimates and maintenance resets.

        The filter's state is a pure function of its rows, so replaying the stored friction
        levels (grouped by speed set, one batched likelihood call per set) and the ``reset``
        events in their order gives the trend the service had before the restart.
        """
        self.wear_trend = self._new_trend()
        if not records:
            return self.wear_trend
        rows: list[Optional[np.ndarray]] = [None] * len(records)
        groups: dict[tuple[float, ...], list[int]] = {}
        for i, record in enumerate(records):
            if record.valid:  # an invalid estimate was never evidence
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
        """
        Run the estimator once on model friction levels (nothing is stored or published).

        The first estimate of a process pays for imports and caches (about 0.5 s here), and the
        first interval of a design for the calibration of its cutoffs (about 2 s, see
        :func:`~robot_wear_monitor.estimation.intervals.calibrate_cutoffs`); a node pays both at
        start for its configured speeds, not at its first experiment while /joint_states keeps
        arriving.
        """
        # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
        from robot_wear_monitor.estimation.intervals import calibrate_cutoffs
        configured = self.config.experiment_speeds_rad_s
        speeds = np.asarray(configured or (30.0, 40.0), dtype=float)
        levels = np.asarray(friction(speeds, 0.5, 40.0, 10.0, self.config.params.model),
                            dtype=float)
        self._estimate(speeds, levels, params=self.config.params)
        if configured and self.config.params.estimates_wear:
            calibrate_cutoffs(speeds, params=self.config.params)

    def prepare(self, levels: Sequence[FrictionLevelsMessage]) -> int:
        """
        Estimate several experiments' levels together, ahead of their one-by-one handling.

        :meth:`process_levels` then takes each one's estimate instead of computing it (the
        same numbers); the trend, alarm and history still advance one experiment at a time,
        in order.  Only the default estimator prepares; returns how many were prepared.
        """
        if self._estimate is not _default_estimate or not self.config.params.estimates_wear:
            return 0  # (a set without a wear model: T-hat only, estimated one by one)
        return self.prepared.prepare(levels, joint=self.config.joint, params=self.config.params,
                                     trend_grid=self.wear_trend.wear_grid)

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
        """
        Estimate, update the alarm, store the history; None if the estimate fails.

        A reset stored in the history by someone else (the dashboard) is taken over before the
        experiment (:meth:`follow_history_reset`); one stored while the experiment is estimated
        makes the store refuse the old life's row (:class:`LatchMoved`), and the experiment is
        estimated again in the new life: the rows stored after a reset are the new life's.
        """
        counts = (self.experiments, self.invalid_estimates)
        try:
            return self._process_levels(levels)
        except LatchMoved:
            self.experiments, self.invalid_estimates = counts
            return self._process_levels(levels)  # follows the reset first

    def _process_levels(self, levels: FrictionLevelsMessage) -> Optional[WearUpdate]:
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
        self.follow_history_reset()
        known = self.history.find_estimate(joint=self.config.joint, stamp_s=levels.stamp_s)
        if known is not None:
            # the same experiment again (a re-run of a recording into the same history, a
            # replayed message): its estimate is stored and in the trend; never twice
            self.reject('already_in_history', f'the experiment ending at {levels.stamp_s:.6f} '
                                              f's is estimate {known} of the history; skipped')
            return None
        batch = None
        prepared = self.prepared.take(levels)  # what a replay computed ahead, if anything
        try:
            if self._estimate is _default_estimate:  # keep the batch for the interval
                batch = (prepared.estimates if prepared is not None
                         else _estimate_batch(speeds, frictions, params=self.config.params))
                estimate = batch[0]
            else:
                estimate = self._estimate(speeds, frictions, params=self.config.params)
        except (InputError, ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            self.reject('estimation_failed', str(error).splitlines()[0] if str(error) else '')
            return None
        wear = float(estimate.wear)
        wear_std = float(estimate.wear_std)
        plausibility = check_levels(
            speeds_rad_s=speeds, frictions=frictions, params=self.config.params,
            estimate=estimate, expected_speeds_rad_s=self.config.experiment_speeds_rad_s,
            speed_tolerance_rad_s=self.config.speed_tolerance_rad_s,
            invalid_p_value=self.config.invalid_fit_p_value)
        interval = trend = None
        raised = False
        wear_determined = self.config.params.estimates_wear
        if not wear_determined:  # no wear model: T-hat and its interval, no evidence of wear
            if plausibility.valid:
                interval = self._temperature_interval(speeds, frictions)
            else:
                self.invalid_estimates += 1
        elif plausibility.valid:
            interval, trend = self._interval_and_trend(speeds, frictions,
                                                       stamp_s=levels.stamp_s, estimates=batch,
                                                       prepared=prepared)
            raised = self.latch.update(
                wear=wear, wear_std=wear_std,
                probability_above_threshold=(math.nan if trend is None
                                             else trend.probability_above_threshold))
        else:  # not evidence for or against the alarm: the latch and the trend stay
            self.invalid_estimates += 1
        self.experiments += 1
        update_std = meaningful_std(
            std=wear_std, value=wear,
            low=math.nan if interval is None else interval.wear_low,
            high=math.nan if interval is None else interval.wear_high,
            open_above=bool(interval is not None and interval.wear_high_at_grid_end))
        status = self._status(estimate=estimate, speeds=levels.speeds_rad_s,
                              interval=interval, trend=trend, wear_std=update_std,
                              plausibility=plausibility)
        invalid_reason = '' if plausibility.valid else plausibility.text()
        if not wear_determined:
            # the history's wear column holds a number: 0 here, never read as wear (the
            # reason marks the row as not judged, as the dashboard, fleet and trend read it)
            wear = 0.0
            invalid_reason = '; '.join(filter(None, (
                f'wear not determined: parameter set {self.config.params.name} has no wear '
                'model (identify --no-wear-model); temperature only', invalid_reason)))
        record = HistoryRecord(
            joint=self.config.joint, stamp_s=levels.stamp_s, speeds_rad_s=levels.speeds_rad_s,
            frictions=levels.frictions, temperature_degc=float(estimate.temperature_degc),
            temperature_std_degc=float(estimate.temperature_std_degc), wear=wear,
            wear_std=wear_std, chi2=float(estimate.chi2), dof=int(estimate.dof),
            p_value=float(estimate.p_value),
            temperature_at_bound=bool(estimate.temperature_at_bound),
            wear_at_bound=bool(estimate.wear_at_bound), alarm_active=self.latch.active,
            alarm_evidence=self.latch.evidence, status_level=status.level,
            parameter_set=self.config.params.name, **_interval_columns(interval, trend),
            invalid_reason=invalid_reason, threshold=self.config.alarm.threshold,
            warning_level=self.config.wear_warning)
        events = [AlarmEvent(joint=self.config.joint, stamp_s=levels.stamp_s, event='raised',
                             wear=wear, note=self._raise_note(wear, trend))] if raised else []
        record_id = self.history.append(record, events=events,
                                        latch_id=self._latch_event_id)
        if record_id is None:  # another writer stored this experiment meanwhile
            self.reject('already_in_history', f'the experiment ending at {levels.stamp_s:.6f} '
                                              f's was stored by another writer; skipped')
            return None
        self.trend.append(HistoryRecord(**{**record.__dict__, 'id': record_id}))
        self.last_update = WearUpdate(
            index=self.experiments, stamp_s=levels.stamp_s, joint=self.config.joint,
            speeds_rad_s=levels.speeds_rad_s, frictions=levels.frictions, estimate=estimate,
            alarm_active=self.latch.active, alarm_raised=raised,
            alarm_evidence=self.latch.evidence, status=status, interval=interval, trend=trend,
            plausibility=plausibility, wear_determined=wear_determined)
        return self.last_update

    def _temperature_interval(self, speeds: np.ndarray, frictions: np.ndarray
                              ) -> Optional[WearInterval]:
        """Return the 95 % interval of T of a set without a wear model (w's ends NaN)."""
        # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
        from robot_wear_monitor.estimation.intervals import WearInterval
        from robot_wear_monitor.estimation.temperature_only import estimate_temperature
        try:
            t_only = estimate_temperature(speeds, frictions[None, :], self.config.params)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            self.reject('interval_failed', str(error).splitlines()[0] if str(error) else '')
            return None
        return WearInterval(wear_low=math.nan, wear_high=math.nan,
                            temperature_low=float(t_only.temperature_low[0]),
                            temperature_high=float(t_only.temperature_high[0]),
                            wear_high_at_grid_end=False, level=0.95)

    def _raise_note(self, wear: float, trend: Optional[TrendEstimate]) -> str:
        """Say which evidence raised the alarm (the history's ``alarm_events.note``)."""
        policy = self.config.alarm
        if policy.rule == 'trend' and trend is not None:
            return (f'trend P(w >= {fmt_number(policy.threshold)}) = '
                    f'{fmt_number(trend.probability_above_threshold, 3)} >= '
                    f'{fmt_number(policy.probability, 3)}; trend w {fmt_number(trend.wear)} '
                    f'[{fmt_number(trend.wear_low)}, {fmt_number(trend.wear_high)}], '
                    f'w-hat {fmt_number(wear)}')
        return (f'w-hat {fmt_number(wear)} >= {fmt_number(policy.threshold)}, evidence '
                f'{fmt_number(self.latch.evidence, 3)}')

    def _interval_and_trend(self, speeds: np.ndarray, frictions: np.ndarray, *,
                            stamp_s: float, estimates: Optional[WearEstimates] = None,
                            prepared: Optional[Prepared] = None
                            ) -> tuple[Optional[WearInterval], Optional[TrendEstimate]]:
        """
        Return the 95 % intervals of (w, T) and the updated trend (None where they fail).

        ``estimates``: the estimator's batch result for these levels, if the default estimator
        made it (the interval needs the ML estimate; it is not computed twice).  ``prepared``:
        the interval and trend row computed ahead (:meth:`prepare`), used where present.
        """
        # deferred import: start-up time (estimation: segment loads this module, estimates nothing)
        from robot_wear_monitor.estimation.intervals import wear_intervals
        interval = trend = None
        try:
            interval = (prepared.intervals if prepared is not None
                        and prepared.intervals is not None and estimates is prepared.estimates
                        else wear_intervals(speeds, frictions, params=self.config.params,
                                            estimates=estimates))[0]
        except (InputError, ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            self.reject('interval_failed', str(error).splitlines()[0] if str(error) else '')
        try:
            row = (prepared.trend_row_on(self.wear_trend.wear_grid) if prepared is not None
                   else None)
            if row is None:
                row = self._likelihood_rows(speeds, frictions)
            row = row[0]
            trend = self.wear_trend.update(time_s=stamp_s, log_likelihood=row)
        except (InputError, ValueError, FloatingPointError) as error:
            self.reject('trend_failed', str(error).splitlines()[0] if str(error) else '')
        return interval, trend

    def reset_alarm(self, *, stamp_s: float, note: str = 'reset after maintenance'
                    ) -> tuple[bool, str]:
        """
        Clear the latched alarm (``~/reset_alarm``); return (success, message).

        A reset follows maintenance: the wear trend starts a new segment from the new-joint prior.
        """
        was_active = self.latch.reset()
        self._reset_trend()
        last_id = self.trend[-1].id if self.trend else None
        stored = self.history.record_event(AlarmEvent(joint=self.config.joint, stamp_s=stamp_s,
                                                      event='reset', wear=None, note=note,
                                                      estimate_id=last_id, source='ros'))
        self._latch_event_id = stored.id
        if was_active:
            return True, 'wear alarm cleared; evidence and trend reset'
        return True, 'no wear alarm was active; evidence and trend reset'

    def follow_history_reset(self) -> Optional[AlarmEvent]:
        """
        Take over a reset stored in the history by someone else; return it (else None).

        The dashboard resets an alarm in the history (``WearHistory.reset_alarm``) while this
        estimator runs: it clears the latch and the evidence and restarts the trend exactly as
        :meth:`reset_alarm` does (and as a restart would restore it), without storing a second
        event.  Called before each experiment and by the node's periodic timer (one indexed
        query).
        """
        event = self.history.latch_event(joint=self.config.joint)
        if event is None or event.id == self._latch_event_id:
            return None
        self._latch_event_id = event.id
        if event.event != 'reset':
            return None  # this estimator's own raise
        self.latch.reset()
        self._reset_trend()
        return event

    # ----------------------------------------------------------------- diagnostics

    def _status(self, *, estimate: WearEstimate, speeds: Sequence[float],
                interval: Optional[WearInterval] = None,
                trend: Optional[TrendEstimate] = None,
                wear_std: float = math.nan,
                plausibility: Plausibility = VALID) -> DiagnosticReport:
        config = self.config
        wear = float(estimate.wear)
        p_value = float(estimate.p_value)
        summary = (f'w = {fmt_number(wear, 3)}{interval_text(interval)}, '
                   f'T = {fmt_number(estimate.temperature_degc, 3)} degC')
        if not config.params.estimates_wear:
            summary = (f'T = {fmt_number(estimate.temperature_degc, 3)} degC'
                       + ('' if interval is None else
                          f' (95 %: {fmt_number(interval.temperature_low, 3)}-'
                          f'{fmt_number(interval.temperature_high, 3)})')
                       + '; wear not determined (the parameter set has no wear model)')
        if trend is not None:
            summary += (f'; trend {fmt_number(trend.wear, 3)} ({fmt_number(trend.wear_low, 3)}-'
                        f'{fmt_number(trend.wear_high, 3)}), P(w >= '
                        f'{fmt_number(config.alarm.threshold)}) '
                        f'{trend.probability_above_threshold:.0%}{forecast_text(trend)}')
        warnings = []
        if wear >= config.wear_warning and not self.latch.active:
            warnings.append(f'wear near the alarm level {fmt_number(config.alarm.threshold)}')
        if math.isfinite(p_value) and p_value < config.min_fit_p_value:
            warnings.append(f'the friction levels do not fit the model (p = {p_value:.2g})')
        if bool(estimate.temperature_at_bound):
            warnings.append('temperature estimate on its bound')
        if not plausibility.valid:
            # the levels are not what the parameter set speaks about: w-hat is no judgement
            level = DIAGNOSTIC_ERROR
            message = (f'CANNOT JUDGE THE WEAR ({plausibility.detail()}); the estimate '
                       f'w = {fmt_number(wear, 3)} is not used' if config.params.estimates_wear
                       else f'CANNOT JUDGE THE LEVELS ({plausibility.detail()}); the estimate '
                       f'T = {fmt_number(estimate.temperature_degc, 3)} degC is not used')
            if self.latch.active:
                message = 'WEAR ALARM (latched, reset after maintenance); ' + message
        elif self.latch.active:
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
            ('wear', fmt_number(wear, 6, missing='not determined')
             if not config.params.estimates_wear else fmt_number(wear, 6)),
            ('wear_std', fmt_number(wear_std, 6, missing=STD_NOT_REPORTED)),
            ('wear_low', fmt_number(math.nan if interval is None else interval.wear_low, 6)),
            ('wear_high', fmt_number(math.nan if interval is None else interval.wear_high, 6)),
            ('temperature_degc', fmt_number(estimate.temperature_degc, 6)),
            ('temperature_std_degc', fmt_number(estimate.temperature_std_degc, 6)),
            ('temperature_low_degc',
             fmt_number(math.nan if interval is None else interval.temperature_low, 6)),
            ('temperature_high_degc',
             fmt_number(math.nan if interval is None else interval.temperature_high, 6)),
            ('speeds_rad_s', ','.join(fmt_number(v, 6) for v in speeds)),
            ('n_levels', str(int(estimate.n_levels))),
            ('fit_p_value', fmt_number(p_value, 4)), ('chi2', fmt_number(estimate.chi2, 4)),
            ('dof', str(int(estimate.dof))),
            ('temperature_at_bound', str(bool(estimate.temperature_at_bound)).lower()),
            ('wear_at_bound', str(bool(estimate.wear_at_bound)).lower()),
            ('alarm', str(self.latch.active).lower()),
            ('alarm_evidence', fmt_number(self.latch.evidence, 4)),
            ('alarm_rule', config.alarm.rule),
            ('wear_threshold', fmt_number(config.alarm.threshold)),
            ('wear_warning', fmt_number(config.wear_warning)),
            ('experiments', str(self.experiments)),
            ('parameter_set', config.params.name),
            ('valid', str(plausibility.valid).lower()),
        ]
        if not plausibility.valid:
            values += [('invalid_checks', ','.join(plausibility.failed)),
                       ('likely_cause', plausibility.likely_cause or 'unknown')]
        values += trend_values(trend)
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
                       ('alarm_evidence', fmt_number(self.latch.evidence, 4))]
            level = status.level
            message = status.message
            if not self.latch.active and level == DIAGNOSTIC_ERROR:
                level, message = DIAGNOSTIC_OK, 'wear alarm reset; waiting for the next experiment'
            return DiagnosticReport(level=level, message=message,
                                    values=tuple(values + self._rejection_values()))
        values = [('joint', self.config.joint), ('alarm', str(self.latch.active).lower()),
                  ('alarm_evidence', fmt_number(self.latch.evidence, 4)),
                  ('experiments', str(self.experiments))]
        if self.trend:
            last = self.trend[-1]
            values += [('wear', fmt_number(last.wear, 6)),
                       ('wear_std',
                        fmt_number(last.wear_std, 6, missing=STD_NOT_REPORTED)),
                       ('temperature_degc', fmt_number(last.temperature_degc, 6))]
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
        values = status.values
        if self.config.robot:
            values = (('robot', self.config.robot), *values)
        return messages.diagnostics_to_msg(
            kit, stamp_s=stamp_s, name=self.diagnostic_name(), hardware_id=self.hardware_id(),
            level=status.level, message=status.message, values=values)

    def hardware_id(self) -> str:
        """Return the DiagnosticStatus hardware_id: ``<robot_id>/<joint>``, or the joint alone."""
        return f'{self.config.robot}/{self.config.joint}' if self.config.robot \
            else self.config.joint


def _interval_columns(interval: Optional[WearInterval], trend: Optional[TrendEstimate]
                      ) -> dict[str, Any]:
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
