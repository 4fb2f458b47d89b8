"""Fixtures of the monitoring tests: a real PostgreSQL server and a history on each backend.

``postgresql_server`` starts one server for the test session (``test/postgres_server.py``).
Without PostgreSQL (or psycopg) the PostgreSQL tests are skipped with the reason, except in CI
(environment variable ``CI`` set and not empty), where they fail: a PostgreSQL test never skips
in CI.  ``history_location`` gives a fresh history per test, parametrised on 'sqlite' (a file
path) and 'postgresql' (a URL of a new database).
"""

import os

from postgres_server import find_postgresql_binaries, PostgresServer  # test/ is on the path
import pytest

BACKENDS = ('sqlite', 'postgresql')


def _unavailable(reason: str) -> None:
    if os.environ.get('CI'):
        pytest.fail(f'PostgreSQL is required in CI: {reason}', pytrace=False)
    pytest.skip(reason)


@pytest.fixture(scope='session')
def postgresql_server():
    """Yield a running :class:`PostgresServer` (skip outside CI when there is none)."""
    try:
        import psycopg  # noqa: F401
    except ImportError:
        _unavailable('psycopg 3 is not installed (pip install "psycopg[binary]")')
    binaries = find_postgresql_binaries()
    if binaries is None:
        _unavailable('no PostgreSQL server binaries (initdb, pg_ctl); on Debian: '
                     'apt-get install postgresql')
    server = PostgresServer(binaries)
    try:
        server.start()
    except (RuntimeError, OSError, ValueError) as error:
        server.stop()
        _unavailable(f'the PostgreSQL server did not start: {error}')
    yield server
    server.stop()


@pytest.fixture
def postgresql_url(postgresql_server):
    """Return the URL of a new empty database on the session's server."""
    return postgresql_server.create_database()


@pytest.fixture(params=BACKENDS)
def history_location(request, tmp_path):
    """Return where a new history goes: an SQLite path, or a PostgreSQL URL."""
    if request.param == 'sqlite':
        return str(tmp_path / 'h.sqlite3')
    return request.getfixturevalue('postgresql_url')
