"""
The layout of the wear history: one ordered list of SQL steps per schema version and backend.

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
rows are valid).  Version 5 (the maintenance team's dashboard): alarm events may also be
'acknowledged' and carry the user, the owner and the planned maintenance date (SQLite rebuilds
``alarm_events`` for its new CHECK; ids and rows are kept); ``users`` (dashboard accounts,
argon2 hashes), ``notifications`` (one row per notification event sent, unique key),
``joint_summary`` (per robot and joint: the latest estimate's id, the count and the first
stamp, kept by every append in the same transaction, filled from the rows on migration, so
that the fleet view reads one row per joint whatever the number of estimates) and the index
of the fleet's alarm log per robot, newest first.  Version 6: ``sessions`` (the dashboard's
server-side sessions).  Version 7 (accounts and the write API): alarm events may also be
'acknowledgement_edited' and 'acknowledgement_withdrawn' and carry a ``work_order`` (''
in old rows); a user's role may also be 'admin' (SQLite rebuilds ``alarm_events`` and
``users`` for their new CHECKs, keeping ids and rows; PostgreSQL replaces the constraints);
``api_tokens`` (per-user API tokens: only their SHA-256, when made and last used).  Version 8
(one owner of the threshold): every estimate stores the wear ``threshold`` and the
``warning_level`` it was judged by (the estimator's node parameters ``wear_threshold`` and
``wear_warning``); old rows hold NULL (not known: readers assume the parameter set's and say
so).  Version 9 (maintenance states): alarm events carry their ``source`` (web, api, cli,
ros; '' for the monitor's raises and old rows) and ``changes`` (what an edit changed, ''
otherwise).  Version 10: ``account_audit`` (every change of a dashboard account: when,
who, from where, what, whom; never a secret).  Version 11: the alarm event kind
``reescalated`` (an acknowledged alarm back on top, logged once with its source).
Version 12 (a fleet page that does not read the fleet): ``joint_summary`` keeps each joint's
ranking key and the stable parts of its state, with the times the clock is compared with
(stale, crossing, planned date), indexed; every append and alarm event keeps them, and the
migration fills them for the existing joints (``fleet_index.py``, run by the store after
these steps); ``fleet_robots`` lists the robots (the robot search and count).  Version 13
(the dashboard on several workers): ``login_failures`` (the login rate limit's counted
attempts, per client address and per user name from an address, shared by every worker);
``notifications.pending_until_s`` (the lease of a claimed send until it is settled: NULL once
settled and in older rows; a claim whose notifier died is taken over after it).  Version 14
(the fleet's counts kept on write): ``fleet_state_counts`` (the joints per stable state,
kept by triggers on ``joint_summary``: ``fleet_counts.py``) and the index of the stale
moments per stable state (the clock's share of the counts).
"""

from __future__ import annotations

from robot_wear_monitor.history import fleet_counts
from robot_wear_monitor.history.records import INTERVAL_COLUMNS

SCHEMA_VERSION = 14

#: The tables of a wear history (a database holding some of them without ``schema_version``
#: is not ours).
TABLES = ('schema_version', 'estimates', 'alarm_events', 'recordings', 'users',
          'notifications', 'joint_summary', 'sessions', 'api_tokens', 'account_audit',
          'login_failures', 'fleet_robots', 'fleet_state_counts')

#: Fill ``joint_summary`` from the estimates (the migration; a bulk load runs it too).
JOINT_SUMMARY_REBUILD = (
    'DELETE FROM joint_summary',
    'INSERT INTO joint_summary (robot, joint, last_id, experiments, first_stamp_s) '
    'SELECT robot, joint, MAX(id), COUNT(*), MIN(stamp_s) FROM estimates GROUP BY robot, joint',
)

#: Count one new estimate (robot, joint, its id, its stamp) into ``joint_summary``.
JOINT_SUMMARY_ADD = (
    'INSERT INTO joint_summary (robot, joint, last_id, experiments, first_stamp_s) '
    'VALUES (?, ?, ?, 1, ?) ON CONFLICT (robot, joint) DO UPDATE SET '
    'last_id = CASE WHEN excluded.last_id > joint_summary.last_id THEN excluded.last_id '
    'ELSE joint_summary.last_id END, experiments = joint_summary.experiments + 1, '
    'first_stamp_s = CASE WHEN excluded.first_stamp_s < joint_summary.first_stamp_s '
    'THEN excluded.first_stamp_s ELSE joint_summary.first_stamp_s END')

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

#: The alarm events of version 5 (SQLite cannot change a CHECK: the table is rebuilt).
_EVENT_KINDS_CHECK = "CHECK (event IN ('raised', 'reset', 'acknowledged'))"
_EVENT_V5_COLUMNS = ('id, robot, joint, stamp_s, wall_time_s, event, wear, estimate_id, '
                     'note')

_SQLITE_V5 = (
    f"""CREATE TABLE alarm_events_v5 (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    robot TEXT NOT NULL DEFAULT 'default',
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    event TEXT NOT NULL {_EVENT_KINDS_CHECK},
    wear REAL,
    estimate_id INTEGER REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT '',
    user_name TEXT NOT NULL DEFAULT '',
    owner TEXT NOT NULL DEFAULT '',
    planned_maintenance TEXT NOT NULL DEFAULT '')""",
    f'INSERT INTO alarm_events_v5 ({_EVENT_V5_COLUMNS}) SELECT {_EVENT_V5_COLUMNS} '
    'FROM alarm_events ORDER BY id',
    'DROP TABLE alarm_events',
    'ALTER TABLE alarm_events_v5 RENAME TO alarm_events',
    'CREATE INDEX alarm_events_robot_joint ON alarm_events (robot, joint, id)',
    'CREATE INDEX alarm_events_robot ON alarm_events (robot, id)',
    """CREATE TABLE users (
    name TEXT PRIMARY KEY,
    role TEXT NOT NULL CHECK (role IN ('viewer', 'maintainer')),
    password_hash TEXT NOT NULL,
    created_wall_time_s REAL NOT NULL)""",
    """CREATE TABLE notifications (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    event_key TEXT NOT NULL UNIQUE,
    robot TEXT,
    joint TEXT,
    kind TEXT,
    wall_time_s REAL,
    channel TEXT,
    payload TEXT)""",
    """CREATE TABLE joint_summary (
    robot TEXT NOT NULL,
    joint TEXT NOT NULL,
    last_id INTEGER NOT NULL,
    experiments INTEGER NOT NULL,
    first_stamp_s REAL NOT NULL,
    PRIMARY KEY (robot, joint))""",
    JOINT_SUMMARY_REBUILD[1],
)

#: Version 6: the dashboard's sessions, kept server-side (a logout or a removed user ends them
#: at once); the cookie holds a random id whose SHA-256 is ``id_hash``.
_V6 = (
    """CREATE TABLE sessions (
    id_hash TEXT PRIMARY KEY,
    user_name TEXT NOT NULL,
    csrf TEXT NOT NULL,
    created_wall_time_s DOUBLE PRECISION NOT NULL,
    expires_wall_time_s DOUBLE PRECISION NOT NULL)""",
    'CREATE INDEX sessions_user ON sessions (user_name)',
)

#: The event kinds and roles of version 7 (a layout's CHECKs never change: a new kind or role
#: is a new version; ``users.ROLES`` and ``records.ALARM_EVENT_KINDS`` are these).
_EVENT_KINDS_V7_CHECK = ("CHECK (event IN ('raised', 'reset', 'acknowledged', "
                         "'acknowledgement_edited', 'acknowledgement_withdrawn'))")
_ROLES_V7_CHECK = "CHECK (role IN ('viewer', 'maintainer', 'admin'))"
_EVENT_V7_COLUMNS = _EVENT_V5_COLUMNS + ', user_name, owner, planned_maintenance'
_USER_COLUMNS = 'name, role, password_hash, created_wall_time_s'

#: Version 7: per-user API tokens (the write API); the token itself is never stored.
_API_TOKENS = (
    """CREATE TABLE api_tokens (
    id {id_column},
    user_name TEXT NOT NULL,
    token_hash TEXT NOT NULL UNIQUE,
    label TEXT NOT NULL DEFAULT '',
    created_wall_time_s DOUBLE PRECISION NOT NULL,
    last_used_wall_time_s DOUBLE PRECISION)""",
    'CREATE INDEX api_tokens_user ON api_tokens (user_name)',
)

_SQLITE_V7 = (
    f"""CREATE TABLE alarm_events_v7 (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    robot TEXT NOT NULL DEFAULT 'default',
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    event TEXT NOT NULL {_EVENT_KINDS_V7_CHECK},
    wear REAL,
    estimate_id INTEGER REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT '',
    user_name TEXT NOT NULL DEFAULT '',
    owner TEXT NOT NULL DEFAULT '',
    planned_maintenance TEXT NOT NULL DEFAULT '',
    work_order TEXT NOT NULL DEFAULT '')""",
    f'INSERT INTO alarm_events_v7 ({_EVENT_V7_COLUMNS}) SELECT {_EVENT_V7_COLUMNS} '
    'FROM alarm_events ORDER BY id',
    'DROP TABLE alarm_events',
    'ALTER TABLE alarm_events_v7 RENAME TO alarm_events',
    'CREATE INDEX alarm_events_robot_joint ON alarm_events (robot, joint, id)',
    'CREATE INDEX alarm_events_robot ON alarm_events (robot, id)',
    f"""CREATE TABLE users_v7 (
    name TEXT PRIMARY KEY,
    role TEXT NOT NULL {_ROLES_V7_CHECK},
    password_hash TEXT NOT NULL,
    created_wall_time_s REAL NOT NULL)""",
    f'INSERT INTO users_v7 ({_USER_COLUMNS}) SELECT {_USER_COLUMNS} FROM users',
    'DROP TABLE users',
    'ALTER TABLE users_v7 RENAME TO users',
    _API_TOKENS[0].format(id_column='INTEGER PRIMARY KEY AUTOINCREMENT'),
    _API_TOKENS[1],
)

#: Version 8: the threshold and warning level each estimate was judged by [w] (NULL: not
#: stored, rows of older versions).
_V8 = ('ALTER TABLE estimates ADD COLUMN threshold DOUBLE PRECISION',
       'ALTER TABLE estimates ADD COLUMN warning_level DOUBLE PRECISION')

#: Version 9: where a person's alarm event came from and what an edit changed.
_V9 = ("ALTER TABLE alarm_events ADD COLUMN source TEXT NOT NULL DEFAULT ''",
       "ALTER TABLE alarm_events ADD COLUMN changes TEXT NOT NULL DEFAULT ''")

#: Version 10: the audit of the dashboard's accounts (``history.account_audit``).
_ACCOUNT_AUDIT = (
    """CREATE TABLE account_audit (
    id {id_column},
    time_s DOUBLE PRECISION NOT NULL,
    user_name TEXT NOT NULL,
    source TEXT NOT NULL,
    action TEXT NOT NULL,
    target TEXT NOT NULL,
    detail TEXT NOT NULL DEFAULT '')""",
    'CREATE INDEX account_audit_time ON account_audit (time_s, id)',
)

#: Version 11: a re-escalated acknowledged alarm is an event of the alarm log ('reescalated',
#: recorded once by whoever sees it first: the notifier, the dashboard, the command line).
_EVENT_KINDS_V11_CHECK = ("CHECK (event IN ('raised', 'reset', 'acknowledged', "
                          "'acknowledgement_edited', 'acknowledgement_withdrawn', "
                          "'reescalated'))")
_EVENT_V11_COLUMNS = _EVENT_V7_COLUMNS + ', work_order, source, changes'
_SQLITE_V11 = (
    f"""CREATE TABLE alarm_events_v11 (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    robot TEXT NOT NULL DEFAULT 'default',
    joint TEXT NOT NULL,
    stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    event TEXT NOT NULL {_EVENT_KINDS_V11_CHECK},
    wear REAL,
    estimate_id INTEGER REFERENCES estimates (id),
    note TEXT NOT NULL DEFAULT '',
    user_name TEXT NOT NULL DEFAULT '',
    owner TEXT NOT NULL DEFAULT '',
    planned_maintenance TEXT NOT NULL DEFAULT '',
    work_order TEXT NOT NULL DEFAULT '',
    source TEXT NOT NULL DEFAULT '',
    changes TEXT NOT NULL DEFAULT '')""",
    f'INSERT INTO alarm_events_v11 ({_EVENT_V11_COLUMNS}) SELECT {_EVENT_V11_COLUMNS} '
    'FROM alarm_events ORDER BY id',
    'DROP TABLE alarm_events',
    'ALTER TABLE alarm_events_v11 RENAME TO alarm_events',
    'CREATE INDEX alarm_events_robot_joint ON alarm_events (robot, joint, id)',
    'CREATE INDEX alarm_events_robot ON alarm_events (robot, id)',
)
_POSTGRESQL_V11 = (
    'ALTER TABLE alarm_events DROP CONSTRAINT IF EXISTS alarm_events_event_check',
    f'ALTER TABLE alarm_events ADD CONSTRAINT alarm_events_event_check '
    f'{_EVENT_KINDS_V11_CHECK}',
)

#: Version 13: the login rate limit's counted attempts (``history.login_failures``), one row
#: per attempt and key: ``scope`` 'address' (any name from ``address``; ``user_name`` '') or
#: 'user' (``user_name`` from ``address``); rows older than the window are swept.
_LOGIN_FAILURES = (
    """CREATE TABLE login_failures (
    id {id_column},
    scope TEXT NOT NULL CHECK (scope IN ('address', 'user')),
    user_name TEXT NOT NULL,
    address TEXT NOT NULL,
    time_s DOUBLE PRECISION NOT NULL)""",
    'CREATE INDEX login_failures_key ON login_failures (address, scope, user_name, time_s)',
    'CREATE INDEX login_failures_time ON login_failures (time_s)',
    'ALTER TABLE notifications ADD COLUMN pending_until_s DOUBLE PRECISION',
)
#: Version 12: the ranking keys of each joint in ``joint_summary`` (``fleet_index.KEY_COLUMNS``:
#: filled by ``fleet_index.rebuild`` after the steps) and their indexes.
_V12_COLUMNS = (
    'ALTER TABLE joint_summary ADD COLUMN rank_tier INTEGER NOT NULL DEFAULT 3',
    'ALTER TABLE joint_summary ADD COLUMN rank_crossing DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN rank_high DOUBLE PRECISION',
    "ALTER TABLE joint_summary ADD COLUMN state_base TEXT NOT NULL DEFAULT 'judged'",
    'ALTER TABLE joint_summary ADD COLUMN stale_since_s DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN usual_interval_s DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN stale_at_s DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN crossing_at_s DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN warn_fixed INTEGER NOT NULL DEFAULT 0',
    'ALTER TABLE joint_summary ADD COLUMN wear_top DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN warning_level DOUBLE PRECISION',
    "ALTER TABLE joint_summary ADD COLUMN parameter_set TEXT NOT NULL DEFAULT ''",
    'ALTER TABLE joint_summary ADD COLUMN ack_then DOUBLE PRECISION',
    'ALTER TABLE joint_summary ADD COLUMN ack_now DOUBLE PRECISION',
    "ALTER TABLE joint_summary ADD COLUMN planned_date TEXT NOT NULL DEFAULT ''",
    'ALTER TABLE joint_summary ADD COLUMN ack_rise DOUBLE PRECISION',
    'CREATE INDEX joint_summary_stale ON joint_summary (stale_at_s)',
    'CREATE INDEX joint_summary_crossing ON joint_summary (crossing_at_s)',
    'CREATE INDEX joint_summary_last ON joint_summary (last_id)',
    'CREATE INDEX joint_summary_assumed ON joint_summary (warning_level, parameter_set)',
    'CREATE INDEX joint_summary_rise ON joint_summary (ack_rise)',
    'CREATE INDEX joint_summary_near ON joint_summary (state_base, warn_fixed, crossing_at_s, '
    'stale_at_s, warning_level, wear_top, parameter_set)',
    'CREATE INDEX joint_summary_planned ON joint_summary (planned_date)',
    'CREATE TABLE fleet_robots (robot TEXT PRIMARY KEY)',
)
#: The fleet's order (``FleetRow.rank_key``); PostgreSQL orders names by code point as Python.
_SQLITE_V12 = _V12_COLUMNS + (
    'CREATE INDEX joint_summary_rank ON joint_summary (rank_tier, rank_crossing, rank_high, '
    'robot, joint)',
    'CREATE INDEX joint_summary_state ON joint_summary (state_base, warn_fixed, rank_tier, '
    'rank_crossing, rank_high, robot, joint)')
_POSTGRESQL_V12 = _V12_COLUMNS + (
    'CREATE INDEX joint_summary_rank ON joint_summary (rank_tier, rank_crossing, rank_high, '
    'robot COLLATE "C", joint COLLATE "C")',
    'CREATE INDEX joint_summary_state ON joint_summary (state_base, warn_fixed, rank_tier, '
    'rank_crossing, rank_high, robot COLLATE "C", joint COLLATE "C")')

#: Version 14: the joints per stable state kept on write (``fleet_counts``), and the index
#: of the stale moments per stable state.
_V14_INDEX = ('CREATE INDEX joint_summary_stale_state ON joint_summary (state_base, warn_fixed, '
              'stale_at_s, crossing_at_s)',)

#: SQLite: version -> its steps, oldest first.
SQLITE_MIGRATIONS: dict[int, tuple[str, ...]] = {1: _SQLITE_V1, 2: _SQLITE_V2, 3: _SQLITE_V3,
                                                 4: _V4, 5: _SQLITE_V5, 6: _V6, 7: _SQLITE_V7,
                                                 8: _V8, 9: _V9,
                                                 10: (_ACCOUNT_AUDIT[0].format(
                                                     id_column='INTEGER PRIMARY KEY '
                                                               'AUTOINCREMENT'),
                                                      _ACCOUNT_AUDIT[1]),
                                                 11: _SQLITE_V11, 12: _SQLITE_V12,
                                                 13: (_LOGIN_FAILURES[0].format(
                                                     id_column='INTEGER PRIMARY KEY '
                                                               'AUTOINCREMENT'),
                                                      *_LOGIN_FAILURES[1:]),
                                                 14: _V14_INDEX + fleet_counts.SQLITE_STEPS}

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

_POSTGRESQL_V5 = (
    'ALTER TABLE alarm_events DROP CONSTRAINT IF EXISTS alarm_events_event_check',
    f'ALTER TABLE alarm_events ADD CONSTRAINT alarm_events_event_check {_EVENT_KINDS_CHECK}',
    "ALTER TABLE alarm_events ADD COLUMN user_name TEXT NOT NULL DEFAULT ''",
    "ALTER TABLE alarm_events ADD COLUMN owner TEXT NOT NULL DEFAULT ''",
    "ALTER TABLE alarm_events ADD COLUMN planned_maintenance TEXT NOT NULL DEFAULT ''",
    'CREATE INDEX alarm_events_robot ON alarm_events (robot, id)',
    """CREATE TABLE users (
    name TEXT PRIMARY KEY,
    role TEXT NOT NULL CHECK (role IN ('viewer', 'maintainer')),
    password_hash TEXT NOT NULL,
    created_wall_time_s DOUBLE PRECISION NOT NULL)""",
    """CREATE TABLE notifications (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    event_key TEXT NOT NULL UNIQUE,
    robot TEXT,
    joint TEXT,
    kind TEXT,
    wall_time_s DOUBLE PRECISION,
    channel TEXT,
    payload TEXT)""",
    """CREATE TABLE joint_summary (
    robot TEXT NOT NULL,
    joint TEXT NOT NULL,
    last_id BIGINT NOT NULL,
    experiments BIGINT NOT NULL,
    first_stamp_s DOUBLE PRECISION NOT NULL,
    PRIMARY KEY (robot, joint))""",
    JOINT_SUMMARY_REBUILD[1],
)

_POSTGRESQL_V7 = (
    'ALTER TABLE alarm_events DROP CONSTRAINT IF EXISTS alarm_events_event_check',
    f'ALTER TABLE alarm_events ADD CONSTRAINT alarm_events_event_check {_EVENT_KINDS_V7_CHECK}',
    "ALTER TABLE alarm_events ADD COLUMN work_order TEXT NOT NULL DEFAULT ''",
    'ALTER TABLE users DROP CONSTRAINT IF EXISTS users_role_check',
    f'ALTER TABLE users ADD CONSTRAINT users_role_check {_ROLES_V7_CHECK}',
    _API_TOKENS[0].format(id_column='BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY'),
    _API_TOKENS[1],
)

#: PostgreSQL: version -> its steps, oldest first.
POSTGRESQL_MIGRATIONS: dict[int, tuple[str, ...]] = {3: _POSTGRESQL_V3, 4: _V4,
                                                     5: _POSTGRESQL_V5, 6: _V6,
                                                     7: _POSTGRESQL_V7, 8: _V8, 9: _V9,
                                                     10: (_ACCOUNT_AUDIT[0].format(
                                                         id_column='BIGINT GENERATED ALWAYS '
                                                                   'AS IDENTITY PRIMARY KEY'),
                                                          _ACCOUNT_AUDIT[1]),
                                                     11: _POSTGRESQL_V11, 12: _POSTGRESQL_V12,
                                                     13: (_LOGIN_FAILURES[0].format(
                                                         id_column='BIGINT GENERATED ALWAYS '
                                                                   'AS IDENTITY PRIMARY KEY'),
                                                          *_LOGIN_FAILURES[1:]),
                                                     14: _V14_INDEX
                                                     + fleet_counts.POSTGRESQL_STEPS}
