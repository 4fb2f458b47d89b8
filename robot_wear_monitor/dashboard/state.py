"""
What the dashboard keeps between requests: its settings and the pool of open histories.

:class:`HistoryPool` lends each request an open wear history of its own for the request's
time (:func:`robot_wear_monitor.dashboard.deps.get_history`): a connection is never used by two
requests at once, and the histories are opened once, not per request.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
import threading
from typing import Iterator, Optional, TYPE_CHECKING

from robot_wear_monitor.history import open_history, WearHistory

if TYPE_CHECKING:  # the type only; the configuration is read by the command that starts
    from robot_wear_monitor.fleet.notify_config import NotificationConfig

#: How often the pages ask for news [ms] (they get 304 while nothing changed).
POLL_INTERVAL_MS = 5000


class HistoryPool:
    """The open wear histories of a server, each lent to one request at a time."""

    def __init__(self, location: str) -> None:
        """Check that ``location`` is a wear history now (HistoryError when not)."""
        self.location = location
        self._idle: list[WearHistory] = []
        self._all: list[WearHistory] = []
        self._lock = threading.Lock()
        self._idle.append(self._open())

    def _open(self) -> WearHistory:
        history = open_history(self.location, init=False)
        with self._lock:
            self._all.append(history)
        return history

    @contextmanager
    def borrow(self) -> Iterator[WearHistory]:
        """Lend an open history for the block (an idle one, else a new one)."""
        with self._lock:
            history = self._idle.pop() if self._idle else None
        if history is None:
            history = self._open()
        try:
            yield history
        finally:
            with self._lock:
                if history in self._all:  # not closed meanwhile
                    self._idle.append(history)

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
    rate limit.
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
