"""The layout of the wear history: one ordered list of SQL steps per schema version and backend.

A history records its version in the one-row table ``schema_version``.  Opening a history
applies, in one transaction, the steps of every version above the recorded one; a new history
runs them all.  SQLite histories exist since version 1; PostgreSQL histories start at version 3
(the first version with robots), so its list starts there.  Steps take no values except the
robot given to old rows (``:robot`` in SQLite), always as a bound parameter.

Version 1: estimates and alarm events per joint.  Version 2: the 95 % intervals of w and T and
the trend columns (NULL in old rows).  Version 3: ``robot`` on every estimate and alarm event
(old rows get the robot the history is opened for, else ``default``); the experiment's identity
(robot, joint, end stamp) is a unique key, so that a re-run or a concurrent writer adds nothing;
``recordings`` lists the recordings a batch re-analysis replayed completely (robot and content
fingerprint), so that a re-run skips them.  Version 4: ``invalid_reason`` on every estimate
('' for a valid one, the plausibility checks' verdict for one the monitor could not judge; old
rows are valid).
"""

from __future__ import annotations

from robot_wear_monitor.monitoring.history.records import INTERVAL_COLUMNS

SCHEMA_VERSION = 4

#: The tables of a wear history (a database holding some of them without ``schema_version``
#: is not ours).
TABLES = ('schema_version', 'estimates', 'alarm_events', 'recordings')

_SQLITE_V1 = (
    'CREATE TABLE schema_version (version INTEGER NOT NULL)',
    """CREATE TABLE estimates (
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
    parameter_set TEXT NOT NULL)""",
    'CREATE INDEX estimates_joint ON estimates (joint, id)',
    'CREATE INDEX estimates_joint_stamp ON estimates (joint, stamp_s)',
    """CREATE TABLE alarm_events (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    event TEXT NOT NULL CHECK (event IN ('raised', 'reset')),
    wear REAL,
    estimate_id INTEGER REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT '')""",
    'CREATE INDEX alarm_events_joint ON alarm_events (joint, id)',
)

_SQLITE_V2 = tuple(f'ALTER TABLE estimates ADD COLUMN {column} REAL'
                   for column in INTERVAL_COLUMNS)

_SQLITE_V3 = (
    # ADD COLUMN ... NOT NULL needs a default; every insert names the robot
    "ALTER TABLE estimates ADD COLUMN robot TEXT NOT NULL DEFAULT 'default'",
    "ALTER TABLE alarm_events ADD COLUMN robot TEXT NOT NULL DEFAULT 'default'",
    'UPDATE estimates SET robot = :robot',
    'UPDATE alarm_events SET robot = :robot',
    'DROP INDEX IF EXISTS estimates_joint',
    'DROP INDEX IF EXISTS estimates_joint_stamp',
    'DROP INDEX IF EXISTS alarm_events_joint',
    'CREATE UNIQUE INDEX estimates_experiment ON estimates (robot, joint, stamp_s)',
    'CREATE INDEX estimates_robot_joint ON estimates (robot, joint, id)',
    'CREATE INDEX alarm_events_robot_joint ON alarm_events (robot, joint, id)',
    """CREATE TABLE recordings (
    robot TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    name TEXT NOT NULL,
    experiments INTEGER NOT NULL,
    wall_time_s REAL NOT NULL,
    PRIMARY KEY (robot, fingerprint))""",
)

_V4 = ("ALTER TABLE estimates ADD COLUMN invalid_reason TEXT NOT NULL DEFAULT ''",)

#: SQLite: version -> its steps, oldest first.
SQLITE_MIGRATIONS: dict[int, tuple[str, ...]] = {1: _SQLITE_V1, 2: _SQLITE_V2, 3: _SQLITE_V3,
                                                 4: _V4}

_POSTGRESQL_V3 = (
    'CREATE TABLE schema_version (version INTEGER NOT NULL)',
    """CREATE TABLE estimates (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    robot TEXT NOT NULL,
    joint TEXT NOT NULL,
    stamp_s DOUBLE PRECISION NOT NULL,
    wall_time_s DOUBLE PRECISION NOT NULL,
    speeds_rad_s TEXT NOT NULL,
    frictions TEXT NOT NULL,
    temperature_degc DOUBLE PRECISION NOT NULL,
    temperature_std_degc DOUBLE PRECISION,
    wear DOUBLE PRECISION NOT NULL,
    wear_std DOUBLE PRECISION,
    chi2 DOUBLE PRECISION,
    dof INTEGER NOT NULL,
    p_value DOUBLE PRECISION,
    temperature_at_bound INTEGER NOT NULL,
    wear_at_bound INTEGER NOT NULL,
    alarm_active INTEGER NOT NULL,
    alarm_evidence DOUBLE PRECISION NOT NULL,
    status_level INTEGER NOT NULL,
    parameter_set TEXT NOT NULL,
    """ + ',\n    '.join(f'{c} DOUBLE PRECISION' for c in INTERVAL_COLUMNS) + ')',
    'CREATE UNIQUE INDEX estimates_experiment ON estimates (robot, joint, stamp_s)',
    'CREATE INDEX estimates_robot_joint ON estimates (robot, joint, id)',
    """CREATE TABLE alarm_events (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    robot TEXT NOT NULL,
    joint TEXT NOT NULL,
    stamp_s DOUBLE PRECISION NOT NULL,
    wall_time_s DOUBLE PRECISION NOT NULL,
    event TEXT NOT NULL CHECK (event IN ('raised', 'reset')),
    wear DOUBLE PRECISION,
    estimate_id BIGINT REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT '')""",
    'CREATE INDEX alarm_events_robot_joint ON alarm_events (robot, joint, id)',
    """CREATE TABLE recordings (
    robot TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    name TEXT NOT NULL,
    experiments INTEGER NOT NULL,
    wall_time_s DOUBLE PRECISION NOT NULL,
    PRIMARY KEY (robot, fingerprint))""",
)

#: PostgreSQL: version -> its steps, oldest first.
POSTGRESQL_MIGRATIONS: dict[int, tuple[str, ...]] = {3: _POSTGRESQL_V3, 4: _V4}
