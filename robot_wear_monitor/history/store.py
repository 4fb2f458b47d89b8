"""
The wear history of a fleet: every estimate and alarm event of every robot's joints.

:class:`WearHistory` stores and reads the rows the same way on both backends (an SQLite file or
a PostgreSQL database, see ``backends.py``): one transaction per experiment (the estimate and
its alarm events together), the experiment's identity (robot, joint, end stamp) as a unique
key so that a re-run of a recording or a concurrent writer adds nothing, the trend and latched
alarm of each robot's joint restored from here, and the fleet's latest state per joint.  Opening
migrates an older layout in place (``migrations.py``) and refuses a database that is not a wear
history, leaving it untouched.
"""

from __future__ import annotations

from contextlib import contextmanager
import json
import math
import os
import time
from typing import Any, Iterator, Optional, Sequence

from robot_wear_monitor.history import alarms, fleet_index, fleet_rows, notifications_store
from robot_wear_monitor.history import sessions as dashboard_sessions
from robot_wear_monitor.history import tokens as api_tokens
from robot_wear_monitor.history import users as user_accounts
from robot_wear_monitor.history.account_audit import Actor, audit_log, AuditRecord
from robot_wear_monitor.history.alarms import EVENT_COLUMNS, event_from_row
from robot_wear_monitor.history.backends import (
    HistoryBackend, is_postgresql_url, lock_key, not_ours_message, PostgresqlBackend,
    SqliteBackend)
from robot_wear_monitor.history.fleet_index import FleetIndex
from robot_wear_monitor.history.login_failures import LoginFailures
from robot_wear_monitor.history.migrations import (
    JOINT_SUMMARY_ADD, SCHEMA_VERSION, TABLES)
from robot_wear_monitor.history.records import (
    AlarmEvent, DEFAULT_ROBOT, FleetRow, HistoryError, HistoryRecord, INTERVAL_COLUMNS,
    LATCH_EVENTS, LatchMoved, RestoredState)
from robot_wear_monitor.json_values import finite_or_none

_RECORD_COLUMNS = ('id', 'robot', 'joint', 'stamp_s', 'speeds_rad_s', 'frictions',
                   'temperature_degc', 'temperature_std_degc', 'wear', 'wear_std', 'chi2',
                   'dof', 'p_value', 'temperature_at_bound', 'wear_at_bound', 'alarm_active',
                   'alarm_evidence', 'status_level', 'parameter_set', *INTERVAL_COLUMNS,
                   'invalid_reason', 'threshold', 'warning_level')


def _nan_if_none(value: Optional[float]) -> float:
    return math.nan if value is None else float(value)


def _check_name(what: str, value: Any) -> str:
    if not isinstance(value, str) or not value or '\x00' in value:
        raise HistoryError(f'the {what} name must be a non-empty text without NUL, got '
                           f'{str(value)[:80]!r}')
    return value


def _record_from_row(row: Sequence[Any]) -> HistoryRecord:
    return HistoryRecord(
        id=int(row[0]), robot=row[1], joint=row[2], stamp_s=float(row[3]),
        speeds_rad_s=tuple(json.loads(row[4])), frictions=tuple(json.loads(row[5])),
        temperature_degc=float(row[6]), temperature_std_degc=_nan_if_none(row[7]),
        wear=float(row[8]), wear_std=_nan_if_none(row[9]), chi2=_nan_if_none(row[10]),
        dof=int(row[11]), p_value=_nan_if_none(row[12]), temperature_at_bound=bool(row[13]),
        wear_at_bound=bool(row[14]), alarm_active=bool(row[15]),
        alarm_evidence=float(row[16]), status_level=int(row[17]), parameter_set=row[18],
        **{c: _nan_if_none(v) for c, v in zip(INTERVAL_COLUMNS, row[19:])},
        invalid_reason=row[19 + len(INTERVAL_COLUMNS)] or '',
        threshold=_nan_if_none(row[20 + len(INTERVAL_COLUMNS)]),
        warning_level=_nan_if_none(row[21 + len(INTERVAL_COLUMNS)]))


class WearHistory:
    """
    The wear history of one or more robots' joints, in SQLite or PostgreSQL.

    :param location: an SQLite file path (``':memory:'`` for a history that is not kept) or a
        PostgreSQL URL ``postgresql://USER[:PASSWORD]@HOST:PORT/DB``.
    :param robot: the robot of the calls that name none, and of the rows of a version-2 history
        migrated on open (default ``'default'``).
    :param init: None (default): create a missing SQLite file or initialise an empty PostgreSQL
        database; True: also initialise an existing empty SQLite file, or add the tables
        to a PostgreSQL database that holds other tables; False: never create anything
        (read an existing history only).

    Raises :class:`HistoryError` (an :class:`~robot_wear_monitor.errors.InputError`, one line
    naming the history) when the history cannot be opened, is not a wear history, has a newer
    layout, or when its server goes away; what was committed before stays.
    """

    def __init__(self, location: str | os.PathLike, *, robot: Optional[str] = None,
                 init: Optional[bool] = None) -> None:
        """Open (and create or migrate) the history at ``location``."""
        self.robot = _check_name('robot', robot if robot is not None else DEFAULT_ROBOT)
        if is_postgresql_url(location):
            self._backend: HistoryBackend = PostgresqlBackend(str(location))
        else:
            self._backend = SqliteBackend(location, init=init)
        #: The history's name in messages (a path, or the URL without its password).
        self.path = self._backend.name
        try:
            with self._guard('cannot open the wear history'):
                self._migrate(init=init)
        except BaseException:
            self._backend.close()
            raise

    @property
    def backend(self) -> str:
        """Return ``'sqlite'`` or ``'postgresql'``."""
        return self._backend.kind

    # ------------------------------------------------------------------ plumbing

    @contextmanager
    def _guard(self, what: str) -> Iterator[None]:
        """Turn the backend's errors into one-line :class:`HistoryError` naming the history."""
        try:
            yield
        except HistoryError:
            raise
        except self._backend.errors as error:
            raise HistoryError(f'{self.path}: {what}: {self._backend.describe(error)}') from None

    def _migrate(self, *, init: Optional[bool]) -> None:
        """Bring the layout to :data:`SCHEMA_VERSION` in one transaction (or refuse it)."""
        backend = self._backend
        if self._stored_version(backend.tables()) == SCHEMA_VERSION:
            return  # the usual case: no write, no lock (a read-only history opens too)
        with backend.transaction():
            backend.lock_migration()
            tables = backend.tables()
            version = self._stored_version(tables)
            if version is None:
                if tables & set(TABLES) or (tables and backend.kind == 'sqlite'):
                    raise HistoryError(not_ours_message(self.path, tables))
                if tables and not init:
                    raise HistoryError(f'{self.path}: the database holds other tables and no '
                                       'wear history; give --init to add the history to it')
                version = 0
            if version == 0 and init is False:
                raise HistoryError(f'{self.path}: holds no wear history')
            if version == SCHEMA_VERSION:
                return
            if version > SCHEMA_VERSION:
                raise HistoryError(f'{self.path}: wear history schema version {version}, '
                                   f'this version reads {SCHEMA_VERSION}')
            if version and version < min(backend.migrations):
                raise HistoryError(f'{self.path}: wear history schema version {version} is '
                                   f'not known to the {backend.kind} store')
            for step_version in sorted(v for v in backend.migrations if v > version):
                for step in backend.migrations[step_version]:
                    if step.startswith('CREATE TABLE schema_version') and \
                            'schema_version' in tables:
                        continue  # a new SQLite file comes with it (see backends.py)
                    backend.execute(step, {'robot': self.robot} if ':robot' in step else ())
            if version < 12:  # the ranking keys of the existing joints (schema version 12)
                fleet_index.rebuild(backend)
            if backend.execute('SELECT version FROM schema_version'):
                backend.execute('UPDATE schema_version SET version = ?', (SCHEMA_VERSION,))
            else:
                backend.execute('INSERT INTO schema_version (version) VALUES (?)',
                                (SCHEMA_VERSION,))

    def _stored_version(self, tables: set[str]) -> Optional[int]:
        """Return the layout version (0 for a new history; None when not ours)."""
        if 'schema_version' not in tables:
            return None
        rows = self._backend.execute('SELECT version FROM schema_version')
        if rows:
            return int(rows[0][0])
        if 'estimates' not in tables:
            return 0  # a new history, or the start of one another process makes
        # a history of the first releases, whose writer died before it stored its version
        columns = self._backend.columns('estimates')
        if 'rank_tier' in self._backend.columns('joint_summary'):
            return 12
        if 'account_audit' in tables:
            return 10
        if 'source' in self._backend.columns('alarm_events'):
            return 9
        if 'threshold' in columns:
            return 8
        if 'api_tokens' in tables:
            return 7
        if 'sessions' in tables:
            return 6
        if 'users' in tables:
            return 5
        return (4 if 'invalid_reason' in columns else 3 if 'robot' in columns
                else 2 if 'wear_low' in columns else 1)

    def connection_alive(self, *, check: bool = True) -> bool:
        """Return whether the history's connection still serves (``check``: ask the server)."""
        return self._backend.alive(check=check)

    def close(self) -> None:
        """Close the history (SQLite: a WAL checkpoint folds the log into the file)."""
        self._backend.close()

    def __enter__(self) -> 'WearHistory':
        """Return self."""
        return self

    def __exit__(self, *exc_info: Any) -> None:
        """Close the history."""
        self.close()

    def _robot(self, robot: Optional[str]) -> str:
        return self.robot if robot is None else _check_name('robot', robot)

    # ------------------------------------------------------------------ writing

    def append(self, record: HistoryRecord, *, events: Sequence[AlarmEvent] = (),
               latch_id: Any = ...) -> Optional[int]:
        """
        Store one estimate and its alarm events in one transaction; return the estimate id.

        Returns None, storing nothing, when the history already holds that experiment (same
        robot, joint and end stamp, see :meth:`find_estimate`): the unique key makes the check
        and the insert one step, so writers at once never store an experiment twice.
        ``latch_id``: the id of the joint's last raise or reset the estimate was made after
        (None: none); when given and the history's is another one (a reset stored meanwhile),
        nothing is stored and :class:`LatchMoved` is raised, in the same transaction as a
        reset's (so the rows after a reset are the new life's).
        """
        robot = self._robot(record.robot)
        joint = _check_name('joint', record.joint)
        values = (robot, joint, float(record.stamp_s), time.time(),
                  json.dumps([float(v) for v in record.speeds_rad_s]),
                  json.dumps([float(f) for f in record.frictions]),
                  float(record.temperature_degc), finite_or_none(record.temperature_std_degc),
                  float(record.wear), finite_or_none(record.wear_std),
                  finite_or_none(record.chi2), int(record.dof), finite_or_none(record.p_value),
                  int(bool(record.temperature_at_bound)), int(bool(record.wear_at_bound)),
                  int(bool(record.alarm_active)), float(record.alarm_evidence),
                  int(record.status_level), record.parameter_set,
                  *(finite_or_none(getattr(record, c)) for c in INTERVAL_COLUMNS),
                  str(record.invalid_reason)[:2000], finite_or_none(record.threshold),
                  finite_or_none(record.warning_level))
        columns = ('robot', 'joint', 'stamp_s', 'wall_time_s', *_RECORD_COLUMNS[4:])
        with self._guard('cannot store the estimate'), self._backend.transaction():
            if latch_id is not ...:
                self._backend.lock_in_transaction(alarms.action_lock(robot, joint))
                stored = self._backend.execute(
                    'SELECT MAX(id) FROM alarm_events WHERE robot = ? AND joint = ? AND '
                    f'{LATCH_EVENTS}', (robot, joint))
                if (stored[0][0] if stored else None) != latch_id:
                    raise LatchMoved(f'{self.path}: the latch of robot {robot[:80]!r} joint '
                                     f'{joint[:80]!r} changed (a reset stored meanwhile)')
            if self.find_estimate(joint=joint, stamp_s=record.stamp_s, robot=robot) is not None:
                return None
            rows = self._backend.execute(
                f'INSERT INTO estimates ({", ".join(columns)}) VALUES '
                f'({", ".join("?" * len(columns))}) '
                'ON CONFLICT (robot, joint, stamp_s) DO NOTHING RETURNING id', values)
            if not rows:
                return None
            estimate_id = int(rows[0][0])
            self._backend.execute(JOINT_SUMMARY_ADD, (robot, joint, estimate_id,
                                                      float(record.stamp_s)))
            for event in events:
                self._insert_event(event, estimate_id, refresh=False)
            fleet_index.refresh(self._backend, robot=robot, joint=joint)
        return estimate_id

    def record_event(self, event: AlarmEvent) -> AlarmEvent:
        """
        Store an alarm event on its own (the ROS reset service's); return it as stored.

        People acknowledge and reset through :meth:`acknowledge_alarm` and :meth:`reset_alarm`,
        which check the latch first.
        """
        with self._guard('cannot store the alarm event'), self._backend.transaction():
            return self._insert_event(event, event.estimate_id)

    def _insert_event(self, event: AlarmEvent, estimate_id: Optional[int], *,
                      refresh: bool = True) -> AlarmEvent:
        return alarms.insert_event(self._backend, event, robot=self._robot(event.robot),
                                   joint=_check_name('joint', event.joint),
                                   estimate_id=estimate_id, refresh=refresh)

    def acknowledge_alarm(self, *, joint: str, robot: Optional[str] = None, user: str,
                          owner: str, comment: str, planned_maintenance: str = '',
                          work_order: str = '', source: str = '') -> AlarmEvent:
        """
        Acknowledge the latched alarm of the robot's ``joint``; return the stored event.

        The alarm stays latched and shows as acknowledged (``FleetRow.acknowledged``) until a
        reset or a new raise.  ``user``: who acknowledges; ``owner``: who takes the
        maintenance on (both 1-128 printable characters); ``comment``: free text (at most
        2000 characters); ``planned_maintenance``: 'YYYY-MM-DD' or ''; ``work_order``: the
        maintenance system's work order (at most 128 printable characters, '' for none);
        ``source``: web, api, cli or ros.  Raises :class:`HistoryError` when the joint has no
        latched alarm (``UnknownJointError``: no estimate of it), when it is acknowledged
        already, or on bad values.
        """
        with self._guard('cannot acknowledge the alarm'):
            return alarms.acknowledge_alarm(
                self._backend, robot=self._robot(robot), joint=_check_name('joint', joint),
                user=user, owner=owner, comment=comment,
                planned_maintenance=planned_maintenance, work_order=work_order, source=source)

    def edit_acknowledgement(self, *, joint: str, robot: Optional[str] = None, user: str,
                             owner: Optional[str] = None, comment: Optional[str] = None,
                             planned_maintenance: Optional[str] = None,
                             work_order: Optional[str] = None, source: str = '') -> AlarmEvent:
        """
        Edit the current acknowledgement of the robot's ``joint``; return the stored event.

        Only the values given change (None keeps the current one); ``user``: who edits; the
        event holds the acknowledgement after the edit and what changed.  Raises
        :class:`HistoryError` when the alarm is not acknowledged, the edit changes nothing,
        or on bad values.
        """
        with self._guard('cannot edit the acknowledgement'):
            return alarms.edit_acknowledgement(
                self._backend, robot=self._robot(robot), joint=_check_name('joint', joint),
                user=user, owner=owner, comment=comment,
                planned_maintenance=planned_maintenance, work_order=work_order, source=source)

    def withdraw_acknowledgement(self, *, joint: str, robot: Optional[str] = None, user: str,
                                 reason: str, source: str = '') -> AlarmEvent:
        """
        Withdraw the acknowledgement of the robot's ``joint`` (non-empty ``reason``).

        The alarm stays latched, unacknowledged.  Return the stored event; raise
        :class:`HistoryError` when the alarm is not acknowledged or on bad values.
        """
        with self._guard('cannot withdraw the acknowledgement'):
            return alarms.withdraw_acknowledgement(
                self._backend, robot=self._robot(robot), joint=_check_name('joint', joint),
                user=user, reason=reason, source=source)

    def reset_alarm(self, *, joint: str, robot: Optional[str] = None, user: str, reason: str,
                    stamp_s: Optional[float] = None, work_order: str = '',
                    source: str = '') -> AlarmEvent:
        """
        Reset the robot's ``joint`` after maintenance or a replacement; return the event.

        Exactly what the ROS ``~/reset_alarm`` stores (a ``reset`` tied to the joint's latest
        estimate), with ``user`` and ``reason`` (non-empty): a restarted estimator restores
        the alarm clear with evidence 0 and restarts its trend (the component's new life).
        ``stamp_s``: the moment [s] (default now); ``work_order``: as for an acknowledgement.
        With or without a latched alarm (:func:`~robot_wear_monitor.history.alarms.reset_alarm`:
        refused for an unknown joint, or one reset already with no experiment since).
        """
        with self._guard('cannot reset the joint'):
            return alarms.reset_alarm(self._backend, robot=self._robot(robot),
                                      joint=_check_name('joint', joint), user=user,
                                      reason=reason, stamp_s=stamp_s, work_order=work_order,
                                      source=source)

    def alarm_log(self, *, robot: Optional[str] = None, joint: Optional[str] = None,
                  limit: Optional[int] = None, before_id: Optional[int] = None,
                  stored_after_s: Optional[float] = None) -> list[AlarmEvent]:
        """
        Return the alarm events of the fleet, newest first by event time (robot, id, times).

        The event time: a raise's experiment stamp, an acknowledgement's or a reset's wall
        time (:func:`~robot_wear_monitor.history.alarms.alarm_log`), whatever the order the
        recordings were replayed in.  ``robot`` None: every robot (not the history's robot);
        ``joint``: that joint only; ``before_id``: the events after that one in this order
        (the next page); ``limit``: at most so many; ``stored_after_s``: only the events
        stored after that wall time [s] (a poller's ``since``).
        """
        with self._guard('cannot read the alarm log'):
            return alarms.alarm_log(self._backend, robot=robot, joint=joint, limit=limit,
                                    before_id=before_id, stored_after_s=stored_after_s)

    def resolved_raises(self) -> list[tuple[str, str, float, float, int]]:
        """
        Return the raises a reset resolved (the latch of their joint is that reset).

        (robot, joint, the raise's stamp [s], the reset's wall time [s], the reset's id) per
        joint: what the notifier sends as ``resolved``.
        """
        with self._guard('cannot read the alarm log'):
            return alarms.resolved_raises(self._backend)

    def estimate_rows(self, *, joint: str, robot: Optional[str] = None,
                      limit: Optional[int] = None) -> tuple[HistoryRecord, ...]:
        """Return the estimates of the robot's ``joint``, oldest first (see :meth:`records`)."""
        return self.records(joint=joint, robot=robot, limit=limit)

    # ------------------------------------------------------------------ users, notifications

    def add_user(self, *, name: str, role: str, password: str,
                 by: Optional[Actor] = None) -> user_accounts.User:
        """
        Add a dashboard user (a role of ``users.ROLES``; argon2 hash of ``password``).

        Raises :class:`HistoryError` when the name exists or is not 1-64 of
        ``A-Za-z0-9_.@-``, the role is unknown, or the password has fewer than 8 characters.
        """
        with self._guard('cannot add the user'):
            return user_accounts.add_user(self._backend, name=name, role=role, password=password,
                                          by=by)

    def remove_user(self, *, name: str, keep_an_admin: bool = False,
                    by: Optional[Actor] = None) -> None:
        """
        Remove the dashboard user ``name`` (:class:`HistoryError` when there is none).

        ``keep_an_admin``: refuse to remove the last admin (the Users page does).
        """
        with self._guard('cannot remove the user'):
            user_accounts.remove_user(self._backend, name=name, keep_an_admin=keep_an_admin,
                                      by=by)

    def set_password(self, *, name: str, password: str, by: Optional[Actor] = None) -> int:
        """Give user ``name`` a new password, ending their sessions; return how many ended."""
        with self._guard('cannot change the password'):
            return user_accounts.set_password(self._backend, name=name, password=password,
                                              by=by)

    def set_role(self, *, name: str, role: str, keep_an_admin: bool = False,
                 by: Optional[Actor] = None) -> user_accounts.User:
        """
        Give user ``name`` the role ``role`` (it counts at once); return the user.

        ``keep_an_admin``: refuse a change that would leave no admin (the Users page does).
        """
        with self._guard('cannot change the role'):
            return user_accounts.set_role(self._backend, name=name, role=role,
                                          keep_an_admin=keep_an_admin, by=by)

    def add_token(self, *, user: str, label: str = '',
                  by: Optional[Actor] = None) -> tuple[api_tokens.ApiToken, str]:
        """Make an API token of ``user``; return it as listed and the token (shown once)."""
        with self._guard('cannot add the token'):
            return api_tokens.add_token(self._backend, user=user, label=label, by=by)

    def tokens(self, *, user: Optional[str] = None) -> list[api_tokens.ApiToken]:
        """Return the API tokens as listed (of ``user``): ids and times, never the tokens."""
        with self._guard('cannot read the tokens'):
            return api_tokens.list_tokens(self._backend, user=user)

    def remove_tokens(self, *, user: str, token_id: Optional[int] = None,
                      by: Optional[Actor] = None) -> int:
        """Remove the token ``token_id`` of ``user`` (None: all of theirs); return how many."""
        with self._guard('cannot remove the token'):
            return api_tokens.remove_tokens(self._backend, user=user, token_id=token_id, by=by)

    def account_audit(self, *, limit: Optional[int] = None) -> list[AuditRecord]:
        """Return the recorded changes of accounts (``by`` whom, what), newest first."""
        with self._guard('cannot read the account audit'):
            return audit_log(self._backend, limit=limit)

    def find_token(self, *, token: str) -> Optional[api_tokens.TokenUser]:
        """Return who an API token acts as, with their role now (None: no such token)."""
        with self._guard('cannot check the token'):
            return api_tokens.find_token(self._backend, token=token)

    def login_failures(self, *, max_failures: int, window_s: float) -> LoginFailures:
        """Return the login rate limit's counts kept here (shared by every dashboard worker)."""
        return LoginFailures(self._backend, guard=self._guard, max_failures=max_failures,
                             window_s=window_s)

    def users(self) -> list[user_accounts.User]:
        """Return the dashboard users, sorted by name (no hashes)."""
        with self._guard('cannot read the users'):
            return user_accounts.list_users(self._backend)

    def start_session(self, *, user: str, lifetime_s: float,
                      now_s: Optional[float] = None) -> Optional[dashboard_sessions.Session]:
        """Start a dashboard session of ``user`` (None when there is no such user)."""
        with self._guard('cannot start the session'):
            return dashboard_sessions.start_session(self._backend, user=user,
                                                    lifetime_s=lifetime_s, now_s=now_s)

    def find_session(self, *, token: str,
                     now_s: Optional[float] = None) -> Optional[dashboard_sessions.Session]:
        """Return the live dashboard session of ``token`` (None: ended, expired or unknown)."""
        with self._guard('cannot read the session'):
            return dashboard_sessions.find_session(self._backend, token=token, now_s=now_s)

    def end_session(self, *, token: str) -> bool:
        """End the dashboard session of ``token`` (a logout); return whether there was one."""
        with self._guard('cannot end the session'):
            return dashboard_sessions.end_session(self._backend, token=token)

    def verify_user(self, *, name: str, password: str) -> Optional[user_accounts.User]:
        """Return the user when ``password`` is theirs, else None (about as slow either way)."""
        with self._guard('cannot check the user'):
            return user_accounts.verify_user(self._backend, name=name, password=password)

    def claim_notification(self, *, event_key: str, robot: Optional[str],
                           joint: Optional[str], kind: str, channel: str,
                           payload: dict[str, Any], lease_s: Optional[float] = None) -> bool:
        """
        Claim the notification of ``event_key``: True when this call stored it (send it).

        False when it was claimed before, by any notifier, also before a restart (unless that
        claim's ``lease_s`` [s] passed unsettled: its notifier died; this call takes it).
        """
        with self._guard('cannot store the notification'):
            return notifications_store.claim_notification(
                self._backend, event_key=event_key, robot=robot, joint=joint, kind=kind,
                channel=channel, payload=payload, lease_s=lease_s)

    def settle_notification(self, *, event_key: str) -> bool:
        """End the lease of the claim of ``event_key`` (its send ended, delivered or not)."""
        with self._guard('cannot store the notification'):
            return notifications_store.settle_notification(self._backend, event_key=event_key)

    def release_notification(self, *, event_key: str) -> bool:
        """Drop the claim of ``event_key`` (its sending failed for good), so it is retried."""
        with self._guard('cannot release the notification'):
            return notifications_store.release_notification(self._backend,
                                                            event_key=event_key)

    def notifications(self, limit: Optional[int] = None) -> list[dict[str, Any]]:
        """Return the notifications sent, newest first (``payload`` as a dict)."""
        with self._guard('cannot read the notifications'):
            return notifications_store.list_notifications(self._backend, limit=limit)

    @contextmanager
    def writer_lock(self, *, joint: str, robot: Optional[str] = None,
                    wait: bool = True) -> Iterator[None]:
        """
        Be the only writer of (robot, joint) while the block runs (an advisory lock).

        Take it before restoring the state of the joint and hold it for the whole run: a second
        writer of the same robot's joint waits (``wait``) or gets :class:`HistoryError`, and
        then restores the first one's rows, so that its trend is the sequential run's.
        SQLite: a byte range of ``<history>-lock`` (per process); PostgreSQL: an advisory lock
        of the server (per connection).
        """
        key = lock_key(self._robot(robot), _check_name('joint', joint))
        with self._guard('cannot lock the joint'):
            with self._backend.writer_lock(key, wait=wait):
                yield

    def add_recording(self, *, fingerprint: str, name: str, experiments: int,
                      robot: Optional[str] = None) -> bool:
        """
        Note that a recording was replayed completely; return False when it already was.

        ``fingerprint``: the recording's content fingerprint (hex); ``name``: its bag name (for
        people); ``experiments``: the estimates it added.
        """
        with self._guard('cannot store the recording'), self._backend.transaction():
            rows = self._backend.execute(
                'INSERT INTO recordings (robot, fingerprint, name, experiments, wall_time_s) '
                'VALUES (?, ?, ?, ?, ?) ON CONFLICT (robot, fingerprint) DO NOTHING '
                'RETURNING robot', (self._robot(robot), str(fingerprint)[:128], str(name)[:256],
                                    int(experiments), time.time()))
        return bool(rows)

    def has_recording(self, *, fingerprint: str, robot: Optional[str] = None) -> bool:
        """Return True when the recording ``fingerprint`` of ``robot`` was replayed already."""
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute(
                'SELECT 1 FROM recordings WHERE robot = ? AND fingerprint = ?',
                (self._robot(robot), str(fingerprint)[:128]))
        return bool(rows)

    # ------------------------------------------------------------------ reading

    def find_estimate(self, *, joint: str, stamp_s: float, robot: Optional[str] = None,
                      tolerance_s: float = 1e-6) -> Optional[int]:
        """
        Return the id of the stored estimate of the experiment ending at ``stamp_s`` [s].

        An experiment's identity is its robot, its joint and the stamp of its end (one joint
        ends one experiment at a time): a re-run of the same recording finds its estimates here.
        """
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute(
                'SELECT id FROM estimates WHERE robot = ? AND joint = ? AND stamp_s BETWEEN ? '
                'AND ? ORDER BY id LIMIT 1',
                (self._robot(robot), joint, float(stamp_s) - tolerance_s,
                 float(stamp_s) + tolerance_s))
        return None if not rows else int(rows[0][0])

    def records(self, *, joint: str, robot: Optional[str] = None,
                limit: Optional[int] = None) -> tuple[HistoryRecord, ...]:
        """
        Return the stored estimates of the robot's ``joint``, oldest first.

        With ``limit``: the last ``limit`` of them.
        """
        query = (f'SELECT {", ".join(_RECORD_COLUMNS)} FROM estimates WHERE robot = ? '
                 'AND joint = ? ORDER BY id DESC')
        params: tuple = (self._robot(robot), joint)
        if limit is not None:
            query += ' LIMIT ?'
            params += (int(limit),)
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute(query, params)
        return tuple(_record_from_row(row) for row in reversed(rows))

    def joints(self, *, robot: Optional[str] = None) -> tuple[str, ...]:
        """Return the joints of the robot that have stored estimates, sorted."""
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute(
                'SELECT DISTINCT joint FROM estimates WHERE robot = ? ORDER BY joint',
                (self._robot(robot),))
        return tuple(row[0] for row in rows)

    def robots(self) -> tuple[str, ...]:
        """Return the robots that have stored estimates, sorted."""
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute('SELECT DISTINCT robot FROM estimates ORDER BY robot')
        return tuple(row[0] for row in rows)

    def events(self, *, joint: str, robot: Optional[str] = None) -> tuple[AlarmEvent, ...]:
        """Return the alarm events of the robot's ``joint``, oldest first."""
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute(
                f'SELECT {EVENT_COLUMNS} FROM alarm_events WHERE robot = ? AND joint = ? '
                'ORDER BY id', (self._robot(robot), joint))
        return tuple(event_from_row(row) for row in rows)

    def restore(self, *, joint: str, robot: Optional[str] = None,
                trend_length: Optional[int] = None) -> RestoredState:
        """
        Return the trend, the latched alarm and the alarm evidence of the robot's ``joint``.

        The alarm is latched when the last raise or reset is ``raised`` (acknowledgements
        leave the latch as it is; ``last_event`` is that raise or reset); the evidence is that
        of the last estimate, or 0 after a reset that came later.
        """
        robot = self._robot(robot)
        records = self.records(joint=joint, robot=robot, limit=trend_length)
        with self._guard('cannot read the wear history'):
            last_event, _ = alarms.latch_events(self._backend, robot=robot, joint=joint)
        active = last_event is not None and last_event.event == 'raised'
        evidence = records[-1].alarm_evidence if records else 0.0
        if last_event is not None and last_event.event == 'reset' and records and (
                last_event.estimate_id is None or records[-1].id is None
                or last_event.estimate_id >= records[-1].id):
            evidence = 0.0
        return RestoredState(records=records, alarm_active=active, alarm_evidence=evidence,
                             last_event=last_event)

    def latest_ids(self) -> tuple[int, int]:
        """
        Return the ids of the newest estimate and alarm event (0 when none), in one query.

        They change whenever a row the fleet view or the alarm log shows is added (ids only
        grow): a cache of those views is current while they are the same.
        """
        with self._guard('cannot read the wear history'):
            rows = self._backend.execute('SELECT (SELECT MAX(id) FROM estimates), '
                                         '(SELECT MAX(id) FROM alarm_events)')
        return int(rows[0][0] or 0), int(rows[0][1] or 0)

    def acknowledgement(self, *, joint: str, robot: Optional[str] = None
                        ) -> Optional[AlarmEvent]:
        """Return the current acknowledgement of the latched alarm (its last edit), or None."""
        with self._guard('cannot read the wear history'):
            return alarms.latch_events(self._backend, robot=self._robot(robot),
                                       joint=_check_name('joint', joint))[1]

    def latch_event(self, *, joint: str, robot: Optional[str] = None) -> Optional[AlarmEvent]:
        """
        Return the last raise or reset of the robot's ``joint`` (None: never raised).

        One indexed query: a running estimator polls it to take over a reset stored by
        someone else (the dashboard).
        """
        with self._guard('cannot read the wear history'):
            return alarms.latch_events(self._backend, robot=self._robot(robot),
                                       joint=_check_name('joint', joint))[0]

    def fleet(self, *, robot: Optional[str] = None) -> list[FleetRow]:
        """
        Return the latest state of every robot's joint, worst first (:meth:`FleetRow.rank_key`).

        ``robot`` keeps one robot's joints (all robots when None); see
        :func:`~robot_wear_monitor.history.fleet_rows.read_fleet`.
        """
        with self._guard('cannot read the wear history'):
            return fleet_rows.read_fleet(
                self._backend, robot=None if robot is None else _check_name('robot', robot))

    def fleet_index(self) -> FleetIndex:
        """Return the fleet's index (the stored ranking keys): pages, counts, robots, changes."""
        return FleetIndex(self._backend, self._guard)


def open_history(location: str | os.PathLike, *, robot: Optional[str] = None,
                 init: Optional[bool] = None) -> WearHistory:
    """
    Open the wear history at an SQLite path or a ``postgresql://`` URL.

    See :class:`WearHistory` for the arguments.
    """
    return WearHistory(location, robot=robot, init=init)
