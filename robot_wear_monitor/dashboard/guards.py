"""
The dashboard's outermost guards: every request body bounded before anything trusts it.

:class:`BodyGuard` is the outermost ASGI middleware.  It reads the body of every request
itself, before the session, the API token, the role or any parser looks at it:

- a declared ``Content-Length`` over :data:`MAX_BODY_BYTES` is answered 413 before a byte of
  the body is read (two Content-Length or Content-Type headers, or one that is no number:
  400); a body without one (chunked) is counted as it arrives and answered 413 at the first
  chunk past the limit.  64 kB is far above the largest valid body (the API's bodies hold at
  most a few texts of 2000 characters, escaped; the login form a name and a password);
- a body that has not arrived within :data:`BODY_TIMEOUT_S` is answered 408;
- a JSON body (a JSON Content-Type, or any body of an ``/api/`` write) is checked once,
  bounded by the size limit (milliseconds): more than :data:`MAX_JSON_KEYS` keys is 413,
  nesting deeper than :data:`MAX_JSON_DEPTH` 422, and a value the API cannot take anywhere
  (``NaN``, ``Infinity``, a number out of range such as ``1e999``, a lone surrogate such as
  U+D800, in a text or a key) is 422 naming the field (``loc`` as FastAPI gives it, e.g.
  ``["body", "comment"]``).  Malformed JSON is left to FastAPI (422 too).

The body passed on is the one read (the app never reads the socket itself).  Every answer
of this guard carries the security headers; an answer served over TLS by this server itself
(``scope['scheme'] == 'https'``: uvicorn's own TLS, no proxy header is trusted) carries
``Strict-Transport-Security``.  :func:`validation_error_answer` is the app's answer to a
request that fails its models: the field, the message and the kind of error, without the
value given (which could be anything the client sent).  :func:`history_error_answer` answers
a request the wear history could not serve (its server gone, a file unreadable) with 503 and
no location; :func:`public_message` is an error's text as a user may see it (the history's
location is the server's business).
"""

from __future__ import annotations

import asyncio
import json
import math
from typing import Any, Optional

from fastapi.exceptions import RequestValidationError
from robot_wear_monitor.dashboard.auth import SECURITY_HEADERS
from robot_wear_monitor.history.passwords import redact_location
from starlette.requests import Request
from starlette.responses import Response

#: The largest request body [bytes] (any path).
MAX_BODY_BYTES = 64 * 1024
#: The most keys a JSON body may have, all objects together.
MAX_JSON_KEYS = 256
#: The deepest a JSON body may nest (objects and arrays).
MAX_JSON_DEPTH = 16
#: How long a request body may take to arrive [s].
BODY_TIMEOUT_S = 30.0
#: ``Strict-Transport-Security`` of an answer this server sends over its own TLS.
HSTS = 'max-age=31536000'
#: The longest text of a key named in an error [characters].
_KEY_CHARS = 40


class BodyRefused(Exception):
    """A request body refused before the app: the status and the answer's ``detail``."""

    def __init__(self, status: int, detail: Any) -> None:
        """Refuse with ``status`` (413, 422, ...) and ``detail`` (a text or FastAPI's list)."""
        super().__init__(str(detail))
        self.status = status
        self.detail = detail


def _answer(status: int, detail: Any, *, https: bool) -> Response:
    """Return a JSON answer ``{"detail": ...}`` (ASCII: a lone surrogate stays escaped)."""
    headers = dict(SECURITY_HEADERS)
    if https:
        headers['Strict-Transport-Security'] = HSTS
    if status in (400, 408, 413):
        headers['Connection'] = 'close'  # the rest of the body is not read
    body = json.dumps({'detail': detail}, ensure_ascii=True, separators=(',', ':'))
    return Response(body, status_code=status, media_type='application/json', headers=headers)


def _key_text(key: str) -> str:
    """Return a key as it may be named in an error: cut short, lone surrogates escaped."""
    text = key[:_KEY_CHARS]
    return text.encode('utf-8', 'backslashreplace').decode('utf-8')


def _bad_text(text: str) -> bool:
    """Return whether ``text`` holds a lone surrogate (not encodable as UTF-8)."""
    try:
        text.encode('utf-8')
    except UnicodeEncodeError:
        return True
    return False


class _NotANumber:
    """What ``NaN``, ``Infinity`` and ``-Infinity`` parse to (refused with their place)."""

    def __init__(self, name: str) -> None:
        self.name = name


def _value_error(loc: list[Any], message: str, kind: str) -> BodyRefused:
    return BodyRefused(422, [{'loc': loc, 'msg': message, 'type': kind}])


def _walk(value: Any, loc: list[Any]) -> None:
    """Refuse (422, naming ``loc``) the first value no field of the API takes."""
    if len(loc) > MAX_JSON_DEPTH:
        raise _value_error(loc[:MAX_JSON_DEPTH + 1], f'the body nests deeper than '
                           f'{MAX_JSON_DEPTH} levels', 'too_deep')
    if isinstance(value, dict):
        for key, item in value.items():
            if _bad_text(key):
                raise _value_error([*loc, _key_text(key)], 'a key with a lone surrogate (not '
                                   'Unicode text)', 'string_unicode')
            _walk(item, [*loc, key[:_KEY_CHARS]])
    elif isinstance(value, list):
        for index, item in enumerate(value):
            _walk(item, [*loc, index])
    elif isinstance(value, _NotANumber):
        raise _value_error(loc, f'{value.name} is not a number the API takes (finite '
                           'numbers only)', 'finite_number')
    elif isinstance(value, float) and not math.isfinite(value):
        raise _value_error(loc, 'a number out of range (finite numbers only)',
                           'finite_number')
    elif isinstance(value, str) and _bad_text(value):
        raise _value_error(loc, 'a text with a lone surrogate (not Unicode text)',
                           'string_unicode')


def check_json_body(body: bytes) -> None:
    """
    Refuse a JSON body that is too wide (413), too deep or holds a value no field takes (422).

    Malformed JSON passes (the app's parser answers it).  Bounded by :data:`MAX_BODY_BYTES`.
    """
    keys = 0

    def count(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        nonlocal keys
        keys += len(pairs)
        if keys > MAX_JSON_KEYS:
            raise BodyRefused(413, f'a JSON body has at most {MAX_JSON_KEYS} keys')
        return dict(pairs)

    try:
        text = body.decode('utf-8')
    except UnicodeDecodeError as error:
        raise _value_error(['body'], f'the body is not UTF-8 (byte {error.start})',
                           'json_invalid') from None
    try:
        value = json.loads(text, object_pairs_hook=count, parse_constant=_NotANumber)
    except RecursionError:
        raise _value_error(['body'], f'the body nests deeper than {MAX_JSON_DEPTH} levels',
                           'too_deep') from None
    except ValueError:
        return  # malformed: FastAPI says where
    _walk(value, ['body'])


def _header_values(scope: Any) -> dict[str, list[str]]:
    headers: dict[str, list[str]] = {}
    for key, value in scope.get('headers', []):
        headers.setdefault(key.decode('latin-1').lower(), []).append(value.decode('latin-1'))
    return headers


def _is_json(scope: Any, kinds: list[str]) -> bool:
    kind = kinds[0].split(';')[0].strip().lower() if kinds else ''
    if kind == 'application/json' or kind.endswith('+json'):
        return True
    return not kind and str(scope.get('path', '')).startswith('/api/')


class BodyGuard:
    """
    The outermost middleware: bodies bounded, read and checked before the app sees them.

    ``max_bytes``: the body limit [bytes]; ``timeout_s``: how long a body may take [s].
    """

    def __init__(self, app: Any, *, max_bytes: int = MAX_BODY_BYTES,
                 timeout_s: float = BODY_TIMEOUT_S) -> None:
        """Wrap the ASGI ``app``."""
        self.app = app
        self.max_bytes = max_bytes
        self.timeout_s = timeout_s

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        """Answer a refused body here; pass every other request on with its body read."""
        if scope['type'] != 'http':
            await self.app(scope, receive, send)
            return
        https = scope.get('scheme') == 'https'
        if https:
            send = _with_hsts(send)
        try:
            body = await self._read(scope, receive)
        except BodyRefused as refused:
            await _answer(refused.status, refused.detail, https=https)(scope, receive, send)
            return
        if body is None:
            return  # the client went away
        given = False

        async def replay() -> Any:
            nonlocal given
            if not given:
                given = True
                return {'type': 'http.request', 'body': body, 'more_body': False}
            return await receive()
        await self.app(scope, replay, send)

    async def _read(self, scope: Any, receive: Any) -> Optional[bytes]:
        """Return the whole body (None: the client left); :class:`BodyRefused` when refused."""
        headers = _header_values(scope)
        kinds = headers.get('content-type', [])
        lengths = headers.get('content-length', [])
        if len(kinds) > 1 or len(lengths) > 1:  # which one a parser takes is anybody's guess
            raise BodyRefused(400, 'one Content-Type and one Content-Length, please')
        too_large = BodyRefused(413, f'a request body is at most {self.max_bytes} bytes')
        if lengths:
            if not lengths[0].strip().isdigit():
                raise BodyRefused(400, 'Content-Length is not a number')
            if int(lengths[0]) > self.max_bytes:
                raise too_large  # not a byte of it read
        chunks: list[bytes] = []
        size = 0
        more = True
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.timeout_s
        while more:
            try:
                message = await asyncio.wait_for(receive(), max(deadline - loop.time(), 0.0))
            except asyncio.TimeoutError:
                raise BodyRefused(408, f'the request body did not arrive within '
                                       f'{self.timeout_s:g} s') from None
            if message['type'] != 'http.request':
                return None
            chunk = message.get('body', b'')
            size += len(chunk)
            if size > self.max_bytes:
                raise too_large
            chunks.append(chunk)
            more = bool(message.get('more_body', False))
        body = b''.join(chunks)
        if body and _is_json(scope, kinds):
            check_json_body(body)
        return body


def _with_hsts(send: Any) -> Any:
    """Return ``send`` adding ``Strict-Transport-Security`` to the answer's start."""
    async def sending(message: Any) -> None:
        if message['type'] == 'http.response.start':
            headers = [(k, v) for k, v in message.get('headers', [])
                       if k.lower() != b'strict-transport-security']
            headers.append((b'strict-transport-security', HSTS.encode()))
            message = {**message, 'headers': headers}
        await send(message)
    return sending


async def validation_error_answer(request: Request, error: Exception) -> Response:
    """
    Answer a request that fails the app's models: 422 naming each field, never its value.

    FastAPI's own answer echoes the value given, which fails to encode for a lone surrogate
    or a non-finite number (a 500) and sends back whatever was sent.
    """
    errors = error.errors() if isinstance(error, RequestValidationError) else []
    detail = [{'loc': [_key_text(p) if isinstance(p, str) else p for p in e.get('loc', ())],
               'msg': str(e.get('msg', ''))[:200], 'type': str(e.get('type', ''))}
              for e in errors[:20]]
    return _answer(422, detail, https=request.url.scheme == 'https')


def public_message(error: BaseException, *, location: str) -> str:
    """Return the first line of ``error`` without the history's ``location`` (either form)."""
    text = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
    for shown in {redact_location(location), str(location)}:
        text = text.replace(f'{shown}: ', '').replace(shown, 'the wear history')
    return text


async def history_error_answer(request: Request, error: Exception) -> Response:
    """Answer 503 to a request the wear history could not serve (no location in it)."""
    location = str(getattr(request.app.state, 'settings', None) and
                   request.app.state.settings.history or '')
    detail = 'the wear history cannot be read just now: try again shortly'
    if location:
        detail += f' ({public_message(error, location=location)[:200]})'
    response = _answer(503, detail, https=request.url.scheme == 'https')
    response.headers['Retry-After'] = '5'
    return response
