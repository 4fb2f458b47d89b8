"""
The dashboard's ASGI application: FastAPI with Jinja2 pages, its own static files, sessions.

:func:`create_app` builds the app for one wear history.  Everything the browser loads comes
from here (no CDN): the app's style and scripts (``static/``), Plotly.js from the installed
``plotly`` Python package and Swagger UI from ``fastapi-offline`` (the OpenAPI page
``/docs``).  FastAPI's own ``/docs`` (which loads Swagger UI from a CDN) is off.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import os
from pathlib import Path
import threading
from typing import Any, Optional

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles
import jinja2
from robot_wear_monitor import __version__
from robot_wear_monitor.dashboard.auth import LoginLimiter, new_secret_key, RequireSession
from robot_wear_monitor.dashboard.views import FleetCache, ParameterSets
from starlette.middleware.sessions import SessionMiddleware
from starlette.responses import FileResponse

HERE = Path(__file__).resolve().parent
#: How long a session lasts without a new login [s].
SESSION_MAX_AGE_S = 12 * 3600
#: How often the pages ask for news [ms] (they get 304 while nothing changed).
POLL_INTERVAL_MS = 5000


def plotly_js_path() -> Path:
    """Return plotly.min.js of the installed ``plotly`` Python package."""
    import plotly
    return Path(plotly.__file__).resolve().parent / 'package_data' / 'plotly.min.js'


def swagger_ui_folder() -> Path:
    """
    Return the Swagger UI 5 files of the installed ``fastapi-offline`` package.

    (Swagger UI 5 reads the OpenAPI 3.1 that FastAPI writes; 4.x does not.)
    """
    import fastapi_offline
    return Path(fastapi_offline.__file__).resolve().parent / 'static'


class HistoryPool:
    """One open wear history per server thread (connections are not shared across threads)."""

    def __init__(self, location: str) -> None:
        """Check that ``location`` is a wear history now (HistoryError when not)."""
        from robot_wear_monitor.history import open_history
        self.location = location
        self._open = open_history
        self._local = threading.local()
        self._all: list[Any] = []
        self._lock = threading.Lock()
        self.get()

    def get(self) -> Any:
        """Return this thread's open history."""
        history = getattr(self._local, 'history', None)
        if history is None:
            history = self._open(self.location, init=False)
            self._local.history = history
            with self._lock:
                self._all.append(history)
        return history

    def close(self) -> None:
        """Close every history this pool opened."""
        with self._lock:
            for history in self._all:
                try:
                    history.close()
                except Exception:  # noqa: BLE001 - closing at shutdown: nothing to do
                    pass
            self._all.clear()
        self._local = threading.local()


@dataclass
class DashboardSettings:
    """
    What the app serves: the history, the parameter sets, notifications, sessions.

    ``history``: an SQLite path or a ``postgresql://`` URL; ``params``: parameter-set files
    the estimates may name (beside the packaged ones); ``secret_key``: the session key (a new
    random one when None); ``https``: the session cookie is Secure (served over TLS);
    ``notify_config``: a notification configuration file run in the background
    (``notify_interval_s`` apart); ``max_failures`` and ``window_s``: the login rate limit.
    """

    history: str
    params: tuple[str, ...] = ()
    secret_key: Optional[str] = None
    https: bool = False
    notify_config: Optional[str] = None
    notify_interval_s: float = 60.0
    max_failures: int = 5
    window_s: float = 300.0
    poll_interval_ms: int = POLL_INTERVAL_MS
    extra: dict[str, Any] = field(default_factory=dict)


def _templates() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(HERE / 'templates')),
                             autoescape=True, undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True)
    env.globals['version'] = __version__
    return env


def create_app(settings: DashboardSettings) -> FastAPI:
    """Return the dashboard app of ``settings.history`` (HistoryError when it is none)."""
    from robot_wear_monitor.dashboard import api, pages
    from robot_wear_monitor.dashboard.notifier import notification_lifespan

    pool = HistoryPool(settings.history)
    app = FastAPI(title='robot_wear_monitor dashboard', version=__version__,
                  description="The fleet of a wear history: joints worst first, one joint's "
                              'wear story, the alarm log. Wear w: 0 new, 100 failure; '
                              'temperatures degC; speeds motor side rad/s; frictions '
                              'normalised; times s since the epoch (UTC).',
                  docs_url=None, redoc_url=None, openapi_url='/openapi.json',
                  lifespan=notification_lifespan)
    app.state.settings = settings
    app.state.pool = pool
    app.state.parameter_sets = ParameterSets(settings.params)
    app.state.fleet_cache = FleetCache()
    app.state.limiter = LoginLimiter(max_failures=settings.max_failures,
                                     window_s=settings.window_s)
    app.state.templates = _templates()
    # the session must be read before RequireSession looks at it: added last = outermost
    app.add_middleware(RequireSession)
    app.add_middleware(SessionMiddleware, secret_key=settings.secret_key or new_secret_key(),
                       session_cookie='rwm_session', max_age=SESSION_MAX_AGE_S,
                       same_site='strict', https_only=settings.https)
    app.mount('/static/swagger', StaticFiles(directory=str(swagger_ui_folder())),
              name='swagger')
    app.mount('/static', StaticFiles(directory=str(HERE / 'static')), name='static')
    plotly_js = plotly_js_path()

    @app.get('/vendor/plotly.min.js', include_in_schema=False)
    def plotly_script() -> FileResponse:
        """Serve Plotly.js from the installed plotly package."""
        return FileResponse(plotly_js, media_type='text/javascript')

    app.include_router(pages.router)
    app.include_router(api.router)
    return app


def history_of(request: Any) -> Any:
    """Return the request thread's open wear history."""
    return request.app.state.pool.get()


def environment_secret() -> Optional[str]:
    """Return the session key from ``ROBOT_WEAR_MONITOR_DASHBOARD_SECRET`` (None: random)."""
    return os.environ.get('ROBOT_WEAR_MONITOR_DASHBOARD_SECRET') or None
