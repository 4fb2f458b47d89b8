"""
The fleet at a glance: one row per robot and joint from the history, worst first.

Order (the maintenance team's triage): the unacknowledged latched alarms first; then the
acknowledged ones (someone took the alarm on: the views name who and the planned maintenance
date); then the joints that cannot be judged (an invalid latest estimate); then the forecast
crossing of the wear threshold soonest (in experiments); then the highest upper bound of the
95 % interval of w.  An acknowledged alarm is *re-escalated* (ordered as unacknowledged again,
and notified again) when its wear rises :data:`DEFAULT_REESCALATION_MARGIN` wear units (or the
margin given) past its value at the acknowledgement (the trend when both are known, else w-hat),
or when its planned maintenance date has passed (UTC).  A joint is ``stale`` when it has had no
experiment for longer than :data:`STALE_FACTOR` times its usual interval (the median of its
recent intervals, :attr:`FleetRow.usual_interval_s`, so that an outage does not stretch it),
counted up to ``now`` from its latest experiment or its last reset, whichever is later.  The
crossing gets a date when the joint's experiment rate is known (two experiments or more); a
date that has passed without an alarm is ``crossing_overdue`` ("overdue since <date>").
After a reset the row is the joint's new life (``life_started_s``).  Each row's ``state`` is
the first of :data:`~robot_wear_monitor.fleet.states.STATES` that applies.
Each row carries the ``threshold`` and ``warning_level`` its latest estimate was judged by
(stored with it; a row of an older history gets the parameter set's, ``threshold_assumed``:
see :mod:`robot_wear_monitor.fleet.thresholds`).
"""

from __future__ import annotations

from dataclasses import dataclass
import datetime
import math
from typing import Any, Iterable, Optional, Sequence

from robot_wear_monitor.csv_cells import csv_text
from robot_wear_monitor.fleet.notify_settings import (
    DEFAULT_REESCALATION_MARGIN as NOTIFY_REESCALATION_MARGIN)
from robot_wear_monitor.fleet.states import (crossing_overdue, DAY_S,
                                             DEFAULT_FORECAST_HORIZON_DAYS, joint_state)
from robot_wear_monitor.fleet.thresholds import judged_levels, ParameterSets, threshold_words
from robot_wear_monitor.history import FleetRow
from robot_wear_monitor.history.fleet_index import STALE_FACTOR  # noqa: F401 - its name here
from robot_wear_monitor.history.recent import RECENT_INTERVALS
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.text import iso_time, shown_time

#: An acknowledged alarm is re-escalated when its wear rises this much past its value at the
#: acknowledgement [wear units, w 0..100]: the notification configuration's declared default.
DEFAULT_REESCALATION_MARGIN = NOTIFY_REESCALATION_MARGIN


@dataclass(frozen=True)
class FleetView:
    """
    One row of the fleet view: a joint's latest state and what it means for maintenance.

    ``state``: the history's latest state of the joint (:class:`FleetRow`); ``stale``: no
    experiment for longer than :data:`STALE_FACTOR` usual intervals; ``crossing_time_s``: the
    forecast crossing as a time [s since the epoch], None when the rate or the crossing is
    unknown; ``threshold`` and ``warning_level``: those the latest estimate was judged by [w]
    (stored with it); ``threshold_assumed``: the history stores none for the row (an older
    history), they are the parameter set's.
    """

    state: FleetRow
    stale: bool
    crossing_time_s: Optional[float]
    #: why an acknowledged alarm is back on top ('' when it is not): see the module's text
    reescalated: str = ''
    threshold: float = math.nan
    warning_level: float = math.nan
    #: the joint's state: one of :data:`~robot_wear_monitor.fleet.states.STATES`
    condition: str = 'ok'
    #: the forecast crossing's date has passed without an alarm (no experiment since)
    crossing_overdue: bool = False
    threshold_assumed: bool = False

    def rank_key(self) -> tuple[int, float, float, str, str]:
        """Return the sort key, worst first (:meth:`FleetRow.rank_key`, re-escalation too)."""
        return self.state.rank_key(reescalated=bool(self.reescalated))

    def as_json(self) -> dict[str, Any]:
        """Return the row as a JSON-ready dict (non-finite numbers as null)."""
        s = self.state
        return {
            'robot': s.robot, 'joint': s.joint, 'wear': finite_or_none(s.wear),
            'wear_low': finite_or_none(s.wear_low), 'wear_high': finite_or_none(s.wear_high),
            'trend_wear': finite_or_none(s.trend_wear),
            'trend_low': finite_or_none(s.trend_low),
            'trend_high': finite_or_none(s.trend_high), 'alarm': bool(s.alarm),
            'alarm_since_s': finite_or_none(s.alarm_since_stamp_s),
            'experiments': int(s.experiments), 'last_stamp_s': finite_or_none(s.last_stamp_s),
            'crossing_experiments': finite_or_none(s.crossing_experiments),
            'crossing_time_s': self.crossing_time_s,
            'crossing_overdue': self.crossing_overdue,
            'usual_interval_s': finite_or_none(s.usual_interval_s),
            'usual_interval_basis': interval_basis(s),
            'stale': self.stale, 'status_level': int(s.status_level),
            'valid': not s.invalid_reason, 'invalid_reason': s.invalid_reason or None,
            'acknowledged': bool(s.acknowledged), 'acknowledged_by': s.acknowledged_by or None,
            'acknowledged_time_s': finite_or_none(s.acknowledged_wall_time_s),
            'edited_by': getattr(s, 'edited_by', '') or None,
            'planned_maintenance': s.planned_maintenance or None,
            'reescalated': bool(self.reescalated), 'reescalated_reason': self.reescalated or None,
            'life_started_s': finite_or_none(s.life_started_s),
            'reset_by': s.reset_by or None if math.isfinite(s.life_started_s) else None,
            'reset_reason': s.reset_reason or None if math.isfinite(s.life_started_s) else None,
            'state': self.condition,
            'threshold': finite_or_none(self.threshold),
            'warning_level': finite_or_none(self.warning_level),
            'threshold_assumed': self.threshold_assumed,
        }


def interval_basis(state: FleetRow) -> Optional[str]:
    """Return how the usual interval was found, in words (None when it is not known)."""
    if not math.isfinite(state.usual_interval_s):
        return None
    if len(state.recent_stamps) >= 2:
        return (f'median of the last {len(state.recent_stamps) - 1} intervals (at most '
                f'{RECENT_INTERVALS}): an outage does not stretch it')
    return 'mean of all intervals'


def reescalation(state: FleetRow, *, now_s: float, margin: float) -> str:
    """
    Return why the acknowledged alarm of ``state`` is back on top ('' when it is not).

    The wear rose ``margin`` wear units past its value at the acknowledgement (the trend when
    it is known then and now, else w-hat), or the planned maintenance date (UTC) has passed.
    """
    if not (state.alarm and state.acknowledged):
        return ''
    reasons = []
    trend_known = math.isfinite(state.acknowledged_trend_wear) and math.isfinite(
        state.trend_wear)
    then, now, what = ((state.acknowledged_trend_wear, state.trend_wear, 'trend w')
                       if trend_known else (state.acknowledged_wear, state.wear, 'w-hat'))
    if math.isfinite(then) and math.isfinite(now) and now >= then + margin:
        reasons.append(f'{what} rose to {now:.1f}, {now - then:.1f} past the {then:.1f} at the '
                       f'acknowledgement (margin {margin:g})')
    if state.planned_maintenance:
        today = datetime.datetime.fromtimestamp(now_s, tz=datetime.timezone.utc).date()
        try:
            planned = datetime.date.fromisoformat(state.planned_maintenance)
        except ValueError:
            planned = None
        if planned is not None and planned < today:
            reasons.append(f'the planned maintenance date {planned.isoformat()} has passed')
    return '; '.join(reasons)


def fleet_view(states: Iterable[FleetRow], *, now_s: float,
               reescalation_margin: float = DEFAULT_REESCALATION_MARGIN,
               forecast_horizon_s: float = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S,
               parameter_sets: Optional[ParameterSets] = None) -> list[FleetView]:
    """
    Return the fleet rows worst first (the triage order of the module's text), at ``now_s``.

    ``now_s``: the time [s since the epoch] staleness, planned dates and crossing dates are
    judged at; ``reescalation_margin``: the rise of the wear past its value at the
    acknowledgement that re-escalates an acknowledged alarm [wear units];
    ``forecast_horizon_s``: a crossing this soon makes a ``warning`` [s] (the notifications'
    horizon); ``parameter_sets``: where a row without a stored threshold finds its parameter
    set's (None: the packaged sets).
    """
    rows = []
    assumed_levels: dict[str, tuple[float, float, bool]] = {}  # per parameter set
    for state in states:
        if math.isfinite(state.threshold) and math.isfinite(state.warning_level):
            threshold, warning, assumed = state.threshold, state.warning_level, False
        else:
            found = None if math.isfinite(state.threshold) else assumed_levels.get(
                state.parameter_set)
            threshold, warning, assumed = found or judged_levels(state, parameter_sets)
            if assumed:
                assumed_levels[state.parameter_set] = (threshold, warning, assumed)
        interval = state.usual_interval_s
        known = math.isfinite(interval) and interval > 0
        since = state.last_stamp_s
        if math.isfinite(state.life_started_s):
            since = max(since, state.life_started_s)  # a new life: counted from the reset
        stale = bool(known and now_s - since > STALE_FACTOR * interval)
        crossing_time = None
        if known and math.isfinite(state.crossing_experiments):
            crossing_time = state.last_stamp_s + state.crossing_experiments * interval
        reescalated = reescalation(state, now_s=now_s, margin=reescalation_margin)
        rows.append(FleetView(
            state=state, stale=stale, crossing_time_s=crossing_time, reescalated=reescalated,
            condition=joint_state(state, stale=stale, reescalated=bool(reescalated),
                                  crossing_time_s=crossing_time, now_s=now_s,
                                  warning=warning, horizon_s=forecast_horizon_s),
            crossing_overdue=crossing_overdue(state, crossing_time_s=crossing_time,
                                              now_s=now_s),
            threshold=threshold, warning_level=warning, threshold_assumed=assumed))
    return sorted(rows, key=FleetView.rank_key)


def crossing_text(row: FleetView, *, local: bool = False,
                  zone: Optional[datetime.tzinfo] = None) -> str:
    """
    Return the forecast crossing in words: experiments to go and the date it falls on.

    The date is the day in ``zone`` (the plant's, :func:`~robot_wear_monitor.text.shown_time`;
    None: UTC, or the machine's with ``local``).
    """
    crossing = row.state.crossing_experiments
    if row.state.awaiting_first_experiment:
        return 'no forecast yet (new life)'
    if not math.isfinite(crossing):
        return 'not within the forecast horizon'
    if crossing <= 0:
        return 'crossed (trend past the threshold)'
    if row.crossing_overdue and row.crossing_time_s is not None:
        return f'overdue since {_day(row.crossing_time_s, local, zone)}'
    text = f'in {plural(round(crossing), "experiment")}'
    if row.crossing_time_s is not None:
        text += f' (~{_day(row.crossing_time_s, local, zone)})'
    return text


def _day(stamp_s: float, local: bool, zone: Optional[datetime.tzinfo]) -> str:
    return shown_time(stamp_s, local=local, zone=zone, date_only=True)


def plural(count: int, noun: str) -> str:
    """Return '1 robot', '2 robots' (``count`` and ``noun``, with an s unless one)."""
    return f'{count} {noun}' if count == 1 else f'{count} {noun}s'


FLEET_COLUMNS = ('robot', 'joint', 'wear', 'wear_low', 'wear_high', 'trend_wear', 'alarm',
                 'alarm_since', 'experiments', 'last_experiment', 'crossing_experiments',
                 'crossing_date', 'stale', 'valid', 'acknowledged_by', 'planned_maintenance',
                 'reescalated', 'life_started', 'threshold', 'threshold_assumed', 'state',
                 'crossing_overdue', 'reset_by', 'reset_reason')


def threshold_text(row: FleetView) -> str:
    """Return the row's threshold as people read it: '30', or '35 (assumed)' when not stored."""
    return threshold_words(row.threshold, assumed=row.threshold_assumed)


def fleet_csv_rows(rows: Sequence[FleetView], *, local: bool = False,
                   terminal: bool = False) -> list[list[str]]:
    """
    Return the fleet as CSV rows (header first): numbers plain, times ISO 8601.

    Text cells (robot, joint, user, planned maintenance) are spreadsheet-safe, their control
    characters escaped for a ``terminal`` (:func:`~robot_wear_monitor.csv_cells.csv_text`).
    """
    def number(value: Optional[float]) -> str:
        return '' if value is None or not math.isfinite(value) else f'{value:.6g}'

    def text(value: str) -> str:
        return csv_text(value, terminal=terminal)

    out = [list(FLEET_COLUMNS)]
    for row in rows:
        s = row.state
        out.append([text(s.robot), text(s.joint), number(s.wear),
                    number(s.wear_low), number(s.wear_high),
                    number(s.trend_wear), 'latched' if s.alarm else 'no',
                    iso_time(s.alarm_since_stamp_s, local=local) if s.alarm else '',
                    str(s.experiments), iso_time(s.last_stamp_s, local=local),
                    number(s.crossing_experiments),
                    iso_time(row.crossing_time_s, local=local)
                    if row.crossing_time_s is not None else '',
                    'yes' if row.stale else 'no', 'no' if s.invalid_reason else 'yes',
                    text(s.acknowledged_by or '') if s.acknowledged else '',
                    text(s.planned_maintenance or '') if s.acknowledged else '',
                    text(row.reescalated),
                    iso_time(s.life_started_s, local=local)
                    if math.isfinite(s.life_started_s) else '', number(row.threshold),
                    'yes' if row.threshold_assumed else 'no', row.condition,
                    'yes' if row.crossing_overdue else 'no',
                    text(s.reset_by) if math.isfinite(s.life_started_s) else '',
                    text(s.reset_reason) if math.isfinite(s.life_started_s) else ''])
    return out
