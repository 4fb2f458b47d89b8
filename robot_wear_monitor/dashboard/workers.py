"""
``dashboard --workers N``: N server processes on one listening socket and one PostgreSQL history.

uvicorn's multiprocess supervisor (:class:`uvicorn.supervisors.Multiprocess`) starts N worker
processes (spawned: each imports the app anew), hands each the socket the parent bound, and
starts a new worker in place of one that died.  Each worker builds its app with
:func:`worker_app` (an import-string app factory) from the settings the parent pickled into
uvicorn's configuration (:class:`WorkerConfig`), among them the session key the parent made,
so a session cookie signed by one worker is good on every other.

What the workers share lives in the history, not in a process: the sessions (a login on one
worker is valid on the others, a logout ends it on all), the login rate limit's counts
(``history.login_failures``), the notifications sent (each worker runs the notifier loop of
``--notify``; a send is claimed by a unique row first, so one worker sends it) and what the
pages poll (the fleet's and a joint's ETag are hashes of what the history holds, so a change
written through one worker shows through another at the next poll).  What each worker keeps
for itself: its history connections, its fleet cache (checked against the history's latest
ids at every request) and ``--limit-concurrency`` (per worker).

An SQLite history is refused for N > 1 (``cli/dashboard.py``): SQLite lets one process write
at a time, so the workers would queue on its lock and gain nothing.

With ``ROBOT_WEAR_MONITOR_DASHBOARD_WORKER_PID=1`` in the environment (the tests), every answer
names the worker that made it in the header ``X-Dashboard-Worker`` (its process id); otherwise
no answer names it.
"""

from __future__ import annotations

import os
import socket
from typing import Any, Optional

from robot_wear_monitor.dashboard.app import create_app
from robot_wear_monitor.dashboard.server import header_timeout_protocol
from robot_wear_monitor.dashboard.server_limits import HEADER_TIMEOUT_S, MAX_HEADER_BYTES
from robot_wear_monitor.dashboard.state import DashboardSettings
import uvicorn
from uvicorn.supervisors import Multiprocess

#: The app factory each worker imports (uvicorn's ``factory=True``).
APP_FACTORY = 'robot_wear_monitor.dashboard.workers:worker_app'
#: The environment variable that makes every answer name its worker's process id (tests).
WORKER_PID_ENV = 'ROBOT_WEAR_MONITOR_DASHBOARD_WORKER_PID'
#: The header that names the worker (only with :data:`WORKER_PID_ENV` set to 1).
WORKER_PID_HEADER = 'X-Dashboard-Worker'

#: The settings of this worker, set by :meth:`WorkerConfig.load` before the factory runs.
_SETTINGS: Optional[DashboardSettings] = None


class WorkerHeaderTimeoutProtocol(header_timeout_protocol()):  # type: ignore[misc]
    """The request-header timer of ``server.py``, its timeout read from :class:`WorkerConfig`."""

    @property
    def header_timeout_s(self) -> float:
        """Return how long a request's headers may take [s]."""
        return float(getattr(self.config, 'header_timeout_s', HEADER_TIMEOUT_S))


class WorkerConfig(uvicorn.Config):
    """uvicorn's configuration with the dashboard's settings (pickled into every worker)."""

    def __init__(self, *, settings: DashboardSettings, header_timeout_s: float,
                 **kwargs: Any) -> None:
        """Serve :data:`APP_FACTORY` with ``settings``; ``kwargs``: uvicorn's options."""
        super().__init__(APP_FACTORY, factory=True, **kwargs)
        self.dashboard_settings = settings
        self.header_timeout_s = float(header_timeout_s)

    def load(self) -> None:
        """Hand the settings to :func:`worker_app`, then load the app (in the worker)."""
        global _SETTINGS
        _SETTINGS = self.dashboard_settings
        super().load()


class WorkerPidHeader:
    """Name the worker's process id in every answer (:data:`WORKER_PID_HEADER`; tests only)."""

    def __init__(self, app: Any) -> None:
        """Wrap the ASGI ``app``."""
        self.app = app
        self.pid = str(os.getpid()).encode('ascii')

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        """Pass the request on; add the header to the answer's start."""
        async def named(message: Any) -> None:
            if message['type'] == 'http.response.start':
                message = dict(message)
                message['headers'] = [*message.get('headers', []),
                                      (WORKER_PID_HEADER.lower().encode('ascii'), self.pid)]
            await send(message)
        await self.app(scope, receive, named if scope['type'] == 'http' else send)


def worker_app() -> Any:
    """Return the dashboard app of this worker (uvicorn's app factory, called in the worker)."""
    if _SETTINGS is None:
        raise RuntimeError('worker_app is the app factory of dashboard --workers: it runs in '
                           'a worker that WorkerConfig.load has given its settings')
    app = create_app(_SETTINGS)
    if os.environ.get(WORKER_PID_ENV) == '1':
        app.add_middleware(WorkerPidHeader)
    return app


def serve_workers(settings: DashboardSettings, *, workers: int, host: str, port: int,
                  listener: socket.socket, tls_cert: Optional[str] = None,
                  tls_key: Optional[str] = None, limit_concurrency: int,
                  header_timeout_s: float = HEADER_TIMEOUT_S) -> None:
    """
    Serve the dashboard of ``settings`` in ``workers`` processes until interrupted.

    ``settings.secret_key`` must be set (the parent's key, shared by the workers);
    ``listener``: the socket of :func:`~robot_wear_monitor.dashboard.server.bind_listener`;
    ``limit_concurrency``: connections and requests at once, per worker;
    ``header_timeout_s``: how long a request's headers may take [s].
    """
    if not settings.secret_key:
        raise ValueError('serve_workers needs the session key every worker shares')
    config = WorkerConfig(settings=settings, header_timeout_s=header_timeout_s, host=host,
                          port=port, workers=workers, ssl_certfile=tls_cert,
                          ssl_keyfile=tls_key, log_level='info', proxy_headers=False,
                          server_header=False, limit_concurrency=limit_concurrency,
                          http=WorkerHeaderTimeoutProtocol,
                          h11_max_incomplete_event_size=MAX_HEADER_BYTES)
    Multiprocess(config, sockets=[listener]).run()
