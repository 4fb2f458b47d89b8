"""
A planned maintenance date in the past: refused unless the person says it is meant.

A date typed a year wrong re-escalates the alarm at once; a maintenance system that records a
date already passed (a late entry) says so: the API's ``allow_past_date: true``, the form's
"the date has passed (record it anyway)" box.  An edit that keeps the date it had is never
refused (the owner of an overdue acknowledgement can still be changed).  Days are UTC.
"""

from __future__ import annotations

import datetime
import time
from typing import Any, Callable, Optional

from robot_wear_monitor.history import HistoryError

__all__ = ['checked_date', 'PastDateError']


class PastDateError(HistoryError):
    """A planned maintenance date before today (UTC) without ``allow_past_date``."""


def checked_date(action: Callable[[], Any], *, planned: Optional[str], allow_past: bool,
                 kept: Callable[[], str] = lambda: '',
                 now_s: Optional[float] = None) -> Callable[[], Any]:
    """
    Return ``action`` preceded by the check of ``planned`` ('YYYY-MM-DD', '' or None).

    Raises :class:`PastDateError` (a :class:`HistoryError`: 422 from the API, an error on the
    page) when ``planned`` is before today (UTC, at ``now_s`` [s], default now), differs from
    ``kept()`` (the date before an edit, read when the action runs) and ``allow_past`` is
    false.  A malformed date is left to
    the history's own check.
    """
    def run() -> Any:
        if planned and not allow_past and planned != kept():
            try:
                day = datetime.date.fromisoformat(planned)
            except ValueError:
                day = None
            today = datetime.datetime.fromtimestamp(
                time.time() if now_s is None else now_s, tz=datetime.timezone.utc).date()
            if day is not None and day < today:
                raise PastDateError(
                    f'planned_maintenance {day.isoformat()} has passed (today is '
                    f'{today.isoformat()} UTC): give a date from today on, or send '
                    'allow_past_date (the form: tick "the date has passed") to record it')
        return action()
    return run
