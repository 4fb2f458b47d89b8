"""
Who may see and do what: sessions, roles, the CSRF token and the login rate limit.

Sessions are kept server-side, in the wear history (``history.sessions``): a login stores a
session (user, CSRF token, expiry after :data:`SESSION_MAX_AGE_S`) and puts only its random id
in Starlette's signed cookie (itsdangerous; HttpOnly, SameSite=Strict, Secure under TLS; the
key is made at every server start, so a restart logs everybody out; the workers of
``dashboard --workers N`` share the key their parent made).  Every request looks the
session up (:class:`RequireSession`): a logout or the removal of the user ends it at once, so a
copied cookie is worth nothing after either.  Every request but ``/login`` and the login
page's style needs a session: pages redirect to ``/login``, the API answers 401.  Every POST
carries the session's CSRF token (form field ``csrf_token`` or header ``X-CSRF-Token``) or gets
403.  Login attempts are counted per client address and per (user name, address) in the wear
history (schema version 13, :class:`~robot_wear_monitor.history.login_failures.LoginFailures`:
every worker of ``dashboard --workers N`` counts in the same table) before the password is
checked: after
:data:`MAX_FAILURES` attempts that did not succeed within :data:`WINDOW_S` the login from that
address (of any name, or of that name) answers 429 until the window has passed, however many
arrive at once; the same name from another address is not refused (nobody locks the owner
out), a login the history could not check (503) does not count.  :class:`LoginLimiter` is the
same rule in one process's memory (at most :data:`MAX_LIMITER_KEYS` keys), for a caller
without a history.  :class:`LoginBodyLimit` refuses a ``/login`` POST that is
multipart (415) before the form parser reads it (its size is bounded by ``guards.BodyGuard``, as
every body's).

The JSON API (``/api/``) also takes a per-user API token (``Authorization: Bearer TOKEN``,
``history.tokens``): the request acts as the token's user with their role read now; a token
that is unknown, removed or whose user is gone gets 401 (a cookie does not stand in for it).
CSRF does not apply to such a request (a browser never sends that header by itself); it does
to every request of a cookie session.
"""

from __future__ import annotations

from collections import deque
import hmac
import secrets
import threading
import time
from typing import Any, Awaitable, Callable, Optional, TypedDict
from urllib.parse import quote

from robot_wear_monitor.history.records import HistoryError
from robot_wear_monitor.history.users import ROLES
from starlette.concurrency import run_in_threadpool
from starlette.middleware.base import BaseHTTPMiddleware
from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, RedirectResponse, Response

#: Failed logins allowed per user name and per client address within :data:`WINDOW_S`.
MAX_FAILURES = 5
#: How long a session lasts without a new login [s].
SESSION_MAX_AGE_S = 12 * 3600
#: The window of the login rate limit [s].
WINDOW_S = 300.0
#: The most keys the login rate limit keeps (addresses and name-address pairs).
MAX_LIMITER_KEYS = 10000
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
    """
    Failed logins per client address and per (user name, address), in this process's memory.

    (The dashboard counts in the history instead, where all its workers see the counts:
    :class:`~robot_wear_monitor.history.login_failures.LoginFailures`, the same methods.)

    The owner of an account is never locked out by somebody else: wrong passwords count
    against the address they came from (any name) and against that address's tries of the
    name, never against the name alone, so a name tried from one address still logs in from
    another.  The memory is bounded: a key's failures older than the window are dropped,
    a key without failures is forgotten, and past :attr:`max_keys` keys the oldest key goes
    (after the expired ones).
    """

    def __init__(self, *, max_failures: int = MAX_FAILURES, window_s: float = WINDOW_S,
                 clock: Callable[[], float] = time.monotonic,
                 max_keys: int = MAX_LIMITER_KEYS) -> None:
        """Allow ``max_failures`` failures per key within ``window_s`` [s]."""
        self.max_failures = max_failures
        self.window_s = window_s
        self.max_keys = max_keys
        self._clock = clock
        self._failures: dict[str, deque[float]] = {}
        self._lock = threading.Lock()

    @staticmethod
    def _keys(user: str, address: str) -> tuple[str, str]:
        return f'address:{address}', f'user:{user}\0address:{address}'

    def __len__(self) -> int:
        """Return how many keys are kept (addresses and name-address pairs)."""
        return len(self._failures)

    def _recent(self, key: str, now: float, *, create: bool) -> Optional[deque[float]]:
        times = self._failures.get(key)
        if times is None:
            if not create:
                return None
            if len(self._failures) >= self.max_keys:
                self._make_room(now)
            times = self._failures[key] = deque()
        while times and now - times[0] > self.window_s:
            times.popleft()
        if not times and not create:
            del self._failures[key]
            return None
        return times

    def _make_room(self, now: float) -> None:
        """Drop the expired keys; then the oldest ones until there is room for one more."""
        for key in [k for k, t in self._failures.items() if not t or now - t[-1] > self.window_s]:
            del self._failures[key]
        while len(self._failures) >= self.max_keys:
            del self._failures[next(iter(self._failures))]

    def _wait(self, keys: tuple[str, str], now: float) -> float:
        wait = 0.0
        for key in keys:
            times = self._recent(key, now, create=False)
            if times is not None and len(times) >= self.max_failures:
                wait = max(wait, self.window_s - (now - times[0]))
        return wait

    def retry_after_s(self, *, user: str, address: str) -> float:
        """Return how long a login of ``user`` from ``address`` stays refused [s] (0: allowed)."""
        with self._lock:
            return self._wait(self._keys(user, address), self._clock())

    def begin_attempt(self, *, user: str, address: str) -> float:
        """
        Count a login attempt before its password is checked; return 0, or the wait [s].

        The check and the count are one step under the lock: of many attempts at once, at
        most :attr:`max_failures` pass per address and per name from it.  A refused attempt
        (wait > 0) is not counted.  :meth:`succeeded` takes a good attempt back, and
        :meth:`not_counted` one the history could not check.
        """
        now = self._clock()
        with self._lock:
            keys = self._keys(user, address)
            wait = self._wait(keys, now)
            if wait > 0.0:
                return max(wait, 1e-3)
            for key in keys:
                times = self._recent(key, now, create=True)
                assert times is not None
                times.append(now)
        return 0.0

    def failed(self, *, user: str, address: str) -> None:
        """Count one failed login of ``user`` from ``address`` (an attempt not begun here)."""
        now = self._clock()
        with self._lock:
            for key in self._keys(user, address):
                times = self._recent(key, now, create=True)
                assert times is not None
                times.append(now)

    def not_counted(self, *, user: str, address: str) -> None:
        """Take back an attempt that was not a wrong password (the history could not say)."""
        with self._lock:
            for key in self._keys(user, address):
                times = self._failures.get(key)
                if times:
                    times.pop()
                if times is not None and not times:
                    del self._failures[key]

    def succeeded(self, *, user: str, address: Optional[str] = None) -> None:
        """Forget the failures of ``user`` from ``address``; take the good attempt back."""
        with self._lock:
            for key in list(self._failures):
                if key.startswith(f'user:{user}\0') and (
                        address is None or key.endswith(f'\0address:{address}')):
                    del self._failures[key]
            if address is not None:
                times = self._failures.get(f'address:{address}')
                if times:
                    times.pop()


def new_secret_key() -> str:
    """Return a random session key (one per server start)."""
    return secrets.token_urlsafe(48)


def start_session(request: Request, *, history: Any, name: str) -> bool:
    """
    Log ``name`` in: a new server-side session (role, CSRF token, expiry); its id in the cookie.

    Return False when the user is gone (removed between the password check and now).
    """
    old = request.session.get('sid')
    if isinstance(old, str):  # a new login ends the session this browser had
        history.end_session(token=old)
    session = history.start_session(user=name, lifetime_s=SESSION_MAX_AGE_S)
    request.session.clear()
    if session is None:
        return False
    request.session['sid'] = session.token
    _attach(request, session)
    return True


def end_session(request: Request, *, history: Any) -> None:
    """Log out: the server-side session ends (a copied cookie is void too), the cookie empties."""
    token = request.session.get('sid')
    if isinstance(token, str):
        history.end_session(token=token)
    request.session.clear()
    request.state.session_user = None
    request.state.session_csrf = None


def _attach(request: Request, session: Any) -> None:
    if session is None or session.role not in ROLES:
        request.state.session_user = None
        request.state.session_csrf = None
        return
    request.state.session_user = {'name': str(session.user), 'role': str(session.role)}
    request.state.session_csrf = str(session.csrf)


def load_session(request: Request, history: Any) -> None:
    """Look the cookie's session up in the history (ended, expired or unknown: none)."""
    token = request.session.get('sid')
    session = history.find_session(token=token) if isinstance(token, str) else None
    if token is not None and session is None:
        request.session.pop('sid', None)
    _attach(request, session)


def csrf_token(request: Request) -> str:
    """Return the session's CSRF token (made for an anonymous session on the login page)."""
    token = getattr(request.state, 'session_csrf', None) or request.session.get('csrf')
    if not token:
        token = secrets.token_urlsafe(32)
        request.session['csrf'] = token
    return str(token)


def csrf_ok(request: Request, supplied: Optional[str]) -> bool:
    """Return whether ``supplied`` is the session's CSRF token (a constant-time compare)."""
    expected = getattr(request.state, 'session_csrf', None) or request.session.get('csrf')
    return bool(expected and supplied and hmac.compare_digest(str(expected), str(supplied)))


def current_user(request: Request) -> Optional[SessionUser]:
    """Return ``{'name', 'role'}`` of the request's live session, or None."""
    user: Optional[SessionUser] = getattr(request.state, 'session_user', None)
    return user


def client_address(request: Request) -> str:
    """
    Return the client's address: the peer of the connection.

    When the peer is one of the settings' ``trusted_proxies`` (``--trusted-proxy``), the
    last address of its ``X-Forwarded-For`` instead (the one that proxy saw); no header is
    trusted from anybody else.
    """
    peer = request.client.host if request.client else 'unknown'
    trusted = getattr(getattr(request.app.state, 'settings', None), 'trusted_proxies', ())
    if peer in trusted:
        forwarded = request.headers.get('x-forwarded-for', '').split(',')[-1].strip()
        if forwarded:
            return forwarded[:64]
    return peer


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
        bearer = bearer_token(request)
        request.state.token_auth = False
        try:
            return await self._dispatch(request, call_next, path, bearer)
        except HistoryError:  # the history cannot serve now (its server restarting): 503
            return _history_away()

    async def _dispatch(self, request: Request,
                        call_next: Callable[[Request], Awaitable[Response]], path: str,
                        bearer: Optional[str]) -> Response:
        response: Response
        if bearer is not None and (path.startswith('/api/') or path == '/openapi.json'):
            pool = request.app.state.pool
            if not await run_in_threadpool(_token_from_pool, request, pool, bearer):
                response = JSONResponse({'detail': 'unknown or removed API token'},
                                        status_code=401,
                                        headers={'WWW-Authenticate': 'Bearer'})
                for key, value in SECURITY_HEADERS.items():
                    response.headers.setdefault(key, value)
                return response
        elif 'sid' in request.session:  # every request looks its session up in the history
            pool = request.app.state.pool
            await run_in_threadpool(_load_from_pool, request, pool)
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


def _history_away() -> Response:
    """Return 503: the session or token could not be looked up (no location in it)."""
    response = JSONResponse({'detail': 'the wear history cannot be read just now: try again '
                                       'shortly'}, status_code=503, headers={'Retry-After': '5'})
    for key, value in SECURITY_HEADERS.items():
        response.headers.setdefault(key, value)
    return response


def _load_from_pool(request: Request, pool: Any) -> None:
    with pool.borrow() as history:
        load_session(request, history)


def bearer_token(request: Request) -> Optional[str]:
    """Return the token of an ``Authorization: Bearer TOKEN`` header, or None."""
    scheme, _, token = request.headers.get('authorization', '').partition(' ')
    return token.strip() if scheme.lower() == 'bearer' else None


def is_token_request(request: Request) -> bool:
    """Return whether the request acts through an API token (not a cookie session)."""
    return bool(getattr(request.state, 'token_auth', False))


def _token_from_pool(request: Request, pool: Any, token: str) -> bool:
    """Act as the user of API ``token`` (their role now); return False when it is none."""
    with pool.borrow() as history:
        found = history.find_token(token=token)
    if found is None or found.role not in ROLES:
        return False
    request.state.session_user = {'name': found.user, 'role': found.role}
    request.state.session_csrf = None
    request.state.token_auth = True
    return True


class LoginBodyLimit:
    """
    Refuse a multipart ``/login`` POST (415) without reading its body.

    The login form is URL-encoded and small; a multipart body would be spooled to a temporary
    file by the form parser before any check.  The body's size, its arrival and ambiguous
    headers are the outer :class:`~robot_wear_monitor.dashboard.guards.BodyGuard`'s (every
    request body, this one too, bounded before it gets here).
    """

    def __init__(self, app: Any) -> None:
        """Wrap the ASGI ``app``."""
        self.app = app

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        """Pass the request on, or answer 415 for a multipart ``/login`` POST."""
        if scope['type'] == 'http' and scope['method'] == 'POST' and scope['path'] == '/login':
            kinds = [value.decode('latin-1') for key, value in scope.get('headers', [])
                     if key.decode('latin-1').lower() == 'content-type']
            if any(k.split(';')[0].strip().lower().startswith('multipart/') for k in kinds):
                await PlainTextResponse('the login form is sent URL-encoded, not multipart',
                                        status_code=415)(scope, receive, send)
                return
        await self.app(scope, receive, send)


def safe_next(target: Any) -> str:
    """Return a local path to go to after the login ('/' for anything else)."""
    text = str(target or '/')
    if not text.startswith('/') or text.startswith('//') or '\\' in text:
        return '/'
    return text
