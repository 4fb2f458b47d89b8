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

from robot_wear_monitor.dashboard.auth import MAX_FAILURES, WINDOW_S
from robot_wear_monitor.dashboard.server_limits import ServerSettings
from robot_wear_monitor.display_time import DisplayTimeConfig
from robot_wear_monitor.fleet.notify_settings import NotifierSettings
from robot_wear_monitor.history import open_history, WearHistory
from robot_wear_monitor.setting_fields import check_settings, in_range, setting, shared_setting

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
    random one when None); ``notifications``: the notification configuration (``dashboard
    --notify CONFIG``, read once with
    :func:`~robot_wear_monitor.fleet.notify_config.load_notification_config` where the server
    starts): the background loop sends with it every ``notify_interval_s``, and the pages
    order by its re-escalation margin; ``trusted_proxies``: peer addresses whose
    ``X-Forwarded-For`` names the client (the login rate limit counts per client address);
    ``display_timezone``: the IANA zone of the times the pages show (declared by
    :class:`~robot_wear_monitor.display_time.DisplayTimeConfig`; the API's times stay UTC).
    ``workers``: server processes (``dashboard --workers``; more than 1 needs a PostgreSQL
    history). The other fields are declared settings (default, unit, description, check: a
    bad value is an :class:`~robot_wear_monitor.errors.InputError` naming the field, the value
    and the range, from Python as from the command line).
    """

    history: str
    params: tuple[str, ...] = ()
    secret_key: Optional[str] = None
    https: bool = setting(False, description='serve HTTPS: the session cookie is Secure')
    notifications: Optional[NotificationConfig] = None
    notify_interval_s: float = shared_setting(
        NotifierSettings, 'interval_s',
        description='time between two notification passes of the server (with --notify)')
    max_failures: int = setting(
        MAX_FAILURES, check=in_range(1, 1000),
        description='failed logins allowed per user name and per client address within the '
                    'login window')
    window_s: float = setting(WINDOW_S, unit='s', check=in_range(1.0, 86400.0),
                              description='the window of the login rate limit')
    poll_interval_ms: int = setting(
        POLL_INTERVAL_MS, unit='ms', check=in_range(100, 600000),
        description='how often the pages ask for news (304 while nothing changed)')
    behind_tls: bool = setting(
        False, description='a TLS proxy is in front: the session cookie is Secure although '
                           'this server speaks plain HTTP')
    trusted_proxies: tuple[str, ...] = ()
    display_timezone: str = shared_setting(DisplayTimeConfig, 'display_timezone')
    workers: int = shared_setting(ServerSettings, 'workers')

    def __post_init__(self) -> None:
        """Check the declared settings (InputError naming the setting, value and range)."""
        check_settings(self, prefix='dashboard settings: ')
