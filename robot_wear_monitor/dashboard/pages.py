"""
The dashboard's HTML pages and forms: login, fleet, joint, alarm log, the OpenAPI page.

Jinja2 with autoescape renders every name and note as text.  The forms (login, logout,
acknowledge, edit or withdraw the acknowledgement, reset) carry the session's CSRF token; a
POST without it gets 403 (``deps.check_csrf``).  Acknowledge, edit, withdraw and reset are a
maintainer's or an admin's: a viewer gets 403 (``deps.MaintainerUser``); each is stored in the
history with the user, the time and the text (:meth:`WearHistory.acknowledge_alarm`,
:meth:`WearHistory.edit_acknowledgement`, :meth:`WearHistory.withdraw_acknowledgement`,
:meth:`WearHistory.reset_alarm`).  A reset needs its confirmation box ticked (``confirm``):
the browser will not send the form without it, and the server refuses it too, so the step
holds without JavaScript.  What a route needs comes by dependency
(:mod:`robot_wear_monitor.dashboard.deps`).
"""

from __future__ import annotations

import csv
import io
import time
from typing import Any, Optional

from fastapi import APIRouter, Depends, Form, Query, Request
from robot_wear_monitor.csv_cells import spreadsheet_text
from robot_wear_monitor.dashboard.auth import (client_address, csrf_token, current_user,
                                               end_session, safe_next, start_session)
from robot_wear_monitor.dashboard.deps import (check_csrf, FleetCacheDep, get_display_zone,
                                               get_settings, get_templates, HistoryDep,
                                               LimiterDep, MaintainerUser, ParameterSetsDep)
from robot_wear_monitor.dashboard.fleet_page import fleet_json, page_links
from robot_wear_monitor.dashboard.guards import public_message
from robot_wear_monitor.dashboard.planned_dates import checked_date
from robot_wear_monitor.dashboard.views import (ALARM_CSV_COLUMNS, alarm_log, event_json,
                                                fleet_row_html, forecast_horizon_s, joint_json,
                                                joint_url, MAX_PAGE_ROWS, PAGE_ROWS,
                                                reescalation_margin)
from robot_wear_monitor.display_time import time_zone
from robot_wear_monitor.fleet.states import STATES
from robot_wear_monitor.history import HistoryError
from robot_wear_monitor.history.users import ACTING_ROLES
from starlette.responses import HTMLResponse, RedirectResponse, Response

router = APIRouter(include_in_schema=False)


def render(request: Request, template: str, *, status_code: int = 200,
           **context: Any) -> HTMLResponse:
    """Return a page rendered with the user, the CSRF token and a one-time message."""
    flash = request.session.pop('flash', None) if 'flash' in request.session else None
    html = get_templates(request).get_template(template).render(
        user=current_user(request), csrf_token=csrf_token(request), flash=flash,
        joint_url=joint_url, poll_ms=get_settings(request).poll_interval_ms,
        times_text=times_text(get_settings(request).display_timezone),
        acting_roles=ACTING_ROLES,
        path=request.url.path, **context)
    return HTMLResponse(html, status_code=status_code)


def for_people(events: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Return events whose ``time`` is their ``time_text`` (the plant's zone) for a page."""
    return [{**event, 'time': event['time_text']} for event in events]


def times_text(display_timezone: str) -> str:
    """Return the footer's words on the times: 'UTC (ISO 8601)' or the zone's name."""
    zone = time_zone(display_timezone)
    return 'UTC (ISO 8601)' if zone is None else f"{display_timezone} (the plant's clock)"


@router.get('/login')
def login_page(request: Request, next: str = '/') -> HTMLResponse:  # noqa: A002
    """Show the login form."""
    return render(request, 'login.html', next=safe_next(next), error=None)


@router.post('/login', dependencies=[Depends(check_csrf)])
def login(request: Request, history: HistoryDep, limiter: LimiterDep,
          username: str = Form(''), password: str = Form(''),
          next: str = Form('/')) -> Response:  # noqa: A002
    """Log in: 303 to ``next``; 401 on a wrong name or password; 429 after too many."""
    address = client_address(request)
    name = username.strip()[:64]
    wait = limiter.begin_attempt(user=name, address=address)  # counted before the check
    if wait > 0:
        response = render(request, 'login.html', status_code=429, next=safe_next(next),
                          error=f'too many failed logins: try again in {wait:.0f} s')
        response.headers['Retry-After'] = str(int(wait) + 1)
        return response
    try:
        user = history.verify_user(name=name, password=password[:1024])
        started = user is not None and start_session(request, history=history, name=user.name)
    except HistoryError:  # the history could not say (a malformed name is no error): no count
        limiter.not_counted(user=name, address=address)
        return render(request, 'login.html', status_code=503, next=safe_next(next),
                      error='the wear history cannot be read just now: try again shortly')
    if user is None or not started:
        return render(request, 'login.html', status_code=401, next=safe_next(next),
                      error='wrong user name or password')
    limiter.succeeded(user=name, address=address)
    return RedirectResponse(safe_next(next), status_code=303)


@router.post('/logout', dependencies=[Depends(check_csrf)])
def logout(request: Request, history: HistoryDep) -> Response:
    """Log out: the session ends in the history (a copied cookie is void), the cookie empties."""
    end_session(request, history=history)
    return RedirectResponse('/login', status_code=303)


@router.get('/')
def fleet_page(request: Request, history: HistoryDep, parameter_sets: ParameterSetsDep,
               cache: FleetCacheDep, robot: Optional[str] = None,
               state: Optional[str] = None, page: int = Query(1, ge=1),
               limit: int = Query(PAGE_ROWS, ge=1, le=MAX_PAGE_ROWS)) -> HTMLResponse:
    """
    Show the fleet, worst first, with counts per state and filters by robot and state.

    One page of ``limit`` rows (``page`` from 1), with links to the others.
    """
    fleet = fleet_json(history, now_s=time.time(), parameter_sets=parameter_sets,
                       robot=robot or None, state=state if state in STATES else None,
                       cache=cache, page=page, limit=limit,
                       reescalation_margin=reescalation_margin(request),
                       forecast_horizon_s=forecast_horizon_s(request), source='web',
                       zone=get_display_zone(request))
    return render(request, 'fleet.html', fleet=fleet, states=STATES, row_html=fleet_row_html,
                  page_links=page_links(fleet))


@router.get('/robots/{robot}/joints/{joint}')
def joint_page(request: Request, robot: str, joint: str, history: HistoryDep,
               parameter_sets: ParameterSetsDep) -> HTMLResponse:
    """One joint's wear story, its alarm log and (for a maintainer) the alarm forms."""
    data = joint_json(history, robot=robot, joint=joint, now_s=time.time(),
                      parameter_sets=parameter_sets,
                      reescalation_margin=reescalation_margin(request),
                      forecast_horizon_s=forecast_horizon_s(request),
                      zone=get_display_zone(request))
    if data is None:
        return render(request, 'error.html', status_code=404,
                      message=f'no estimates of robot {robot!r} joint {joint!r}')
    acknowledgement = history.acknowledgement(joint=joint, robot=robot)
    if data['state'] is not None:  # the page shows the time in the plant's zone
        data['state']['acknowledged_at'] = data['state']['acknowledged_at_text']
    return render(request, 'joint.html', data={**data, 'events': for_people(data['events'])},
                  api_url='/api' + joint_url(robot, joint),
                  acknowledgement=None if acknowledgement is None else for_people(
                      [event_json(acknowledgement, zone=get_display_zone(request))])[0])


def _flash_outcome(request: Request, robot: str, joint: str, action: Any,
                   done: str) -> Response:
    """Run ``action``; flash ``done`` or the history's refusal; go back to the joint's page."""
    try:
        action()
    except HistoryError as error:
        request.session['flash'] = {'kind': 'error', 'text': _message(error, request)}
    else:
        request.session['flash'] = {'kind': 'ok', 'text': done}
    return RedirectResponse(joint_url(robot, joint), status_code=303)


@router.post('/robots/{robot}/joints/{joint}/acknowledge', dependencies=[Depends(check_csrf)])
def acknowledge(request: Request, robot: str, joint: str, user: MaintainerUser,
                history: HistoryDep, owner: str = Form(''), comment: str = Form(''),
                planned_maintenance: str = Form(''), work_order: str = Form(''),
                allow_past_date: str = Form('')) -> Response:
    """Acknowledge the latched alarm: owner, comment, planned maintenance date, work order."""
    return _flash_outcome(request, robot, joint, checked_date(lambda: history.acknowledge_alarm(
        joint=joint, robot=robot, user=user['name'], owner=owner.strip(),
        comment=comment.strip(), planned_maintenance=planned_maintenance.strip(),
        work_order=work_order.strip(), source='web'), planned=planned_maintenance.strip(),
        allow_past=bool(allow_past_date)), 'alarm acknowledged')


@router.post('/robots/{robot}/joints/{joint}/acknowledgement/edit',
             dependencies=[Depends(check_csrf)])
def edit_acknowledgement(request: Request, robot: str, joint: str, user: MaintainerUser,
                         history: HistoryDep, owner: str = Form(''), comment: str = Form(''),
                         planned_maintenance: str = Form(''),
                         work_order: str = Form(''),
                         allow_past_date: str = Form('')) -> Response:
    """Edit the acknowledgement (the values after the edit); recorded with who and when."""
    def kept() -> str:
        current = history.acknowledgement(joint=joint, robot=robot)
        return current.planned_maintenance if current is not None else ''
    return _flash_outcome(request, robot, joint, checked_date(
        lambda: history.edit_acknowledgement(
            joint=joint, robot=robot, user=user['name'], owner=owner.strip(),
            comment=comment.strip(), planned_maintenance=planned_maintenance.strip(),
            work_order=work_order.strip(), source='web'), planned=planned_maintenance.strip(),
        allow_past=bool(allow_past_date), kept=kept), 'acknowledgement edited')


@router.post('/robots/{robot}/joints/{joint}/acknowledgement/withdraw',
             dependencies=[Depends(check_csrf)])
def withdraw_acknowledgement(request: Request, robot: str, joint: str, user: MaintainerUser,
                             history: HistoryDep, reason: str = Form('')) -> Response:
    """Withdraw the acknowledgement, with a reason; the alarm stays latched."""
    return _flash_outcome(request, robot, joint, lambda: history.withdraw_acknowledgement(
        joint=joint, robot=robot, user=user['name'], reason=reason.strip(), source='web'),
        'acknowledgement withdrawn: the alarm is unacknowledged')


@router.post('/robots/{robot}/joints/{joint}/reset', dependencies=[Depends(check_csrf)])
def reset(request: Request, robot: str, joint: str, user: MaintainerUser, history: HistoryDep,
          reason: str = Form(''), work_order: str = Form(''),
          confirm: str = Form('')) -> Response:
    """Record maintenance or a replacement (a new life), with a reason, once confirmed."""
    if confirm != 'yes':
        request.session['flash'] = {'kind': 'error', 'text': 'not reset: tick "the maintenance '
                                                             'is done" to confirm the reset'}
        return RedirectResponse(joint_url(robot, joint), status_code=303)
    try:
        latch = history.latch_event(joint=joint, robot=robot)
    except HistoryError:
        latch = None  # the reset below names what is wrong
    done = ('alarm reset: a new life starts, the trend restarts'
            if latch is not None and latch.event == 'raised'
            else 'maintenance recorded: a new life starts, the trend restarts')
    return _flash_outcome(request, robot, joint, lambda: history.reset_alarm(
        joint=joint, robot=robot, user=user['name'], reason=reason.strip(),
        work_order=work_order.strip(), source='web'), done)


def _message(error: Exception, request: Request) -> str:
    """Return the error's first line without the history's location (the server's business)."""
    return public_message(error, location=get_settings(request).history)


@router.get('/alarms')
def alarms_page(request: Request, history: HistoryDep, robot: Optional[str] = None,
                joint: Optional[str] = None,
                limit: int = Query(500, ge=1, le=100000)) -> HTMLResponse:
    """Show the fleet's alarm log, newest first: raised, acknowledged and reset, who and why."""
    events = alarm_log(history, robot=robot or None, joint=joint or None, limit=limit,
                       zone=get_display_zone(request))
    return render(request, 'alarms.html', events=for_people(events), robot=robot or '',
                  joint=joint or '', limit=limit)


@router.get('/alarms.csv')
def alarms_csv(history: HistoryDep, robot: Optional[str] = None,
               joint: Optional[str] = None) -> Response:
    """Return the alarm log as CSV for audits (the columns of ``history --alarms --csv``)."""
    events = alarm_log(history, robot=robot or None, joint=joint or None)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator='\n')
    writer.writerow(ALARM_CSV_COLUMNS)
    for event in events:
        writer.writerow(['' if event[c] is None else _csv_cell(event[c])
                         for c in ALARM_CSV_COLUMNS])
    return Response(buffer.getvalue(), media_type='text/csv; charset=utf-8',
                    headers={'Content-Disposition': 'attachment; filename="alarms.csv"'})


def _csv_cell(value: Any) -> str:
    """Return a CSV cell: a number as a number, a text spreadsheet-safe (no live formula)."""
    if isinstance(value, float):
        return f'{value:.6g}'
    return str(value) if isinstance(value, int) else spreadsheet_text(str(value))


@router.get('/docs')
def docs_page(request: Request) -> HTMLResponse:
    """Show the OpenAPI page (Swagger UI served by the app itself)."""
    return render(request, 'docs.html')
