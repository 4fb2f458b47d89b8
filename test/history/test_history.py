"""
Tests of the wear history on both backends (SQLite file, real PostgreSQL server).

Atomic rows, restore of trend and latched alarm per robot and joint, migration of the files of
older releases, foreign databases refused untouched, concurrent writers, a lost server, the
fleet view.
"""

import math
from pathlib import Path
import shutil
import sqlite3
import subprocess
import sys

import pytest
from robot_wear_monitor.history import (
    AlarmEvent, DEFAULT_ROBOT, HistoryError, HistoryRecord, INTERVAL_COLUMNS, is_postgresql_url,
    open_history, redact_url, SCHEMA_VERSION, WearHistory)

ROOT = Path(__file__).resolve().parents[2]
HISTORY_V2 = Path(__file__).resolve().parent / 'data' / 'history_v2.db'


def _record(k, *, wear=10.0, alarm=False, evidence=0.0, joint='joint_2', robot=None,
            **extra):
    return HistoryRecord(joint=joint, stamp_s=100.0 + k, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=float('nan'), chi2=1.0,
                         dof=0, p_value=float('nan'), temperature_at_bound=False,
                         wear_at_bound=False, alarm_active=alarm, alarm_evidence=evidence,
                         status_level=0, parameter_set='p', robot=robot, **extra)


def _execute(location, sql, params=()):
    """Run raw SQL on the history behind the API (to damage or inspect it)."""
    if is_postgresql_url(location):
        import psycopg
        with psycopg.connect(location, autocommit=True) as conn:
            cursor = conn.execute(sql.replace('?', '%s'), params)
            return cursor.fetchall() if cursor.description else []
    with sqlite3.connect(location) as conn:
        return conn.execute(sql, params).fetchall()


def test_records_survive_reopening_in_order(history_location):
    with WearHistory(history_location) as history:
        for k in range(3):
            history.append(_record(k, wear=float(k)))
        history.append(_record(9, joint='joint_3'))
    with WearHistory(history_location) as history:
        records = history.records(joint='joint_2')
        assert [r.wear for r in records] == [0.0, 1.0, 2.0]
        assert records[0].speeds_rad_s == (2.1, 28.5) and records[0].robot == DEFAULT_ROBOT
        assert math.isnan(records[0].p_value) and math.isnan(records[0].wear_std)
        assert [r.wear for r in history.records(joint='joint_2', limit=2)] == [1.0, 2.0]
        assert len(history.records(joint='joint_3')) == 1
        assert history.joints() == ('joint_2', 'joint_3')
    if not is_postgresql_url(history_location):
        mode = sqlite3.connect(history_location).execute('PRAGMA journal_mode').fetchone()[0]
        assert mode == 'wal'


def test_restore_latched_alarm_and_reset(history_location):
    with WearHistory(history_location) as history:
        history.append(_record(0, wear=20.0, evidence=1.0))
        last = history.append(_record(1, wear=36.0, alarm=True, evidence=4.0), events=[
            AlarmEvent(joint='joint_2', stamp_s=101.0, event='raised', wear=36.0)])
    with WearHistory(history_location) as history:
        state = history.restore(joint='joint_2')
        assert state.alarm_active and state.alarm_evidence == 4.0
        assert state.last_event.estimate_id == last
        history.record_event(AlarmEvent(joint='joint_2', stamp_s=102.0, event='reset',
                                        wear=None, estimate_id=last))
    with WearHistory(history_location) as history:
        state = history.restore(joint='joint_2')
        assert not state.alarm_active and state.alarm_evidence == 0.0
        assert [e.event for e in history.events(joint='joint_2')] == ['raised', 'reset']
        assert not history.restore(joint='other').alarm_active


def test_robots_with_the_same_joint_names_never_mix(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        history.append(_record(0, wear=5.0))
        history.append(_record(0, wear=50.0, alarm=True, evidence=3.0, robot='cell_2'),
                       events=[AlarmEvent(joint='joint_2', stamp_s=100.0, event='raised',
                                          wear=50.0, robot='cell_2')])
    with WearHistory(history_location, robot='cell_2') as history:
        assert history.robots() == ('cell_1', 'cell_2')
        [mine] = history.records(joint='joint_2')
        assert (mine.robot, mine.wear) == ('cell_2', 50.0)
        assert history.restore(joint='joint_2').alarm_active
        state = history.restore(joint='joint_2', robot='cell_1')
        assert not state.alarm_active and [r.wear for r in state.records] == [5.0]
        assert history.events(joint='joint_2', robot='cell_1') == ()
        assert history.find_estimate(joint='joint_2', stamp_s=100.0, robot='cell_1') \
            != history.find_estimate(joint='joint_2', stamp_s=100.0)
        assert history.joints(robot='nobody') == ()


def test_a_rerun_of_the_same_experiment_adds_nothing(history_location):
    with WearHistory(history_location) as history:
        first = history.append(_record(0), events=[
            AlarmEvent(joint='joint_2', stamp_s=100.0, event='raised', wear=10.0)])
        assert first is not None
        assert history.append(_record(0, wear=99.0), events=[
            AlarmEvent(joint='joint_2', stamp_s=100.0, event='raised', wear=99.0)]) is None
        assert history.append(_record(0.0000004)) is None  # within the stamp tolerance
        assert history.find_estimate(joint='joint_2', stamp_s=100.0) == first
        assert [r.wear for r in history.records(joint='joint_2')] == [10.0]
        assert len(history.events(joint='joint_2')) == 1


def test_failed_transaction_leaves_nothing(history_location):
    with WearHistory(history_location) as history:
        with pytest.raises(HistoryError, match='event must be one of raised, reset, ack'):
            history.append(_record(0), events=[AlarmEvent(joint='joint_2', stamp_s=1.0,
                                                          event='bogus', wear=1.0)])
        assert history.records(joint='joint_2') == ()
        with pytest.raises(HistoryError, match='robot name'):
            history.append(_record(1, robot=''))
        assert history.append(_record(0)) is not None  # the connection still works


def test_unknown_schema_version_is_a_clear_error(history_location):
    WearHistory(history_location).close()
    _execute(history_location, 'UPDATE schema_version SET version = ?', (SCHEMA_VERSION + 1,))
    with pytest.raises(HistoryError, match=f'schema version {SCHEMA_VERSION + 1}, this '
                                           f'version reads {SCHEMA_VERSION}'):
        WearHistory(history_location)


def test_garbage_is_a_clear_error(tmp_path):
    garbage = tmp_path / 'garbage.sqlite3'
    garbage.write_bytes(b'not a database' * 100)
    with pytest.raises(HistoryError, match='not a usable'):
        WearHistory(garbage)
    assert garbage.read_bytes() == b'not a database' * 100


def test_a_version_2_history_of_the_released_code_loads_with_its_rows_alarms_and_trend(
        tmp_path):
    original = sqlite3.connect(f'{HISTORY_V2.as_uri()}?immutable=1', uri=True)
    assert original.execute('SELECT version FROM schema_version').fetchone()[0] == 2
    columns = ('id', 'joint', 'stamp_s', 'wear', 'wear_std', 'alarm_active', 'alarm_evidence',
               'parameter_set', *INTERVAL_COLUMNS)
    stored = original.execute(f'SELECT {", ".join(columns)} FROM estimates ORDER BY id')
    stored = [dict(zip(columns, row)) for row in stored.fetchall()]
    original.close()
    assert len(stored) == 11 and sum(1 for r in stored if r['trend_wear'] is not None) == 11
    path = tmp_path / 'history.db'
    shutil.copyfile(HISTORY_V2, path)
    with WearHistory(path, robot='cell_7') as history:
        assert history.robots() == ('cell_7',)
        assert history.joints() == ('joint_2', 'joint_3')
        loaded = [*history.records(joint='joint_2'), *history.records(joint='joint_3')]
        for record, row in zip(loaded, stored):
            assert record.robot == 'cell_7'
            for column, value in row.items():
                got = getattr(record, column)
                assert got == value or (value is None and math.isnan(got)), column
        joint_2 = history.restore(joint='joint_2', trend_length=5)
        assert joint_2.alarm_active and joint_2.alarm_evidence == stored[7]['alarm_evidence']
        assert [r.id for r in joint_2.records] == [4, 5, 6, 7, 8]
        assert joint_2.last_event.estimate_id == 5 and 'trend P' in joint_2.last_event.note
        joint_3 = history.restore(joint='joint_3')
        assert not joint_3.alarm_active and joint_3.alarm_evidence == 0.0
        assert [e.event for e in history.events(joint='joint_3')] == ['raised', 'reset']
        # the re-run of the recording that made it adds nothing; a new experiment is stored
        old = history.records(joint='joint_2')[0]
        assert history.append(HistoryRecord(**{**old.__dict__, 'id': None})) is None
        new = history.append(HistoryRecord(**{**old.__dict__, 'id': None, 'stamp_s': 2e9}))
        assert new == 12
    with sqlite3.connect(path) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION
    shutil.copyfile(HISTORY_V2, path)
    with WearHistory(path) as history:  # no robot given: the old rows are the default robot's
        assert history.robots() == (DEFAULT_ROBOT,)
        assert history.fleet()[0].alarm and history.fleet()[0].joint == 'joint_2'


_VERSION_1_SCHEMA = """
CREATE TABLE schema_version (version INTEGER NOT NULL);
INSERT INTO schema_version VALUES (1);
CREATE TABLE estimates (
    id INTEGER PRIMARY KEY AUTOINCREMENT, joint TEXT NOT NULL, stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL, speeds_rad_s TEXT NOT NULL, frictions TEXT NOT NULL,
    temperature_degc REAL NOT NULL, temperature_std_degc REAL, wear REAL NOT NULL,
    wear_std REAL, chi2 REAL, dof INTEGER NOT NULL, p_value REAL,
    temperature_at_bound INTEGER NOT NULL, wear_at_bound INTEGER NOT NULL,
    alarm_active INTEGER NOT NULL, alarm_evidence REAL NOT NULL, status_level INTEGER NOT NULL,
    parameter_set TEXT NOT NULL);
CREATE TABLE alarm_events (
    id INTEGER PRIMARY KEY AUTOINCREMENT, joint TEXT NOT NULL, stamp_s REAL NOT NULL,
    wall_time_s REAL NOT NULL, event TEXT NOT NULL CHECK (event IN ('raised', 'reset')),
    wear REAL, estimate_id INTEGER REFERENCES estimates (id), note TEXT NOT NULL DEFAULT '');
INSERT INTO estimates VALUES (1, 'joint_2', 100.0, 1.0, '[2.1, 28.5]', '[0.1, 0.05]', 41.0,
    2.0, 37.5, 4.0, 1.0, 0, NULL, 0, 0, 1, 3.0, 2, 'p');
INSERT INTO alarm_events VALUES (1, 'joint_2', 100.0, 1.0, 'raised', 37.5, 1, 'old');
"""


def test_a_version_1_history_is_migrated_and_keeps_its_rows_and_alarm(tmp_path):
    path = tmp_path / 'old.sqlite3'
    with sqlite3.connect(path) as conn:
        conn.executescript(_VERSION_1_SCHEMA)
    with WearHistory(path) as history:
        [old] = history.records(joint='joint_2')
        assert (old.wear, old.temperature_degc, old.alarm_active) == (37.5, 41.0, True)
        assert math.isnan(old.wear_low) and math.isnan(old.trend_wear)
        restored = history.restore(joint='joint_2')
        assert restored.alarm_active and restored.alarm_evidence == 3.0
        history.append(HistoryRecord(**{**_record(1, wear=40.0).__dict__, 'wear_low': 31.0,
                                        'wear_high': 48.5, 'trend_wear': 38.0}))
    with WearHistory(path) as history:
        records = history.records(joint='joint_2')
    assert [r.wear for r in records] == [37.5, 40.0]
    assert (records[1].wear_low, records[1].wear_high, records[1].trend_wear) == (31.0, 48.5,
                                                                                  38.0)
    with sqlite3.connect(path) as conn:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == SCHEMA_VERSION


def test_a_foreign_sqlite_file_is_refused_and_left_byte_for_byte(tmp_path):
    path = tmp_path / 'theirs.db'
    with sqlite3.connect(path) as conn:
        conn.execute('CREATE TABLE estimates (x)')  # even a table of our name
        conn.execute('CREATE TABLE customers (name TEXT)')
        conn.execute("INSERT INTO customers VALUES ('ada')")
    before = path.read_bytes()
    for init in (None, True, False):
        with pytest.raises(HistoryError, match='not a wear history of this monitor.*untouched'):
            WearHistory(path, init=init)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ['theirs.db']


def test_an_empty_file_is_initialised_only_when_asked(tmp_path):
    path = tmp_path / 'empty.db'
    path.touch()
    with pytest.raises(HistoryError, match='empty file.*--init'):
        WearHistory(path)
    assert path.read_bytes() == b''
    with WearHistory(path, init=True) as history:
        history.append(_record(0))
    with WearHistory(path) as history:
        assert len(history.records(joint='joint_2')) == 1
    missing = tmp_path / 'missing.db'
    with pytest.raises(HistoryError, match='no such wear history'):
        WearHistory(missing, init=False)
    assert not missing.exists()
    with open_history(tmp_path / 'sub' / 'new.db') as history:  # missing: created
        assert history.backend == 'sqlite' and history.records(joint='joint_2') == ()


def test_a_postgresql_database_with_other_tables_needs_init(postgresql_url):
    _execute(postgresql_url, 'CREATE TABLE customers (name TEXT)')
    with pytest.raises(HistoryError, match='other tables.*--init'):
        WearHistory(postgresql_url)
    tables = _execute(postgresql_url, 'SELECT table_name FROM information_schema.tables '
                                      'WHERE table_schema = current_schema()')
    assert tables == [('customers',)]
    _execute(postgresql_url, 'CREATE TABLE estimates (x INTEGER)')
    with pytest.raises(HistoryError, match='not a wear history of this monitor'):
        WearHistory(postgresql_url, init=True)
    _execute(postgresql_url, 'DROP TABLE estimates')
    with WearHistory(postgresql_url, init=True) as history:
        assert history.append(_record(0)) is not None


def test_an_unreachable_server_is_a_clear_error(postgresql_server):
    url = postgresql_server.url('no_such_database').replace('postgres@', 'postgres:secret@')
    with pytest.raises(HistoryError, match='cannot connect to the wear history server') as info:
        WearHistory(url)
    assert 'secret' not in str(info.value) and 'postgres:***@127.0.0.1' in str(info.value)


def test_a_server_that_goes_away_is_a_clear_error_and_the_committed_rows_stay(postgresql_url):
    history = WearHistory(postgresql_url, robot='cell_1')
    history.append(_record(0))
    history.append(_record(1))
    backend_pid = history._backend.conn.info.backend_pid
    _execute(postgresql_url, 'SELECT pg_terminate_backend(?)', (backend_pid,))
    with pytest.raises(HistoryError) as info:
        history.append(_record(2))
    message = str(info.value)
    assert message.startswith(postgresql_url) and 'lost the connection' in message
    assert '\n' not in message
    with pytest.raises(HistoryError, match='lost the connection'):
        history.records(joint='joint_2')
    history.close()
    with WearHistory(postgresql_url, robot='cell_1') as again:
        assert [r.stamp_s for r in again.records(joint='joint_2')] == [100.0, 101.0]


def test_the_fleet_view_ranks_alarms_then_crossings_then_upper_bounds(history_location):
    with WearHistory(history_location) as history:
        history.append(_record(0, wear=10.0, robot='a', wear_high=30.0))
        history.append(_record(1, wear=12.0, robot='a', wear_high=31.0,
                               crossing_experiments=40.0))
        history.append(_record(0, wear=20.0, robot='b', wear_high=45.0))
        history.append(_record(0, wear=30.0, robot='c', joint='joint_1', wear_high=35.0,
                               crossing_experiments=5.0))
        history.append(_record(3, wear=36.0, robot='c', alarm=True, evidence=2.0),
                       events=[AlarmEvent(joint='joint_2', stamp_s=103.0, event='raised',
                                          wear=36.0, robot='c')])
        history.append(_record(0, wear=40.0, robot='d', alarm=True), events=[
            AlarmEvent(joint='joint_2', stamp_s=100.0, event='raised', wear=40.0, robot='d')])
        history.record_event(AlarmEvent(joint='joint_2', stamp_s=150.0, event='reset',
                                        wear=None, robot='d'))
        rows = history.fleet()
        assert [(r.robot, r.joint) for r in rows] == [
            ('c', 'joint_2'), ('c', 'joint_1'), ('a', 'joint_2'), ('b', 'joint_2'),
            ('d', 'joint_2')]
        alarm, _, a, b, d = rows
        assert alarm.alarm and alarm.alarm_since_stamp_s == 103.0 and alarm.wear == 36.0
        assert (a.experiments, a.first_stamp_s, a.last_stamp_s) == (2, 100.0, 101.0)
        assert (a.wear, a.wear_high, a.crossing_experiments, a.usual_interval_s) == (
            12.0, 31.0, 40.0, 1.0)
        assert math.isnan(b.usual_interval_s) and math.isnan(b.crossing_experiments)
        assert not d.alarm and math.isnan(d.alarm_since_stamp_s)
        assert [(r.robot, r.joint) for r in history.fleet(robot='c')] == [
            ('c', 'joint_2'), ('c', 'joint_1')]


_WRITER = """
import sys
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory
location, worker = sys.argv[2], int(sys.argv[3])
workers = [worker] if worker >= 0 else list(range(8))
with WearHistory(location) as history:
    for w in workers:
        # each worker: its own robot, and the shared robot's experiments that all write
        for robot in (f'robot_{w}', 'shared'):
            for k in range(12):
                stamp = 1000.0 + 60.0 * k + (0.0 if robot == 'shared' else w / 8)
                raised = k == 7
                record = HistoryRecord(
                    robot=robot, joint=f'joint_{k % 2}', stamp_s=stamp,
                    speeds_rad_s=(2.1, 28.5), frictions=(0.1 + k / 100, 0.05),
                    temperature_degc=40.0, temperature_std_degc=1.0, wear=float(k),
                    wear_std=0.5, chi2=1.0, dof=1, p_value=0.5, temperature_at_bound=False,
                    wear_at_bound=False, alarm_active=k >= 7, alarm_evidence=float(k),
                    status_level=0, parameter_set='p', trend_wear=k / 2)
                events = [AlarmEvent(robot=robot, joint=record.joint, stamp_s=stamp,
                                     event='raised', wear=float(k), note='n')] if raised else []
                history.append(record, events=events)
print('ok')
"""


def _content(location):
    with WearHistory(location) as history:
        records, events = [], []
        for robot in history.robots():
            for joint in history.joints(robot=robot):
                by_id = {r.id: r.stamp_s for r in history.records(joint=joint, robot=robot)}
                records += [(r.robot, r.joint, r.stamp_s, r.wear, r.frictions, r.trend_wear,
                             r.alarm_active) for r in history.records(joint=joint, robot=robot)]
                events += [(e.robot, e.joint, e.stamp_s, e.event, by_id[e.estimate_id])
                           for e in history.events(joint=joint, robot=robot)]
        return sorted(records), sorted(events)


def test_eight_writers_at_once_lose_nothing_and_duplicate_nothing(
        history_location, tmp_path, request):
    if is_postgresql_url(history_location):
        sequential = request.getfixturevalue('postgresql_server').create_database()
    else:
        sequential = str(tmp_path / 'sequential.sqlite3')
    run = subprocess.run([sys.executable, '-c', _WRITER, str(ROOT), sequential, '-1'],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    runs = [subprocess.Popen([sys.executable, '-c', _WRITER, str(ROOT), history_location,
                              str(w)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True) for w in range(8)]
    for writer in runs:
        out, err = writer.communicate(timeout=300)
        assert writer.returncode == 0 and out.strip() == 'ok', err
    records, events = _content(history_location)
    assert (records, events) == _content(sequential)
    # the fleet view's per-joint summary, kept by each append, counted every row once
    kept = _execute(history_location, 'SELECT robot, joint, last_id, experiments, '
                    'first_stamp_s FROM joint_summary')
    counted = _execute(history_location, 'SELECT robot, joint, MAX(id), COUNT(*), '
                       'MIN(stamp_s) FROM estimates GROUP BY robot, joint')
    assert sorted(kept) == sorted(counted) and len(kept) == 18
    assert len(records) == 9 * 12 and len(events) == 9 * 1
    assert len({r[:3] for r in records}) == len(records)


_LOCKER = """
import sys
from robot_wear_monitor.history import HistoryError, WearHistory
with WearHistory(sys.argv[2], robot='cell_1') as history:
    for joint in ('joint_2', 'joint_3'):
        try:
            with history.writer_lock(joint=joint, wait=False):
                print(joint, 'free')
        except HistoryError as error:
            print(joint, 'busy', error)
"""


def test_the_writer_lock_keeps_a_second_writer_of_a_joint_out(history_location):
    with WearHistory(history_location, robot='cell_1') as history:
        with history.writer_lock(joint='joint_2'):
            run = subprocess.run([sys.executable, '-c', _LOCKER, str(ROOT), history_location],
                                 capture_output=True, text=True, timeout=120)
            assert run.returncode == 0, run.stderr
            lines = run.stdout.splitlines()
            assert lines[0].startswith('joint_2 busy') and 'in use by another writer' in lines[0]
            assert lines[1] == 'joint_3 free'
        run = subprocess.run([sys.executable, '-c', _LOCKER, str(ROOT), history_location],
                             capture_output=True, text=True, timeout=120)
        assert run.stdout.splitlines() == ['joint_2 free', 'joint_3 free']


def test_urls_are_recognised_and_their_passwords_hidden():
    assert is_postgresql_url('postgresql://u@h:5432/db') and is_postgresql_url('postgres://h/d')
    assert not is_postgresql_url('history.db') and not is_postgresql_url(Path('x'))
    assert redact_url('postgresql://u:pw@h:5432/db') == 'postgresql://u:***@h:5432/db'
    assert redact_url('postgresql://u@h/db') == 'postgresql://u@h/db'


def test_processes_opening_a_new_history_at_once_all_succeed(tmp_path):
    # WAL needs a moment of exclusive access when the file is created; SQLite reports that as
    # "database is locked" without waiting, so opening retries (it failed in about 3 % of
    # opens of six racing processes before); a new file appears whole (linked into place)
    path = tmp_path / 'shared.sqlite3'
    code = ('import sys; '
            'from robot_wear_monitor.history import WearHistory; '
            'h = WearHistory(sys.argv[2]); h.close(); print("ok")')
    runs = [subprocess.Popen([sys.executable, '-c', code, str(ROOT), str(path)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for _ in range(6)]
    for run in runs:
        out, err = run.communicate(timeout=60)
        assert run.returncode == 0 and out.strip() == 'ok', err
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(
        'shared.sqlite3-')) == ['shared.sqlite3']


def test_the_old_import_path_works_for_a_release_with_a_deprecation_warning():
    code = ('import warnings\n'
            'with warnings.catch_warnings(record=True) as caught:\n'
            '    warnings.simplefilter("always")\n'
            '    from robot_wear_monitor.monitoring.history import open_history, WearHistory\n'
            'import robot_wear_monitor.history as new\n'
            'assert open_history is new.open_history and WearHistory is new.WearHistory\n'
            'print([(w.category.__name__, str(w.message)) for w in caught])\n')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True)
    assert 'DeprecationWarning' in result.stdout
    assert 'import from robot_wear_monitor.history' in result.stdout
