"""
Tests of the history's schema 5 (the dashboard's data) on both backends.

The migration of a version-4 file written by the released code (and of a version-4 PostgreSQL
database), acknowledge and reset by people (the latch ignores acknowledgements; a stored reset
is what the ROS reset is to a restarted estimator), the fleet's alarm log, the dashboard's
users (argon2) and notifications claimed once by concurrent notifiers.
"""

import math
from pathlib import Path
import shutil
import sqlite3
import threading
import time

import pytest
from robot_wear_monitor.history import (
    AlarmEvent, HistoryError, HistoryRecord, is_postgresql_url, POSTGRESQL_MIGRATIONS,
    SCHEMA_VERSION, WearHistory)
from robot_wear_monitor.history.alarms import UnknownJointError

HISTORY_V4 = Path(__file__).resolve().parent / 'data' / 'history_v4.db'
V4_EVENTS = [  # (robot, joint, event, estimate id, note) as the released code stored them
    ('cell_1', 'joint_2', 'raised', 5, 'w above the threshold'),
    ('cell_1', 'joint_3', 'raised', 9, 'w above the threshold'),
    ('cell_1', 'joint_3', 'reset', 9, 'reset after maintenance')]


def _record(k, *, wear=10.0, alarm=False, evidence=0.0, joint='joint_2', robot=None):
    return HistoryRecord(joint=joint, stamp_s=100.0 + k, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=3.0, chi2=1.0, dof=0,
                         p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=alarm, alarm_evidence=evidence, status_level=0,
                         parameter_set='p', robot=robot)


def _raise(history, k, *, joint='joint_2', robot=None, wear=40.0):
    """Store an estimate that raises the alarm of ``joint``; return its id."""
    return history.append(_record(k, wear=wear, alarm=True, evidence=5.0, joint=joint,
                                  robot=robot),
                          events=[AlarmEvent(joint=joint, stamp_s=100.0 + k, event='raised',
                                             wear=wear, note='w above the threshold',
                                             robot=robot)])


def _v4_rows():
    conn = sqlite3.connect(f'{HISTORY_V4.as_uri()}?immutable=1', uri=True)
    try:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == 4
        estimates = conn.execute('SELECT * FROM estimates ORDER BY id').fetchall()
        columns = [d[0] for d in conn.execute('SELECT * FROM estimates').description]
        events = conn.execute('SELECT robot, joint, event, estimate_id, note, id, stamp_s, '
                              'wall_time_s, wear FROM alarm_events ORDER BY id').fetchall()
        recordings = conn.execute('SELECT * FROM recordings').fetchall()
    finally:
        conn.close()
    return columns, estimates, events, recordings


def _check_migrated(history, events):
    assert history.robots() == ('cell_1', 'cell_2')
    assert [e[:5] for e in events] == V4_EVENTS
    joint_2 = history.restore(joint='joint_2', robot='cell_1')
    assert joint_2.alarm_active and joint_2.alarm_evidence == 6.0
    assert [r.wear for r in joint_2.records] == [20.0, 28.0, 36.0, 44.0, 52.0, 55.0]
    joint_3 = history.restore(joint='joint_3', robot='cell_1')
    assert not joint_3.alarm_active and joint_3.last_event.event == 'reset'
    logged = history.alarm_log()
    # newest first by event time: a raise at its experiment's stamp, a reset at its wall time
    by_time = sorted(events, key=lambda e: (e[6] if e[2] == 'raised' else e[7], e[5]),
                     reverse=True)
    assert [(e.robot, e.joint, e.event, e.estimate_id, e.note) for e in logged] == \
        [tuple(e[:5]) for e in by_time]
    assert [e[:3] for e in by_time] == [('cell_1', 'joint_3', 'reset'),
                                        ('cell_1', 'joint_2', 'raised'),
                                        ('cell_1', 'joint_3', 'raised')]
    assert [(e.id, e.stamp_s, e.wall_time_s, e.wear) for e in logged] == \
        [tuple(e[5:]) for e in by_time]
    assert all((e.user, e.owner, e.planned_maintenance) == ('', '', '') for e in logged)
    fleet = history.fleet()
    assert [(r.robot, r.joint, r.alarm, r.acknowledged) for r in fleet] == [
        ('cell_1', 'joint_2', True, False), ('cell_2', 'joint_1', False, False),
        ('cell_1', 'joint_3', False, False)]
    # the per-joint summary of the fleet view was filled from the old rows
    assert [(max(r.total_experiments, r.experiments), r.first_stamp_s, r.last_stamp_s)
            for r in fleet] == [(6, 1.7e9, 1.7e9 + 5 * 3600.0), (2, 1.7e9, 1.7e9 + 3600.0),
                                (4, 1.7e9, 1.7e9 + 3 * 3600.0)]
    # joint_3 was reset after its estimate 9: its new life is the one experiment after it
    reset = [e for e in events if e[2] == 'reset'][0]
    assert (fleet[2].experiments, fleet[2].life_started_s) == (1, reset[6])
    assert [r.experiments for r in fleet[:2]] == [6, 2]
    # the new features work on the migrated history
    history.acknowledge_alarm(joint='joint_2', robot='cell_1', user='ana', owner='ben',
                              comment='gear box ordered', planned_maintenance='2026-12-01')
    assert history.fleet()[0].acknowledged and history.users() == []


def test_a_version_4_history_of_the_released_code_migrates_in_place(tmp_path):
    columns, estimates, events, recordings = _v4_rows()
    path = tmp_path / 'history.db'
    shutil.copyfile(HISTORY_V4, path)
    with WearHistory(path, init=False) as history:
        stored = [r for robot in history.robots() for joint in history.joints(robot=robot)
                  for r in history.records(joint=joint, robot=robot)]
        assert sorted((r.id, r.robot, r.joint, r.stamp_s, r.wear, r.alarm_evidence,
                       r.invalid_reason) for r in stored) == [
            tuple(row[columns.index(c)] for c in ('id', 'robot', 'joint', 'stamp_s', 'wear',
                                                  'alarm_evidence', 'invalid_reason'))
            for row in estimates]
        _check_migrated(history, events)
        assert history.has_recording(fingerprint=recordings[0][1], robot='cell_1')
    with sqlite3.connect(path) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION
        assert conn.execute('PRAGMA integrity_check').fetchone()[0] == 'ok'
        assert conn.execute('PRAGMA foreign_key_check').fetchall() == []
        # the rebuilt table keeps counting ids after the old ones
        assert conn.execute("SELECT seq FROM sqlite_sequence WHERE name = 'alarm_events'"
                            ).fetchone()[0] == 4


def test_a_version_4_postgresql_history_migrates_in_place(postgresql_url):
    import psycopg
    columns, estimates, events, _ = _v4_rows()
    with psycopg.connect(postgresql_url, autocommit=True) as conn:
        for version in (3, 4):
            for step in POSTGRESQL_MIGRATIONS[version]:
                conn.execute(step)
        conn.execute('INSERT INTO schema_version (version) VALUES (4)')
        names = ', '.join(columns)
        marks = ', '.join(['%s'] * len(columns))
        with conn.cursor() as cursor:
            cursor.executemany(f'INSERT INTO estimates ({names}) OVERRIDING SYSTEM VALUE '
                               f'VALUES ({marks})', estimates)
            cursor.executemany(
                'INSERT INTO alarm_events (robot, joint, event, estimate_id, note, id, stamp_s, '
                'wall_time_s, wear) OVERRIDING SYSTEM VALUE VALUES '
                '(%s, %s, %s, %s, %s, %s, %s, %s, %s)', events)
        # the identity goes on after the copied ids, as it does in a database that made them
        conn.execute("SELECT setval(pg_get_serial_sequence('alarm_events', 'id'), 3)")
    with WearHistory(postgresql_url, init=False) as history:
        _check_migrated(history, events)
        assert history.alarm_log(limit=1)[0].id == 4
    with psycopg.connect(postgresql_url) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION


def test_acknowledge_keeps_the_alarm_latched_and_reset_clears_it(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        history.append(_record(0, wear=20.0))
        estimate = _raise(history, 1)
        with pytest.raises(UnknownJointError, match="no estimates of robot 'cell_1' joint "
                                                    "'joint_3'"):
            history.acknowledge_alarm(joint='joint_3', user='ana', owner='ben', comment='x')
        before = time.time()
        ack = history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben',
                                        comment='bearing ordered',
                                        planned_maintenance='2026-12-01')
        assert (ack.event, ack.user, ack.owner, ack.note, ack.planned_maintenance) == (
            'acknowledged', 'ana', 'ben', 'bearing ordered', '2026-12-01')
        assert ack.robot == 'cell_1' and ack.estimate_id == estimate and ack.wear == 40.0
        assert before <= ack.wall_time_s <= time.time()
        with pytest.raises(HistoryError, match="already acknowledged by 'ana'"):
            history.acknowledge_alarm(joint='joint_2', user='cy', owner='cy', comment='')
        # the latch ignores the acknowledgement: still latched on restore and in the fleet
        restored = history.restore(joint='joint_2')
        assert restored.alarm_active and restored.alarm_evidence == 5.0
        assert restored.last_event.event == 'raised'
        [row] = history.fleet()
        assert row.alarm and row.alarm_since_stamp_s == 101.0
        assert (row.acknowledged, row.acknowledged_by, row.planned_maintenance) == (
            True, 'ana', '2026-12-01')
        assert row.acknowledged_wall_time_s == ack.wall_time_s
        # the estimator goes on; its new estimates keep the alarm and the acknowledgement
        history.append(_record(2, wear=45.0, alarm=True, evidence=7.0))
        assert history.fleet()[0].acknowledged

        with pytest.raises(HistoryError, match='reset reason must be a non-empty text'):
            history.reset_alarm(joint='joint_2', user='ana', reason='  ')
        reset = history.reset_alarm(joint='joint_2', user='ana', reason='bearing replaced',
                                    stamp_s=500.0)
        assert (reset.event, reset.user, reset.note, reset.stamp_s, reset.wear) == (
            'reset', 'ana', 'bearing replaced', 500.0, None)
        last = history.records(joint='joint_2')[-1]
        assert reset.estimate_id == last.id  # as the ROS reset ties it
        restored = history.restore(joint='joint_2')
        assert not restored.alarm_active and restored.alarm_evidence == 0.0
        [row] = history.fleet()
        assert not row.alarm and not row.acknowledged and math.isnan(row.alarm_since_stamp_s)
        assert row.acknowledged_by == '' and row.planned_maintenance == ''
        with pytest.raises(HistoryError, match="was reset already by 'ana' and awaits its "
                                               'first experiment'):
            history.reset_alarm(joint='joint_2', user='ana', reason='again')
        with pytest.raises(HistoryError, match='no latched alarm to acknowledge'):
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='')

        # a new raise is a new alarm: not acknowledged until someone acknowledges it
        _raise(history, 3, wear=50.0)
        [row] = history.fleet()
        assert row.alarm and not row.acknowledged and row.alarm_since_stamp_s == 103.0
        second = history.acknowledge_alarm(joint='joint_2', user='dee', owner='ed',
                                           comment='')
        assert history.fleet()[0].acknowledged_by == 'dee' and second.id > ack.id
        kinds = [e.event for e in history.events(joint='joint_2')]
        assert kinds == ['raised', 'acknowledged', 'reset', 'raised', 'acknowledged']


@pytest.mark.parametrize('date', ['2026-02-30', '2026-1-05', '20261201', 'next week',
                                  '2026-12-01T10:00'])
def test_the_planned_maintenance_date_is_a_real_iso_date(tmp_path, date):
    with WearHistory(tmp_path / 'h.db') as history:
        _raise(history, 0)
        with pytest.raises(HistoryError, match='planned maintenance date must be an ISO date '
                                               f'YYYY-MM-DD, got {date!r}'):
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='',
                                      planned_maintenance=date)
        for bad_person in ('', '   ', 'a\nb', 'x' * 129):
            with pytest.raises(HistoryError, match='owner must be a name'):
                history.acknowledge_alarm(joint='joint_2', user='ana', owner=bad_person,
                                          comment='')
        with pytest.raises(HistoryError, match='comment must be a text of at most 2000'):
            history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben',
                                      comment='x' * 2001)
        assert [e.event for e in history.events(joint='joint_2')] == ['raised']


def test_the_alarm_log_is_the_fleets_newest_first(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        _raise(history, 0, joint='joint_2')
        _raise(history, 1, joint='joint_3', robot='cell_2')
        history.acknowledge_alarm(joint='joint_3', robot='cell_2', user='ana', owner='ben',
                                  comment='<b>ordered</b>', planned_maintenance='2026-12-24')
        history.reset_alarm(joint='joint_2', user='cy', reason='replaced the gear')
        history.record_event(AlarmEvent(joint='joint_2', stamp_s=900.0, event='reset',
                                        wear=None, note='reset after maintenance'))  # ROS
        log = history.alarm_log()
        assert [(e.robot, e.joint, e.event, e.user) for e in log] == [
            ('cell_1', 'joint_2', 'reset', ''), ('cell_1', 'joint_2', 'reset', 'cy'),
            ('cell_2', 'joint_3', 'acknowledged', 'ana'),
            ('cell_2', 'joint_3', 'raised', ''), ('cell_1', 'joint_2', 'raised', '')]
        ids = [e.id for e in log]
        assert ids == sorted(ids, reverse=True) and len(set(ids)) == 5
        assert all(math.isfinite(e.wall_time_s) for e in log)
        assert log[2].note == '<b>ordered</b>' and log[2].planned_maintenance == '2026-12-24'
        assert [e.event for e in history.alarm_log(robot='cell_2')] == [
            'acknowledged', 'raised']
        assert [e.robot for e in history.alarm_log(joint='joint_2')] == ['cell_1'] * 3
        assert history.alarm_log(limit=2) == log[:2]
        assert history.alarm_log(before_id=ids[1], limit=2) == log[2:4]
        assert history.alarm_log(robot='nobody') == []
        with pytest.raises(HistoryError, match="limit must be an integer >= 1, got '0'"):
            history.alarm_log(limit=0)


def test_users_have_argon2_hashes_and_roles(history_location):
    with WearHistory(history_location) as history:
        before = time.time()
        ana = history.add_user(name='ana.m@plant-1', role='maintainer', password='s3cret pass')
        history.add_user(name='viewer_1', role='viewer', password='12345678')
        assert ana.role == 'maintainer' and before <= ana.created_wall_time_s <= time.time()
        assert [(u.name, u.role) for u in history.users()] == [
            ('ana.m@plant-1', 'maintainer'), ('viewer_1', 'viewer')]
        assert history.verify_user(name='ana.m@plant-1', password='s3cret pass') == ana
        assert history.verify_user(name='ana.m@plant-1', password='s3cret pas') is None
        assert history.verify_user(name='viewer_1', password='s3cret pass') is None
        assert history.verify_user(name='nobody', password='s3cret pass') is None
        assert history.verify_user(name='bad name!', password='s3cret pass') is None
        with pytest.raises(HistoryError, match="user 'viewer_1' exists already"):
            history.add_user(name='viewer_1', role='viewer', password='another one')
        for name, role, password, message in (
                ('bob', 'root', '12345678', 'role is viewer, maintainer or admin'),
                ('bob', 'viewer', '1234567', 'at least 8 characters'),
                ('bob', 'viewer', '', 'at least 8 characters'),
                ('', 'viewer', '12345678', 'user name is 1-64 characters'),
                ('bo b', 'viewer', '12345678', 'user name is 1-64 characters'),
                ('<img>', 'viewer', '12345678', 'user name is 1-64 characters'),
                ('b' * 65, 'viewer', '12345678', 'user name is 1-64 characters')):
            with pytest.raises(HistoryError, match=message):
                history.add_user(name=name, role=role, password=password)
        history.remove_user(name='viewer_1')
        assert [u.name for u in history.users()] == ['ana.m@plant-1']
        assert history.verify_user(name='viewer_1', password='12345678') is None
        with pytest.raises(HistoryError, match="no user 'viewer_1'"):
            history.remove_user(name='viewer_1')
    # stored: an argon2id hash, never the password
    from argon2 import PasswordHasher
    hashes = _raw(history_location, 'SELECT name, password_hash FROM users')
    [(name, stored)] = hashes
    assert stored.startswith('$argon2id$') and 's3cret' not in stored
    assert PasswordHasher().verify(stored, 's3cret pass')


def _raw(location, sql):
    if is_postgresql_url(location):
        import psycopg
        with psycopg.connect(location) as conn:
            return conn.execute(sql).fetchall()
    with sqlite3.connect(location) as conn:
        return conn.execute(sql).fetchall()


def test_each_notification_is_claimed_once_by_concurrent_notifiers(history_location):
    WearHistory(history_location).close()
    keys = [f'alarm_raised/cell_1/joint_{k}/{k}' for k in range(5)]
    results: list[tuple[str, bool]] = []
    errors: list[BaseException] = []
    start = threading.Barrier(6)

    def notifier(worker):
        try:
            with WearHistory(history_location) as history:  # one connection each
                start.wait()
                for key in keys:
                    claimed = history.claim_notification(
                        event_key=key, robot='cell_1', joint=key.split('/')[2],
                        kind='alarm_raised', channel='webhook',
                        payload={'worker': worker, 'summary': 'wear alarm'})
                    results.append((key, claimed))
        except BaseException as error:  # noqa: B902 - reported by the test below
            errors.append(error)

    threads = [threading.Thread(target=notifier, args=(w,)) for w in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert not errors
    for key in keys:
        assert sorted(c for k, c in results if k == key) == [False] * 5 + [True]
    with WearHistory(history_location) as history:  # a restarted notifier sends nothing again
        assert not history.claim_notification(event_key=keys[0], robot=None, joint=None,
                                              kind='alarm_raised', channel='email',
                                              payload={})
        sent = history.notifications()
        assert sorted(n['event_key'] for n in sent) == sorted(keys)
        assert [n['id'] for n in sent] == sorted((n['id'] for n in sent), reverse=True)
        assert sent[0]['payload']['summary'] == 'wear alarm' and sent[0]['kind'] == \
            'alarm_raised'
        assert len(history.notifications(limit=2)) == 2
        # a notifier whose sending failed for good releases its claim: the next pass retries
        assert history.release_notification(event_key=keys[1])
        assert history.claim_notification(event_key=keys[1], robot='cell_1', joint='joint_1',
                                          kind='alarm_raised', channel='webhook', payload={})
        with pytest.raises(HistoryError, match='payload of notification .* is not JSON'):
            history.claim_notification(event_key='k', robot=None, joint=None, kind='x',
                                       channel='webhook', payload={'v': float('nan')})


def test_a_history_of_the_next_version_is_refused(history_location):
    WearHistory(history_location).close()
    newer = SCHEMA_VERSION + 1
    if is_postgresql_url(history_location):
        import psycopg
        with psycopg.connect(history_location, autocommit=True) as conn:
            conn.execute('UPDATE schema_version SET version = %s', (newer,))
    else:
        with sqlite3.connect(history_location) as conn:
            conn.execute('UPDATE schema_version SET version = ?', (newer,))
    assert SCHEMA_VERSION >= 10  # the account audit (issue 45)
    with pytest.raises(HistoryError, match=f'schema version {newer}, this version reads '
                                           f'{SCHEMA_VERSION}'):
        WearHistory(history_location)


def test_the_fleet_view_shows_who_acknowledged_and_the_planned_maintenance(tmp_path):
    from robot_wear_monitor.fleet.fleet_table import fleet_table
    from robot_wear_monitor.fleet.ranking import fleet_csv_rows, fleet_view
    with WearHistory(tmp_path / 'h.db', robot='cell_1') as history:
        _raise(history, 0, joint='joint_2')
        _raise(history, 1, joint='joint_3', wear=60.0)
        history.append(_record(2, joint='joint_4', wear=5.0))
        history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='',
                                  planned_maintenance='2026-12-01')
        rows = fleet_view(history.fleet(), now_s=200.0)
        history.acknowledge_alarm(joint='joint_3', user='ana', owner='ben', comment='')
        acknowledged_both = fleet_view(history.fleet(), now_s=200.0)
    # the unacknowledged alarm first, then the acknowledged one (whatever their wear)
    assert [(r.state.joint, r.state.alarm, r.state.acknowledged) for r in rows] == [
        ('joint_3', True, False), ('joint_2', True, True), ('joint_4', False, False)]
    # both acknowledged: they rank by their wear (joint_3's is the higher)
    assert [r.state.joint for r in acknowledged_both] == ['joint_3', 'joint_2', 'joint_4']
    rows = [rows[1], rows[0], rows[2]]
    payload = [r.as_json() for r in rows]
    assert (payload[0]['acknowledged'], payload[0]['acknowledged_by'],
            payload[0]['planned_maintenance']) == (True, 'ana', '2026-12-01')
    assert payload[0]['acknowledged_time_s'] == rows[0].state.acknowledged_wall_time_s
    assert (payload[1]['acknowledged'], payload[1]['acknowledged_by'],
            payload[1]['acknowledged_time_s']) == (False, None, None)
    table = fleet_table(rows, wide=True).splitlines()  # one line per joint
    assert 'acknowledged by ana, maintenance planned 2026-12-01' in table[1]
    assert 'acknowledged' not in table[2] and 'LATCHED' in table[2]
    csv_rows = fleet_csv_rows(rows)
    first = csv_rows[0].index('acknowledged_by')
    assert csv_rows[0][first:first + 4] == ['acknowledged_by', 'planned_maintenance',
                                            'reescalated', 'life_started']
    assert [r[first:first + 2] for r in csv_rows[1:]] == [['ana', '2026-12-01'], ['', ''],
                                                          ['', '']]


def test_the_joint_summary_follows_every_append_and_skips_reruns(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        for k in (3, 1, 2):  # stored out of stamp order: the first stamp is the smallest
            history.append(_record(k, joint='joint_2'))
        assert history.append(_record(1, joint='joint_2')) is None  # a re-run adds nothing
        history.append(_record(0, joint='joint_2', robot='cell_2'))
        last = history.append(_record(9, joint='joint_3'))
        rows = {(r.robot, r.joint): r for r in history.fleet()}
    assert {key: (r.experiments, r.first_stamp_s, r.last_stamp_s) for key, r in rows.items()} \
        == {('cell_1', 'joint_2'): (3, 101.0, 102.0), ('cell_2', 'joint_2'): (1, 100.0, 100.0),
            ('cell_1', 'joint_3'): (1, 109.0, 109.0)}
    summary = _raw(history_location, 'SELECT robot, joint, last_id, experiments, first_stamp_s '
                                     'FROM joint_summary')
    assert sorted(summary) == sorted(_raw(
        history_location, 'SELECT robot, joint, MAX(id), COUNT(*), MIN(stamp_s) FROM estimates '
                          'GROUP BY robot, joint'))
    assert ('cell_1', 'joint_3', last, 1, 109.0) in summary


def test_the_latest_ids_change_with_every_new_row(history_location):
    with WearHistory(history_location) as history:
        assert history.latest_ids() == (0, 0)
        first = history.append(_record(0))
        assert history.latest_ids() == (first, 0)
        raised = _raise(history, 1)
        event = history.latest_ids()[1]
        assert history.latest_ids()[0] == raised and event > 0
        ack = history.acknowledge_alarm(joint='joint_2', user='ana', owner='ben', comment='')
        assert history.latest_ids() == (raised, ack.id) and ack.id > event
        history.add_user(name='ana', role='viewer', password='12345678')
        assert history.latest_ids() == (raised, ack.id)


def _at_once(location, action, workers=6):
    """Run ``action(history)`` in ``workers`` threads at once, each its own connection."""
    outcomes: list = []
    start = threading.Barrier(workers)

    def worker():
        with WearHistory(location, robot='cell_1') as history:
            start.wait()
            try:
                outcomes.append(action(history))
            except HistoryError as error:
                outcomes.append(str(error))

    threads = [threading.Thread(target=worker) for _ in range(workers)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    return outcomes


def test_people_acting_at_once_store_one_acknowledgement_and_one_reset(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        _raise(history, 0)
    acks = _at_once(history_location, lambda h: h.acknowledge_alarm(
        joint='joint_2', user='ana', owner='ben', comment='', planned_maintenance=''))
    assert sum(isinstance(o, AlarmEvent) for o in acks) == 1
    assert sum('already acknowledged' in str(o) for o in acks) == 5
    resets = _at_once(history_location, lambda h: h.reset_alarm(joint='joint_2', user='cy',
                                                                reason='replaced'))
    assert sum(isinstance(o, AlarmEvent) for o in resets) == 1
    assert sum('was reset already' in str(o) for o in resets) == 5
    with WearHistory(history_location, robot='cell_1') as history:
        assert [e.event for e in history.events(joint='joint_2')] == [
            'raised', 'acknowledged', 'reset']
