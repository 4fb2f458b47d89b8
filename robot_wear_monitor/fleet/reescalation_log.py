"""
Re-escalations into the alarm log: an ``reescalated`` event, once, by whoever sees it first.

The fleet view (:func:`~robot_wear_monitor.fleet.ranking.fleet_view`) judges an acknowledged
alarm re-escalated at the time it is asked about (its wear rose past the margin, or its
planned maintenance date passed); nothing is stored then.  :func:`log_reescalations` records
each re-escalation it is shown as an alarm event ``reescalated`` (history schema version 11)
with its reason as the note (one event per reason), the wear then, and the source that saw it
(``notify``, ``web``, ``api``, ``cli``), once per acknowledgement and reason (the wear's rise
past the margin; a planned date that passed: a postponed date missed again is a new reason):
an event of the same reason after the acknowledgement already in the log is not written
again.  Two processes seeing the same
re-escalation at the same instant may both write it (the notifier's and the dashboard's); the
log shows both, the later a repeat of the earlier.
"""

from __future__ import annotations

import math
from typing import Iterable

from robot_wear_monitor.fleet.ranking import FleetView
from robot_wear_monitor.history import AlarmEvent, HistoryError, WearHistory
from robot_wear_monitor.history.records import REESCALATED

__all__ = ['log_reescalations', 'try_log_reescalations']


def log_reescalations(history: WearHistory, views: Iterable[FleetView], *,
                      source: str) -> list[AlarmEvent]:
    """
    Record each re-escalated acknowledged alarm of ``views`` not yet logged; return the events.

    ``source``: who looked (one of the history's event sources).  A history that cannot be
    written (read-only, an older version) raises :class:`HistoryError` to the caller.
    """
    written = []
    for view in views:
        s = view.state
        if not (s.acknowledged and view.reescalated):
            continue
        since = s.acknowledged_wall_time_s
        logged = {_reason_key(e.note) for e in history.events(joint=s.joint, robot=s.robot)
                  if e.event == REESCALATED
                  and (not math.isfinite(since) or e.wall_time_s >= since)}
        for reason in view.reescalated.split('; '):
            if _reason_key(reason) in logged:
                continue
            wear = s.wear if math.isfinite(s.wear) else None
            written.append(history.record_event(AlarmEvent(
                robot=s.robot, joint=s.joint, stamp_s=s.last_stamp_s, event=REESCALATED,
                wear=wear, note=reason, source=source)))
    return written


def _reason_key(note: str) -> str:
    """Return a reason's identity: 'margin' (its numbers change), or the date's text."""
    return 'margin' if ' rose to ' in note else note


def try_log_reescalations(history: WearHistory, views: Iterable[FleetView], *,
                          source: str) -> list[AlarmEvent]:
    """Return :func:`log_reescalations`, or [] when the history cannot be written."""
    try:
        return log_reescalations(history, views, source=source)
    except HistoryError:
        return []
