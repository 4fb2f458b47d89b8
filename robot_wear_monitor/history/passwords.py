"""
The password of a PostgreSQL history location, kept out of every message.

A history location is an SQLite path or a PostgreSQL URL; the URL may carry a password in two
forms, ``postgresql://USER:PASSWORD@HOST/DB`` and ``postgresql://USER@HOST/DB?password=...``.
:func:`redact_location` gives the location as it may be shown; :func:`location_secrets` the
strings that must never be printed (the command line's output guard replaces them).  The
documented ways to give a password are PGPASSWORD, ``~/.pgpass`` or a service file (libpq's
own), which keep it out of argv too.
"""

from __future__ import annotations

import os
from urllib.parse import parse_qsl, quote, unquote, urlencode, urlsplit, urlunsplit

_POSTGRESQL_SCHEMES = ('postgresql', 'postgres')
#: query parameters of a libpq URL that hold a secret
SECRET_PARAMETERS = ('password', 'sslpassword')
#: what a password is shown as
HIDDEN = '***'


def _is_url(location: object) -> bool:
    return isinstance(location, str) and '://' in location and \
        location.split('://', 1)[0] in _POSTGRESQL_SCHEMES


def redact_location(location: str | os.PathLike) -> str:
    """Return ``location`` as it may be shown: a URL's password (both forms) as ``***``."""
    text = os.fspath(location)
    if not _is_url(text):
        return text
    try:
        parts = urlsplit(text)
        netloc = parts.netloc
        if '@' in netloc:
            userinfo, host = netloc.rsplit('@', 1)
            if ':' in userinfo:
                netloc = f'{userinfo.split(":", 1)[0]}:{HIDDEN}@{host}'
        query = parse_qsl(parts.query, keep_blank_values=True)
        shown = [(k, HIDDEN if k.lower() in SECRET_PARAMETERS else v) for k, v in query]
        return urlunsplit(parts._replace(netloc=netloc,
                                         query=urlencode(shown, safe='*')))
    except ValueError:  # not a URL after all: show the scheme only
        return text.split('://', 1)[0] + f'://{HIDDEN}'


def location_secrets(location: object) -> list[str]:
    """Return the secrets a location carries, as given and decoded (none for a path)."""
    if not _is_url(location):
        return []
    text = str(location)
    found: list[str] = []
    try:
        parts = urlsplit(text)
        userinfo = parts.netloc.rsplit('@', 1)[0] if '@' in parts.netloc else ''
        if ':' in userinfo:
            found.append(userinfo.split(':', 1)[1])
        for raw in parts.query.split('&'):
            key, _, value = raw.partition('=')
            if unquote(key).lower() in SECRET_PARAMETERS and value:
                found.append(value)
    except ValueError:
        return []
    forms = set()
    for secret in found:
        forms.update({secret, unquote(secret), unquote(secret.replace('+', ' ')),
                      quote(unquote(secret), safe='')})
    return sorted((s for s in forms if s), key=len, reverse=True)
