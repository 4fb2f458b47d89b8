"""
The dashboard's ASGI application: FastAPI with Jinja2 pages, its own static files, sessions.

:func:`create_app` builds the app for one wear history: the settings, the history pool and the
other shared objects on ``app.state``, the middleware, the routers ``pages``, ``accounts`` and
``api`` (which take what they need by dependency, :mod:`robot_wear_monitor.dashboard.deps`,
and import nothing from here).  Everything the browser loads comes from here (no CDN): the
app's style and scripts (``static/``), Plotly.js from the installed ``plotly`` Python package
and Swagger UI from ``fastapi-offline`` (the OpenAPI page ``/docs``).  FastAPI's own
``/docs`` (which loads Swagger UI from a CDN) is off.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError
from fastapi.staticfiles import StaticFiles
import jinja2
from robot_wear_monitor import __version__
from robot_wear_monitor.dashboard import accounts, api, pages
from robot_wear_monitor.dashboard.auth import (LoginBodyLimit, new_secret_key, RequireSession,
                                               SESSION_MAX_AGE_S)
from robot_wear_monitor.dashboard.guards import (BodyGuard, history_error_answer,
                                                 validation_error_answer)
from robot_wear_monitor.dashboard.notifier import notification_lifespan
from robot_wear_monitor.dashboard.state import DashboardSettings, HistoryPool, POLL_INTERVAL_MS
from robot_wear_monitor.dashboard.views import FleetCache, time_spans
from robot_wear_monitor.display_time import time_zone
from robot_wear_monitor.fleet.thresholds import ParameterSets
from robot_wear_monitor.history import HistoryError
from starlette.middleware.sessions import SessionMiddleware
from starlette.responses import FileResponse

HERE = Path(__file__).resolve().parent

__all__ = ['create_app', 'DashboardSettings', 'environment_secret', 'HistoryPool',
           'plotly_js_path', 'POLL_INTERVAL_MS', 'SESSION_MAX_AGE_S', 'swagger_ui_folder']


def plotly_js_path() -> Path:
    """Return plotly.min.js of the installed ``plotly`` Python package."""
    # deferred import: optional extra 'dashboard' (plotly)
    import plotly
    return Path(plotly.__file__).resolve().parent / 'package_data' / 'plotly.min.js'


def swagger_ui_folder() -> Path:
    """
    Return the Swagger UI 5 files of the installed ``fastapi-offline`` package.

    (Swagger UI 5 reads the OpenAPI 3.1 that FastAPI writes; 4.x does not.)
    """
    # deferred import: optional extra 'dashboard' (fastapi_offline)
    import fastapi_offline
    return Path(fastapi_offline.__file__).resolve().parent / 'static'


def _templates() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(HERE / 'templates')),
                             autoescape=True, undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True)
    env.globals['version'] = __version__
    env.filters['times'] = time_spans  # dates and times kept on one line
    return env


def create_app(settings: DashboardSettings) -> FastAPI:
    """
    Return the dashboard app of ``settings.history`` (HistoryError when it is none).

    The shared objects go on ``app.state``, where the routers' dependencies
    (:mod:`robot_wear_monitor.dashboard.deps`) find them.
    """
    time_zone(settings.display_timezone)  # a bad name: InputError naming the setting
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
    app.state.templates = _templates()
    # the session must be read before RequireSession looks at it: added last = outermost
    app.add_middleware(RequireSession)
    app.add_middleware(SessionMiddleware, secret_key=settings.secret_key or new_secret_key(),
                       session_cookie='rwm_session', max_age=SESSION_MAX_AGE_S,
                       same_site='strict',
                       https_only=settings.https or settings.behind_tls)
    app.add_middleware(LoginBodyLimit)  # a multipart login body is refused before it is read
    app.add_middleware(BodyGuard)  # outermost: every body bounded and checked before anything
    app.add_exception_handler(RequestValidationError, validation_error_answer)
    app.add_exception_handler(HistoryError, history_error_answer)  # 503, no location
    app.mount('/static/swagger', StaticFiles(directory=str(swagger_ui_folder())),
              name='swagger')
    app.mount('/static', StaticFiles(directory=str(HERE / 'static')), name='static')
    plotly_js = plotly_js_path()

    @app.get('/vendor/plotly.min.js', include_in_schema=False)
    def plotly_script() -> FileResponse:
        """Serve Plotly.js from the installed plotly package."""
        return FileResponse(plotly_js, media_type='text/javascript')

    app.include_router(pages.router)
    app.include_router(accounts.router)
    app.include_router(api.router)
    return app


def environment_secret() -> Optional[str]:
    """Return the session key from ``ROBOT_WEAR_MONITOR_DASHBOARD_SECRET`` (None: random)."""
    return os.environ.get('ROBOT_WEAR_MONITOR_DASHBOARD_SECRET') or None
