"""
The dashboard's JSON API under ``/api/`` (described at ``/openapi.json`` and ``/docs``).

The same dicts as the pages (:mod:`robot_wear_monitor.dashboard.views`); each route declares
its response model (:mod:`robot_wear_monitor.dashboard.schemas`), so ``/openapi.json`` gives
the shapes.  ``/api/fleet`` and the joint's route send an ``ETag`` (a hash of the content); a
request with that value in ``If-None-Match`` gets 304 while nothing changed, which is how the
pages poll for news.  Every route needs a session or an API token (401 without one).  What a
route needs comes by dependency (:mod:`robot_wear_monitor.dashboard.deps`).

The write API (for a maintenance-management system): ``POST
/api/robots/{robot}/joints/{joint}/acknowledge`` and ``.../reset``, and
``.../acknowledgement/edit`` and ``.../acknowledgement/withdraw``, each with a JSON body.
They store what the page's forms store, with the same role check (a maintainer or an admin;
403 otherwise) and the user and the source (``api``) in the alarm log; they answer the stored
event, 404 for a robot or joint the history holds no estimate of, 409 when the alarm is not in
the state the action needs, 422 on bad values.  An edit changes only the fields it sends.  A
reset needs no alarm (a replacement before an alarm is a new life too).  Every route answers
422 to a query parameter it does not take.  With an API token
(``Authorization: Bearer``) no CSRF token is needed; a cookie session sends its CSRF token in
the ``X-CSRF-Token`` header.
"""

from __future__ import annotations

import hashlib
import json
import time
from typing import Any, Callable, Iterator, Optional

from fastapi import APIRouter, Depends, HTTPException, Query, Request
from robot_wear_monitor.dashboard.api_checks import BEARER, reject_unknown_query
from robot_wear_monitor.dashboard.auth import csrf_token, is_token_request
from robot_wear_monitor.dashboard.deps import (check_api_csrf, CurrentUser, FleetCacheDep,
                                               get_display_zone, HistoryDep, MaintainerUser,
                                               ParameterSetsDep)
from robot_wear_monitor.dashboard.fleet_page import (fleet_etag, fleet_json, ROBOT_CHOICES,
                                                     robot_choices, stream_json)
from robot_wear_monitor.dashboard.planned_dates import checked_date
from robot_wear_monitor.dashboard.schemas import (AcknowledgeRequest, AlarmEventJson,
                                                  EditRequest, FleetJson, JointJson, MeJson,
                                                  ResetRequest, RobotChoicesJson,
                                                  WithdrawRequest)
from robot_wear_monitor.dashboard.views import (alarm_log, event_json, forecast_horizon_s,
                                                joint_json, PAGE_ROWS, reescalation_margin)
from robot_wear_monitor.fleet.states import STATES
from robot_wear_monitor.history import HistoryError
from robot_wear_monitor.history.alarms import AlarmStateError, UnknownJointError
from starlette.responses import Response, StreamingResponse

router = APIRouter(prefix='/api', tags=['api'],
                   dependencies=[Depends(reject_unknown_query), Depends(BEARER)])
#: The answer to a request whose If-None-Match is the current ETag.
NOT_MODIFIED: dict[int | str, dict[str, Any]] = {
    304: {'description': 'Not modified: the ETag in If-None-Match is the current one'}}


def json_with_etag(request: Request, payload: dict[str, Any]) -> Response:
    """
    Return the payload as JSON with its ETag, or 304 when the client has it already.

    The ETag is a hash of the JSON text (made once, sent as it is).
    """
    body = json.dumps(payload, ensure_ascii=False, allow_nan=False,
                      separators=(',', ':')).encode()
    tag = f'"{hashlib.sha256(body).hexdigest()[:32]}"'
    if request.headers.get('if-none-match') == tag:
        return Response(status_code=304, headers={'ETag': tag})
    return Response(body, media_type='application/json', headers={'ETag': tag})


def _state(value: Optional[str]) -> Optional[str]:
    if value in (None, ''):
        return None
    if value not in STATES:
        raise HTTPException(status_code=422, detail=f'state must be one of {", ".join(STATES)}, '
                                                    f'got {str(value)[:40]!r}')
    return value


@router.get('/fleet', summary='Every robot joint, worst first (the order of `fleet`)',
            response_model=FleetJson, responses=NOT_MODIFIED)
def api_fleet(request: Request, history: HistoryDep, parameter_sets: ParameterSetsDep,
              cache: FleetCacheDep,
              robot: Optional[str] = Query(None, description='one robot'),
              state: Optional[str] = Query(None, description='one state: ' + ', '.join(STATES)),
              page: Optional[int] = Query(None, ge=1, description='one page of the rows, from '
                                          '1 (past the last: the last); with limit'),
              limit: Optional[int] = Query(None, ge=1, le=100000, description='rows per page '
                                           f'(default {PAGE_ROWS} with page; none: every row)')
              ) -> Response:
    """
    Return the fleet: counts per state, robots, rows worst first (``fleet --json`` keys).

    Each row adds ``state``, ``arrow``, ``threshold``, the acknowledgement, the bar's
    positions and the texts the page shows.  Every row unless ``page`` or ``limit`` asks for
    one page; ``total`` and ``pages`` say how many there are.  Every row is streamed (read a
    chunk at a time from the history's index, written as read; ``robots`` comes last).
    """
    margin, horizon = reescalation_margin(request), forecast_horizon_s(request)
    state = _state(state)
    if robot and not history.fleet_index().has_robot(robot):
        raise HTTPException(status_code=404, detail=f'no robot {robot[:80]!r} in the history')
    zone = get_display_zone(request)
    if page is None and limit is None:
        tag = fleet_etag(history, now_s=time.time(), query=str(request.query_params),
                         parameter_sets=parameter_sets, reescalation_margin=margin,
                         forecast_horizon_s=horizon, source='api')
        if request.headers.get('if-none-match') == tag:
            return Response(status_code=304, headers={'ETag': tag})
        pool = request.app.state.pool

        def every_row() -> Iterator[bytes]:
            with pool.borrow() as own:  # the request's history is given back before this runs
                yield from stream_json(fleet_json(
                    own, now_s=time.time(), parameter_sets=parameter_sets,
                    robot=robot or None, state=state, cache=cache,
                    reescalation_margin=margin, forecast_horizon_s=horizon, stream=True,
                    zone=zone))

        return StreamingResponse(every_row(), media_type='application/json',
                                 headers={'ETag': tag})
    payload = fleet_json(history, now_s=time.time(), parameter_sets=parameter_sets,
                         robot=robot or None, state=state, cache=cache, page=page,
                         limit=limit, reescalation_margin=margin, forecast_horizon_s=horizon,
                         source='api', zone=zone)
    return json_with_etag(request, payload)


@router.get('/robots', summary='The robots whose name holds a text (the robot search)',
            response_model=RobotChoicesJson)
def api_robots(history: HistoryDep,
               search: str = Query('', max_length=200, description='a part of the name '
                                   '(case-insensitive; the names that start with it first)'),
               limit: int = Query(ROBOT_CHOICES, ge=1, le=1000, description='at most so many')
               ) -> dict[str, Any]:
    """Return ``robots`` (sorted, prefix matches first) and ``more`` (some were left out)."""
    return robot_choices(history, search=search, limit=limit)


@router.get('/robots/{robot}/joints/{joint}', summary="One joint's wear story",
            response_model=JointJson, responses=NOT_MODIFIED)
def api_joint(request: Request, robot: str, joint: str, history: HistoryDep,
              parameter_sets: ParameterSetsDep) -> Response:
    """
    Return one joint's wear story.

    Every experiment (w-hat, 95 % interval, trend, T-hat, p-value), the forecast cone, the
    friction levels of the last experiments with the model, the alarm log.
    """
    payload = joint_json(history, robot=robot, joint=joint, now_s=time.time(),
                         parameter_sets=parameter_sets,
                         reescalation_margin=reescalation_margin(request),
                         forecast_horizon_s=forecast_horizon_s(request),
                         zone=get_display_zone(request))
    if payload is None:
        raise HTTPException(status_code=404, detail=f'no estimates of robot {robot[:80]!r} '
                                                    f'joint {joint[:80]!r}')
    return json_with_etag(request, payload)


@router.get('/alarms', summary='The alarm log of the fleet, newest first',
            response_model=list[AlarmEventJson])
def api_alarms(request: Request, history: HistoryDep, robot: Optional[str] = None,
               joint: Optional[str] = None,
               limit: Optional[int] = Query(None, ge=1, le=100000),
               since: Optional[float] = Query(None, ge=0, le=1e11, description=(
                   'only the events stored after this time [s since the epoch] (for a '
                   'system that polls: pass the largest wall_time_s it has seen)')),
               ) -> list[dict[str, Any]]:
    """
    Return the raised, acknowledged and reset events, newest first, with who and why.

    ``since``: the events stored after that wall time only (a late-replayed raise too).
    """
    return alarm_log(history, robot=robot or None, joint=joint or None, limit=limit,
                     stored_after_s=since, zone=get_display_zone(request))


@router.get('/me', summary='The logged-in user', response_model=MeJson)
def api_me(request: Request, user: CurrentUser) -> dict[str, Any]:
    """Return the user's name, role and the session's CSRF token ('' with an API token)."""
    return {**user, 'csrf_token': '' if is_token_request(request) else csrf_token(request)}


#: The answers of the write API besides 200.
WRITE_ERRORS: dict[int | str, dict[str, Any]] = {
    401: {'description': 'no session and no (valid) API token'},
    403: {'description': 'not a maintainer or admin, or a cookie session without its '
                         'X-CSRF-Token header'},
    404: {'description': 'the history holds no estimate of the robot or joint'},
    409: {'description': 'the alarm is not in the state the action needs (e.g. no latched '
                         'alarm, already acknowledged, reset already and no experiment '
                         'since)'},
    422: {'description': 'a bad value (named in detail)'}}


def _act(history: Any, action: Callable[[], Any]) -> dict[str, Any]:
    """Run a write on the history; return the stored event (404/409/422 with its reason)."""
    try:
        return event_json(action())
    except UnknownJointError as error:
        raise HTTPException(status_code=404, detail=_reason(history, error)) from None
    except AlarmStateError as error:
        raise HTTPException(status_code=409, detail=_reason(history, error)) from None
    except HistoryError as error:
        raise HTTPException(status_code=422, detail=_reason(history, error)) from None


def _reason(history: Any, error: Exception) -> str:
    """Return the error's first line without the history's name (the server's business)."""
    text = str(error).splitlines()[0] if str(error) else type(error).__name__
    prefix = f'{history.path}: '
    return text[len(prefix):] if text.startswith(prefix) else text


_WRITE: dict[str, Any] = {'response_model': AlarmEventJson, 'responses': WRITE_ERRORS,
                          'dependencies': [Depends(check_api_csrf)]}


@router.post('/robots/{robot}/joints/{joint}/acknowledge', summary='Acknowledge the alarm',
             **_WRITE)
def api_acknowledge(robot: str, joint: str, body: AcknowledgeRequest, user: MaintainerUser,
                    history: HistoryDep) -> dict[str, Any]:
    """Acknowledge the latched alarm: owner, comment, planned maintenance date, work order."""
    return _act(history, checked_date(lambda: history.acknowledge_alarm(
        joint=joint, robot=robot, user=user['name'], owner=body.owner, comment=body.comment,
        planned_maintenance=body.planned_maintenance, work_order=body.work_order,
        source='api'), planned=body.planned_maintenance, allow_past=body.allow_past_date))


@router.post('/robots/{robot}/joints/{joint}/acknowledgement/edit',
             summary='Edit the acknowledgement (only the fields sent)', **_WRITE)
def api_edit_acknowledgement(robot: str, joint: str, body: EditRequest,
                             user: MaintainerUser, history: HistoryDep) -> dict[str, Any]:
    """
    Edit the current acknowledgement: only the fields sent change (PATCH semantics).

    The event answered (and stored in the log) holds the acknowledgement as it stands after
    the edit and ``changes``, what the edit changed.
    """
    def kept() -> str:
        current = history.acknowledgement(joint=joint, robot=robot)
        return current.planned_maintenance if current is not None else ''
    return _act(history, checked_date(lambda: history.edit_acknowledgement(
        joint=joint, robot=robot, user=user['name'], owner=body.owner, comment=body.comment,
        planned_maintenance=body.planned_maintenance, work_order=body.work_order,
        source='api'), planned=body.planned_maintenance, allow_past=body.allow_past_date,
        kept=kept))


@router.post('/robots/{robot}/joints/{joint}/acknowledgement/withdraw',
             summary='Withdraw the acknowledgement', **_WRITE)
def api_withdraw_acknowledgement(robot: str, joint: str, body: WithdrawRequest,
                                 user: MaintainerUser, history: HistoryDep) -> dict[str, Any]:
    """Withdraw the current acknowledgement, with a reason (the alarm stays latched)."""
    return _act(history, lambda: history.withdraw_acknowledgement(
        joint=joint, robot=robot, user=user['name'], reason=body.reason, source='api'))


@router.post('/robots/{robot}/joints/{joint}/reset',
             summary='Reset after maintenance or a replacement (a new life)', **_WRITE)
def api_reset(robot: str, joint: str, body: ResetRequest, user: MaintainerUser,
              history: HistoryDep) -> dict[str, Any]:
    """
    Record maintenance or a replacement: the joint's new life (with or without an alarm).

    The reason and the work order; a latched alarm unlatches; the old life stays in the
    history.  409 when the joint was reset already and no experiment followed.
    """
    return _act(history, lambda: history.reset_alarm(
        joint=joint, robot=robot, user=user['name'], reason=body.reason,
        work_order=body.work_order, source='api'))
