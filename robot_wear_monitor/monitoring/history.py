"""Wear history in SQLite: every estimate with its time, inputs, result and the alarm state.

One transaction per estimate (the estimate row and, when the alarm changes, the alarm event are
committed together), WAL journal with ``synchronous=FULL``: a killed process loses nothing that
was reported.  On start the estimator restores its trend, its latched alarm and the evidence of
the alarm test from here.  A ``schema_version`` table guards the layout; a history of an older
layout is migrated in place when opened (version 1 -> 2 adds the confidence intervals and the
trend columns, empty for the old rows), so a file that loads today loads tomorrow.
"""

from __future__ import annotations

from dataclasses import dataclass
import json
import math
import os
from pathlib import Path
import sqlite3
import time
from typing import Optional, Sequence

from robot_wear_monitor.errors import InputError

SCHEMA_VERSION = 2

#: Columns added by schema version 2 (nullable REAL): intervals of the estimate and the trend.
INTERVAL_COLUMNS = ('wear_low', 'wear_high', 'temperature_low_degc', 'temperature_high_degc',
                    'trend_wear', 'trend_low', 'trend_high', 'crossing_experiments',
                    'crossing_time_s')

#: How long a writer waits for another process's transaction [s] (SQLite busy timeout).
_BUSY_TIMEOUT_S = 30.0
#: How long opening retries while another process creates or converts the file [s].
_OPEN_TIMEOUT_S = 30.0

_SCHEMA = """
CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS estimates (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    speeds_rad_s TEXT NOT NULL,
    frictions TEXT NOT NULL,
    temperature_degc REAL NOT NULL,
    temperature_std_degc REAL,
    wear REAL NOT NULL,
    wear_std REAL,
    chi2 REAL,
    dof INTEGER NOT NULL,
    p_value REAL,
    temperature_at_bound INTEGER NOT NULL,
    wear_at_bound INTEGER NOT NULL,
    alarm_active INTEGER NOT NULL,
    alarm_evidence REAL NOT NULL,
    status_level INTEGER NOT NULL,
    parameter_set TEXT NOT NULL,
    wear_low REAL,
    wear_high REAL,
    temperature_low_degc REAL,
    temperature_high_degc REAL,
    trend_wear REAL,
    trend_low REAL,
    trend_high REAL,
    crossing_experiments REAL,
    crossing_time_s REAL
);
CREATE INDEX IF NOT EXISTS estimates_joint ON estimates (joint, id);
CREATE INDEX IF NOT EXISTS estimates_joint_stamp ON estimates (joint, stamp_s);
CREATE TABLE IF NOT EXISTS alarm_events (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    event TEXT NOT NULL CHECK (event IN ('raised', 'reset')),
    wear REAL,
    estimate_id INTEGER REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS alarm_events_joint ON alarm_events (joint, id);
"""


class HistoryError(InputError):
    """The history database cannot be opened or has an unknown layout."""


@dataclass(frozen=True)
class HistoryRecord:
    """One stored estimate: the inputs, the result and the alarm state after it."""

    joint: str
    stamp_s: float
    speeds_rad_s: tuple[float, ...]
    frictions: tuple[float, ...]
    temperature_degc: float
    temperature_std_degc: float
    wear: float
    wear_std: float
    chi2: float
    dof: int
    p_value: float
    temperature_at_bound: bool
    wear_at_bound: bool
    alarm_active: bool
    alarm_evidence: float
    status_level: int
    parameter_set: str
    id: Optional[int] = None
    wear_low: float = math.nan
    wear_high: float = math.nan
    temperature_low_degc: float = math.nan
    temperature_high_degc: float = math.nan
    trend_wear: float = math.nan
    trend_low: float = math.nan
    trend_high: float = math.nan
    crossing_experiments: float = math.nan
    crossing_time_s: float = math.nan


@dataclass(frozen=True)
class AlarmEvent:
    """An alarm raise or reset."""

    joint: str
    stamp_s: float
    event: str
    wear: Optional[float]
    note: str = ''
    estimate_id: Optional[int] = None


@dataclass(frozen=True)
class RestoredState:
    """What a restarted estimator takes over: the trend, the latched alarm and its evidence."""

    records: tuple[HistoryRecord, ...]
    alarm_active: bool
    alarm_evidence: float
    last_event: Optional[AlarmEvent]


def _finite_or_none(value: float) -> Optional[float]:
    value = float(value)
    return value if math.isfinite(value) else None


def _nan_if_none(value: Optional[float]) -> float:
    return float('nan') if value is None else float(value)


class WearHistory:
    """SQLite store of the wear history of one or more joints (one file, WAL).

    Use ``':memory:'`` for a history that is not kept (tests, replay without ``--history``).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        """Open (and create) the database; raise :class:`HistoryError` if it is unusable."""
        self.path = str(path)
        if self.path != ':memory:':
            try:
                Path(self.path).parent.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise HistoryError(f'{self.path}: cannot create its folder: '
                                   f'{error.strerror}') from None
        deadline = time.monotonic() + _OPEN_TIMEOUT_S
        while True:
            conn = None
            try:
                conn = sqlite3.connect(self.path, isolation_level=None,
                                       check_same_thread=False, timeout=_BUSY_TIMEOUT_S)
                self._conn = conn
                conn.execute('PRAGMA journal_mode=WAL')
                conn.execute('PRAGMA synchronous=FULL')
                conn.execute('PRAGMA foreign_keys=ON')
                self._migrate()
                conn.executescript(_SCHEMA)
                self._check_version()
                return
            except sqlite3.OperationalError as error:
                if conn is not None:
                    conn.close()
                # another process is creating or converting the file (WAL needs a moment of
                # exclusive access, which SQLite reports as busy without waiting): retry
                if 'locked' in str(error) and time.monotonic() < deadline:
                    time.sleep(0.05)
                    continue
                raise HistoryError(f'{self.path}: cannot open the wear history: '
                                   f'{error}') from None
            except sqlite3.DatabaseError as error:
                if conn is not None:
                    conn.close()
                raise HistoryError(f'{self.path}: not a usable wear history database: '
                                   f'{error}') from None

    def _migrate(self) -> None:
        """Bring a history of an older schema version to this one (in one transaction)."""
        tables = {row[0] for row in self._conn.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table'")}
        if 'schema_version' not in tables or 'estimates' not in tables:
            return
        rows = self._conn.execute('SELECT version FROM schema_version').fetchall()
        if not rows or rows[0][0] != 1:
            return
        with self._transaction() as conn:
            for column in INTERVAL_COLUMNS:
                conn.execute(f'ALTER TABLE estimates ADD COLUMN {column} REAL')
            conn.execute('UPDATE schema_version SET version = ?', (SCHEMA_VERSION,))

    def _check_version(self) -> None:
        rows = self._conn.execute('SELECT version FROM schema_version').fetchall()
        if not rows:
            with self._transaction():
                self._conn.execute('INSERT INTO schema_version (version) VALUES (?)',
                                   (SCHEMA_VERSION,))
        elif rows[0][0] != SCHEMA_VERSION:
            raise HistoryError(f'{self.path}: wear history schema version {rows[0][0]}, '
                               f'this version reads {SCHEMA_VERSION}')

    class _Transaction:
        def __init__(self, conn: sqlite3.Connection) -> None:
            self.conn = conn

        def __enter__(self) -> sqlite3.Connection:
            self.conn.execute('BEGIN IMMEDIATE')
            return self.conn

        def __exit__(self, exc_type, exc, tb) -> None:
            self.conn.execute('COMMIT' if exc_type is None else 'ROLLBACK')

    def _transaction(self) -> '_Transaction':
        return WearHistory._Transaction(self._conn)

    def close(self) -> None:
        """Close the database (a WAL checkpoint folds the log into the file)."""
        self._conn.close()

    def __enter__(self) -> 'WearHistory':
        """Return self."""
        return self

    def __exit__(self, *exc_info) -> None:
        """Close the database."""
        self.close()

    def append(self, record: HistoryRecord, *,
               events: Sequence[AlarmEvent] = ()) -> Optional[int]:
        """Store one estimate and its alarm events atomically; return the estimate id.

        Returns None, storing nothing, when the history already holds that experiment (same
        joint and end stamp, see :meth:`find_estimate`); the check and the insert are one
        transaction, so two processes writing one history never store an experiment twice.
        """
        with self._transaction() as conn:
            if self.find_estimate(joint=record.joint, stamp_s=record.stamp_s) is not None:
                return None
            cursor = conn.execute(
                'INSERT INTO estimates (joint, stamp_s, wall_time_s, speeds_rad_s, frictions, '
                'temperature_degc, temperature_std_degc, wear, wear_std, chi2, dof, p_value, '
                'temperature_at_bound, wear_at_bound, alarm_active, alarm_evidence, '
                'status_level, parameter_set, ' + ', '.join(INTERVAL_COLUMNS) + ') VALUES ('
                + ','.join('?' * (18 + len(INTERVAL_COLUMNS))) + ')',
                (record.joint, float(record.stamp_s), time.time(),
                 json.dumps([float(v) for v in record.speeds_rad_s]),
                 json.dumps([float(f) for f in record.frictions]),
                 float(record.temperature_degc), _finite_or_none(record.temperature_std_degc),
                 float(record.wear), _finite_or_none(record.wear_std),
                 _finite_or_none(record.chi2), int(record.dof), _finite_or_none(record.p_value),
                 int(bool(record.temperature_at_bound)), int(bool(record.wear_at_bound)),
                 int(bool(record.alarm_active)), float(record.alarm_evidence),
                 int(record.status_level), record.parameter_set,
                 *(_finite_or_none(getattr(record, c)) for c in INTERVAL_COLUMNS)))
            estimate_id = int(cursor.lastrowid)
            for event in events:
                self._insert_event(conn, event, estimate_id)
        return estimate_id

    def find_estimate(self, *, joint: str, stamp_s: float,
                      tolerance_s: float = 1e-6) -> Optional[int]:
        """Return the id of the stored estimate of ``joint``'s experiment ending at ``stamp_s``.

        An experiment's identity is its joint and the stamp of its end [s] (one joint ends one
        experiment at a time): a re-run of the same recording finds its estimates here.
        """
        row = self._conn.execute(
            'SELECT id FROM estimates WHERE joint = ? AND stamp_s BETWEEN ? AND ? '
            'ORDER BY id LIMIT 1', (joint, float(stamp_s) - tolerance_s,
                                    float(stamp_s) + tolerance_s)).fetchone()
        return None if row is None else int(row[0])

    def record_event(self, event: AlarmEvent) -> None:
        """Store an alarm event on its own (a reset after maintenance)."""
        with self._transaction() as conn:
            self._insert_event(conn, event, event.estimate_id)

    @staticmethod
    def _insert_event(conn: sqlite3.Connection, event: AlarmEvent,
                      estimate_id: Optional[int]) -> None:
        conn.execute('INSERT INTO alarm_events (joint, stamp_s, wall_time_s, event, wear, '
                     'estimate_id, note) VALUES (?,?,?,?,?,?,?)',
                     (event.joint, float(event.stamp_s), time.time(), event.event,
                      None if event.wear is None else _finite_or_none(event.wear),
                      estimate_id, event.note))

    def records(self, *, joint: str, limit: Optional[int] = None) -> tuple[HistoryRecord, ...]:
        """Return the stored estimates of ``joint``, oldest first (the last ``limit`` if given)."""
        query = ('SELECT id, joint, stamp_s, speeds_rad_s, frictions, temperature_degc, '
                 'temperature_std_degc, wear, wear_std, chi2, dof, p_value, '
                 'temperature_at_bound, wear_at_bound, alarm_active, alarm_evidence, '
                 'status_level, parameter_set, ' + ', '.join(INTERVAL_COLUMNS)
                 + ' FROM estimates WHERE joint = ? ORDER BY id DESC')
        params: tuple = (joint,)
        if limit is not None:
            query += ' LIMIT ?'
            params = (joint, int(limit))
        rows = self._conn.execute(query, params).fetchall()
        return tuple(HistoryRecord(
            id=row[0], joint=row[1], stamp_s=row[2],
            speeds_rad_s=tuple(json.loads(row[3])), frictions=tuple(json.loads(row[4])),
            temperature_degc=row[5], temperature_std_degc=_nan_if_none(row[6]), wear=row[7],
            wear_std=_nan_if_none(row[8]), chi2=_nan_if_none(row[9]), dof=row[10],
            p_value=_nan_if_none(row[11]), temperature_at_bound=bool(row[12]),
            wear_at_bound=bool(row[13]), alarm_active=bool(row[14]), alarm_evidence=row[15],
            status_level=row[16], parameter_set=row[17],
            **{c: _nan_if_none(v) for c, v in zip(INTERVAL_COLUMNS, row[18:])})
            for row in reversed(rows))

    def joints(self) -> tuple[str, ...]:
        """Return the joints that have stored estimates, sorted."""
        rows = self._conn.execute('SELECT DISTINCT joint FROM estimates ORDER BY joint')
        return tuple(row[0] for row in rows.fetchall())

    def events(self, *, joint: str) -> tuple[AlarmEvent, ...]:
        """Return the alarm events of ``joint``, oldest first."""
        rows = self._conn.execute(
            'SELECT joint, stamp_s, event, wear, note, estimate_id FROM alarm_events '
            'WHERE joint = ? ORDER BY id', (joint,)).fetchall()
        return tuple(AlarmEvent(joint=r[0], stamp_s=r[1], event=r[2], wear=r[3], note=r[4],
                                estimate_id=r[5]) for r in rows)

    def restore(self, *, joint: str, trend_length: Optional[int] = None) -> RestoredState:
        """Return the trend, the latched alarm and the alarm evidence stored for ``joint``.

        The alarm is latched when the last alarm event is ``raised``; the evidence is that
        of the last estimate, or 0 after a reset that came later.
        """
        records = self.records(joint=joint, limit=trend_length)
        row = self._conn.execute(
            'SELECT joint, stamp_s, event, wear, note, estimate_id, id FROM alarm_events '
            'WHERE joint = ? ORDER BY id DESC LIMIT 1', (joint,)).fetchone()
        last_event = None if row is None else AlarmEvent(
            joint=row[0], stamp_s=row[1], event=row[2], wear=row[3], note=row[4],
            estimate_id=row[5])
        active = last_event is not None and last_event.event == 'raised'
        evidence = records[-1].alarm_evidence if records else 0.0
        if last_event is not None and last_event.event == 'reset' and records and (
                last_event.estimate_id is None or last_event.estimate_id >= records[-1].id):
            evidence = 0.0
        return RestoredState(records=records, alarm_active=active, alarm_evidence=evidence,
                             last_event=last_event)


LEVEL_CSV_COLUMNS = ('speed', 'friction', 'experiment', 'time_s', 'wear_hat',
                     'temperature_hat_degc', 'fit_p_value')


def write_levels_csv(path: str | os.PathLike, *, records: Sequence[HistoryRecord]) -> Path:
    """Write the friction levels of stored estimates as a CSV table for ``audit``.

    One row per friction level: ``speed`` [rad/s, motor side], ``friction`` (normalised),
    ``experiment`` (the estimate id, so that the audit folds by experiment), ``time_s`` (stamp
    of the estimate), and the estimate it led to (``wear_hat``, ``temperature_hat_degc``,
    ``fit_p_value``; empty when not finite).  Written to a temporary file and renamed.
    """
    import csv
    import tempfile

    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f'.{target.name}.', dir=target.parent)
    try:
        with os.fdopen(handle, 'w', newline='', encoding='utf-8') as stream:
            writer = csv.writer(stream)
            writer.writerow(LEVEL_CSV_COLUMNS)
            for number, record in enumerate(records, 1):
                experiment = record.id if record.id is not None else number
                estimate = (record.wear, record.temperature_degc, record.p_value)
                extras = [_finite_or_none(value) for value in estimate]
                for speed, friction in zip(record.speeds_rad_s, record.frictions):
                    writer.writerow([repr(float(speed)), repr(float(friction)), experiment,
                                     repr(float(record.stamp_s)),
                                     *('' if v is None else repr(float(v)) for v in extras)])
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return target
