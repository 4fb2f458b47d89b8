"""
Wear history of a fleet: every estimate and alarm event per robot and joint, and the fleet view.

One store behind one interface, :class:`WearHistory` (:func:`open_history`): an SQLite file
(the default; WAL, ``synchronous=FULL``) or a PostgreSQL database (``postgresql://`` URL,
psycopg 3).  One transaction per experiment (the estimate row and its alarm events together),
so a killed process loses nothing that was reported; the experiment's identity (robot, joint,
end stamp) is a unique key, so a re-run of a recording or a concurrent writer adds nothing.  On
start the estimator restores its trend, its latched alarm and the evidence of the alarm test per
robot and joint from here.  A ``schema_version`` table guards the layout (version 10); an older
history is migrated in place when opened (``migrations.py``: version 2 -> 3 gives the old rows
the robot the history is opened for, else ``default``), so a file that loads today loads
tomorrow; a database that is not a wear history is refused and left untouched.  Version 5
adds what the maintenance team's dashboard stores: acknowledgements and resets by people
(user, owner, reason, planned maintenance date), the dashboard's users and the notifications
sent; version 6 its server-side sessions; version 7 the edit and withdrawal of an
acknowledgement, a work order on acknowledgements and resets, the admin role and per-user API
tokens; version 10 the audit of the accounts (who changed a user, role, password or token);
version 13 the login rate limit's counts (``login_failures``: every dashboard worker shares
them).

Modules: ``records`` (the row types), ``migrations`` (the layout per version and backend),
``backends`` (SQLite and PostgreSQL connections), ``store`` (:class:`WearHistory`),
``alarms`` (acknowledge, reset, the fleet's alarm log), ``fleet_rows`` (the fleet's rows
read), ``fleet_index`` (the ranking keys kept per joint, version 12: a page of the fleet by
index), ``users`` (dashboard users, argon2 hashes), ``sessions`` (the dashboard's
sessions), ``tokens`` (API tokens), ``account_audit`` (the changes of accounts),
``notifications_store`` (each notification event once), ``login_failures`` (the login rate
limit's counts), ``levels_csv`` (export for ``audit``).
"""

from robot_wear_monitor.history.backends import is_postgresql_url, redact_url
from robot_wear_monitor.history.levels_csv import LEVEL_CSV_COLUMNS, write_levels_csv
from robot_wear_monitor.history.migrations import (
    POSTGRESQL_MIGRATIONS, SCHEMA_VERSION, SQLITE_MIGRATIONS)
from robot_wear_monitor.history.records import (
    ACKNOWLEDGEMENT_EVENTS, ALARM_EVENT_KINDS, AlarmEvent, DEFAULT_ROBOT, FleetRow, HistoryError,
    HistoryRecord, INTERVAL_COLUMNS, LatchMoved, RestoredState)
from robot_wear_monitor.history.store import open_history, WearHistory
from robot_wear_monitor.history.users import (
    MIN_PASSWORD_CHARS, ROLES, User)

__all__ = ['ACKNOWLEDGEMENT_EVENTS', 'ALARM_EVENT_KINDS', 'AlarmEvent', 'DEFAULT_ROBOT',
           'FleetRow', 'HistoryError', 'HistoryRecord', 'INTERVAL_COLUMNS', 'is_postgresql_url',
           'LatchMoved', 'LEVEL_CSV_COLUMNS', 'MIN_PASSWORD_CHARS', 'open_history',
           'POSTGRESQL_MIGRATIONS', 'redact_url', 'RestoredState', 'ROLES', 'SCHEMA_VERSION',
           'SQLITE_MIGRATIONS', 'User',
           'WearHistory', 'write_levels_csv']
