"""
What a notification pass reads: the joints that changed since the last pass, and the clock's.

The first pass of a notifier reads every joint.  It keeps :class:`PassMarks` (in memory: the
newest estimate and alarm event ids and the time of its last pass), and each later pass reads
only the joints whose due notifications may differ (:func:`joints_to_read`): those with an
estimate or an alarm event stored after the marks (index ranges of ids), those whose state the
clock may have moved since the last pass (gone stale, a forecast crossing come within the
horizon or passed, a planned maintenance date passed: index ranges of the stored times,
:meth:`~robot_wear_monitor.history.fleet_index.FleetIndex.clock_moved`), and those with a
failed send to try again.  A notification already sent stays sent (the history's log); an
alert of a joint not read stays as it was (its cause cannot have ended without a write or the
clock).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Optional

from robot_wear_monitor.history import WearHistory


@dataclass
class PassMarks:
    """The newest ids a notifier's last pass read and its time (a fresh one: read all)."""

    estimate_id: int = 0
    event_id: int = 0
    now_s: float = math.nan

    @property
    def started(self) -> bool:
        """Return True after a first (whole) pass."""
        return math.isfinite(self.now_s)


def joints_to_read(history: WearHistory, marks: PassMarks, *, now_s: float,
                   horizon_s: float, log_rows: list[dict[str, Any]]
                   ) -> tuple[Optional[set[tuple[str, str]]], tuple[int, int]]:
    """
    Return the joints a pass at ``now_s`` reads (None: every joint) and the marks after it.

    The marks are read before the fleet, so that a row stored during the pass is read by the
    next one.  ``horizon_s``: the forecast horizon [s]; ``log_rows``: the notification log
    (its failed sends' joints are read again, to retry them).
    """
    index = history.fleet_index()
    after = index.marks()
    if not marks.started:
        return None, after
    joints = index.changed(estimate_mark=marks.estimate_id, event_mark=marks.event_id)
    joints |= index.clock_moved(since_s=marks.now_s, now_s=now_s, horizon_s=horizon_s)
    joints |= {(str(row['robot']), str(row['joint'])) for row in log_rows
               if '#failed' in str(row['event_key']) and row.get('robot') is not None
               and row.get('joint') is not None}
    return joints, after


def advance(marks: PassMarks, after: tuple[int, int], *, now_s: float) -> None:
    """Keep the marks of a pass that went through (a failed pass reads the same again)."""
    marks.estimate_id, marks.event_id = after
    marks.now_s = float(now_s)
