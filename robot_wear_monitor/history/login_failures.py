"""
The login rate limit's counted attempts, kept in the wear history (schema version 13).

Every worker of a dashboard (``dashboard --workers N``, or several servers on one history)
counts login attempts in the same table, so the limit holds for all of them together.  An
attempt is counted under two keys: its client address (any user name), and the (user name,
address) pair; a key refuses more logins once :attr:`LoginFailures.max_failures` of its
attempts lie within the window.  The check and the count of an attempt are one transaction
under one lock (a PostgreSQL advisory lock; SQLite's ``BEGIN IMMEDIATE``), so of many
attempts at once on any number of workers at most ``max_failures`` pass per key.  Rows older
than the window are swept by every write, and the table keeps at most
:data:`MAX_ROWS` rows (the oldest go first).
"""

from __future__ import annotations

from contextlib import AbstractContextManager
import time
from typing import Callable, Optional

from robot_wear_monitor.history.backends import HistoryBackend

#: The advisory lock of the login counts (one for all keys: logins are rare).
_LOGIN_LOCK_KEY = 0x7765617266616C
#: The most rows the table keeps (2 per counted attempt).
MAX_ROWS = 20000
#: Longest user name and address kept [characters] (longer ones are cut: still one key each).
MAX_NAME_CHARS = 256


def _key_rows(user: str, address: str) -> tuple[tuple[str, str, str], tuple[str, str, str]]:
    """Return the (scope, user_name, address) of the two keys of an attempt."""
    address = str(address)[:MAX_NAME_CHARS].replace('\x00', '?')
    user = str(user)[:MAX_NAME_CHARS].replace('\x00', '?')
    return ('address', '', address), ('user', user, address)


class LoginFailures:
    """
    The counted login attempts of one history (the dashboard's login rate limit).

    The same methods as the in-memory
    :class:`~robot_wear_monitor.dashboard.auth.LoginLimiter`; times are wall times [s since
    the epoch] (``clock``), so that the workers, and a restart, agree.
    """

    def __init__(self, backend: HistoryBackend, *,
                 guard: Callable[[str], AbstractContextManager[None]], max_failures: int,
                 window_s: float, clock: Callable[[], float] = time.time) -> None:
        """Count on ``backend``; ``guard(what)`` turns its errors into HistoryError."""
        self._backend = backend
        self._guard = guard
        self.max_failures = int(max_failures)
        self.window_s = float(window_s)
        self._clock = clock

    def _wait(self, keys: tuple, now: float) -> float:
        """Return how long the keys stay refused at ``now`` [s] (0: allowed)."""
        wait = 0.0
        for scope, user, address in keys:
            rows = self._backend.execute(
                'SELECT COUNT(*), MIN(time_s) FROM login_failures WHERE address = ? AND '
                'scope = ? AND user_name = ? AND time_s > ?',
                (address, scope, user, now - self.window_s))
            count, oldest = rows[0]
            if int(count) >= self.max_failures and oldest is not None:
                wait = max(wait, self.window_s - (now - float(oldest)))
        return wait

    def _count(self, keys: tuple, now: float) -> None:
        """Add one attempt under each key; sweep expired rows and keep :data:`MAX_ROWS`."""
        backend = self._backend
        backend.execute('DELETE FROM login_failures WHERE time_s <= ?', (now - self.window_s,))
        for scope, user, address in keys:
            backend.execute('INSERT INTO login_failures (scope, user_name, address, time_s) '
                            'VALUES (?, ?, ?, ?)', (scope, user, address, now))
        over = int(backend.execute('SELECT COUNT(*) FROM login_failures')[0][0]) - MAX_ROWS
        if over > 0:
            backend.execute('DELETE FROM login_failures WHERE id IN (SELECT id FROM '
                            'login_failures ORDER BY time_s, id LIMIT ?)', (over,))

    def retry_after_s(self, *, user: str, address: str) -> float:
        """Return how long a login of ``user`` from ``address`` stays refused [s] (0: allowed)."""
        with self._guard('cannot read the login counts'):
            return self._wait(_key_rows(user, address), self._clock())

    def begin_attempt(self, *, user: str, address: str) -> float:
        """
        Count a login attempt before its password is checked; return 0, or the wait [s].

        The check and the count are one transaction under the lock: of many attempts at once
        on every worker, at most :attr:`max_failures` pass per key.  A refused attempt is not
        counted.
        """
        keys = _key_rows(user, address)
        with self._guard('cannot count the login'), self._backend.transaction():
            self._backend.lock_in_transaction(_LOGIN_LOCK_KEY)
            now = self._clock()  # read under the lock: the counts' times grow in its order
            wait = self._wait(keys, now)
            if wait > 0.0:
                return max(wait, 1e-3)
            self._count(keys, now)
        return 0.0

    def failed(self, *, user: str, address: str) -> None:
        """Count one failed login of ``user`` from ``address`` (an attempt not begun here)."""
        with self._guard('cannot count the login'), self._backend.transaction():
            self._backend.lock_in_transaction(_LOGIN_LOCK_KEY)
            self._count(_key_rows(user, address), self._clock())

    def _drop_newest(self, key: tuple[str, str, str]) -> None:
        scope, user, address = key
        self._backend.execute(
            'DELETE FROM login_failures WHERE id IN (SELECT id FROM login_failures WHERE '
            'address = ? AND scope = ? AND user_name = ? ORDER BY id DESC LIMIT 1)',
            (address, scope, user))

    def not_counted(self, *, user: str, address: str) -> None:
        """Take back an attempt that was not a wrong password (the history could not say)."""
        with self._guard('cannot count the login'), self._backend.transaction():
            self._backend.lock_in_transaction(_LOGIN_LOCK_KEY)
            for key in _key_rows(user, address):
                self._drop_newest(key)

    def succeeded(self, *, user: str, address: Optional[str] = None) -> None:
        """Forget the failures of ``user`` (from ``address``); take the good attempt back."""
        name = str(user)[:MAX_NAME_CHARS].replace('\x00', '?')
        with self._guard('cannot count the login'), self._backend.transaction():
            self._backend.lock_in_transaction(_LOGIN_LOCK_KEY)
            if address is None:
                self._backend.execute("DELETE FROM login_failures WHERE scope = 'user' AND "
                                      'user_name = ?', (name,))
                return
            by_address, (_, name, where) = _key_rows(user, address)
            self._backend.execute('DELETE FROM login_failures WHERE address = ? AND '
                                  "scope = 'user' AND user_name = ?", (where, name))
            self._drop_newest(by_address)
