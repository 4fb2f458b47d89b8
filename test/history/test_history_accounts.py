"""
Tests of the history's schema 7 (accounts and the write API) on both backends.

The migration of a version-6 file written by the released code (and of a version-6 PostgreSQL
database made of the same rows) keeps every row, user, session and notification; the edit and
the withdrawal of an acknowledgement are events of their own; the work order is stored; the
admin role is admitted by the layout; a new password ends the user's sessions; API tokens are
stored as hashes only and die with their user.
"""

import hashlib
from pathlib import Path
import shutil
import sqlite3

import pytest
from robot_wear_monitor.history import (
    AlarmEvent, HistoryError, HistoryRecord, is_postgresql_url, POSTGRESQL_MIGRATIONS, ROLES,
    SCHEMA_VERSION, WearHistory)

HISTORY_V6 = Path(__file__).resolve().parent / 'data' / 'history_v6.db'
#: The tables of version 6 and their rows, as the released code stored them.
V6_TABLES = ('estimates', 'alarm_events', 'users', 'sessions', 'notifications', 'recordings',
             'joint_summary')
#: (robot, joint, event, user, owner, planned maintenance, note) of the version-6 file.
V6_EVENTS = [
    ('cell_1', 'joint_2', 'raised', '', '', '', 'w above the threshold'),
    ('cell_1', 'joint_2', 'acknowledged', 'mia', 'Team B', '2026-12-01', 'gearbox ordered'),
    ('cell_1', 'joint_3', 'raised', '', '', '', 'w above the threshold'),
    ('cell_1', 'joint_3', 'reset', 'mia', '', '', 'gearbox replaced')]


def _record(k, *, wear=10.0, alarm=False, joint='joint_2', robot=None):
    return HistoryRecord(joint=joint, stamp_s=100.0 + k, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=3.0, chi2=1.0, dof=0,
                         p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=alarm, alarm_evidence=5.0 if alarm else 0.0,
                         status_level=0, parameter_set='p', robot=robot)


def _raise(history, k, *, joint='joint_2', wear=40.0):
    return history.append(_record(k, wear=wear, alarm=True, joint=joint),
                          events=[AlarmEvent(joint=joint, stamp_s=100.0 + k, event='raised',
                                             wear=wear, note='w above the threshold')])


def _v6_rows() -> dict[str, tuple[list[str], list[tuple]]]:
    """Return the columns and rows (ordered) of every table of the version-6 file."""
    conn = sqlite3.connect(f'{HISTORY_V6.as_uri()}?immutable=1', uri=True)
    try:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == 6
        tables = {}
        for table in V6_TABLES:
            cursor = conn.execute(f'SELECT * FROM {table} ORDER BY 1, 2')
            tables[table] = ([d[0] for d in cursor.description], cursor.fetchall())
    finally:
        conn.close()
    return tables


def _rows(location, table, columns):
    order = '1, 2' if len(columns) > 1 else '1'
    sql = f'SELECT {", ".join(columns)} FROM {table} ORDER BY {order}'
    if is_postgresql_url(location):
        import psycopg
        with psycopg.connect(location) as conn:
            return [tuple(r) for r in conn.execute(sql).fetchall()]
    with sqlite3.connect(location) as conn:
        return conn.execute(sql).fetchall()


def _check_v6_kept(location):
    """Every row of the version-6 file is in the migrated history, unchanged."""
    for table, (columns, rows) in _v6_rows().items():
        assert _rows(location, table, columns) == rows, table
    with WearHistory(location, init=False) as history:
        logged = history.alarm_log()
        assert sorted((e.robot, e.joint, e.event, e.user, e.owner, e.planned_maintenance,
                       e.note) for e in logged) == sorted(V6_EVENTS)
        assert all(e.work_order == '' for e in logged)
        fleet = {r.joint: r for r in history.fleet()}
        assert fleet['joint_2'].alarm and fleet['joint_2'].acknowledged
        assert fleet['joint_2'].acknowledged_by == 'mia'
        assert not fleet['joint_3'].alarm
        assert history.verify_user(name='mia', password='maintainer-pass-1').role == \
            'maintainer'
        assert history.verify_user(name='vic', password='viewer-pass-22').role == 'viewer'
        # what version 7 adds works on the migrated history
        history.set_role(name='vic', role='admin')
        assert [(u.name, u.role) for u in history.users()] == [
            ('mia', 'maintainer'), ('vic', 'admin')]
        edited = history.edit_acknowledgement(joint='joint_2', robot='cell_1', user='vic',
                                              owner='Team C', comment='gearbox ordered',
                                              planned_maintenance='2026-12-03',
                                              work_order='WO-4711')
        assert edited.id == max(e.id for e in logged) + 1  # ids go on after the old ones
        _, token = history.add_token(user='mia', label='CMMS')
        assert history.find_token(token=token).role == 'maintainer'
        history.remove_user(name='mia')
        assert history.find_token(token=token) is None
        assert _rows(location, 'sessions', ['user_name']) == []


def test_a_version_6_history_of_the_released_code_migrates_in_place(tmp_path):
    path = tmp_path / 'history.db'
    shutil.copyfile(HISTORY_V6, path)
    _check_v6_kept(str(path))
    with sqlite3.connect(path) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION
        assert conn.execute('PRAGMA integrity_check').fetchone()[0] == 'ok'
        assert conn.execute('PRAGMA foreign_key_check').fetchall() == []
        indexes = {r[0] for r in conn.execute(
            "SELECT name FROM sqlite_master WHERE type = 'index' AND tbl_name = 'alarm_events'")}
        assert {'alarm_events_robot_joint', 'alarm_events_robot'} <= indexes


def test_a_version_6_postgresql_history_migrates_in_place(postgresql_url):
    import psycopg
    v6 = _v6_rows()
    with psycopg.connect(postgresql_url, autocommit=True) as conn:
        for version in (3, 4, 5, 6):
            for step in POSTGRESQL_MIGRATIONS[version]:
                conn.execute(step)
        conn.execute('INSERT INTO schema_version (version) VALUES (6)')
        with conn.cursor() as cursor:
            for table, (columns, rows) in v6.items():
                if table == 'joint_summary':
                    continue  # version 5 filled it (from no rows): the rows go in below
                overriding = 'OVERRIDING SYSTEM VALUE ' if 'id' in columns else ''
                cursor.executemany(
                    f'INSERT INTO {table} ({", ".join(columns)}) {overriding}VALUES '
                    f'({", ".join(["%s"] * len(columns))})', rows)
            columns, rows = v6['joint_summary']
            cursor.executemany(f'INSERT INTO joint_summary ({", ".join(columns)}) VALUES '
                               f'({", ".join(["%s"] * len(columns))})', rows)
        for table in ('estimates', 'alarm_events', 'notifications'):
            conn.execute(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                         f'(SELECT MAX(id) FROM {table}))')
    _check_v6_kept(postgresql_url)
    with psycopg.connect(postgresql_url) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION


def test_the_layout_admits_exactly_the_roles_of_users_py(history_location):
    with WearHistory(history_location) as history:
        for role in ROLES:
            history.add_user(name=f'u_{role}', role=role, password='12345678')
        assert sorted(u.role for u in history.users()) == sorted(ROLES)
    # the CHECK of the layout refuses another role written past the code
    sql = ('INSERT INTO users (name, role, password_hash, created_wall_time_s) '
           "VALUES ('x', 'root', 'h', 0)")
    if is_postgresql_url(history_location):
        import psycopg
        with pytest.raises(psycopg.errors.CheckViolation):
            with psycopg.connect(history_location) as conn:
                conn.execute(sql)
    else:
        with pytest.raises(sqlite3.IntegrityError, match='CHECK'):
            with sqlite3.connect(history_location) as conn:
                conn.execute(sql)


def test_an_acknowledgement_is_edited_and_withdrawn_each_an_event(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        _raise(history, 0)
        history.append(_record(1, wear=44.0, alarm=True))
        with pytest.raises(HistoryError, match='not acknowledged: nothing to edit'):
            history.edit_acknowledgement(joint='joint_2', user='ana', owner='ben', comment='')
        first = history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben',
                                          comment='gearbox ordered', work_order='WO-1')
        assert (first.work_order, first.wear) == ('WO-1', 44.0)
        history.append(_record(2, wear=47.0, alarm=True))
        edited = history.edit_acknowledgement(joint='joint_2', user='carl', owner='dora',
                                              comment='gearbox ordered, 2 weeks',
                                              planned_maintenance='2026-12-24',
                                              work_order='WO-2')
        # the edit keeps the wear that was acknowledged; it is who edited, when, the values
        assert (edited.event, edited.user, edited.owner, edited.wear, edited.work_order,
                edited.planned_maintenance) == ('acknowledgement_edited', 'carl', 'dora', 44.0,
                                                'WO-2', '2026-12-24')
        with pytest.raises(HistoryError, match='changes nothing'):
            history.edit_acknowledgement(joint='joint_2', user='carl', owner='dora',
                                         comment='gearbox ordered, 2 weeks',
                                         planned_maintenance='2026-12-24', work_order='WO-2')
        row = history.fleet()[0]
        # issue 44: "acknowledged by" is the first acknowledger, the last editor apart
        assert (row.acknowledged, row.acknowledged_by, row.edited_by,
                row.planned_maintenance) == (True, 'ana', 'carl', '2026-12-24')
        with pytest.raises(HistoryError, match='already acknowledged'):
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='')
        with pytest.raises(HistoryError, match='withdrawal reason must be a non-empty'):
            history.withdraw_acknowledgement(joint='joint_2', user='ana', reason=' ')
        withdrawn = history.withdraw_acknowledgement(joint='joint_2', user='ana',
                                                     reason='order cancelled')
        assert (withdrawn.event, withdrawn.user, withdrawn.note) == (
            'acknowledgement_withdrawn', 'ana', 'order cancelled')
        row = history.fleet()[0]
        assert row.alarm and not row.acknowledged and row.acknowledged_by == ''
        assert history.restore(joint='joint_2').alarm_active  # the latch is untouched
        with pytest.raises(HistoryError, match='nothing to withdraw'):
            history.withdraw_acknowledgement(joint='joint_2', user='ana', reason='again')
        # acknowledged anew after a withdrawal
        history.acknowledge_alarm(joint='joint_2', user='ana', owner='ed', comment='')
        assert history.fleet()[0].acknowledged_by == 'ana'
        log = history.alarm_log(joint='joint_2')
        assert sorted(e.event for e in log) == sorted(
            ['raised', 'acknowledged', 'acknowledgement_edited', 'acknowledgement_withdrawn',
             'acknowledged'])
        reset = history.reset_alarm(joint='joint_2', user='ana', reason='replaced',
                                    work_order='WO-2')
        assert reset.work_order == 'WO-2'
        with pytest.raises(HistoryError, match='no latched alarm'):
            history.withdraw_acknowledgement(joint='joint_2', user='ana', reason='late')
        with pytest.raises(HistoryError, match='work order must be at most 128'):
            _raise(history, 5)
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='',
                                      work_order='W' * 129)
        with pytest.raises(HistoryError, match='work order must be at most 128 printable'):
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='',
                                      work_order='WO\n1')
    with WearHistory(history_location, robot='cell_1') as again:  # stored, read back
        stored = {e.id: e for e in again.alarm_log()}
        assert stored[edited.id].work_order == 'WO-2' and stored[first.id].work_order == 'WO-1'
        assert stored[reset.id].work_order == 'WO-2'


def test_a_new_password_ends_the_sessions_and_a_role_change_counts_at_once(history_location):
    with WearHistory(history_location) as history:
        history.add_user(name='ana', role='viewer', password='first password')
        session = history.start_session(user='ana', lifetime_s=3600.0)
        assert history.find_session(token=session.token).role == 'viewer'
        assert history.set_role(name='ana', role='maintainer').role == 'maintainer'
        assert history.find_session(token=session.token).role == 'maintainer'
        assert history.set_password(name='ana', password='second password') == 1
        assert history.find_session(token=session.token) is None
        assert history.verify_user(name='ana', password='first password') is None
        assert history.verify_user(name='ana', password='second password').name == 'ana'
        for call, message in (
                (lambda: history.set_password(name='bob', password='12345678'), 'no user'),
                (lambda: history.set_password(name='ana', password='short'), 'at least 8'),
                (lambda: history.set_role(name='bob', role='viewer'), 'no user'),
                (lambda: history.set_role(name='ana', role='root'), 'role is viewer')):
            with pytest.raises(HistoryError, match=message):
                call()


def test_api_tokens_are_stored_as_hashes_and_die_with_their_user(history_location):
    with WearHistory(history_location) as history:
        history.add_user(name='ana', role='maintainer', password='12345678')
        history.add_user(name='vic', role='viewer', password='12345678')
        listed, token = history.add_token(user='ana', label='CMMS')
        _, second = history.add_token(user='ana')
        _, viewer = history.add_token(user='vic')
        assert token.startswith('rwm_') and len(token) > 40 and token != second
        assert listed.last_used_wall_time_s is None and listed.label == 'CMMS'
        found = history.find_token(token=token)
        assert (found.user, found.role, found.token_id) == ('ana', 'maintainer', listed.id)
        assert history.find_token(token=viewer).role == 'viewer'
        assert history.find_token(token=token + 'x') is None
        assert history.find_token(token='not a token') is None
        tokens = history.tokens(user='ana')
        assert [t.id for t in tokens] == sorted(t.id for t in tokens) and len(tokens) == 2
        assert tokens[0].last_used_wall_time_s is not None  # used once above
        assert tokens[1].last_used_wall_time_s is None
        with pytest.raises(HistoryError, match="no user 'bob'"):
            history.add_token(user='bob')
        with pytest.raises(HistoryError, match='no token 99 of user'):
            history.remove_tokens(user='ana', token_id=99)
        assert history.remove_tokens(user='ana', token_id=tokens[1].id) == 1
        assert history.find_token(token=second) is None
        assert history.find_token(token=token) is not None
    # only the SHA-256 is stored: no token in any column
    stored = _rows(history_location, 'api_tokens', ['token_hash', 'label', 'user_name'])
    assert hashlib.sha256(token.encode()).hexdigest() in [r[0] for r in stored]
    assert not any(token in str(r) or viewer in str(r) for r in stored)
    with WearHistory(history_location) as history:
        history.remove_user(name='ana')
        assert history.find_token(token=token) is None
        assert history.tokens(user='ana') == []
        assert history.remove_tokens(user='vic') == 1
        assert history.tokens() == []
