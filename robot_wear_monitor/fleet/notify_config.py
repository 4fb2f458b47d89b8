"""
The notification configuration: one YAML file, every field checked, unknown keys refused.

The file (``config/notifications.example.yaml`` shows every field) says which events are sent
(``events``), how far ahead a forecast crossing counts (``forecast_horizon_days``), how far the
wear of an acknowledged alarm may rise before it is notified again (``reescalation_margin``,
wear units, default 5), where the
links in the messages point (``dashboard_url``), how hard a send is tried (``retry``), and the
channels: ``webhooks`` (JSON POSTs) and ``email`` (one SMTP server).  Secrets never live in the
file: the SMTP password is read from ``email.password_file`` (relative paths are relative to
the configuration file's folder).  A problem raises :class:`NotificationConfigError` naming the
file and the dotted field (``email.port``), with the value echoed cut short.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import email.utils
import ipaddress
import math
import os
from pathlib import Path
import re
import ssl
from typing import Any, Mapping, Optional
from urllib.parse import urlsplit

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN
from robot_wear_monitor.input_files import MAX_PEM_BYTES, read_text_file
from robot_wear_monitor.yaml_files import load_yaml_file, shorten

#: The events a configuration may name: an alarm latched, a forecast crossing of the wear
#: threshold inside the horizon, a joint without experiments for too long.
EVENTS = ('alarm_raised', 'forecast_crossing', 'joint_stale')
#: The largest password file read [bytes].
MAX_PASSWORD_BYTES = 4096
_CHANNEL_NAME = re.compile(r'[A-Za-z0-9_.-]{1,64}')


class NotificationConfigError(InputError):
    """The notification configuration is invalid; the message names the file and the field."""


@dataclass(frozen=True)
class RetryPolicy:
    """
    How hard one send is tried.

    Within a pass: up to ``attempts`` tries, the n-th retry after ``backoff_initial_s`` x 2^(n-1)
    [s] (at most ``backoff_max_s``), all tries of a send within ``total_s`` [s]; a send whose
    tries all failed is recorded as failed and tried again on later passes, in all on at most
    ``passes`` passes.
    """

    attempts: int = 4
    backoff_initial_s: float = 1.0
    backoff_max_s: float = 30.0
    total_s: float = 120.0
    passes: int = 3

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
    receiver: str = 'robot-wear-monitor'
    timeout_s: float = 10.0


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
    port: int
    sender: str
    to: tuple[str, ...]
    starttls: bool = True
    user: str = ''
    password_file: str = ''
    password: str = field(default='', repr=False)
    ca_file: str = ''
    timeout_s: float = 30.0
    ca_pem: str = field(default='', repr=False)
    name: str = 'email'


@dataclass(frozen=True)
class NotificationConfig:
    """The whole configuration (see the module's text); ``source``: the file it came from."""

    events: tuple[str, ...] = EVENTS
    forecast_horizon_days: float = 30.0
    #: an acknowledged alarm is notified again when its wear rises this much past its value
    #: at the acknowledgement [wear units] (or its planned maintenance date passes)
    reescalation_margin: float = DEFAULT_REESCALATION_MARGIN
    dashboard_url: str = ''
    #: the first pass on a channel (nothing sent on it before) sends the events due then as
    #: one summary message (one webhook POST with every alert, one e-mail), not one each
    first_pass_summary: bool = True
    retry: RetryPolicy = RetryPolicy()
    webhooks: tuple[WebhookConfig, ...] = ()
    email: Optional[EmailConfig] = None
    source: str = '<config>'

    @property
    def forecast_horizon_s(self) -> float:
        """Return the forecast horizon [s]."""
        return self.forecast_horizon_days * 86400.0

    @property
    def channels(self) -> tuple[str, ...]:
        """Return the channel names (``webhook:NAME`` ..., ``email``)."""
        names = tuple(f'webhook:{hook.name}' for hook in self.webhooks)
        return names + (('email',) if self.email is not None else ())


# --------------------------------------------------------------------------- field readers

class _Reader:
    """Checks the fields of one mapping of the file; errors name the file and the dotted field."""

    def __init__(self, source: str, values: Any, where: str, known: tuple[str, ...]) -> None:
        self.source = source
        self.where = where
        if not isinstance(values, Mapping):
            raise self.error('', f'must be a mapping, got {_kind(values)}')
        unknown = sorted(str(key) for key in values if key not in known)
        if unknown:
            raise self.error('', f'unknown key {shorten(repr(unknown[0]))} (known: '
                                 f'{", ".join(known)})')
        self.values = values

    def error(self, name: str, message: str) -> NotificationConfigError:
        dotted = '.'.join(part for part in (self.where, name) if part) or '(top level)'
        return NotificationConfigError(f'{self.source}: {dotted}: {message}')

    def has(self, name: str) -> bool:
        return self.values.get(name) is not None

    def number(self, name: str, default: float, *, low: float, high: float,
               unit: str, integer: bool = False, low_open: bool = False) -> Any:
        value = self.values.get(name, default)
        if value is None:
            value = default
        kind_ok = isinstance(value, int) if integer else isinstance(value, (int, float))
        if isinstance(value, bool) or not kind_ok:
            raise self.error(name, f'must be {"an integer" if integer else "a number"} '
                                   f'[{unit}], got {shorten(repr(value))}')
        inside = math.isfinite(value) and (value > low if low_open else value >= low) \
            and value <= high
        if not inside:
            raise self.error(name, f'must be {">" if low_open else ">="} {low:g} and <= '
                                   f'{high:g} {unit}, got {shorten(value)} {unit}')
        return int(value) if integer else float(value)

    def text(self, name: str, default: Optional[str] = None, *, limit: int = 500) -> str:
        value = self.values.get(name, default)
        if value is None:
            raise self.error(name, 'is required')
        if not isinstance(value, str) or not value.strip():
            raise self.error(name, f'must be a non-empty text, got {shorten(repr(value))}')
        if len(value) > limit or not value.isprintable():
            raise self.error(name, f'must be at most {limit} printable characters, got '
                                   f'{shorten(repr(value))}')
        return value.strip()

    def flag(self, name: str, default: bool) -> bool:
        value = self.values.get(name, default)
        if not isinstance(value, bool):
            raise self.error(name, f'must be true or false, got {shorten(repr(value))}')
        return value


def _kind(value: Any) -> str:
    return 'nothing' if value is None else type(value).__name__


def _http_url(reader: _Reader, name: str, *, required: bool) -> str:
    if not required and not reader.has(name):
        return ''
    url = reader.text(name, limit=2000)
    parts = urlsplit(url)
    if parts.scheme not in ('http', 'https') or not parts.hostname:
        raise reader.error(name, f'must be an http:// or https:// URL with a host, got '
                                 f'{shorten(url)}')
    try:
        parts.port
    except ValueError:
        raise reader.error(name, f'has a bad port: {shorten(url)}') from None
    return url


def _channel_name(reader: _Reader, default: str) -> str:
    name = reader.text('name', default, limit=64)
    if not _CHANNEL_NAME.fullmatch(name):
        raise reader.error('name', f'must be 1-64 of A-Z a-z 0-9 _ . -, got {shorten(name)}')
    return name


def _address(reader: _Reader, name: str, value: Any) -> str:
    if not isinstance(value, str) or not value.isprintable():
        raise reader.error(name, f'must be an e-mail address, got {shorten(repr(value))}')
    _, address = email.utils.parseaddr(value)
    if not re.fullmatch(r'[^@\s<>,;]+@[^@\s<>,;]+', address or ''):
        raise reader.error(name, f'must be an e-mail address, got {shorten(value)}')
    return value.strip()


def _is_loopback(host: str) -> bool:
    if host == 'localhost':
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _resolve(path_text: str, base: Path) -> Path:
    path = Path(os.path.expanduser(path_text))
    return path if path.is_absolute() else base / path


def _ca_file(reader: _Reader, base: Path, starttls: bool) -> tuple[str, str]:
    """Return (path, PEM text) of ``ca_file`` (read bounded: a regular file of at most 1 MB)."""
    if not reader.has('ca_file'):
        return '', ''
    if not starttls:
        raise reader.error('ca_file', 'is only used with starttls: true')
    path = _resolve(reader.text('ca_file', limit=4096), base)
    try:
        pem = read_text_file(path, what='CA file', limit_bytes=MAX_PEM_BYTES)
    except InputError as problem:
        raise reader.error('ca_file', str(problem)) from None
    try:
        ssl.create_default_context(cadata=pem)
    except (ssl.SSLError, ValueError) as problem:
        raise reader.error('ca_file', f'{shorten(path, 200)}: not PEM certificates '
                           f'({shorten(problem)})') from None
    return str(path), pem


def _read_password(reader: _Reader, path_text: str, base: Path) -> str:
    """Return the password of ``password_file`` (read bounded: a regular file, 4 kB)."""
    path = _resolve(path_text, base)
    try:
        text = read_text_file(path, what='password file', limit_bytes=MAX_PASSWORD_BYTES)
    except InputError as problem:  # the message names the file, never its content
        raise reader.error('password_file', str(problem)) from None
    password = text.rstrip('\r\n')
    if not password or '\n' in password:
        raise reader.error('password_file', f'{shorten(path, 200)}: must hold the password '
                           'on one line')
    return password


# --------------------------------------------------------------------------- the sections

def _retry(source: str, values: Any) -> RetryPolicy:
    if values is None:
        return RetryPolicy()
    reader = _Reader(source, values, 'retry', ('attempts', 'backoff_initial_s',
                                               'backoff_max_s', 'total_s', 'passes'))
    default = RetryPolicy()
    return RetryPolicy(
        attempts=reader.number('attempts', default.attempts, low=1, high=20, unit='tries',
                               integer=True),
        backoff_initial_s=reader.number('backoff_initial_s', default.backoff_initial_s,
                                        low=0.0, high=3600.0, unit='s'),
        backoff_max_s=reader.number('backoff_max_s', default.backoff_max_s, low=0.0,
                                    high=3600.0, unit='s'),
        total_s=reader.number('total_s', default.total_s, low=0.0, high=86400.0, unit='s',
                              low_open=True),
        passes=reader.number('passes', default.passes, low=1, high=1000, unit='passes',
                             integer=True))


def _webhooks(source: str, values: Any) -> tuple[WebhookConfig, ...]:
    if values is None:
        return ()
    if not isinstance(values, list):
        raise NotificationConfigError(f'{source}: webhooks: must be a list of webhooks, got '
                                      f'{_kind(values)}')
    hooks = []
    for index, item in enumerate(values):
        reader = _Reader(source, item, f'webhooks[{index}]',
                         ('name', 'url', 'receiver', 'timeout_s'))
        hooks.append(WebhookConfig(
            name=_channel_name(reader, f'webhook-{index + 1}'),
            url=_http_url(reader, 'url', required=True),
            receiver=reader.text('receiver', WebhookConfig.receiver, limit=200),
            timeout_s=reader.number('timeout_s', WebhookConfig.timeout_s, low=0.0,
                                    high=600.0, unit='s', low_open=True)))
    names = [hook.name for hook in hooks]
    for name in names:
        if names.count(name) > 1:
            raise NotificationConfigError(f'{source}: webhooks: two webhooks named '
                                          f'{shorten(name)}')
    return tuple(hooks)


def _email(source: str, values: Any, base: Path) -> Optional[EmailConfig]:
    if values is None:
        return None
    reader = _Reader(source, values, 'email', ('host', 'port', 'starttls', 'user',
                                               'password_file', 'from', 'to', 'ca_file',
                                               'timeout_s'))
    host = reader.text('host', limit=253)
    if any(c in host for c in ' /@:') and not _is_ip(host):
        raise reader.error('host', f'must be a host name or address, got {shorten(host)}')
    starttls = reader.flag('starttls', True)
    user = reader.text('user') if reader.has('user') else ''
    password_file = reader.text('password_file', limit=4096) if reader.has('password_file') \
        else ''
    if bool(user) != bool(password_file):
        raise reader.error('password_file' if user else 'user',
                           'user and password_file go together (the password is never in '
                           'this file)')
    if user and not starttls and not _is_loopback(host):
        raise reader.error('starttls', 'must be true to log in to a server that is not on '
                                       'the loopback (the password would go in clear)')
    to_value = values.get('to')
    if isinstance(to_value, str):
        to_value = [to_value]
    if not isinstance(to_value, list) or not to_value:
        raise reader.error('to', f'must be an address or a list of addresses, got '
                                 f'{shorten(repr(to_value))}')
    if len(to_value) > 100:
        raise reader.error('to', f'{len(to_value)} addresses, more than 100')
    ca_file, ca_pem = _ca_file(reader, base, starttls)
    return EmailConfig(
        host=host,
        port=reader.number('port', 587 if starttls else 25, low=1, high=65535, unit='(TCP)',
                           integer=True),
        sender=_address(reader, 'from', values.get('from')),
        to=tuple(_address(reader, f'to[{i}]', item) for i, item in enumerate(to_value)),
        starttls=starttls, user=user, password_file=password_file,
        password=_read_password(reader, password_file, base) if password_file else '',
        ca_file=ca_file, ca_pem=ca_pem,
        timeout_s=reader.number('timeout_s', EmailConfig.timeout_s, low=0.0, high=600.0,
                                unit='s', low_open=True))


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def notification_config_from_mapping(values: Any, *, source: str = '<config>',
                                     base: Optional[Path] = None) -> NotificationConfig:
    """
    Return the configuration of a parsed YAML document (``source`` names it in errors).

    ``base``: the folder relative password files are read from (default: the current one).
    """
    reader = _Reader(source, values, '', ('events', 'forecast_horizon_days', 'dashboard_url',
                                          'reescalation_margin', 'first_pass_summary',
                                          'retry', 'webhooks', 'email'))
    events = values.get('events', list(EVENTS))
    if not isinstance(events, list) or not events:
        raise reader.error('events', f'must be a non-empty list of {", ".join(EVENTS)}, got '
                                     f'{shorten(repr(events))}')
    for index, event in enumerate(events):
        if event not in EVENTS:
            raise reader.error(f'events[{index}]', f'must be one of {", ".join(EVENTS)}, got '
                                                   f'{shorten(repr(event))}')
    webhooks = _webhooks(source, values.get('webhooks'))
    mail = _email(source, values.get('email'), base or Path.cwd())
    if not webhooks and mail is None:
        raise reader.error('', 'names no channel: give webhooks, email or both')
    dashboard_url = _http_url(reader, 'dashboard_url', required=False).rstrip('/')
    return NotificationConfig(
        events=tuple(e for e in EVENTS if e in events),
        forecast_horizon_days=reader.number('forecast_horizon_days', 30.0, low=0.0,
                                            high=3650.0, unit='days'),
        reescalation_margin=reader.number('reescalation_margin', DEFAULT_REESCALATION_MARGIN,
                                          low=0.0, high=100.0, unit='wear units',
                                          low_open=True),
        dashboard_url=dashboard_url,
        first_pass_summary=reader.flag('first_pass_summary', True),
        retry=_retry(source, values.get('retry')),
        webhooks=webhooks, email=mail, source=source)


def load_notification_config(path: str | os.PathLike) -> NotificationConfig:
    """
    Return the notification configuration of the YAML file at ``path``.

    Raises :class:`NotificationConfigError` (exit 2 on the command line) naming the file and
    the field of the first problem: a missing or unreadable file, bad YAML, an unknown key, a
    value of the wrong kind or out of range, an unreadable password file.
    """
    document = load_yaml_file(path, what='notification configuration',
                              error=NotificationConfigError)
    return notification_config_from_mapping(document, source=str(path),
                                            base=Path(path).absolute().parent)
