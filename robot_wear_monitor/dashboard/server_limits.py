"""
The dashboard server's limits, in a module of their own.

The command line reads them for its options' defaults without loading the server (asyncio,
uvicorn) at start-up: :class:`ServerSettings` declares each serving option of ``dashboard``
once (default, unit, description, check; :mod:`robot_wear_monitor.setting_fields`).
"""

from __future__ import annotations

from dataclasses import dataclass

from robot_wear_monitor.setting_fields import (at_least, check_settings, in_range, non_empty,
                                               setting)

#: How long a request's headers may take to arrive, from their first byte [s].
HEADER_TIMEOUT_S = 10.0
#: The largest request head (request line and headers) h11 takes [bytes]; more is 400.
MAX_HEADER_BYTES = 16 * 1024
#: How many connections and requests at once the server takes (``--limit-concurrency``).
LIMIT_CONCURRENCY = 200
#: The most server processes ``dashboard --workers`` starts.
MAX_WORKERS = 64


@dataclass(frozen=True)
class ServerSettings:
    """How the dashboard's server listens and bounds its clients (``dashboard``'s options)."""

    host: str = setting('127.0.0.1', check=non_empty,
                        description='address to listen on (an address that is not loopback '
                                    'needs --tls-cert/--tls-key or --insecure-http)')
    port: int = setting(8080, check=in_range(1, 65535), description='TCP port to listen on')
    limit_concurrency: int = setting(
        LIMIT_CONCURRENCY, check=at_least(1),
        description='connections and requests at once; past it new requests get 503')
    header_timeout_s: float = setting(
        HEADER_TIMEOUT_S, unit='s', check=in_range(0.5, 600.0),
        description='close a connection whose request headers take longer, from their first '
                    'byte')
    workers: int = setting(
        1, check=in_range(1, MAX_WORKERS),
        description='server processes sharing the port (more than 1 needs a postgresql:// '
                    "history: sessions, login limits, notifications and the pages' news are "
                    'shared through it)')

    def __post_init__(self) -> None:
        """Check every setting (InputError naming it, with the value and the range)."""
        check_settings(self, prefix='dashboard server: ')
