"""
The dashboard's users, kept in the wear history (schema version 5): name, role, argon2 hash.

Three roles (:data:`ROLES`): ``viewer`` reads; ``maintainer`` may also acknowledge and reset
alarms; ``admin`` (schema version 7) may also manage the users.  Removing a user ends their
sessions and API tokens in the same transaction; a new password ends their sessions.  Passwords
are hashed with argon2id (argon2-cffi's :class:`~argon2.PasswordHasher`, its default cost);
the plain password is never stored.  :func:`verify_user` spends one hash verification also for
an unknown name, so that the time of a login does not tell which names exist; a hash made with
an older cost is rehashed on the next good login.
"""

from __future__ import annotations

from dataclasses import dataclass
import re
import time
from typing import Any, Optional

from robot_wear_monitor.history.account_audit import Actor, record
from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.records import HistoryError

#: The roles of the dashboard's users: a viewer reads, a maintainer also acknowledges and
#: resets alarms, an admin also manages the users (the one definition: the dashboard and its
#: command line import it; the history's CHECK of schema version 7 admits these).
ROLES = ('viewer', 'maintainer', 'admin')
#: The roles that may acknowledge and reset alarms.
ACTING_ROLES = ('maintainer', 'admin')
#: The role that manages the users.
ADMIN_ROLE = 'admin'
#: What each role may do, in words (for help texts and pages).
ROLE_TEXTS = {'viewer': 'reads', 'maintainer': 'also acknowledges and resets alarms',
              'admin': 'also manages the users'}
#: Shortest password [characters].
MIN_PASSWORD_CHARS = 8
#: Longest password [characters] (a bound on the work of one login).
MAX_PASSWORD_CHARS = 1024

_NAME = re.compile(r'[A-Za-z0-9_.@-]{1,64}')


@dataclass(frozen=True)
class User:
    """A dashboard user: name, role (one of :data:`ROLES`), created [s since the epoch]."""

    name: str
    role: str
    created_wall_time_s: float


def _hasher() -> Any:
    try:
        # deferred import: optional extra 'dashboard' (argon2)
        from argon2 import PasswordHasher
    except ImportError:
        raise HistoryError('dashboard users need argon2-cffi: pip install '
                           '"robot_wear_monitor[dashboard]"') from None
    return PasswordHasher()


_DUMMY_HASH: Optional[str] = None


def _dummy_hash(hasher: Any) -> str:
    """Return a hash to verify against for an unknown name (made once per process)."""
    global _DUMMY_HASH
    if _DUMMY_HASH is None:
        _DUMMY_HASH = hasher.hash('not a password of anyone')
    return _DUMMY_HASH


def check_user_name(name: Any) -> str:
    """Return ``name`` when it is 1-64 of A-Z a-z 0-9 _ . @ -; else :class:`HistoryError`."""
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise HistoryError('a user name is 1-64 characters of A-Z a-z 0-9 _ . @ -, got '
                           f'{str(name)[:40]!r}')
    return name


def check_role(role: Any) -> str:
    """Return ``role`` when it is a known role; else :class:`HistoryError`."""
    if role not in ROLES:
        raise HistoryError(f'a user role is {", ".join(ROLES[:-1])} or {ROLES[-1]}, got '
                           f'{str(role)[:40]!r}')
    return str(role)


def check_password(name: str, password: Any) -> str:
    """
    Return ``password`` when it may be one; else :class:`HistoryError`.

    A password has :data:`MIN_PASSWORD_CHARS` to :data:`MAX_PASSWORD_CHARS` characters.
    """
    if not isinstance(password, str) or len(password) < MIN_PASSWORD_CHARS:
        raise HistoryError(f'the password of user {name!r} must have at least '
                           f'{MIN_PASSWORD_CHARS} characters')
    if len(password) > MAX_PASSWORD_CHARS:
        raise HistoryError(f'the password of user {name!r} must have at most '
                           f'{MAX_PASSWORD_CHARS} characters')
    return password


def add_user(backend: HistoryBackend, *, name: str, role: str, password: str,
             by: Optional[Actor] = None) -> User:
    """
    Add a user with the argon2 hash of ``password``; return it (audited as made ``by``).

    Raises :class:`HistoryError` when the name is taken or not allowed, the role unknown, or
    the password empty, shorter than :data:`MIN_PASSWORD_CHARS` or longer than
    :data:`MAX_PASSWORD_CHARS`.
    """
    name = check_user_name(name)
    role = check_role(role)
    password_hash = _hasher().hash(check_password(name, password))
    now = time.time()
    with backend.transaction():
        rows = backend.execute(
            'INSERT INTO users (name, role, password_hash, created_wall_time_s) '
            'VALUES (?, ?, ?, ?) ON CONFLICT (name) DO NOTHING RETURNING name',
            (name, role, password_hash, now))
        if rows:
            record(backend, by=by, action='user_added', target=name, detail=f'role {role}',
                   now_s=now)
    if not rows:
        raise HistoryError(f'{backend.name}: user {name!r} exists already')
    return User(name=name, role=role, created_wall_time_s=now)


#: The advisory lock of a change that may leave no admin (any constant; 'wear' 'adm').
_ADMINS_LOCK_KEY = 0x7765617261646D


def _keep_an_admin(backend: HistoryBackend, name: str) -> None:
    """Refuse (inside the caller's transaction) a change that left no admin."""
    if not backend.execute('SELECT name FROM users WHERE role = ? LIMIT 1', (ADMIN_ROLE,)):
        raise HistoryError(f'{backend.name}: {name!r} is the last admin: make another user an '
                           'admin first')


def remove_user(backend: HistoryBackend, *, name: str, keep_an_admin: bool = False,
                by: Optional[Actor] = None) -> None:
    """
    Remove the user ``name``, their sessions and tokens; :class:`HistoryError` when none.

    Audited as made ``by`` (with how many tokens went).

    ``keep_an_admin``: refuse to remove the last admin (the Users page; checked in the same
    transaction under a lock, so two admins removing each other at once leave one).
    """
    name = check_user_name(name)
    with backend.transaction():
        if keep_an_admin:
            backend.lock_in_transaction(_ADMINS_LOCK_KEY)
        rows = backend.execute('DELETE FROM users WHERE name = ? RETURNING name', (name,))
        if rows:  # the user's sessions (schema version 6) and tokens (7) end with them
            _end_sessions(backend, name)
            tokens = backend.execute('DELETE FROM api_tokens WHERE user_name = ? RETURNING id',
                                     (name,))
            if keep_an_admin:
                _keep_an_admin(backend, name)
            record(backend, by=by, action='user_removed', target=name,
                   detail=f'{len(tokens)} API token(s) removed with them')
    if not rows:
        raise HistoryError(f'{backend.name}: no user {name!r}')


def set_password(backend: HistoryBackend, *, name: str, password: str,
                 by: Optional[Actor] = None) -> int:
    """
    Give the user ``name`` a new password; end their sessions; return how many ended.

    Audited as made ``by`` (never the password).

    Raises :class:`HistoryError` when there is no such user or the password may not be one
    (:func:`check_password`).  Their API tokens stay (a token is not a password).
    """
    name = check_user_name(name)
    password_hash = _hasher().hash(check_password(name, password))
    with backend.transaction():
        rows = backend.execute('UPDATE users SET password_hash = ? WHERE name = ? '
                               'RETURNING name', (password_hash, name))
        ended = _end_sessions(backend, name) if rows else 0
        if rows:
            record(backend, by=by, action='password_changed', target=name,
                   detail=f'{ended} session(s) ended')
    if not rows:
        raise HistoryError(f'{backend.name}: no user {name!r}')
    return ended


def _end_sessions(backend: HistoryBackend, name: str) -> int:
    """End every session of user ``name`` (inside the caller's transaction); return how many."""
    return len(backend.execute('DELETE FROM sessions WHERE user_name = ? RETURNING id_hash',
                               (name,)))


def set_role(backend: HistoryBackend, *, name: str, role: str,
             keep_an_admin: bool = False, by: Optional[Actor] = None) -> User:
    """
    Give the user ``name`` the role ``role``; return the user.

    The role counts at once, for their live sessions and tokens too (each request reads it).
    Raises :class:`HistoryError` when there is no such user or the role is unknown, and with
    ``keep_an_admin`` when the change would leave no admin (as :func:`remove_user`).  Audited
    as made ``by`` (the old and the new role).
    """
    name = check_user_name(name)
    role = check_role(role)
    with backend.transaction():
        if keep_an_admin:
            backend.lock_in_transaction(_ADMINS_LOCK_KEY)
        old = backend.execute('SELECT role FROM users WHERE name = ?', (name,))
        rows = backend.execute('UPDATE users SET role = ? WHERE name = ? '
                               'RETURNING name, role, created_wall_time_s', (role, name))
        if rows and keep_an_admin:
            _keep_an_admin(backend, name)
        if rows:
            record(backend, by=by, action='role_changed', target=name,
                   detail=f'{old[0][0] if old else "?"} -> {role}')
    if not rows:
        raise HistoryError(f'{backend.name}: no user {name!r}')
    return User(name=rows[0][0], role=rows[0][1], created_wall_time_s=float(rows[0][2]))


def list_users(backend: HistoryBackend) -> list[User]:
    """Return the users, sorted by name."""
    return [User(name=row[0], role=row[1], created_wall_time_s=float(row[2]))
            for row in backend.execute(
                'SELECT name, role, created_wall_time_s FROM users ORDER BY name')]


def verify_user(backend: HistoryBackend, *, name: str, password: str) -> Optional[User]:
    """
    Return the user when ``password`` is theirs; None otherwise (also for unknown names).

    An unknown or malformed name costs one argon2 verification too (against a dummy hash).
    """
    hasher = _hasher()
    # deferred import: optional extra 'dashboard' (argon2)
    from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError
    rows = []
    if isinstance(name, str) and _NAME.fullmatch(name):
        rows = backend.execute('SELECT name, role, created_wall_time_s, password_hash FROM '
                               'users WHERE name = ?', (name,))
    stored = rows[0][3] if rows else _dummy_hash(hasher)
    given = password if isinstance(password, str) else ''
    try:
        hasher.verify(stored, given[:MAX_PASSWORD_CHARS + 1])
    except (VerifyMismatchError, VerificationError, InvalidHashError):
        return None
    if not rows or len(given) > MAX_PASSWORD_CHARS:
        return None
    if hasher.check_needs_rehash(stored):
        with backend.transaction():
            backend.execute('UPDATE users SET password_hash = ? WHERE name = ? AND '
                            'password_hash = ?', (hasher.hash(given), name, stored))
    return User(name=rows[0][0], role=rows[0][1], created_wall_time_s=float(rows[0][2]))
