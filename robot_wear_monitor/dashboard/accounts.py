"""
The users page of the dashboard: an admin adds and removes users, changes roles, resets passwords.

Every route is the admin's (``deps.AdminUser``: the history names the user an admin now, else
403) and every form carries the session's CSRF token (``deps.check_csrf``).  Removing a user
ends their sessions and API tokens; a new password ends their sessions
(:mod:`robot_wear_monitor.history.users`).  An admin neither removes nor demotes their own
account here (the command line can), so that the page never locks its last admin out.  Every
change made here is recorded in the history's account audit as the admin's (source ``web``);
``/users/audit`` shows that audit (the command line's changes too), newest first.
"""

from __future__ import annotations

from typing import Any, Callable

from fastapi import APIRouter, Depends, Form, Request
from robot_wear_monitor.dashboard.deps import AdminUser, check_csrf, get_display_zone, HistoryDep
from robot_wear_monitor.dashboard.pages import render
from robot_wear_monitor.history import HistoryError
from robot_wear_monitor.history.account_audit import Actor
from robot_wear_monitor.history.users import ROLE_TEXTS, ROLES
from robot_wear_monitor.text import shown_time
from starlette.responses import HTMLResponse, RedirectResponse, Response

router = APIRouter(include_in_schema=False)


@router.get('/users')
def users_page(request: Request, admin: AdminUser, history: HistoryDep) -> HTMLResponse:
    """List the users with their roles and API tokens; the forms that manage them."""
    tokens: dict[str, int] = {}
    for token in history.tokens():
        tokens[token.user] = tokens.get(token.user, 0) + 1
    zone = get_display_zone(request)
    users = [{'name': u.name, 'role': u.role,
              'created': shown_time(u.created_wall_time_s, zone=zone),
              'tokens': tokens.get(u.name, 0), 'self': u.name == admin['name']}
             for u in history.users()]
    return render(request, 'users.html', users=users, roles=ROLES, role_texts=ROLE_TEXTS)


def _done(request: Request, history: Any, action: Callable[[], Any], text: str) -> Response:
    """Run ``action``; flash ``text`` or the history's refusal; back to the users page."""
    try:
        action()
    except HistoryError as error:
        message = str(error).splitlines()[0]
        prefix = f'{history.path}: '  # the history's location is not the page's business
        request.session['flash'] = {'kind': 'error', 'text': message[len(prefix):]
                                    if message.startswith(prefix) else message}
    else:
        request.session['flash'] = {'kind': 'ok', 'text': text}
    return RedirectResponse('/users', status_code=303)


def _not_self(request: Request, admin: AdminUser, name: str, what: str) -> Response | None:
    if name != admin['name']:
        return None
    request.session['flash'] = {'kind': 'error', 'text': f'an admin does not {what} their own '
                                                         'account here (use the command line)'}
    return RedirectResponse('/users', status_code=303)


@router.post('/users/add', dependencies=[Depends(check_csrf)])
def add_user(request: Request, admin: AdminUser, history: HistoryDep, name: str = Form(''),
             role: str = Form(''), password: str = Form('')) -> Response:
    """Add a user with a role and a first password."""
    return _done(request, history,
                 lambda: history.add_user(name=name.strip(), role=role, password=password,
                                          by=Actor.web(admin['name'])),
                 f'user {name.strip()[:64]} added ({role[:20]})')


@router.post('/users/{name}/role', dependencies=[Depends(check_csrf)])
def change_role(request: Request, name: str, admin: AdminUser, history: HistoryDep,
                role: str = Form('')) -> Response:
    """Give a user another role (it counts at once, for their sessions and tokens too)."""
    return _not_self(request, admin, name, 'change the role of') or _done(
        request, history, lambda: history.set_role(
            name=name, role=role, keep_an_admin=True, by=Actor.web(admin['name'])),
        f'user {name[:64]} is now {role[:20]}')


@router.post('/users/{name}/password', dependencies=[Depends(check_csrf)])
def reset_password(request: Request, name: str, admin: AdminUser, history: HistoryDep,
                   password: str = Form('')) -> Response:
    """Give a user a new password; their sessions end."""
    return _done(request, history, lambda: history.set_password(
                 name=name, password=password, by=Actor.web(admin['name'])),
                 f'new password of {name[:64]} stored; their sessions ended')


@router.post('/users/{name}/remove', dependencies=[Depends(check_csrf)])
def remove_user(request: Request, name: str, admin: AdminUser, history: HistoryDep,
                confirm: str = Form('')) -> Response:
    """Remove a user, once confirmed; their sessions and API tokens end with them."""
    if confirm != 'yes':
        request.session['flash'] = {'kind': 'error', 'text': f'{name[:64]} not removed: tick '
                                                             'the box to confirm'}
        return RedirectResponse('/users', status_code=303)
    return _not_self(request, admin, name, 'remove') or _done(
        request, history, lambda: history.remove_user(
            name=name, keep_an_admin=True, by=Actor.web(admin['name'])),
        f'user {name[:64]} removed; their sessions and API tokens ended')


#: The most audit records the page shows (the newest).
AUDIT_PAGE_ROWS = 500


@router.get('/users/audit')
def audit_page(request: Request, admin: AdminUser, history: HistoryDep) -> HTMLResponse:
    """Show who changed which account when (page and command line), newest first."""
    records = [{**item.as_dict(), 'time': shown_time(item.time_s,
                                                     zone=get_display_zone(request))}
               for item in history.account_audit(limit=AUDIT_PAGE_ROWS)]
    return render(request, 'audit.html', records=records, rows=AUDIT_PAGE_ROWS)
