"""
The plant's clock: the declared setting ``display_timezone`` and the zone it names.

A plant reads its own clock: every date and time a person reads (the dashboard's pages, the
text of ``fleet`` and ``history``, the notifications' texts) is shown in the IANA time zone
``display_timezone`` (``Europe/Stockholm``) with its abbreviation (``2026-11-28 13:30 CET``),
by :func:`robot_wear_monitor.text.shown_time`.  Machine outputs stay UTC whatever it says:
seconds since the epoch and ISO 8601 UTC in ``fleet --json``, ``/api/*`` (but the ``text``
of ``/api/fleet`` rows, the page's words), stored values, CSV and JSON exports.  The default
``UTC`` shows ISO 8601 UTC, as before the setting existed.
"""

from __future__ import annotations

from dataclasses import dataclass
import datetime
from typing import Optional
import zoneinfo

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.setting_fields import check_settings, setting
from robot_wear_monitor.text import shorten

__all__ = ['DisplayTimeConfig', 'DEFAULT_TIMEZONE', 'time_zone', 'Zone', 'zone_problem']

#: A zone for people's times (None: ISO 8601 UTC), as :func:`time_zone` returns it.
Zone = Optional[datetime.tzinfo]

#: The zone shown unless configured (ISO 8601 UTC, as before the setting).
DEFAULT_TIMEZONE = 'UTC'
#: Names that mean UTC: shown as ISO 8601 UTC (``...Z``).
UTC_NAMES = ('UTC', 'Etc/UTC', 'Etc/Universal', 'Universal', 'Zulu', 'Etc/Zulu')


def _zone_or_error(name: str) -> tuple[Optional[datetime.tzinfo], Optional[str]]:
    """Return (the zone of ``name`` or None for UTC, None) or (None, what is wrong)."""
    if not isinstance(name, str) or not name.strip():
        return None, 'expected an IANA time zone name such as Europe/Stockholm'
    if name in UTC_NAMES:
        return None, None
    try:
        return zoneinfo.ZoneInfo(name), None
    except (zoneinfo.ZoneInfoNotFoundError, ValueError, OSError):
        return None, ('not an IANA time zone name (such as Europe/Stockholm or UTC; the '
                      'names are those of the tz database)')


def zone_problem(name: str) -> Optional[str]:
    """Check of ``display_timezone``: a known IANA time zone name, else what is wrong."""
    return _zone_or_error(name)[1]


def time_zone(name: str, *, where: str = 'display_timezone') -> Zone:
    """
    Return the zone ``name`` names for :func:`~robot_wear_monitor.text.shown_time`.

    None for UTC (:data:`UTC_NAMES`: ISO 8601 UTC is shown).

    :raises InputError: ``<where>: <problem>, got '<name, cut short and escaped>'``.
    """
    zone, problem = _zone_or_error(name)
    if problem:
        raise InputError(f'{where}: {problem}, got {shorten(repr(name), 60)}')
    return zone


@dataclass(frozen=True)
class DisplayTimeConfig:
    """The owner of the setting ``display_timezone`` (the dashboard and the CLI share it)."""

    display_timezone: str = setting(
        DEFAULT_TIMEZONE, check=zone_problem,
        description='the IANA time zone of the dates and times people read (pages, text '
                    'tables, notification texts), e.g. Europe/Stockholm; machine outputs '
                    '(JSON, CSV, the API) stay UTC')

    def __post_init__(self) -> None:
        """Check the setting (InputError naming it and the value)."""
        check_settings(self, prefix='')

    @property
    def zone(self) -> Zone:
        """Return the zone for :func:`~robot_wear_monitor.text.shown_time` (None: UTC)."""
        return time_zone(self.display_timezone)
