"""
Checks every ``/api/`` route shares: unknown query parameters and the bearer scheme.

A maintenance system that misspells a parameter (``?stat=alarm``) must not get the whole
fleet as if it had asked for it: :func:`reject_unknown_query` answers 422 naming the
parameter and the ones the route takes.  :data:`BEARER` declares the API token scheme
(``Authorization: Bearer TOKEN``) in ``/openapi.json``; it checks nothing itself (the
``RequireSession`` middleware does), so a cookie session passes too.
"""

from __future__ import annotations

from fastapi import HTTPException, Request
from fastapi.security import HTTPBearer
from robot_wear_monitor.errors import shorten

#: The API token scheme, declared in ``/openapi.json`` (the middleware checks the token).
BEARER = HTTPBearer(auto_error=False, scheme_name='apiToken',
                    description='a per-user API token (`robot-wear-monitor dashboard-token`); '
                                'a logged-in browser session works too')


def route_query_names(request: Request) -> set[str]:
    """Return the query parameters the matched route declares (with its dependencies')."""
    route = request.scope.get('route')
    dependant = getattr(route, 'dependant', None)
    names: set[str] = set()
    stack = [dependant] if dependant is not None else []
    while stack:
        current = stack.pop()
        names.update(p.alias or p.name for p in current.query_params)
        stack.extend(current.dependencies)
    return names


def reject_unknown_query(request: Request) -> None:
    """Answer 422 when the request names a query parameter its route does not take."""
    known = route_query_names(request)
    unknown = sorted(set(request.query_params) - known)
    if unknown:
        takes = ', '.join(sorted(known)) or 'none'
        raise HTTPException(status_code=422, detail=(
            f'unknown query parameter {shorten(unknown[0], 40)!r}: this route takes {takes}'))
