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
ALARM_EVENT_KINDS = ('raised', 'reset', *ACKNOWLEDGEMENT_EVENTS)


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
    ``experiments`` counts the stored estimates, ``first_stamp_s``/``last_stamp_s`` are the
    stamps of the first and the latest [s] and ``usual_interval_s`` their mean spacing [s]
    (NaN with one experiment).
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

    @property
    def usual_interval_s(self) -> float:
        """Return the mean time between the joint's experiments [s] (NaN with one)."""
        if self.experiments < 2:
            return math.nan
        return (self.last_stamp_s - self.first_stamp_s) / (self.experiments - 1)

    def rank_key(self) -> tuple[int, float, float, str, str]:
        """
        Return the sort key of the fleet view, worst first.

        A latched alarm first, then the joints whose latest estimate cannot be judged (an
        invalid estimate: a monitor that does not know is no healthy joint), then the soonest
        forecast crossing [experiments], then the highest upper bound of w (the estimate itself
        when the interval is unknown).
        """
        crossing = (self.crossing_experiments if math.isfinite(self.crossing_experiments)
                    else math.inf)
        high = self.wear_high if math.isfinite(self.wear_high) else self.wear
        return (0 if self.alarm else 1 if self.invalid_reason else 2, crossing,
                -high if math.isfinite(high) else math.inf, self.robot, self.joint)
