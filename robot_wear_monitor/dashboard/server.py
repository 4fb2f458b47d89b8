"""
Serving the dashboard with uvicorn, and the rule on which addresses it may listen.

The server binds 127.0.0.1 by default.  Another address sends passwords and session cookies
over the network, so it needs TLS (``--tls-cert`` and ``--tls-key``, served by uvicorn) or
an explicit ``--insecure-http`` (for a TLS proxy in front); else the start is refused with one
line naming the options.
"""

from __future__ import annotations

import errno
import ipaddress
import socket
from typing import Any, Optional

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
          tls_key: Optional[str] = None, listener: Optional[socket.socket] = None) -> None:
    """
    Serve ``app`` with uvicorn until interrupted (HTTPS when a certificate is given).

    ``listener``: a socket from :func:`bind_listener` (else uvicorn binds ``host``:``port``).
    """
    # the optional 'dashboard' extra: imported where used
    import uvicorn
    config = uvicorn.Config(app, host=host, port=port, ssl_certfile=tls_cert,
                            ssl_keyfile=tls_key, log_level='info', proxy_headers=False,
                            server_header=False)
    uvicorn.Server(config).run(sockets=[listener] if listener is not None else None)
