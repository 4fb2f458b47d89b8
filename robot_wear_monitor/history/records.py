"""The rows of the wear history: estimates, alarm events, restored state and fleet rows."""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

from robot_wear_monitor.errors import InputError

#: The robot of a history opened without one, and of the rows of a version-2 history.
DEFAULT_ROBOT = 'default'

#: Columns added by schema version 2 (nullable REAL): intervals of the estimate and the trend.
INTERVAL_COLUMNS = ('wear_low', 'wear_high', 'temperature_low_degc', 'temperature_high_degc',
                    'trend_wear', 'trend_low', 'trend_high', 'crossing_experiments',
                    'crossing_time_s')


class HistoryError(InputError):
    """The wear history cannot be opened, read or written; the message names the history."""


class LatchMoved(HistoryError):
    """
    An estimate was not stored: the joint's latch changed since its writer read it.

    Someone (the dashboard) reset the alarm while the estimator worked on the experiment: its
    estimate belongs to the old life.  The writer takes the reset over and estimates again.
    """


@dataclass(frozen=True)
class HistoryRecord:
    """
    One stored estimate: the inputs, the result and the alarm state after it.

    ``stamp_s`` is the ROS stamp of the experiment's end [s]; with ``robot`` and ``joint`` it is
    the experiment's identity.  ``robot`` None means the robot the history was opened for;
    records read back always carry their robot.  Wear values are in the model's wear units,
    temperatures in degC, speeds in rad/s (motor side), frictions normalised.
    """

    joint: str
    stamp_s: float
    speeds_rad_s: tuple[float, ...]
    frictions: tuple[float, ...]
    temperature_degc: float
    temperature_std_degc: float
    wear: float
    wear_std: float
    chi2: float
    dof: int
    p_value: float
    temperature_at_bound: bool
    wear_at_bound: bool
    alarm_active: bool
    alarm_evidence: float
    status_level: int
    parameter_set: str
    id: Optional[int] = None  # noqa: A003 - the history's column name, part of the API
    wear_low: float = math.nan
    wear_high: float = math.nan
    temperature_low_degc: float = math.nan
    temperature_high_degc: float = math.nan
    trend_wear: float = math.nan
    trend_low: float = math.nan
    trend_high: float = math.nan
    crossing_experiments: float = math.nan
    crossing_time_s: float = math.nan
    robot: Optional[str] = None
    #: '' for a valid estimate; else why the monitor could not judge the wear (plausibility)
    invalid_reason: str = ''
    #: the alarm threshold and the warning level the estimate was judged by [w] (schema
    #: version 8; NaN: not stored, a row of an older history)
    threshold: float = math.nan
    warning_level: float = math.nan

    @property
    def valid(self) -> bool:
        """Return True when the estimate passed the plausibility checks."""
        return not self.invalid_reason


#: The events of a person on an acknowledgement (schema version 7 adds the edit and the
#: withdrawal): the alarm is acknowledged while the last of them after its raise is not a
#: withdrawal.
ACKNOWLEDGEMENT_EVENTS = ('acknowledged', 'acknowledgement_edited', 'acknowledgement_withdrawn')
#: The kinds of alarm events: the latch is the last 'raised' or 'reset' (the
#: :data:`ACKNOWLEDGEMENT_EVENTS` are remarks on a raised alarm: they never unlatch it).
ALARM_EVENT_KINDS = ('raised', 'reset', *ACKNOWLEDGEMENT_EVENTS, 'reescalated')
#: The events of a person on an acknowledgement, as SQL.
ACKNOWLEDGEMENT_SQL = 'event IN (' + ', '.join(f"'{e}'" for e in ACKNOWLEDGEMENT_EVENTS) + ')'
#: The events that set the latch (acknowledgements do not), as SQL.
LATCH_EVENTS = "event IN ('raised', 'reset')"
#: Schema version 11: an acknowledged alarm back on top (its wear rose past the margin, or its
#: planned date passed), logged once per acknowledgement and reason by whoever saw it first;
#: a remark like the acknowledgement's: it never unlatches nor acknowledges the alarm.
REESCALATED = 'reescalated'
#: Where a person's alarm event came from (schema version 9): the dashboard's forms, its API,
#: the command line, the ROS reset service, the notifier (version 11: who saw a re-escalation
#: first); '' for the monitor's own raises and older rows.
EVENT_SOURCES = ('web', 'api', 'cli', 'ros', 'notify')


@dataclass(frozen=True)
class AlarmEvent:
    """
    An alarm raise, reset, acknowledgement (or its edit or withdrawal) of one robot's joint.

    ``robot`` None means the history's robot; events read back carry their robot, their ``id``
    and ``wall_time_s`` (when stored [s since the epoch]).  ``stamp_s``: the experiment's stamp
    of a raise, the moment of a reset or acknowledgement [s].  ``note``: why it was raised, the
    reason of a reset or the comment of an acknowledgement; ``user``: who reset or acknowledged
    it ('' for the monitor's own events and the ROS service); ``owner``: who takes the
    maintenance on; ``planned_maintenance``: its planned date ('YYYY-MM-DD' or '');
    ``work_order``: the maintenance system's work order (schema version 7; '' for none).  An
    edit carries the acknowledgement's values after it; a withdrawal its reason as ``note``.
    ``source`` (schema version 9): where a person's event came from (one of
    :data:`EVENT_SOURCES`; '' for the monitor's raises and older rows); ``changes``: what an
    edit changed, as 'field: old -> new' parts joined by '; ' ('' otherwise).
    """

    joint: str
    stamp_s: float
    event: str
    wear: Optional[float]
    note: str = ''
    estimate_id: Optional[int] = None
    robot: Optional[str] = None
    id: Optional[int] = None  # noqa: A003 - the history's column name, part of the API
    wall_time_s: float = math.nan
    user: str = ''
    owner: str = ''
    planned_maintenance: str = ''
    work_order: str = ''
    source: str = ''
    changes: str = ''


@dataclass(frozen=True)
class RestoredState:
    """What a restarted estimator takes over: the trend, the latched alarm and its evidence."""

    records: tuple[HistoryRecord, ...]
    alarm_active: bool
    alarm_evidence: float
    last_event: Optional[AlarmEvent]


@dataclass(frozen=True)
class FleetRow:
    """
    The latest state of one robot's joint, for the fleet view (one row per robot and joint).

    ``wear*``, ``trend*`` and ``crossing*`` are those of the latest estimate (NaN when not
    stored); ``alarm`` is the latched alarm (the last alarm event is a raise) and
    ``alarm_since_stamp_s`` the stamp of that raise [s] (NaN when clear), acknowledgements
    aside (they do not unlatch);
    ``experiments`` counts the stored estimates of the joint's current life (since its last
    reset), ``first_stamp_s``/``last_stamp_s`` are the stamps of the joint's first and latest
    [s] and ``usual_interval_s`` their mean spacing [s] (NaN with one experiment).

    After a reset (the latch is a ``reset``: maintenance started a new life) the row holds the
    new life only: ``life_started_s`` is the reset's moment [s], and while no experiment
    followed it every field of the old life's state (wear, trend, crossing, evidence, status,
    invalid reason) is NaN / clear; the old life stays in the joint's records.
    """

    robot: str
    joint: str
    experiments: int
    first_stamp_s: float
    last_stamp_s: float
    last_wall_time_s: float
    wear: float
    wear_std: float
    wear_low: float
    wear_high: float
    trend_wear: float
    trend_low: float
    trend_high: float
    crossing_experiments: float
    crossing_time_s: float
    alarm: bool
    alarm_since_stamp_s: float
    alarm_evidence: float
    status_level: int
    parameter_set: str
    #: '' when the latest estimate is valid; else why the wear cannot be judged
    invalid_reason: str = ''
    #: the latched alarm was acknowledged after its raise (it stays latched), by whom, when
    #: [s since the epoch] and the planned maintenance date ('YYYY-MM-DD' or '')
    acknowledged: bool = False
    acknowledged_by: str = ''
    acknowledged_wall_time_s: float = math.nan
    planned_maintenance: str = ''
    #: who edited the acknowledgement last ('' when not edited since; ``acknowledged_by`` is
    #: who acknowledged first, ``acknowledged_wall_time_s`` when)
    edited_by: str = ''
    #: the value at the acknowledgement: w-hat and the trend of the joint's latest estimate
    #: then (NaN when unknown); the fleet view re-escalates the alarm when the wear rises a
    #: set margin past it
    acknowledged_wear: float = math.nan
    acknowledged_trend_wear: float = math.nan
    #: the last reset (a new life): its moment [s], who and why ('' from the ROS service);
    #: NaN / '' when the joint was never reset or its alarm is latched again
    life_started_s: float = math.nan
    reset_by: str = ''
    reset_reason: str = ''
    #: every stored estimate of the joint, old lives too (0: the same as ``experiments``)
    total_experiments: int = 0
    #: the stamps of the joint's last experiments, all lives, oldest first [s] (``recent.py``)
    recent_stamps: tuple[float, ...] = ()
    #: the alarm threshold and warning level the latest estimate was judged by [w] (kept
    #: after a reset: the joint's setting); NaN: not stored (a row of an older history)
    threshold: float = math.nan
    warning_level: float = math.nan

    @property
    def usual_interval_s(self) -> float:
        """
        Return the joint's usual time between experiments, all lives [s] (NaN with one).

        The median of the intervals between :attr:`recent_stamps` (an outage is one long
        interval and does not stretch it); without them the mean of all intervals.
        """
        if len(self.recent_stamps) >= 2:
            gaps = sorted(b - a for a, b in zip(self.recent_stamps, self.recent_stamps[1:]))
            middle = len(gaps) // 2
            median = gaps[middle] if len(gaps) % 2 else 0.5 * (gaps[middle - 1] + gaps[middle])
            return median if median > 0 else math.nan
        count = max(self.total_experiments, self.experiments)
        if count < 2:
            return math.nan
        return (self.last_stamp_s - self.first_stamp_s) / (count - 1)

    @property
    def awaiting_first_experiment(self) -> bool:
        """Return True after a reset that no experiment followed yet."""
        return math.isfinite(self.life_started_s) and self.experiments == 0

    def rank_key(self, *, reescalated: bool = False) -> tuple[int, float, float, str, str]:
        """
        Return the sort key of the fleet view, worst first (the maintenance team's triage).

        An unacknowledged latched alarm first (an acknowledged one that is ``reescalated``
        counts as unacknowledged), then the acknowledged alarms, then the joints whose latest
        estimate cannot be judged (an invalid estimate: a monitor that does not know is no
        healthy joint), then the soonest forecast crossing [experiments], then the highest
        upper bound of w (the estimate itself when the interval is unknown).
        """
        crossing = (self.crossing_experiments if math.isfinite(self.crossing_experiments)
                    else math.inf)
        high = self.wear_high if math.isfinite(self.wear_high) else self.wear
        if self.alarm:
            tier = 1 if self.acknowledged and not reescalated else 0
        else:
            tier = 2 if self.invalid_reason else 3
        return (tier, crossing, -high if math.isfinite(high) else math.inf, self.robot,
                self.joint)
