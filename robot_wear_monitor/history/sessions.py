"""
The dashboard's sessions, kept in the wear history (schema version 6).

A login makes a random session id (:func:`secrets.token_urlsafe`, 256 bits) that goes to the
browser in the signed session cookie; the history keeps only its SHA-256 (``id_hash``), the
user, the session's CSRF token and when it expires.  Every request looks the session up:
a logout deletes it, removing a user deletes all of theirs, and an expired one is refused
(and swept at the next login), so a cookie copied before any of these is worth nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
import hashlib
import secrets
import time
from typing import Optional

from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.users import check_user_name


@dataclass(frozen=True)
class Session:
    """A live session: its id (only in the cookie), user, role, CSRF token and expiry [s]."""

    token: str
    user: str
    role: str
    csrf: str
    expires_wall_time_s: float


def secret_digest(secret: str) -> str:
    """
    Return the SHA-256 (hex) a random secret is kept as: a session id, an API token.

    Secrets of 256 random bits need no slow hash; the history never holds the secret itself.
    """
    return hashlib.sha256(secret.encode('utf-8', 'replace')).hexdigest()


def start_session(backend: HistoryBackend, *, user: str, lifetime_s: float,
                  now_s: Optional[float] = None) -> Optional[Session]:
    """
    Start a session of ``user``; return it (None when the user does not exist).

    Expired sessions of every user are swept in the same transaction.

    :param user: a user name of the history.
    :param lifetime_s: how long the session lasts without a new login [s].
    :param now_s: the wall time [s since the epoch] (default: the clock).
    """
    user = check_user_name(user)
    now = time.time() if now_s is None else float(now_s)
    token, csrf = secrets.token_urlsafe(32), secrets.token_urlsafe(32)
    with backend.transaction():
        backend.execute('DELETE FROM sessions WHERE expires_wall_time_s <= ?', (now,))
        rows = backend.execute('SELECT role FROM users WHERE name = ?', (user,))
        if not rows:
            return None
        backend.execute('INSERT INTO sessions (id_hash, user_name, csrf, created_wall_time_s, '
                        'expires_wall_time_s) VALUES (?, ?, ?, ?, ?)',
                        (secret_digest(token), user, csrf, now, now + float(lifetime_s)))
    return Session(token=token, user=user, role=str(rows[0][0]), csrf=csrf,
                   expires_wall_time_s=now + float(lifetime_s))


def find_session(backend: HistoryBackend, *, token: str,
                 now_s: Optional[float] = None) -> Optional[Session]:
    """Return the live session of ``token`` with the user's role now; None when there is none."""
    if not isinstance(token, str) or not 16 <= len(token) <= 128:
        return None
    now = time.time() if now_s is None else float(now_s)
    rows = backend.execute(
        'SELECT s.user_name, u.role, s.csrf, s.expires_wall_time_s FROM sessions s '
        'JOIN users u ON u.name = s.user_name WHERE s.id_hash = ? AND '
        's.expires_wall_time_s > ?', (secret_digest(token), now))
    if not rows:
        return None
    user, role, csrf, expires = rows[0]
    return Session(token=token, user=str(user), role=str(role), csrf=str(csrf),
                   expires_wall_time_s=float(expires))


def end_session(backend: HistoryBackend, *, token: str) -> bool:
    """End the session of ``token``; return whether there was one."""
    with backend.transaction():
        rows = backend.execute('DELETE FROM sessions WHERE id_hash = ? RETURNING user_name',
                               (secret_digest(str(token)),))
    return bool(rows)
