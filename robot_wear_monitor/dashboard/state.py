"""
What the dashboard keeps between requests: its settings and the pool of open histories.

:class:`HistoryPool` lends each request an open wear history of its own for the request's
time (:func:`robot_wear_monitor.dashboard.deps.get_history`): a connection is never used by two
requests at once, and the histories are opened once, not per request.  A PostgreSQL connection
that was lost (the server restarted, a network fault) is not lent again: a history idle for
more than :data:`CHECK_IDLE_S` is checked before it is lent (one round trip), and one whose
request failed with its connection lost is closed; the pool opens a new one in its place, so
the dashboard answers again within seconds of the server's return, on its own.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
import threading
import time
from typing import Iterator, Optional, TYPE_CHECKING

from robot_wear_monitor.dashboard.server_limits import MAX_WORKERS
from robot_wear_monitor.history import open_history, WearHistory
from robot_wear_monitor.setting_fields import check_settings, in_range, setting

if TYPE_CHECKING:  # the type only; the configuration is read by the command that starts
    from robot_wear_monitor.fleet.notify_config import NotificationConfig

#: How often the pages ask for news [ms] (they get 304 while nothing changed).
POLL_INTERVAL_MS = 5000
#: A pooled history idle longer than this is checked before it is lent [s].
CHECK_IDLE_S = 2.0


class HistoryPool:
    """The open wear histories of a server, each lent to one request at a time."""

    def __init__(self, location: str) -> None:
        """Check that ``location`` is a wear history now (HistoryError when not)."""
        self.location = location
        self._idle: list[tuple[WearHistory, float]] = []
        self._all: list[WearHistory] = []
        self._lock = threading.Lock()
        self._idle.append((self._open(), time.monotonic()))

    def _open(self) -> WearHistory:
        history = open_history(self.location, init=False)
        with self._lock:
            self._all.append(history)
        return history

    def _discard(self, history: WearHistory) -> None:
        with self._lock:
            if history in self._all:
                self._all.remove(history)
        try:
            history.close()
        except Exception:  # noqa: BLE001 - a lost connection: closing it is all there is
            pass

    def _take(self) -> WearHistory:
        """Return an idle history that answers (lost ones closed), else a new one."""
        while True:
            with self._lock:
                history, since = self._idle.pop() if self._idle else (None, 0.0)
            if history is None:
                return self._open()
            if time.monotonic() - since <= CHECK_IDLE_S or history.connection_alive():
                return history
            self._discard(history)

    @contextmanager
    def borrow(self) -> Iterator[WearHistory]:
        """Lend an open history for the block (an idle one that answers, else a new one)."""
        history = self._take()
        try:
            yield history
        except BaseException:
            if not history.connection_alive(check=False):
                self._discard(history)  # lost: the next request gets a new connection
            raise
        finally:
            with self._lock:
                if history in self._all and all(h is not history for h, _ in self._idle):
                    self._idle.append((history, time.monotonic()))

    def close(self) -> None:
        """Close every history this pool opened."""
        with self._lock:
            for history in self._all:
                try:
                    history.close()
                except Exception:  # noqa: BLE001 - closing at shutdown: nothing to do
                    pass
            self._all.clear()
            self._idle.clear()


@dataclass
class DashboardSettings:
    """
    What the app serves: the history, the parameter sets, notifications, sessions.

    ``history``: an SQLite path or a ``postgresql://`` URL; ``params``: parameter-set files
    the estimates may name (beside the packaged ones); ``secret_key``: the session key (a new
    random one when None); ``https``: the session cookie is Secure (served over TLS);
    ``notifications``: the notification configuration (``dashboard --notify CONFIG``, read
    once with :func:`~robot_wear_monitor.fleet.notify_config.load_notification_config` where
    the server starts): the background loop sends with it every ``notify_interval_s``, and
    the pages order by its re-escalation margin; ``max_failures`` and ``window_s``: the login
    rate limit;
    ``behind_tls``: a TLS proxy is in front (the session cookie is Secure although this
    server speaks plain HTTP); ``trusted_proxies``: peer addresses whose ``X-Forwarded-For``
    names the client (the login rate limit counts per client address); ``workers``: server
    processes (``dashboard --workers``; more than 1 needs a PostgreSQL history).
    """

    history: str
    params: tuple[str, ...] = ()
    secret_key: Optional[str] = None
    https: bool = False
    notifications: Optional[NotificationConfig] = None
    notify_interval_s: float = 60.0
    max_failures: int = 5
    window_s: float = 300.0
    poll_interval_ms: int = POLL_INTERVAL_MS
    behind_tls: bool = False
    trusted_proxies: tuple[str, ...] = ()
    workers: int = setting(1, check=in_range(1, MAX_WORKERS),
                           description='server processes on one history (each a uvicorn worker '
                                       'with its own connections; more than 1 needs '
                                       'PostgreSQL)')

    def __post_init__(self) -> None:
        """Check the declared settings (InputError naming the first bad one)."""
        check_settings(self)
