"""
Serving the dashboard with uvicorn, and the rule on which addresses it may listen.

The server binds 127.0.0.1 by default.  Another address sends passwords and session cookies
over the network, so it needs TLS (``--tls-cert`` and ``--tls-key``, served by uvicorn) or
an explicit ``--insecure-http`` (for a TLS proxy in front); else the start is refused with one
line naming the options.
"""

from __future__ import annotations

import ipaddress
import os
import socket
from typing import Any, Optional

from robot_wear_monitor.errors import InputError


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
        if path and not os.path.isfile(path):
            raise InputError(f'{option}: no such file: {str(path)[:200]}')
    if tls_cert or insecure_http or is_loopback(host):
        return
    raise InputError(f'--host {host[:80]} is reachable from other machines: give '
                     '--tls-cert and --tls-key (HTTPS), or --insecure-http when a TLS proxy '
                     'is in front')


def serve(app: Any, *, host: str, port: int, tls_cert: Optional[str] = None,
          tls_key: Optional[str] = None) -> None:
    """Serve ``app`` with uvicorn until interrupted (HTTPS when a certificate is given)."""
    import uvicorn
    uvicorn.run(app, host=host, port=port, ssl_certfile=tls_cert, ssl_keyfile=tls_key,
                log_level='info', proxy_headers=False, server_header=False)
