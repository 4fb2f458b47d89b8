"""
Serving the dashboard with uvicorn, and the rule on which addresses it may listen.

The server binds 127.0.0.1 by default.  Another address sends passwords and session cookies
over the network, so it needs TLS (``--tls-cert`` and ``--tls-key``, served by uvicorn) or
an explicit ``--insecure-http`` (for a TLS proxy in front); else the start is refused with one
line naming the options.

Slow and many clients: uvicorn closes a connection idle between requests after its keep-alive
timeout, but has no timeout of its own for a request whose headers never end (a client that
sends half a request line and waits holds its connection, and a file descriptor, for ever;
neither an ASGI middleware nor ``timeout_keep_alive`` sees it: the app is only called once the
headers are complete).  :class:`HeaderTimeoutProtocol` (uvicorn's h11 protocol with a timer)
closes a connection whose request headers are not complete :data:`HEADER_TIMEOUT_S` after its
first byte (or after the connection was made); h11 itself refuses headers over
:data:`MAX_HEADER_BYTES` (400).  ``--limit-concurrency`` (default
:data:`LIMIT_CONCURRENCY`) is uvicorn's bound on connections and tasks at once: past it,
new requests get 503.
"""

from __future__ import annotations

import asyncio
import errno
import ipaddress
import socket
from typing import Any, Optional

from robot_wear_monitor.dashboard.server_limits import (HEADER_TIMEOUT_S,
                                                        LIMIT_CONCURRENCY, MAX_HEADER_BYTES)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.input_files import MAX_PEM_BYTES, read_text_file


def is_loopback(host: str) -> bool:
    """Return whether ``host`` (a name or an address) is only reachable from this machine."""
    if host == 'localhost':
        return True
    try:
        return ipaddress.ip_address(host.strip('[]')).is_loopback
    except ValueError:
        pass
    try:
        addresses = {str(info[4][0]) for info in socket.getaddrinfo(host, None)}
    except OSError:
        return False
    return bool(addresses) and all(ipaddress.ip_address(a.split('%')[0]).is_loopback
                                   for a in addresses)


def check_listen(*, host: str, tls_cert: Optional[str], tls_key: Optional[str],
                 insecure_http: bool) -> None:
    """Raise InputError when the server must not listen on ``host`` as configured."""
    if bool(tls_cert) != bool(tls_key):
        raise InputError('--tls-cert and --tls-key go together (give both or neither)')
    for option, path in (('--tls-cert', tls_cert), ('--tls-key', tls_key)):
        if path:  # read bounded here: a regular file of at most 1 MB (uvicorn reads it again)
            read_text_file(path, what=f'{option} file', limit_bytes=MAX_PEM_BYTES)
    if tls_cert or insecure_http or is_loopback(host):
        return
    raise InputError(f'--host {host[:80]} is reachable from other machines: give '
                     '--tls-cert and --tls-key (HTTPS), or --insecure-http when a TLS proxy '
                     'is in front')


def bind_listener(*, host: str, port: int) -> socket.socket:
    """
    Return a listening socket on ``host``:``port``, bound before the start line is printed.

    :raises InputError: one line naming ``--port`` (or ``--host``) when the address is taken or
        cannot be bound, instead of a start line followed by uvicorn's errno 98.
    """
    try:
        family = socket.getaddrinfo(host.strip('[]'), port, type=socket.SOCK_STREAM)[0][0]
    except OSError as error:
        raise InputError(f'--host {host[:80]}: cannot be resolved ({error.strerror or error})'
                         ) from None
    listener = socket.socket(family, socket.SOCK_STREAM)
    try:
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind((host.strip('[]'), port))
        listener.listen(2048)
    except OSError as error:
        listener.close()
        if error.errno == errno.EADDRINUSE:
            raise InputError(f'--port {port}: {host[:80]}:{port} is already in use (another '
                             'dashboard or server?); choose another --port') from None
        raise InputError(f'--port {port}: cannot listen on {host[:80]}:{port}: '
                         f'{error.strerror or error}') from None
    listener.set_inheritable(True)
    return listener


def serve(app: Any, *, host: str, port: int, tls_cert: Optional[str] = None,
          tls_key: Optional[str] = None, listener: Optional[socket.socket] = None,
          limit_concurrency: int = LIMIT_CONCURRENCY,
          header_timeout_s: float = HEADER_TIMEOUT_S) -> None:
    """
    Serve ``app`` with uvicorn until interrupted (HTTPS when a certificate is given).

    ``listener``: a socket from :func:`bind_listener` (else uvicorn binds ``host``:``port``);
    ``limit_concurrency``: connections and requests at once (503 past it);
    ``header_timeout_s``: how long a request's headers may take [s].
    """
    # deferred import: optional extra 'dashboard' (uvicorn)
    import uvicorn
    config = uvicorn.Config(app, host=host, port=port, ssl_certfile=tls_cert,
                            ssl_keyfile=tls_key, log_level='info', proxy_headers=False,
                            server_header=False, limit_concurrency=limit_concurrency,
                            http=header_timeout_protocol(header_timeout_s),
                            h11_max_incomplete_event_size=MAX_HEADER_BYTES)
    uvicorn.Server(config).run(sockets=[listener] if listener is not None else None)


def header_timeout_protocol(timeout_s: float = HEADER_TIMEOUT_S) -> type:
    """Return uvicorn's h11 protocol with a request-header timer of ``timeout_s`` [s]."""
    # deferred import: optional extra 'dashboard' (uvicorn's HTTP/1.1 parser)
    import h11  # uvicorn's HTTP/1.1 parser
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class HeaderTimeoutProtocol(H11Protocol):
        """uvicorn's h11 protocol that closes a connection whose request headers stall."""

        header_timeout_s = timeout_s

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore
            self._header_timer: Optional[asyncio.TimerHandle] = None
            super().connection_made(transport)
            self._arm()

        def _arm(self) -> None:
            if self._header_timer is None:
                self._header_timer = self.loop.call_later(self.header_timeout_s,
                                                          self._headers_too_slow)

        def _disarm(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
                self._header_timer = None

        def data_received(self, data: bytes) -> None:
            super().data_received(data)
            if self.conn.their_state is h11.IDLE and self.conn.trailing_data[0]:
                self._arm()  # part of a request head: its headers have a deadline
            elif self.conn.their_state is not h11.IDLE:
                self._disarm()  # the head is complete (the body has its own deadline)

        def on_response_complete(self) -> None:
            super().on_response_complete()  # idle between requests: keep-alive's timeout
            if self.conn.their_state is h11.IDLE and self.conn.trailing_data[0]:
                self._arm()

        def connection_lost(self, exc: Optional[Exception]) -> None:
            self._disarm()
            super().connection_lost(exc)

        def _headers_too_slow(self) -> None:
            self._header_timer = None
            if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
                self.logger.info('closed a connection whose request headers did not arrive '
                                 'within %g s', self.header_timeout_s)
                self.transport.close()

    return HeaderTimeoutProtocol
