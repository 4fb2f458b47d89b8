"""
The two stores of the wear history: an SQLite file (the default) and a PostgreSQL server.

Both take the same SQL (``?`` placeholders, values only as bound parameters; PostgreSQL's
``%s`` is put in here) and give rows as tuples.  Each opens its connection, runs transactions,
lists the tables for the foreign-database check, holds the migration lock while the layout is
changed, and an advisory writer lock per (robot, joint).

SQLite: WAL journal, ``synchronous=FULL``, ``BEGIN IMMEDIATE`` transactions with a busy timeout;
a new file is built under a temporary name and linked into place, so that nobody ever sees a
half-made history (and an existing empty file is the user's, not a race).  The writer lock is a
``fcntl.lockf`` byte range in the side file ``<history>-lock``.  PostgreSQL: psycopg 3 in
autocommit mode with explicit transactions; the migration lock and the writer locks are
advisory locks of the server.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, contextmanager
import errno
import fcntl
import hashlib
import os
from pathlib import Path
import sqlite3
import tempfile
import time
from typing import Any, Iterator, Optional, Protocol, Sequence, Union

from robot_wear_monitor.history.migrations import (
    POSTGRESQL_MIGRATIONS, SQLITE_MIGRATIONS)
from robot_wear_monitor.history.passwords import redact_location
from robot_wear_monitor.history.records import HistoryError

#: How long a writer waits for another process's transaction [s] (SQLite busy timeout).
BUSY_TIMEOUT_S = 30.0
#: How long opening retries while another process converts the file [s].
OPEN_TIMEOUT_S = 30.0
#: How long connecting to a PostgreSQL server may take [s].
CONNECT_TIMEOUT_S = 10

_POSTGRESQL_SCHEMES = ('postgresql', 'postgres')
#: Advisory lock key of the migration of a PostgreSQL history (any constant; 'wear' 'hist').
_MIGRATION_LOCK_KEY = 0x7765617268697374


#: The values of one statement: positional (``?``) or named (``:name``) parameters.
SqlParams = Union[Sequence[Any], dict[str, Any]]


class HistoryBackend(Protocol):
    """
    What the store needs of a backend: one connection, transactions, the layout, locks.

    :class:`SqliteBackend` and :class:`PostgresqlBackend` are the two implementations; the
    store (:class:`~robot_wear_monitor.history.store.WearHistory`) and its helper modules
    (``alarms``, ``users``, ``notifications_store``) use nothing else of them.
    """

    @property
    def kind(self) -> str:
        """Return ``'sqlite'`` or ``'postgresql'``."""

    @property
    def name(self) -> str:
        """Return the history's name in messages (a path, or the URL without its password)."""

    @property
    def migrations(self) -> dict[int, tuple[str, ...]]:
        """Return the SQL steps per schema version of this backend."""

    @property
    def errors(self) -> tuple[type[BaseException], ...]:
        """Return the driver's error classes (turned into HistoryError by the store)."""

    def describe(self, error: BaseException) -> str:
        """Return what went wrong, in one line."""

    def execute(self, sql: str, params: SqlParams = ()) -> list[tuple[Any, ...]]:
        """Run one statement (``?`` placeholders); return its rows (empty when none)."""

    def executemany(self, sql: str, rows: Sequence[SqlParams]) -> None:
        """Run one statement once per row of values (a batch)."""

    def transaction(self) -> AbstractContextManager[None]:
        """Return a context that runs its block as one write transaction."""

    def lock_migration(self) -> None:
        """Wait for other processes changing the layout (within the transaction)."""

    def lock_in_transaction(self, key: int) -> None:
        """Hold the advisory lock ``key`` until the transaction ends."""

    def tables(self) -> set[str]:
        """Return the table names of the history's database."""

    def columns(self, table: str) -> set[str]:
        """Return the column names of ``table``."""

    def writer_lock(self, key: int, *, wait: bool) -> AbstractContextManager[None]:
        """Return a context holding the advisory writer lock ``key``."""

    def alive(self, *, check: bool) -> bool:
        """Return whether the connection still serves (``check``: ask the server once)."""

    def close(self) -> None:
        """Close the connection."""


def is_postgresql_url(location: str | os.PathLike) -> bool:
    """Return whether ``location`` is a PostgreSQL URL (``postgresql://USER@HOST:PORT/DB``)."""
    return isinstance(location, str) and location.split('://', 1)[0] in _POSTGRESQL_SCHEMES \
        and '://' in location


def redact_url(url: str) -> str:
    """Return ``url`` without its password, in either form (for messages and logs)."""
    return redact_location(url)


def lock_key(robot: str, joint: str) -> int:
    """Return the signed 64-bit key of the writer lock of (robot, joint)."""
    digest = hashlib.blake2b(f'{robot}\0{joint}'.encode(), digest_size=8).digest()
    return int.from_bytes(digest, 'big', signed=True)


def not_ours_message(name: str, tables: set[str]) -> str:
    """Return the refusal of a database that is not a wear history (it is left untouched)."""
    shown = ', '.join(sorted(tables)[:8]) + (', ...' if len(tables) > 8 else '')
    return (f'{name}: not a wear history of this monitor (tables {shown}; no schema version); '
            'left untouched')


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


class SqliteBackend:
    """An SQLite history file (``':memory:'``: a history that is not kept)."""

    kind = 'sqlite'
    migrations = SQLITE_MIGRATIONS

    def __init__(self, path: str | os.PathLike, *, init: Optional[bool]) -> None:
        """
        Open ``path``; create it when missing (unless ``init`` is False).

        An existing empty file is initialised only when ``init`` is True; a file that is not a
        wear history (other tables, no ``schema_version``) is refused and not touched.
        """
        self.name = str(path)
        self.errors: tuple[type[BaseException], ...] = (sqlite3.Error,)
        self._lock_fd: Optional[int] = None
        if self.name != ':memory:':
            self._prepare_file(init=init)
        deadline = time.monotonic() + OPEN_TIMEOUT_S
        while True:
            conn = None
            try:
                conn = sqlite3.connect(self.name, isolation_level=None,
                                       check_same_thread=False, timeout=BUSY_TIMEOUT_S)
                self._configure(conn)
                self.conn = conn
                return
            except sqlite3.OperationalError as error:
                if conn is not None:
                    conn.close()
                # another process is converting the file (WAL needs a moment of exclusive
                # access, which SQLite reports as busy without waiting): retry
                if 'locked' in str(error) and time.monotonic() < deadline:
                    time.sleep(0.05)
                    continue
                raise HistoryError(f'{self.name}: cannot open the wear history: '
                                   f'{_first_line(error)}') from None
            except sqlite3.DatabaseError as error:
                if conn is not None:
                    conn.close()
                raise HistoryError(f'{self.name}: not a usable wear history database: '
                                   f'{_first_line(error)}') from None

    @staticmethod
    def _configure(conn: sqlite3.Connection) -> None:
        conn.execute('PRAGMA journal_mode=WAL')
        conn.execute('PRAGMA synchronous=FULL')
        conn.execute('PRAGMA foreign_keys=ON')

    def _prepare_file(self, *, init: Optional[bool]) -> None:
        """Check an existing file read-only, or create a new history atomically."""
        path = Path(self.name)
        if path.exists():
            if not path.is_file():
                raise HistoryError(f'{self.name}: not a file; the wear history is an SQLite '
                                   'file or a postgresql:// URL')
            tables = self._tables_read_only(path)
            if tables and 'schema_version' not in tables:
                raise HistoryError(not_ours_message(self.name, tables))
            if not tables and not init:
                raise HistoryError(f'{self.name}: an empty file, not a wear history; give '
                                   '--init to initialise it as one')
            return
        if init is False:
            raise HistoryError(f'{self.name}: no such wear history')
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise HistoryError(f'{self.name}: cannot create its folder: '
                               f'{error.strerror}') from None
        self._create_atomically(path)

    def _tables_read_only(self, path: Path) -> Optional[set[str]]:
        """Return the tables of the file at ``path`` (None when it has zero bytes)."""
        try:
            if path.stat().st_size == 0:
                return None
            conn = sqlite3.connect(path.absolute().as_uri() + '?mode=ro', uri=True,
                                   timeout=BUSY_TIMEOUT_S)
            try:
                return {row[0] for row in conn.execute(
                    "SELECT name FROM sqlite_master WHERE type = 'table' "
                    "AND name NOT LIKE 'sqlite_%'")}
            finally:
                conn.close()
        except sqlite3.DatabaseError as error:
            raise HistoryError(f'{self.name}: not a usable wear history database: '
                               f'{_first_line(error)}') from None
        except OSError as error:
            raise HistoryError(f'{self.name}: cannot read it: {error.strerror}') from None

    def _create_atomically(self, path: Path) -> None:
        """
        Create a WAL-mode database under a temporary name and link it to ``path``.

        The layout itself is made by the migration on open; the link never replaces a file
        another process created meanwhile (that one is opened instead).
        """
        try:
            handle, staging = tempfile.mkstemp(prefix=f'.{path.name}.', suffix='.new',
                                               dir=path.parent)
        except OSError as error:
            raise HistoryError(f'{self.name}: cannot create the wear history: '
                               f'{error.strerror}') from None
        os.close(handle)
        try:
            conn = sqlite3.connect(staging)
            try:
                conn.execute('PRAGMA journal_mode=WAL')
                conn.execute('CREATE TABLE schema_version (version INTEGER NOT NULL)')
            finally:
                conn.close()
            try:
                os.link(staging, path)
            except FileExistsError:
                pass  # another process made it first
            except OSError:  # no hard links on this file system: only if still absent
                if not path.exists():
                    os.replace(staging, path)
        except (OSError, sqlite3.Error) as error:
            reason = getattr(error, 'strerror', None) or _first_line(error)
            raise HistoryError(f'{self.name}: cannot create the wear history: {reason}') from None
        finally:
            Path(staging).unlink(missing_ok=True)

    def describe(self, error: BaseException) -> str:
        """Return what went wrong, in one line."""
        return _first_line(error)

    def execute(self, sql: str, params: SqlParams = ()) -> list[tuple[Any, ...]]:
        """Run one statement; return its rows (empty for statements without rows)."""
        return self.conn.execute(sql, params).fetchall()

    def executemany(self, sql: str, rows: Sequence[SqlParams]) -> None:
        """Run one statement once per row of values (a batch)."""
        self.conn.executemany(sql, rows)

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Run the block as one write transaction, begun IMMEDIATE."""
        self.conn.execute('BEGIN IMMEDIATE')
        try:
            yield
        except BaseException:
            if self.conn.in_transaction:
                self.conn.execute('ROLLBACK')
            raise
        self.conn.execute('COMMIT')

    def lock_migration(self) -> None:
        """Nothing: ``BEGIN IMMEDIATE`` already excludes other writers."""

    def lock_in_transaction(self, key: int) -> None:
        """Nothing: ``BEGIN IMMEDIATE`` already excludes other writers."""

    def tables(self) -> set[str]:
        """Return the table names, without SQLite's own ones."""
        return {row[0] for row in self.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'")}

    def columns(self, table: str) -> set[str]:
        """Return the column names of ``table``."""
        return {row[1] for row in self.execute(f'PRAGMA table_info({table})')}

    @contextmanager
    def writer_lock(self, key: int, *, wait: bool) -> Iterator[None]:
        """Hold the advisory writer lock ``key`` (a byte of ``<history>-lock``)."""
        if self.name == ':memory:':
            yield
            return
        if self._lock_fd is None:
            try:  # never through a link planted at the lock's predictable name
                self._lock_fd = os.open(self.name + '-lock',
                                        os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
            except OSError as error:
                reason = ('a symbolic link (refused)' if error.errno == errno.ELOOP
                          else error.strerror)
                raise HistoryError(f'{self.name}-lock: cannot open the writer lock: '
                                   f'{reason}') from None
        offset = key & 0x7FFFFFFFFFFF  # a byte range far apart from its neighbours
        flags = fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB)
        try:
            fcntl.lockf(self._lock_fd, flags, 1, offset)
        except (BlockingIOError, PermissionError):
            raise HistoryError(f'{self.name}: in use by another writer of this robot and '
                               'joint') from None
        try:
            yield
        finally:
            fcntl.lockf(self._lock_fd, fcntl.LOCK_UN, 1, offset)

    def alive(self, *, check: bool) -> bool:
        """Return True: a file does not go away like a server connection."""
        return True

    def close(self) -> None:
        """Close the connection (a WAL checkpoint folds the log into the file)."""
        self.conn.close()
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None


class PostgresqlBackend:
    """A history in a PostgreSQL database (psycopg 3, autocommit with explicit transactions)."""

    kind = 'postgresql'
    migrations = POSTGRESQL_MIGRATIONS

    def __init__(self, url: str) -> None:
        """Connect to ``url``; raise :class:`HistoryError` naming it when that fails."""
        self.name = redact_url(url)
        try:
            # deferred import: optional extra 'postgresql'
            import psycopg
        except ImportError:
            raise HistoryError(f'{self.name}: a PostgreSQL history needs psycopg 3: pip install '
                               '"robot_wear_monitor[postgresql]" (or apt-get install '
                               'python3-psycopg)') from None
        self._psycopg = psycopg
        self.errors: tuple[type[BaseException], ...] = (psycopg.Error,)
        try:
            self.conn = psycopg.connect(url, autocommit=True, connect_timeout=CONNECT_TIMEOUT_S,
                                        application_name='robot_wear_monitor')
        except psycopg.Error as error:
            raise HistoryError(f'{self.name}: cannot connect to the wear history server: '
                               f'{_first_line(error)}') from None

    def describe(self, error: BaseException) -> str:
        """Return what went wrong, in one line."""
        if isinstance(error, self._psycopg.OperationalError) or self.conn.closed:
            return (f'lost the connection to the wear history server ({_first_line(error)}); '
                    'what was committed before is kept')
        return _first_line(error)

    def execute(self, sql: str, params: Optional[SqlParams] = ()) -> list[tuple[Any, ...]]:
        """Run one statement (``?`` placeholders); return its rows."""
        cursor = self.conn.execute(sql.replace('?', '%s'), params or None)
        return cursor.fetchall() if cursor.description is not None else []

    def executemany(self, sql: str, rows: Sequence[SqlParams]) -> None:
        """Run one statement once per row of values (a batch, pipelined)."""
        with self.conn.cursor() as cursor:
            cursor.executemany(sql.replace('?', '%s'), rows)

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Run the block in one transaction."""
        with self.conn.transaction():
            yield

    def lock_migration(self) -> None:
        """Wait for other processes changing the layout (a transaction-scoped advisory lock)."""
        self.execute('SELECT pg_advisory_xact_lock(?)', (_MIGRATION_LOCK_KEY,))

    def lock_in_transaction(self, key: int) -> None:
        """
        Hold the advisory lock ``key`` until the transaction ends (a check, then a write).

        Use keys other than the writer locks' (a writer holds its lock for a whole run).
        """
        self.execute('SELECT pg_advisory_xact_lock(?)', (key,))

    def tables(self) -> set[str]:
        """Return the names of the tables of the current schema."""
        return {row[0] for row in self.execute(
            'SELECT table_name FROM information_schema.tables '
            'WHERE table_schema = current_schema()')}

    def columns(self, table: str) -> set[str]:
        """Return the column names of ``table`` in the current schema."""
        return {row[0] for row in self.execute(
            'SELECT column_name FROM information_schema.columns '
            'WHERE table_schema = current_schema() AND table_name = ?', (table,))}

    @contextmanager
    def writer_lock(self, key: int, *, wait: bool) -> Iterator[None]:
        """Hold the session advisory lock ``key`` of the server."""
        if wait:
            self.execute('SELECT pg_advisory_lock(?)', (key,))
        elif not self.execute('SELECT pg_try_advisory_lock(?)', (key,))[0][0]:
            raise HistoryError(f'{self.name}: in use by another writer of this robot and joint')
        try:
            yield
        finally:
            if not self.conn.closed:
                self.execute('SELECT pg_advisory_unlock(?)', (key,))

    def alive(self, *, check: bool) -> bool:
        """
        Return whether the connection still serves.

        False once psycopg knows it lost it (closed or broken); with ``check`` also when a
        ``SELECT 1`` fails (a server restart is only seen by the next statement).
        """
        if self.conn.closed or self.conn.broken:
            return False
        if check:
            try:
                self.conn.execute('SELECT 1')
            except self._psycopg.Error:
                return False
        return True

    def close(self) -> None:
        """Close the connection."""
        self.conn.close()
