"""
Who may see and do what: sessions, roles, the CSRF token and the login rate limit.

The session is Starlette's signed cookie (itsdangerous; HttpOnly, SameSite=Strict, Secure
under TLS) holding the user's name, role and CSRF token; the key is made at every server start,
so a restart logs everybody out.  Every request but ``/login`` and the login page's style needs
a session (:class:`RequireSession`): pages redirect to ``/login``, the API answers 401.  Every
POST carries the session's CSRF token (form field ``csrf_token`` or header ``X-CSRF-Token``)
or gets 403.  Failed logins are counted per user name and per client address in this process's
memory (:class:`LoginLimiter`): after :data:`MAX_FAILURES` failures within
:data:`WINDOW_S` the login answers 429 until the window has passed.
"""

from __future__ import annotations

from collections import deque
import hmac
import secrets
import threading
import time
from typing import Any, Awaitable, Callable, Optional, TypedDict
from urllib.parse import quote

from robot_wear_monitor.history.users import ROLES
from starlette.middleware.base import BaseHTTPMiddleware
from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, RedirectResponse, Response

#: Failed logins allowed per user name and per client address within :data:`WINDOW_S`.
MAX_FAILURES = 5
#: The window of the login rate limit [s].
WINDOW_S = 300.0
#: Paths answered without a session: the login page and its style.
PUBLIC_PATHS = ('/login', '/static/dashboard.css', '/favicon.ico')
#: Security headers of every answer (no script but the app's own files, no framing).
SECURITY_HEADERS = {
    'Content-Security-Policy': "default-src 'self'; script-src 'self'; img-src 'self' data:; "
                               "style-src 'self' 'unsafe-inline'; frame-ancestors 'none'; "
                               "form-action 'self'; base-uri 'none'",
    'X-Content-Type-Options': 'nosniff', 'X-Frame-Options': 'DENY',
    'Referrer-Policy': 'no-referrer', 'Cache-Control': 'no-store',
}


class SessionUser(TypedDict):
    """The session's user: name and role (one of :data:`ROLES`)."""

    name: str
    role: str


class LoginLimiter:
    """Failed logins per user name and per client address, in this process's memory."""

    def __init__(self, *, max_failures: int = MAX_FAILURES, window_s: float = WINDOW_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        """Allow ``max_failures`` failures per key within ``window_s`` [s]."""
        self.max_failures = max_failures
        self.window_s = window_s
        self._clock = clock
        self._failures: dict[str, deque[float]] = {}
        self._lock = threading.Lock()

    def _recent(self, key: str, now: float) -> deque[float]:
        times = self._failures.setdefault(key, deque())
        while times and now - times[0] > self.window_s:
            times.popleft()
        return times

    def retry_after_s(self, *, user: str, address: str) -> float:
        """Return how long the login stays refused for this user or address [s] (0: allowed)."""
        now = self._clock()
        wait = 0.0
        with self._lock:
            for key in (f'user:{user}', f'address:{address}'):
                times = self._recent(key, now)
                if len(times) >= self.max_failures:
                    wait = max(wait, self.window_s - (now - times[0]))
        return wait

    def failed(self, *, user: str, address: str) -> None:
        """Count one failed login of ``user`` from ``address``."""
        now = self._clock()
        with self._lock:
            for key in (f'user:{user}', f'address:{address}'):
                self._recent(key, now).append(now)

    def succeeded(self, *, user: str) -> None:
        """Forget the failures of ``user`` (those of the address stay)."""
        with self._lock:
            self._failures.pop(f'user:{user}', None)


def new_secret_key() -> str:
    """Return a random session key (one per server start)."""
    return secrets.token_urlsafe(48)


def start_session(request: Request, *, name: str, role: str) -> None:
    """Log ``name`` in: a fresh session with its role and a new CSRF token."""
    request.session.clear()
    request.session.update({'user': name, 'role': role, 'csrf': secrets.token_urlsafe(32),
                            'since': time.time()})


def csrf_token(request: Request) -> str:
    """Return the session's CSRF token (made for an anonymous session on the login page)."""
    token = request.session.get('csrf')
    if not token:
        token = secrets.token_urlsafe(32)
        request.session['csrf'] = token
    return str(token)


def csrf_ok(request: Request, supplied: Optional[str]) -> bool:
    """Return whether ``supplied`` is the session's CSRF token (a constant-time compare)."""
    expected = request.session.get('csrf')
    return bool(expected and supplied and hmac.compare_digest(str(expected), str(supplied)))


def current_user(request: Request) -> Optional[SessionUser]:
    """Return ``{'name', 'role'}`` of the session's user, or None."""
    name = request.session.get('user')
    role = request.session.get('role')
    if not name or role not in ROLES:
        return None
    return {'name': str(name), 'role': str(role)}


def client_address(request: Request) -> str:
    """Return the client's address (the peer of the connection; no proxy headers trusted)."""
    return request.client.host if request.client else 'unknown'


def _wants_json(path: str) -> bool:
    return path.startswith('/api/') or path in ('/openapi.json', '/alarms.csv')


class RequireSession(BaseHTTPMiddleware):
    """
    Refuse every request without a session but the public paths; add security headers.

    Pages redirect to ``/login?next=PATH`` (303); the API, the CSV and the OpenAPI schema
    answer 401.  A POST without the session's CSRF token in the ``X-CSRF-Token`` header is
    left to the route, which checks the form field (forms cannot set headers).
    """

    async def dispatch(self, request: Request,
                       call_next: Callable[[Request], Awaitable[Response]]) -> Response:
        """Pass the request on when it has a session (or is public); else refuse it."""
        path = request.url.path
        response: Response
        if path in PUBLIC_PATHS or current_user(request) is not None:
            response = await call_next(request)
        elif _wants_json(path):
            response = JSONResponse({'detail': 'log in first (POST /login)'}, status_code=401)
        elif request.method == 'GET':
            target = path + (f'?{request.url.query}' if request.url.query else '')
            response = RedirectResponse(f'/login?next={quote(target, safe="")}',
                                        status_code=303)
        else:
            response = PlainTextResponse('log in first', status_code=401)
        if path.startswith(('/static/', '/vendor/')):  # the app's own files: cached a while
            response.headers.setdefault('Cache-Control', 'private, max-age=3600')
        for key, value in SECURITY_HEADERS.items():
            response.headers.setdefault(key, value)
        return response


def safe_next(target: Any) -> str:
    """Return a local path to go to after the login ('/' for anything else)."""
    text = str(target or '/')
    if not text.startswith('/') or text.startswith('//') or '\\' in text:
        return '/'
    return text
