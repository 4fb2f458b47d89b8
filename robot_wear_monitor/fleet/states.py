"""
One list of a joint's maintenance states, the same word in every view and notification.

The first state that applies (:func:`joint_state`):

1. ``alarm``: a latched alarm nobody acknowledged, or an acknowledged one that is
   re-escalated (its wear rose the margin past its value at the acknowledgement, or its
   planned maintenance date passed: the row says ``reescalated``);
2. ``acknowledged``: a latched alarm someone took on;
3. ``cannot judge``: the latest estimate failed the plausibility checks (or has no w-hat);
4. ``stale``: no experiment for longer than the stale limit (counted from the reset in a new
   life);
5. ``warning``: w-hat or the trend at or above the warning level the estimate was judged by
   (:func:`warning_level`), or the forecast crossing of the wear threshold within the forecast
   horizon (the notifications' ``forecast_horizon_days``: one setting for both), or passed
   (``crossing_overdue``);
6. ``new life``: reset after maintenance, awaiting its first experiment;
7. ``ok``.

``fleet --json``, ``/api/fleet``, the fleet page's badge, counts and filters and the
notifications all take the state from here.
"""

from __future__ import annotations

import math
from typing import Optional

from robot_wear_monitor.fleet.notify_settings import (
    DEFAULT_FORECAST_HORIZON_DAYS as NOTIFY_FORECAST_HORIZON_DAYS)
from robot_wear_monitor.history import FleetRow

#: The states, worst first (the filter and the counts name them so).
STATES = ('alarm', 'acknowledged', 'cannot judge', 'stale', 'warning', 'new life', 'ok')
#: How far ahead a forecast crossing makes a joint a ``warning`` unless configured [days]
#: (the notifications' declared default ``forecast_horizon_days``).
DEFAULT_FORECAST_HORIZON_DAYS = NOTIFY_FORECAST_HORIZON_DAYS
#: Seconds per day.
DAY_S = 86400.0


def warning_level(row: FleetRow) -> float:
    """
    Return the warning level the joint's latest estimate was judged by [w].

    The level stored with the estimate (schema version 8), or for a row of an older history
    the parameter set's (``fleet/thresholds.py``, ``judged_levels``, fills it in); NaN: none
    (no warning by level).
    """
    return float(row.warning_level)


def crossing_overdue(row: FleetRow, *, crossing_time_s: Optional[float], now_s: float) -> bool:
    """
    Return True when the forecast crossing date has passed without an alarm.

    The trend was still below the threshold at the latest experiment (crossing ahead then),
    the crossing's date (at the usual interval) is before ``now_s`` [s] and no alarm is
    latched: no experiment since has confirmed or refuted it.
    """
    crossing = row.crossing_experiments
    return bool(not row.alarm and crossing_time_s is not None and math.isfinite(crossing)
                and crossing > 0 and crossing_time_s < now_s)


def is_warning(row: FleetRow, *, crossing_time_s: Optional[float], now_s: float,
               warning: float, horizon_s: float) -> bool:
    """
    Return True when w-hat or the trend is at or above ``warning`` [w] or the crossing is near.

    Near: the trend past the threshold already, or the forecast crossing's date at most
    ``horizon_s`` [s] after ``now_s`` (passed dates too).
    """
    if any(math.isfinite(v) and v >= warning for v in (row.wear, row.trend_wear)):
        return True
    crossing = row.crossing_experiments
    if not math.isfinite(crossing):
        return False
    if crossing <= 0:
        return True
    return crossing_time_s is not None and crossing_time_s - now_s <= horizon_s


def joint_state(row: FleetRow, *, stale: bool, reescalated: bool,
                crossing_time_s: Optional[float], now_s: float, warning: float,
                horizon_s: float) -> str:
    """Return the joint's state: the first of :data:`STATES` that applies (module text)."""
    if row.alarm:
        return 'acknowledged' if row.acknowledged and not reescalated else 'alarm'
    awaiting = row.awaiting_first_experiment
    if not awaiting and (row.invalid_reason or not math.isfinite(row.wear)):
        return 'cannot judge'
    if stale:
        return 'stale'
    if not awaiting and is_warning(row, crossing_time_s=crossing_time_s, now_s=now_s,
                                   warning=warning, horizon_s=horizon_s):
        return 'warning'
    return 'new life' if awaiting else 'ok'
