"""
The notification settings, each declared once: the configuration file's fields and the loop's.

The dataclasses of the notification configuration (:class:`NotificationConfig` and its
sections :class:`RetryPolicy`, :class:`WebhookConfig`, :class:`EmailConfig`) and
:class:`NotifierSettings` (how often a pass runs: ``notify --interval-s`` and ``dashboard
--notify-interval-s``) declare each setting with
:func:`~robot_wear_monitor.setting_fields.setting`: default, unit, description and check.  The
YAML reader (:mod:`robot_wear_monitor.fleet.notify_config`) checks a file's values with these
checks, the dataclasses check themselves when built in Python, and the options of ``notify``,
``fleet`` and ``dashboard`` take their defaults, help and ranges from here
(:mod:`robot_wear_monitor.cli.fleet_options`); docs/notifications.md, docs/fleet.md and
docs/dashboard.md are tested against them (``test/fleet/test_notify_settings.py``).

This module loads nothing but the declarations (no YAML, no ssl): the command line reads it
for its options' defaults.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.setting_fields import check_settings, in_range, non_empty, setting

#: The events a configuration may name: an alarm latched, a forecast crossing of the wear
#: threshold inside the horizon, a joint without experiments for too long.
EVENTS = ('alarm_raised', 'forecast_crossing', 'joint_stale')
#: How far ahead a forecast crossing counts [days]: notifications, and the fleet's ``warning``.
DEFAULT_FORECAST_HORIZON_DAYS = 30.0
#: How far the wear of an acknowledged alarm may rise before it is notified again [-].
DEFAULT_REESCALATION_MARGIN = 5.0


class NotificationConfigError(InputError):
    """The notification configuration is invalid; the message names the file and the field."""


def _checked(instance: Any, prefix: str) -> None:
    """Check ``instance``'s declared settings; a bad one is a NotificationConfigError."""
    try:
        check_settings(instance, prefix=prefix)
    except NotificationConfigError:
        raise
    except InputError as error:
        raise NotificationConfigError(str(error)) from None


@dataclass(frozen=True)
class NotifierSettings:
    """How often the notifications are judged and sent (``notify``, ``dashboard --notify``)."""

    interval_s: float = setting(
        60.0, unit='s', check=in_range(1.0, 86400.0),
        description='time between two notification passes')

    def __post_init__(self) -> None:
        """Check the interval (InputError naming it, with the value and the range)."""
        check_settings(self, prefix='notifier: ')


@dataclass(frozen=True)
class RetryPolicy:
    """
    How hard one send is tried.

    Within a pass: up to ``attempts`` tries, the n-th retry after ``backoff_initial_s`` x 2^(n-1)
    [s] (at most ``backoff_max_s``), all tries of a send within ``total_s`` [s]; a send whose
    tries all failed is recorded as failed and tried again on later passes, in all on at most
    ``passes`` passes.
    """

    attempts: int = setting(4, check=in_range(1, 20),
                            description='tries of one send within a pass')
    backoff_initial_s: float = setting(
        1.0, unit='s', check=in_range(0.0, 3600.0),
        description='wait before the second try of a send, doubled at each further try')
    backoff_max_s: float = setting(30.0, unit='s', check=in_range(0.0, 3600.0),
                                   description='longest wait between two tries of a send')
    total_s: float = setting(
        120.0, unit='s', check=in_range(0.0, 86400.0, low_open=True),
        description='all tries of one send within this time; a wait that would pass it is '
                    'not made')
    passes: int = setting(3, check=in_range(1, 1000),
                          description='passes a failing send is tried on, in all')

    def __post_init__(self) -> None:
        """Check every field (NotificationConfigError naming it)."""
        _checked(self, 'retry.')

    def delay_s(self, retry: int) -> float:
        """Return the wait before retry number ``retry`` (1 = the second try) [s]."""
        return min(self.backoff_max_s, self.backoff_initial_s * 2.0 ** (retry - 1))


@dataclass(frozen=True)
class WebhookConfig:
    """
    One webhook: a JSON POST of an Alertmanager-like payload to ``url``.

    ``name`` identifies the channel in the history's notification log (renaming it sends the
    current events again); ``receiver`` is the payload's ``receiver``; ``timeout_s`` bounds each
    request (connect, read, write) [s].
    """

    name: str
    url: str
    receiver: str = setting('robot-wear-monitor', check=non_empty,
                            description="the payload's receiver")
    timeout_s: float = setting(
        10.0, unit='s', check=in_range(0.0, 600.0, low_open=True),
        description='bound on each request to the webhook: connect, read, write')

    def __post_init__(self) -> None:
        """Check the declared fields (NotificationConfigError naming it)."""
        _checked(self, 'webhook ')


@dataclass(frozen=True)
class EmailConfig:
    """
    E-mail through one SMTP server (plain text, one message per event to every ``to``).

    ``starttls``: upgrade the connection with STARTTLS before anything else (required for a
    login unless the server is on the loopback), verifying the server's certificate against
    ``ca_file`` (PEM; '' for the system's authorities); ``user`` with the password of
    ``password_file`` logs in; ``timeout_s`` bounds each connection [s].
    """

    host: str
    sender: str
    to: tuple[str, ...]
    port: int = setting(check=in_range(1, 65535),
                        description='TCP port of the SMTP server (587 with STARTTLS, else 25 '
                                    'when not given)')
    starttls: bool = setting(True, description="STARTTLS before anything else; the server's "
                                               'certificate is verified')
    user: str = ''
    password_file: str = ''
    password: str = field(default='', repr=False)
    ca_file: str = ''
    timeout_s: float = setting(30.0, unit='s', check=in_range(0.0, 600.0, low_open=True),
                               description='bound on each connection to the SMTP server')
    ca_pem: str = field(default='', repr=False)
    name: str = 'email'

    def __post_init__(self) -> None:
        """Check the declared fields (NotificationConfigError naming it)."""
        _checked(self, 'email.')


#: The SMTP port when the file gives none: with STARTTLS, and without.
SMTP_PORTS = {True: 587, False: 25}


@dataclass(frozen=True)
class NotificationConfig:
    """
    The whole notification configuration; ``source``: the file it came from.

    See :mod:`robot_wear_monitor.fleet.notify_config` for the file.
    """

    events: tuple[str, ...] = EVENTS
    forecast_horizon_days: float = setting(
        DEFAULT_FORECAST_HORIZON_DAYS, unit='days', check=in_range(0.0, 3650.0),
        description='how far ahead a forecast crossing of the wear threshold counts (the '
                    "notifications' forecast_crossing, the fleet's warning state)")
    reescalation_margin: float = setting(
        DEFAULT_REESCALATION_MARGIN, unit='wear units', check=in_range(0.0, 100.0,
                                                                       low_open=True),
        description='an acknowledged alarm is notified again (and ranked as unacknowledged) '
                    'when its wear rises this much past its value at the acknowledgement')
    dashboard_url: str = ''
    first_pass_summary: bool = setting(
        True, description='the first pass on a channel sends the events due then as one '
                          'summary message, not one each')
    retry: RetryPolicy = RetryPolicy()
    webhooks: tuple[WebhookConfig, ...] = ()
    email: Optional[EmailConfig] = None
    source: str = '<config>'

    def __post_init__(self) -> None:
        """Check the declared fields (NotificationConfigError naming the source and field)."""
        _checked(self, f'{self.source}: ')

    @property
    def forecast_horizon_s(self) -> float:
        """Return the forecast horizon [s]."""
        return self.forecast_horizon_days * 86400.0

    @property
    def channels(self) -> tuple[str, ...]:
        """Return the channel names (``webhook:NAME`` ..., ``email``)."""
        names = tuple(f'webhook:{hook.name}' for hook in self.webhooks)
        return names + (('email',) if self.email is not None else ())


__all__ = ['DEFAULT_FORECAST_HORIZON_DAYS', 'DEFAULT_REESCALATION_MARGIN',
           'EmailConfig', 'EVENTS', 'NotificationConfig', 'NotificationConfigError',
           'NotifierSettings', 'RetryPolicy', 'SMTP_PORTS', 'WebhookConfig']
