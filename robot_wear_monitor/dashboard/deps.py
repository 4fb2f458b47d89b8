"""
What the dashboard's routes take by dependency (FastAPI ``Depends``), as FastAPI's template does.

The routers (``pages``, ``api``) name what they need in their signatures, e.g.
``history: HistoryDep`` or ``user: MaintainerUser``, and import nothing from ``app``, which
builds the application and puts the shared objects on ``app.state``:

* :data:`HistoryDep`: an open wear history lent to the request (:class:`HistoryPool`);
* :data:`SettingsDep`, :data:`ParameterSetsDep`, :data:`FleetCacheDep`, :data:`LimiterDep`:
  the settings, the parameter sets, the fleet cache and the login rate limit (its counts
  kept in the history, so that every worker of ``dashboard --workers N`` shares them);
* :data:`CurrentUser`: the session's user (``RequireSession`` has refused requests without);
* :func:`check_csrf`: 403 unless the form field ``csrf_token`` (or the header
  ``X-CSRF-Token``) is the session's CSRF token; routes add it as
  ``dependencies=[Depends(check_csrf)]``, which runs before their other dependencies;
* :func:`check_api_csrf`: the same for the JSON API's writes (the header ``X-CSRF-Token``)
  of a cookie session; a request with an API token (``Authorization: Bearer``) needs none;
* :data:`MaintainerUser`: the user when the history still names them a maintainer or an
  admin (:data:`~robot_wear_monitor.history.users.ACTING_ROLES`), else 403 (a removed user's
  session or token is void);
* :data:`AdminUser`: the user when the history still names them an admin, else 403.
"""

from __future__ import annotations

import datetime
from typing import Annotated, Iterator, Optional

from fastapi import Depends, Form, HTTPException, Request
import jinja2
from robot_wear_monitor.dashboard.auth import (csrf_ok, current_user, is_token_request,
                                               SessionUser)
from robot_wear_monitor.dashboard.state import DashboardSettings, HistoryPool
from robot_wear_monitor.dashboard.views import FleetCache
from robot_wear_monitor.display_time import time_zone
from robot_wear_monitor.fleet.thresholds import ParameterSets
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.history.login_failures import LoginFailures
from robot_wear_monitor.history.users import ACTING_ROLES, ADMIN_ROLE


def get_settings(request: Request) -> DashboardSettings:
    """Return the app's settings."""
    settings: DashboardSettings = request.app.state.settings
    return settings


def get_display_zone(request: Request) -> Optional[datetime.tzinfo]:
    """Return the zone of the settings' ``display_timezone`` for people's times (None: UTC)."""
    return time_zone(get_settings(request).display_timezone)


def get_history(request: Request) -> Iterator[WearHistory]:
    """Lend the request an open wear history of its own (given back when it is answered)."""
    pool: HistoryPool = request.app.state.pool
    with pool.borrow() as history:
        yield history


def get_parameter_sets(request: Request) -> ParameterSets:
    """Return the parameter sets the estimates may name."""
    parameter_sets: ParameterSets = request.app.state.parameter_sets
    return parameter_sets


def get_fleet_cache(request: Request) -> FleetCache:
    """Return the fleet rows cached while the history is unchanged."""
    cache: FleetCache = request.app.state.fleet_cache
    return cache


def get_limiter(request: Request,
                history: Annotated[WearHistory, Depends(get_history)]) -> LoginFailures:
    """Return the login rate limit: its counts in the history (every worker shares them)."""
    settings: DashboardSettings = request.app.state.settings
    return history.login_failures(max_failures=settings.max_failures,
                                  window_s=settings.window_s)


def get_templates(request: Request) -> jinja2.Environment:
    """Return the pages' Jinja2 environment."""
    templates: jinja2.Environment = request.app.state.templates
    return templates


def get_current_user(request: Request) -> SessionUser:
    """Return the session's user; 401 without one (``RequireSession`` answers that first)."""
    user = current_user(request)
    if user is None:
        raise HTTPException(status_code=401, detail='log in first (POST /login)')
    return user


def check_csrf(request: Request, csrf_token: str = Form('')) -> None:
    """Refuse (403) a POST without the session's CSRF token (form field or X-CSRF-Token)."""
    if not csrf_ok(request, csrf_token or request.headers.get('x-csrf-token')):
        raise HTTPException(status_code=403, detail='missing or wrong CSRF token: reload the '
                                                    'page and send the form again')


def check_api_csrf(request: Request) -> None:
    """Refuse (403) an API write of a cookie session without its X-CSRF-Token header."""
    if is_token_request(request):
        return  # an API token is no ambient credential: no cross-site request carries it
    if not csrf_ok(request, request.headers.get('x-csrf-token')):
        raise HTTPException(status_code=403, detail='missing or wrong X-CSRF-Token header '
                                                    '(GET /api/me gives it), or use an API '
                                                    'token')


SettingsDep = Annotated[DashboardSettings, Depends(get_settings)]
HistoryDep = Annotated[WearHistory, Depends(get_history)]
ParameterSetsDep = Annotated[ParameterSets, Depends(get_parameter_sets)]
FleetCacheDep = Annotated[FleetCache, Depends(get_fleet_cache)]
LimiterDep = Annotated[LoginFailures, Depends(get_limiter)]
CurrentUser = Annotated[SessionUser, Depends(get_current_user)]


def get_current_maintainer(user: CurrentUser) -> SessionUser:
    """
    Return the user when they are a maintainer or admin; else 403.

    The role is the history's at this request: ``RequireSession`` read it with the session
    (or the API token), so a changed role or a removed user counts at once.
    """
    if user['role'] not in ACTING_ROLES:
        raise HTTPException(status_code=403, detail='only a maintainer or an admin may '
                                                    'acknowledge or reset an alarm')
    return user


def get_current_admin(user: CurrentUser) -> SessionUser:
    """Return the user when they are an admin (the history's role at this request); else 403."""
    if user['role'] != ADMIN_ROLE:
        raise HTTPException(status_code=403, detail='only an admin may manage the users')
    return user


MaintainerUser = Annotated[SessionUser, Depends(get_current_maintainer)]
AdminUser = Annotated[SessionUser, Depends(get_current_admin)]
