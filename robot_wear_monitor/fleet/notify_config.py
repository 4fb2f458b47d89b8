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

The settings themselves (default, unit, description and range of each field) are declared once
on the dataclasses of :mod:`robot_wear_monitor.fleet.notify_settings`; this reader checks a
file's values with those declarations.
"""

from __future__ import annotations

import email.utils
import ipaddress
import math
import os
from pathlib import Path
import re
import ssl
from typing import Any, Mapping, Optional, Type
from urllib.parse import urlsplit

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.fleet.notify_settings import (EmailConfig, EVENTS, NotificationConfig,
                                                      NotificationConfigError, RetryPolicy,
                                                      SMTP_PORTS, WebhookConfig)
from robot_wear_monitor.input_files import MAX_PEM_BYTES, read_text_file
from robot_wear_monitor.setting_fields import setting_of
from robot_wear_monitor.yaml_files import load_yaml_file, shorten

__all__ = ['EmailConfig', 'EVENTS', 'load_notification_config', 'MAX_PASSWORD_BYTES',
           'notification_config_from_mapping', 'NotificationConfig', 'NotificationConfigError',
           'RetryPolicy', 'WebhookConfig']

#: The largest password file read [bytes].
MAX_PASSWORD_BYTES = 4096
_CHANNEL_NAME = re.compile(r'[A-Za-z0-9_.-]{1,64}')


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

    def setting(self, owner: Type[Any], name: str, *, key: Optional[str] = None,
                default: Any = None) -> Any:
        """
        Return the value of the declared setting ``name`` of ``owner``, checked by its check.

        ``key``: the file's key (default ``name``); ``default``: when the file has none
        (default: the declared one).  The error names the field, the value (cut short and
        escaped), the range and the unit.
        """
        declared = setting_of(owner, name)
        key = key or name
        value = self.values.get(key)
        if value is None:
            value = declared.default if default is None else default
        unit = f' {declared.unit}' if declared.unit not in ('', '-') else ''
        if declared.kind == 'bool':
            if not isinstance(value, bool):
                raise self.error(key, f'must be true or false, got {shorten(repr(value))}')
            return value
        integer = declared.kind == 'int'
        kind_ok = isinstance(value, int) if integer else isinstance(value, (int, float))
        if isinstance(value, bool) or not kind_ok:
            raise self.error(key, f'must be {"an integer" if integer else "a number"}'
                                  f'{unit}, got {shorten(repr(value))}')
        problem = declared.check(value) if declared.check is not None else None
        if problem is None and not math.isfinite(value):
            problem = 'must be finite'
        if problem:
            raise self.error(key, f'{problem}{unit}, got {shorten(value)}{unit}')
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
    return RetryPolicy(**{name: reader.setting(RetryPolicy, name) for name in (
        'attempts', 'backoff_initial_s', 'backoff_max_s', 'total_s', 'passes')})


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
            receiver=reader.text('receiver', setting_of(WebhookConfig, 'receiver').default,
                                 limit=200),
            timeout_s=reader.setting(WebhookConfig, 'timeout_s')))
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
    starttls = reader.setting(EmailConfig, 'starttls')
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
        port=reader.setting(EmailConfig, 'port', default=SMTP_PORTS[starttls]),
        sender=_address(reader, 'from', values.get('from')),
        to=tuple(_address(reader, f'to[{i}]', item) for i, item in enumerate(to_value)),
        starttls=starttls, user=user, password_file=password_file,
        password=_read_password(reader, password_file, base) if password_file else '',
        ca_file=ca_file, ca_pem=ca_pem,
        timeout_s=reader.setting(EmailConfig, 'timeout_s'))


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
        forecast_horizon_days=reader.setting(NotificationConfig, 'forecast_horizon_days'),
        reescalation_margin=reader.setting(NotificationConfig, 'reescalation_margin'),
        dashboard_url=dashboard_url,
        first_pass_summary=reader.setting(NotificationConfig, 'first_pass_summary'),
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
