"""
The shapes of the dashboard's JSON API (pydantic models, documented at ``/openapi.json``).

The routes send what :mod:`robot_wear_monitor.dashboard.views` makes: ``/api/fleet`` and the
joint's route send that JSON as it is (with its ETag), ``/api/alarms`` and ``/api/me`` are
checked against their model.  Every model forbids keys it does not name, so a key added to a
view without its model fails the API's tests.  Numbers that are not finite are null.  Wear w:
0 new, 100 failure; temperatures degC; speeds motor side rad/s; frictions normalised; times
s since the epoch (UTC).
"""

from __future__ import annotations

from typing import Optional

from pydantic import BaseModel, ConfigDict, Field
from robot_wear_monitor.dashboard.views import FRICTION_EXPERIMENTS
from robot_wear_monitor.fleet.ranking import STALE_FACTOR
from robot_wear_monitor.fleet.states import STATES
from robot_wear_monitor.history import ALARM_EVENT_KINDS


class _Shape(BaseModel):
    """
    A JSON object of the API: exactly the keys named.

    A field named like a Python builtin has another name and the key as its alias (``id``).
    """

    model_config = ConfigDict(extra='forbid', protected_namespaces=())


class WearBar(_Shape):
    """The fleet row's wear bar: positions in % of its width (-1: not drawn)."""

    low: float = Field(description="the 95 % interval's lower end [% of the bar]")
    high: float = Field(description="the 95 % interval's upper end [% of the bar]")
    wear: float = Field(description='w-hat [% of the bar]; -1 when it cannot be judged')
    threshold: float = Field(description="the row's threshold [% of the bar]")
    scale_max: float = Field(description='the wear at the right end of the bar [w]: 1.5 x '
                                         'the threshold in every row')
    clipped: bool = Field(description='w-hat or the upper end is past the scale (drawn at '
                                      'the right end; the text gives the number)')


class RowTexts(_Shape):
    """The texts the fleet page shows in a row's cells."""

    wear: str
    trend: str
    crossing: str
    alarm: str
    last: str
    invalid: str
    threshold: str = Field(description="the row's threshold: '30', or '35 (assumed)' when the "
                                       "history stores none (the parameter set's)")
    life: str = Field(description="a reset joint's new life: 'reset <time> by <user> "
                                  "(<reason>): awaiting the first experiment' ('' when "
                                  'never reset)')


class FleetRowJson(_Shape):
    """One robot's joint in the fleet: the keys of ``fleet --json`` and what the page shows."""

    robot: str
    joint: str
    wear: Optional[float] = Field(description='w-hat of the latest experiment')
    wear_low: Optional[float] = Field(description='its 95 % interval, lower end')
    wear_high: Optional[float] = Field(description='its 95 % interval, upper end')
    trend_wear: Optional[float]
    trend_low: Optional[float]
    trend_high: Optional[float]
    alarm: bool = Field(description='the alarm is latched (acknowledged or not)')
    alarm_since_s: Optional[float] = Field(description="the latching experiment's stamp [s]")
    experiments: int
    last_stamp_s: Optional[float] = Field(description="the latest experiment's stamp [s]")
    crossing_experiments: Optional[float] = Field(
        description='experiments until the forecast crosses the threshold (median)')
    crossing_time_s: Optional[float] = Field(description='when, at the usual spacing [s]')
    crossing_overdue: bool = Field(description='the crossing date has passed without an alarm '
                                               '(no experiment since to confirm it): the page '
                                               "reads 'overdue since <date>'")
    usual_interval_s: Optional[float] = Field(description='the usual time between experiments '
                                                          '[s]: the median of the recent '
                                                          'intervals (an outage does not '
                                                          'stretch it)')
    usual_interval_basis: Optional[str] = Field(description='how usual_interval_s was found')
    stale: bool = Field(description=f'no experiment for {STALE_FACTOR:g} usual intervals')
    status_level: int
    valid: bool
    invalid_reason: Optional[str]
    acknowledged: bool
    acknowledged_by: Optional[str] = Field(description='who acknowledged first')
    acknowledged_time_s: Optional[float]
    edited_by: Optional[str] = Field(description='who edited the acknowledgement last (null: '
                                                 'not edited)')
    planned_maintenance: Optional[str] = Field(description='YYYY-MM-DD')
    reescalated: bool = Field(description='an acknowledged alarm back on top: its wear rose '
                                          'the margin past its value at the acknowledgement, '
                                          'or its planned maintenance date passed')
    reescalated_reason: Optional[str] = Field(description='why it is re-escalated')
    life_started_s: Optional[float] = Field(
        description="the last reset's moment [s] (null: never reset, or latched again); the "
                    'wear, trend, crossing and alarm fields are those of the new life')
    reset_by: Optional[str] = Field(description='who reset it (null: the ROS service)')
    reset_reason: Optional[str] = Field(description='why it was reset')
    state: str = Field(description='the first that applies of: ' + ', '.join(STATES),
                       json_schema_extra={'enum': list(STATES)})
    arrow: str = Field(description='the trend arrow: \u2191, \u2197, \u2192 or ?')
    threshold: Optional[float] = Field(
        description='the alarm threshold the latest estimate was judged by [w] (the node '
                    "parameter wear_threshold, stored with it; the parameter set's when "
                    'threshold_assumed)')
    warning_level: Optional[float] = Field(
        description='the warning level it was judged by [w] (wear_warning; the same rule)')
    threshold_assumed: bool = Field(
        description='the history stores no threshold for the row (an older history): '
                    "threshold and warning_level are the parameter set's, assumed")
    acknowledged_s: Optional[float] = Field(description='when acknowledged [s, wall clock]')
    acknowledged_at: str = Field(description='acknowledged_s as ISO 8601 UTC (- when not)')
    acknowledged_at_text: str = Field(description="acknowledged_s in the dashboard's "
                                                  'display_timezone, as the page shows it')
    parameter_set: str
    alarm_since: Optional[str] = Field(description='alarm_since_s as ISO 8601 UTC')
    last_experiment: str = Field(description='last_stamp_s as ISO 8601 UTC')
    crossing_date: Optional[str] = Field(description='crossing_time_s as YYYY-MM-DD (UTC)')
    crossing_days: Optional[float] = Field(
        description='the crossing in days after the latest experiment (crossing_experiments '
                    'x usual_interval_s); null without a crossing ahead or an interval')
    bar: WearBar
    url: str = Field(description="the joint's page")
    text: RowTexts


class FleetJson(_Shape):
    """The fleet worst first (the order of ``fleet``), the counts per state, the robots."""

    counts: dict[str, int] = Field(description='joints per state, of the whole fleet')
    joints: int = Field(description='joints of the whole fleet')
    robots: list[str] = Field(description='the robots of the rows sent (every robot when every '
                                          'row is sent; streamed: written after the rows)')
    robot_count: int = Field(description='robots of the whole fleet')
    robot: Optional[str] = Field(description='the robot filter (null: all)')
    state: Optional[str] = Field(description='the state filter (null: all)')
    rows: list[FleetRowJson] = Field(description='the rows that pass the filters (one page '
                                                 'of them when paged)')
    total: int = Field(description='rows that pass the filters (on every page)')
    page: int = Field(description='the page sent, from 1 (1 when not paged)')
    pages: int = Field(description='pages of the filtered rows (1 when not paged)')
    limit: Optional[int] = Field(description='rows per page (null: not paged, every row)')
    first: int = Field(description='the position of the first row sent among the filtered '
                                   'rows, from 1 (0: none sent)')


class RobotChoicesJson(_Shape):
    """The robot search: the robots whose name holds a text, those that start with it first."""

    search: str = Field(description='the text searched (case-insensitive)')
    robots: list[str] = Field(description='the robots found, at most the limit')
    more: bool = Field(description='more robots hold the text than were sent')


class AlarmEventJson(_Shape):
    """One alarm event: raised (by an experiment), acknowledged or reset (by a person)."""

    event_id: Optional[int] = Field(alias='id', description="the event's id in the history")
    robot: str
    joint: str
    event: str = Field(description='one of: ' + ', '.join(ALARM_EVENT_KINDS),
                       json_schema_extra={'enum': list(ALARM_EVENT_KINDS)})
    stamp_s: Optional[float] = Field(description="a raise: its experiment's stamp [s]; "
                                                 'else the moment [s]')
    time: str = Field(description='event_time_s as ISO 8601 UTC')
    time_text: str = Field(description="event_time_s as people read it: in the dashboard's "
                                       'display_timezone (ISO 8601 UTC by default)')
    event_time_s: Optional[float] = Field(
        description="the event's time in the log (newest first): a raise's experiment "
                    "stamp, an acknowledgement's or a reset's wall time [s]")
    wall_time_s: Optional[float] = Field(description='when it was stored [s, wall clock]')
    wear: Optional[float]
    note: str = Field(description='as stored')
    note_text: str = Field(description='the note in words')
    estimate_id: Optional[int] = Field(description='the estimate it is tied to (a reset: '
                                                   "the old life's last)")
    user: str
    owner: str
    planned_maintenance: str = Field(description="YYYY-MM-DD or ''")
    work_order: str = Field(description="the maintenance system's work order ('' for none)")
    source: str = Field(description="where a person's event came from: web, api, cli or "
                                    "ros ('' for the monitor's raises and events stored "
                                    'before schema version 9)')
    changes: str = Field(description="what an edit changed ('field: old -> new' joined by "
                                     "'; '; '' for other events)")


class AcknowledgeRequest(_Shape):
    """An acknowledgement (or its edit: the values after it), sent by a person or a system."""

    owner: str = Field(description='who takes the maintenance on (1-128 printable characters)')
    comment: str = Field('', description='free text (at most 2000 characters)')
    planned_maintenance: str = Field('', description="YYYY-MM-DD or ''")
    work_order: str = Field('', description="the maintenance system's work order (at most "
                                            "128 printable characters, '' for none)")
    allow_past_date: bool = Field(
        False, description='record a planned_maintenance date that has passed (else 422)')


class EditRequest(_Shape):
    """An edit of the acknowledgement: only the fields sent change (the others are kept)."""

    owner: Optional[str] = Field(None, description='who takes the maintenance on')
    comment: Optional[str] = Field(None, description='free text (at most 2000 characters)')
    planned_maintenance: Optional[str] = Field(None, description="YYYY-MM-DD ('' clears it)")
    work_order: Optional[str] = Field(None, description="the work order ('' clears it)")
    allow_past_date: bool = Field(
        False, description='record a planned_maintenance date that has passed (else 422)')


class ResetRequest(_Shape):
    """A reset after maintenance or a replacement (with or without an alarm): why, work order."""

    reason: str = Field(description='why (non-empty, at most 2000 characters)')
    work_order: str = Field('', description="the work order ('' for none)")


class WithdrawRequest(_Shape):
    """The withdrawal of an acknowledgement: why."""

    reason: str = Field(description='why (non-empty, at most 2000 characters)')


class ExperimentJson(_Shape):
    """One experiment of a joint: w-hat, T-hat, the trend, the model check."""

    estimate_id: int = Field(alias='id', description="the estimate's id in the history")
    stamp_s: float = Field(description="the experiment's end [s]")
    time: str
    wear: Optional[float]
    wear_low: Optional[float]
    wear_high: Optional[float]
    trend_wear: Optional[float]
    trend_low: Optional[float]
    trend_high: Optional[float]
    temperature_degc: Optional[float]
    temperature_low_degc: Optional[float]
    temperature_high_degc: Optional[float]
    p_value: Optional[float] = Field(description="the model check's p-value")
    model_check_failed: bool = Field(description='p_value below model_check_p_value')
    alarm: bool
    valid: bool
    invalid_reason: Optional[str]
    crossing_experiments: Optional[float]
    crossing_time_s: Optional[float]
    current_life: bool = Field(description='after the last reset (false: an old life)')


class ForecastJson(_Shape):
    """The forecast cone of the latest trend up to the threshold: its middle and 95 % band."""

    time_s: list[float]
    time: list[str]
    wear: list[float]
    high: list[float]
    low: list[float]
    crossing_experiments: float
    crossing_low_experiments: float
    crossing_high_experiments: float
    crossing_time_s: float
    crossing_low_time_s: float
    crossing_high_time_s: float
    crossing: str
    crossing_low: str
    crossing_high: str
    rate_per_experiment: float = Field(description='wear per experiment [w]')
    spacing_s: float = Field(description="the joint's usual experiment spacing [s]")


class FrictionCurveJson(_Shape):
    """The friction levels of one experiment and the model at its T-hat and w-hat."""

    estimate_id: int = Field(alias='id', description="the estimate's id in the history")
    time: str
    speeds_rad_s: list[float] = Field(description='motor side [rad/s]')
    frictions: list[float] = Field(description='normalised')
    model_speeds_rad_s: list[float]
    model_frictions: Optional[list[float]] = Field(description='null without T-hat or w-hat')
    temperature_degc: Optional[float]
    wear: Optional[float]


class JointJson(_Shape):
    """One joint's wear story."""

    robot: str
    joint: str
    threshold: float = Field(description='the alarm threshold the latest estimate was judged '
                                         "by [w] (the parameter set's when threshold_assumed)")
    warning_level: Optional[float] = Field(description='the warning level it was judged by [w]')
    threshold_assumed: bool = Field(description='the history stores no threshold for it: the '
                                                "parameter set's, assumed")
    threshold_text: str = Field(description="'30', or '35 (assumed)'")
    parameter_set: str
    model_note: Optional[str] = Field(description='why another set stands in (null: none)')
    model_check_p_value: float
    state: Optional[FleetRowJson] = Field(description="the joint's fleet row")
    experiments: list[ExperimentJson]
    forecast: Optional[ForecastJson]
    friction: list[FrictionCurveJson] = Field(
        description=f'the last {FRICTION_EXPERIMENTS} experiments')
    events: list[AlarmEventJson] = Field(description='the alarm log, newest first')


class MeJson(_Shape):
    """The user and the session's CSRF token (for scripted POSTs; '' with an API token)."""

    name: str
    role: str
    csrf_token: str
