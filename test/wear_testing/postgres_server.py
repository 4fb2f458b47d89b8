"""
A real PostgreSQL server for the tests, in a temporary folder (initdb + pg_ctl), and fixtures.

:func:`find_postgresql_binaries` looks for ``initdb`` and ``pg_ctl`` on PATH, in
``/usr/lib/postgresql/<version>/bin`` (Debian's ``postgresql`` package) and in ``/usr/local/bin``.
:class:`PostgresServer` makes a cluster in a fresh temporary folder, starts it on a free TCP port
of 127.0.0.1 (its unix socket in the same folder), makes databases on demand and stops and removes
everything at the end.  PostgreSQL refuses to run as root: as root, the server runs as the
``postgres`` user (``runuser -u postgres --``), who is given the folder.

This module is also a pytest plugin (``pytest_plugins = ('wear_testing.postgres_server',)`` in
``test/conftest.py``) with the fixtures ``postgresql_server`` (one server for the test
session), ``postgresql_url`` (a new empty database) and ``history_location`` (a new history,
parametrised on 'sqlite' (a file path) and 'postgresql' (a URL)).  Without PostgreSQL (or
psycopg) the PostgreSQL tests are skipped with the reason, except in CI (environment variable
``CI`` set and not empty), where they fail: a PostgreSQL test never skips in CI.
"""

from __future__ import annotations

import os
from pathlib import Path
import pwd
import shutil
import socket
import subprocess
import tempfile
from typing import Optional

import pytest

SERVER_USER = 'postgres'


def find_postgresql_binaries() -> Optional[Path]:
    """Return the folder holding ``initdb`` and ``pg_ctl`` (None when there is none)."""
    candidates = []
    on_path = shutil.which('initdb')
    if on_path:
        candidates.append(Path(on_path).resolve().parent)
    candidates += sorted(Path('/usr/lib/postgresql').glob('*/bin'),
                         key=lambda p: int(p.parent.name) if p.parent.name.isdigit() else 0,
                         reverse=True)
    candidates += [Path('/usr/local/bin'), *sorted(Path('/usr').glob('pgsql-*/bin'))]
    for folder in candidates:
        if (folder / 'initdb').is_file() and (folder / 'pg_ctl').is_file():
            return folder
    return None


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(('127.0.0.1', 0))
        return int(probe.getsockname()[1])


class PostgresServer:
    """A throw-away PostgreSQL server on 127.0.0.1 (trust authentication, no fsync)."""

    def __init__(self, binaries: Path) -> None:
        """Prepare a server from the ``initdb``/``pg_ctl`` in ``binaries`` (not started)."""
        self.binaries = binaries
        self.folder = Path(tempfile.mkdtemp(prefix='wear-history-pg-'))
        self.data = self.folder / 'data'
        self.log = self.folder / 'server.log'
        self.port = 0
        self.user = SERVER_USER
        self._as_user: list[str] = []
        self._databases = 0
        if os.geteuid() == 0:
            try:
                entry = pwd.getpwnam(SERVER_USER)
            except KeyError:
                raise RuntimeError(f'PostgreSQL does not run as root and there is no '
                                   f'{SERVER_USER!r} user') from None
            os.chown(self.folder, entry.pw_uid, entry.pw_gid)
            runner = shutil.which('runuser')
            self._as_user = ([runner, '-u', SERVER_USER, '--'] if runner
                             else ['su', SERVER_USER, '-s', '/bin/sh', '-c'])
        else:
            self.user = pwd.getpwuid(os.geteuid()).pw_name

    def _run(self, *command: str) -> None:
        if self._as_user and self._as_user[0] == 'su':
            import shlex
            argv = [*self._as_user, shlex.join(command)]
        else:
            argv = [*self._as_user, *command]
        result = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, timeout=120, cwd=self.folder)
        if result.returncode != 0:
            log = self.log.read_text(errors='replace')[-2000:] if self.log.exists() else ''
            raise RuntimeError(f'{" ".join(command[:2])} failed ({result.returncode}): '
                               f'{result.stdout[-2000:]}{log}')

    def start(self) -> str:
        """Make the cluster, start the server; return the URL of its ``postgres`` database."""
        self._run(str(self.binaries / 'initdb'), '-D', str(self.data), '-U', self.user,
                  '-A', 'trust', '-E', 'UTF8', '--no-locale', '--no-sync', '--no-instructions')
        self.port = _free_port()
        options = (f'-p {self.port} -c listen_addresses=127.0.0.1 -k {self.folder} '
                   '-c fsync=off -c full_page_writes=off -c max_connections=60')
        self._options = options
        self._run(str(self.binaries / 'pg_ctl'), '-D', str(self.data), '-l', str(self.log),
                  '-o', options, '-w', '-t', '60', 'start')
        return self.url('postgres')

    def restart(self) -> None:
        """Restart the server (fast: every connection is cut), on the same port and data."""
        self._run(str(self.binaries / 'pg_ctl'), '-D', str(self.data), '-l', str(self.log),
                  '-o', self._options, '-m', 'fast', '-w', '-t', '60', 'restart')

    def url(self, database: str) -> str:
        """Return the URL of ``database`` on this server."""
        return f'postgresql://{self.user}@127.0.0.1:{self.port}/{database}'

    def create_database(self, prefix: str = 'wear') -> str:
        """Create a new empty database; return its URL."""
        import psycopg
        self._databases += 1
        name = f'{prefix}_{self._databases}'
        with psycopg.connect(self.url('postgres'), autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE {name}')  # a name made here, not a value
        return self.url(name)

    def stop(self) -> None:
        """Stop the server (fast shutdown) and remove its folder."""
        try:
            if (self.data / 'postmaster.pid').exists():
                self._run(str(self.binaries / 'pg_ctl'), '-D', str(self.data), '-m', 'fast',
                          '-w', 'stop')
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)


def _unavailable(reason: str) -> None:
    if os.environ.get('CI'):
        pytest.fail(f'PostgreSQL is required in CI: {reason}', pytrace=False)
    pytest.skip(reason)


BACKENDS = ('sqlite', 'postgresql')


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
