"""
The dashboard's API tokens, kept in the wear history (schema version 7): one user each.

A maintenance-management system acknowledges and resets alarms through the JSON API with a
token of a user (``Authorization: Bearer TOKEN``); it acts as that user, with that user's role
read at every request.  A token is :data:`TOKEN_PREFIX` and 256 random bits
(:func:`secrets.token_urlsafe`); it is shown once, when made, and the history keeps only its
SHA-256 (a token this random needs no slow hash), the user, a label, when it was made and
when it was last used (to :data:`LAST_USE_RESOLUTION_S`).  Removing the user removes their
tokens (``users.remove_user``); a token is only honoured while its user exists.
"""

from __future__ import annotations

from dataclasses import dataclass
import secrets
import time
from typing import Any, Optional

from robot_wear_monitor.history.account_audit import Actor, record
from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.records import HistoryError
from robot_wear_monitor.history.sessions import secret_digest
from robot_wear_monitor.history.users import check_user_name

#: The start of every token (so that a leaked one is recognisable, e.g. by secret scanners).
TOKEN_PREFIX = 'rwm_'
#: How finely the last use of a token is kept [s] (a use within this of the last one is not
#: written again: a client polling the API does not write at every request).
LAST_USE_RESOLUTION_S = 60.0
#: Longest label of a token [characters].
MAX_LABEL_CHARS = 128


@dataclass(frozen=True)
class ApiToken:
    """
    An API token as listed: never the token itself.

    ``id``: its number (to remove it); ``user``; ``label``: what it is for;
    ``created_wall_time_s`` and ``last_used_wall_time_s`` (None: never used) [s since the
    epoch].
    """

    id: int  # noqa: A003 - the history's column name
    user: str
    label: str
    created_wall_time_s: float
    last_used_wall_time_s: Optional[float]


@dataclass(frozen=True)
class TokenUser:
    """The user a presented token acts as: name, role now, and the token's id."""

    user: str
    role: str
    token_id: int


def _label(value: object) -> str:
    text = '' if value is None else str(value).strip()
    if len(text) > MAX_LABEL_CHARS or not text.isprintable():
        raise HistoryError(f'a token label is at most {MAX_LABEL_CHARS} printable characters, '
                           f'got {text[:40]!r}')
    return text


def add_token(backend: HistoryBackend, *, user: str, label: str = '',
              now_s: Optional[float] = None, by: Optional[Actor] = None
              ) -> tuple[ApiToken, str]:
    """
    Make an API token of ``user``; return it as listed and the token (shown once).

    Audited as made ``by`` (its id and label; never the token).

    Raises :class:`HistoryError` when there is no such user or the label is too long.
    """
    user = check_user_name(user)
    label = _label(label)
    token = TOKEN_PREFIX + secrets.token_urlsafe(32)
    now = time.time() if now_s is None else float(now_s)
    with backend.transaction():
        if not backend.execute('SELECT 1 FROM users WHERE name = ?', (user,)):
            raise HistoryError(f'{backend.name}: no user {user!r}')
        rows = backend.execute('INSERT INTO api_tokens (user_name, token_hash, label, '
                               'created_wall_time_s) VALUES (?, ?, ?, ?) RETURNING id',
                               (user, secret_digest(token), label, now))
        record(backend, by=by, action='token_added', target=user,
               detail=f'token {int(rows[0][0])}' + (f' ({label})' if label else ''), now_s=now)
    return ApiToken(id=int(rows[0][0]), user=user, label=label, created_wall_time_s=now,
                    last_used_wall_time_s=None), token


def list_tokens(backend: HistoryBackend, *, user: Optional[str] = None) -> list[ApiToken]:
    """Return the tokens (of ``user``, else of everybody), by user and id; never the tokens."""
    query = ('SELECT id, user_name, label, created_wall_time_s, last_used_wall_time_s '
             'FROM api_tokens')
    params: tuple = ()
    if user is not None:
        query += ' WHERE user_name = ?'
        params = (check_user_name(user),)
    rows = backend.execute(query + ' ORDER BY user_name, id', params)
    return [ApiToken(id=int(r[0]), user=r[1], label=r[2], created_wall_time_s=float(r[3]),
                     last_used_wall_time_s=None if r[4] is None else float(r[4])) for r in rows]


def remove_tokens(backend: HistoryBackend, *, user: str,
                  token_id: Optional[int] = None, by: Optional[Actor] = None) -> int:
    """
    Remove the token ``token_id`` of ``user`` (None: all of theirs); return how many.

    Audited as made ``by`` (the ids removed).

    Raises :class:`HistoryError` when there was none to remove.
    """
    user = check_user_name(user)
    query = 'DELETE FROM api_tokens WHERE user_name = ?'
    params: list[Any] = [user]
    if token_id is not None:
        if isinstance(token_id, bool) or not isinstance(token_id, int) or token_id < 1:
            raise HistoryError(f'a token id is an integer >= 1, got {str(token_id)[:40]!r}')
        query += ' AND id = ?'
        params.append(token_id)
    with backend.transaction():
        rows = backend.execute(query + ' RETURNING id', params)
        if rows:
            record(backend, by=by, action='tokens_removed', target=user,
                   detail='token(s) ' + ', '.join(str(int(r[0])) for r in sorted(rows)))
    if not rows:
        which = f'token {token_id} of user' if token_id is not None else 'token of user'
        raise HistoryError(f'{backend.name}: no {which} {user!r}')
    return len(rows)


def find_token(backend: HistoryBackend, *, token: str,
               now_s: Optional[float] = None) -> Optional[TokenUser]:
    """Return who ``token`` acts as (their role now); None for an unknown or orphaned token."""
    if not isinstance(token, str) or not token.startswith(TOKEN_PREFIX) or \
            not 20 <= len(token) <= 128:
        return None
    rows = backend.execute(
        'SELECT t.id, t.user_name, u.role, t.last_used_wall_time_s FROM api_tokens t '
        'JOIN users u ON u.name = t.user_name WHERE t.token_hash = ?', (secret_digest(token),))
    if not rows:
        return None
    token_id, user, role, last_used = rows[0]
    now = time.time() if now_s is None else float(now_s)
    if last_used is None or now - float(last_used) >= LAST_USE_RESOLUTION_S:
        with backend.transaction():
            backend.execute('UPDATE api_tokens SET last_used_wall_time_s = ? WHERE id = ?',
                            (now, int(token_id)))
    return TokenUser(user=str(user), role=str(role), token_id=int(token_id))
