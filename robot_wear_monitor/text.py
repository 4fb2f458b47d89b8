"""
Text a person reads: values echoed safely, numbers and times in words.

The package's one owner of these helpers, below everything that prints (the command line,
the nodes, the fleet, the dashboard): :func:`escaped` and :func:`shorten` for values from
other people's files (a joint's name, a path, an error's text), :func:`fmt_number` for a
number (never 'nan' or 'inf'), :func:`iso_time` for a stamp in a machine's output (UTC) and
:func:`shown_time` for a stamp a person reads (in the plant's time zone, the setting
``display_timezone`` of :mod:`robot_wear_monitor.display_time`).
"""

import datetime
import math
from typing import Any, Optional

#: The most characters of a value an error message echoes.
ECHO_LIMIT = 80
#: The most characters of a name or message a line of output shows.
LINE_LIMIT = 200

#: What a person reads for a number that is not known (never 'nan').
UNKNOWN = 'unknown'
#: What a person reads for a std the estimate does not report (the interval says it).
STD_NOT_REPORTED = 'not reported (see the interval)'
#: What a person reads for an open end of a forecast (never 'inf' or 'nan').
BEYOND_HORIZON = 'beyond the forecast horizon'


def escaped(value: Any) -> str:
    """Return the text of ``value``, each unprintable character escaped as Python writes it."""
    text = str(value)
    return text if text.isprintable() else ''.join(
        c if c.isprintable() else repr(c)[1:-1] for c in text)


def shorten(value: Any, limit: int = ECHO_LIMIT) -> str:
    """
    Return ``repr``-free text of ``value`` cut to ``limit`` characters with an ellipsis.

    Control characters are escaped (:func:`escaped`): names come from recordings and histories
    other people wrote, and a newline, an escape sequence or a carriage return in a joint's
    name must not forge or hide a line of output.
    """
    text = escaped(str(value)[:limit + 1])
    return text if len(text) <= limit else text[:limit - 1] + '\u2026'


def fmt_number(value: float, digits: int = 4, *, missing: str = UNKNOWN) -> str:
    """
    Return ``value`` with ``digits`` significant digits; ``missing`` when not finite.

    Text a person reads never says 'nan' or 'inf' (JSON says null instead).
    """
    value = float(value)
    return f'{value:.{digits}g}' if math.isfinite(value) else missing


def iso_time(stamp_s: Optional[float], *, local: bool = False) -> str:
    """Return a stamp [s since the epoch] as ISO 8601 to the second (UTC unless ``local``)."""
    if stamp_s is None or not math.isfinite(stamp_s):
        return '-'
    moment = datetime.datetime.fromtimestamp(stamp_s, tz=datetime.timezone.utc)
    if local:
        moment = moment.astimezone()
    return moment.isoformat(timespec='seconds').replace('+00:00', 'Z')


def shown_time(stamp_s: Optional[float], *, zone: Optional[datetime.tzinfo] = None,
               local: bool = False, date_only: bool = False) -> str:
    """
    Return a stamp [s since the epoch] as a person reads it ('-' when unknown).

    ``zone`` (a :class:`zoneinfo.ZoneInfo`, the plant's ``display_timezone``): the time there
    to the minute with the zone's abbreviation or offset, ``2026-11-28 13:30 CET`` (summer
    ``CEST``); None: UTC, ISO 8601 to the second as :func:`iso_time` (``2026-11-28T12:30:00Z``);
    ``local``: the machine's zone, ISO 8601 with its offset (``--local``).  ``date_only``:
    the day ``YYYY-MM-DD`` in that zone.
    """
    if zone is None or stamp_s is None or not math.isfinite(stamp_s):
        text = iso_time(stamp_s, local=local)
        return text[:10] if date_only and text != '-' else text
    moment = datetime.datetime.fromtimestamp(stamp_s, tz=zone)
    return moment.strftime('%Y-%m-%d' if date_only else '%Y-%m-%d %H:%M %Z')
