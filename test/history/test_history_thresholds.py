"""
Tests of the history's schema 8 (the threshold an estimate was judged by) on both backends.

A version-7 file written by the released code (and a version-7 PostgreSQL database made of the
same rows) migrates in place: every row kept, the new ``threshold`` and ``warning_level`` NULL
(read back as NaN: not known); what the estimator stores after the migration carries them.
``fleet --json``, its CSV, ``/api/fleet`` and the dashboard's pages show such a row with the
parameter set's threshold, marked as assumed.
"""

import csv
import io
import json
import math
from pathlib import Path
import shutil
import sqlite3

import pytest
from robot_wear_monitor.history import (HistoryRecord, is_postgresql_url, POSTGRESQL_MIGRATIONS,
                                        SCHEMA_VERSION, WearHistory)

HISTORY_V7 = Path(__file__).resolve().parent / 'data' / 'history_v7.db'
#: The tables of version 7 that hold rows in the file.
V7_TABLES = ('estimates', 'alarm_events', 'users', 'joint_summary')


def _v7_rows() -> dict[str, tuple[list[str], list[tuple]]]:
    """Return the columns and rows (ordered) of the tables of the version-7 file."""
    conn = sqlite3.connect(f'{HISTORY_V7.as_uri()}?immutable=1', uri=True)
    try:
        assert conn.execute('SELECT version FROM schema_version').fetchone()[0] == 7
        tables = {}
        for table in V7_TABLES:
            cursor = conn.execute(f'SELECT * FROM {table} ORDER BY 1, 2')
            tables[table] = ([d[0] for d in cursor.description], cursor.fetchall())
    finally:
        conn.close()
    return tables


def _make_postgresql_v7(url: str) -> None:
    """Lay out a version-7 PostgreSQL history holding the rows of the version-7 file."""
    import psycopg
    v7 = _v7_rows()
    with psycopg.connect(url, autocommit=True) as conn:
        for version in (3, 4, 5, 6, 7):
            for step in POSTGRESQL_MIGRATIONS[version]:
                conn.execute(step)
        conn.execute('INSERT INTO schema_version (version) VALUES (7)')
        with conn.cursor() as cursor:
            for table, (columns, rows) in v7.items():
                if table == 'joint_summary':
                    continue  # version 5 filled it (from no rows): the rows go in below
                overriding = 'OVERRIDING SYSTEM VALUE ' if 'id' in columns else ''
                cursor.executemany(
                    f'INSERT INTO {table} ({", ".join(columns)}) {overriding}VALUES '
                    f'({", ".join(["%s"] * len(columns))})', rows)
            columns, rows = v7['joint_summary']
            cursor.executemany(f'INSERT INTO joint_summary ({", ".join(columns)}) VALUES '
                               f'({", ".join(["%s"] * len(columns))})', rows)
        for table in ('estimates', 'alarm_events'):
            conn.execute(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                         f'(SELECT MAX(id) FROM {table}))')


@pytest.fixture
def v7_history(history_location, tmp_path):
    """Return the location of a version-7 history of the released code, on either backend."""
    if is_postgresql_url(history_location):
        _make_postgresql_v7(history_location)
        return history_location
    shutil.copyfile(HISTORY_V7, history_location)
    return history_location


def _stored_version(location: str) -> int:
    sql = 'SELECT version FROM schema_version'
    if is_postgresql_url(location):
        import psycopg
        with psycopg.connect(location) as conn:
            return conn.execute(sql).fetchone()[0]
    with sqlite3.connect(location) as conn:
        return conn.execute(sql).fetchone()[0]


def test_a_version_7_history_migrates_with_unknown_thresholds(v7_history):
    columns, estimates = _v7_rows()['estimates']
    with WearHistory(v7_history, init=False) as history:
        assert _stored_version(v7_history) == SCHEMA_VERSION
        stored = sorted((r for joint in history.joints(robot='cell_1')
                         for r in history.records(joint=joint, robot='cell_1')),
                        key=lambda r: r.id)
        # every row kept, with its values
        assert [(r.id, r.joint, r.stamp_s, r.wear, r.alarm_active) for r in stored] == [
            tuple(row[columns.index(c)] for c in ('id', 'joint', 'stamp_s', 'wear',
                                                  'alarm_active')) for row in estimates]
        # the threshold and warning level of the old rows are not known
        assert all(math.isnan(r.threshold) and math.isnan(r.warning_level) for r in stored)
        fleet = {row.joint: row for row in history.fleet()}
        assert fleet['joint_2'].alarm and fleet['joint_2'].wear == 38.0
        assert all(math.isnan(row.threshold) and math.isnan(row.warning_level)
                   for row in fleet.values())
        # a new estimate after the migration stores what it was judged by
        last = stored[-1]
        new_id = history.append(HistoryRecord(**{
            **last.__dict__, 'id': None, 'stamp_s': last.stamp_s + 3600.0, 'threshold': 30.0,
            'warning_level': 24.0}))
        assert new_id == max(r.id for r in stored) + 1
        (again,) = history.records(joint=last.joint, robot='cell_1', limit=1)
        assert (again.threshold, again.warning_level) == (30.0, 24.0)
        row = next(r for r in history.fleet() if r.joint == last.joint)
        assert (row.threshold, row.warning_level) == (30.0, 24.0)


def test_a_version_7_sqlite_file_stays_intact(tmp_path):
    path = tmp_path / 'history.db'
    shutil.copyfile(HISTORY_V7, path)
    WearHistory(path, init=False).close()
    with sqlite3.connect(path) as conn:
        assert conn.execute('PRAGMA integrity_check').fetchone()[0] == 'ok'
        columns = {r[1]: r[2] for r in conn.execute('PRAGMA table_info(estimates)')}
        assert columns['threshold'] == columns['warning_level'] == 'DOUBLE PRECISION'
        assert conn.execute('SELECT COUNT(*) FROM estimates WHERE threshold IS NULL OR '
                            'warning_level IS NULL').fetchone()[0] == 6


def test_a_version_7_history_shows_the_parameter_sets_threshold_as_assumed(v7_history, capsys):
    from fastapi import testclient as fastapi_testclient
    from robot_wear_monitor.cli import main
    from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
    from wear_testing.fleet_history import login
    capsys.readouterr()
    assert main(['fleet', '--history', v7_history, '--json']) == 0
    rows = {row['joint']: row for row in json.loads(capsys.readouterr().out)}
    # the rows name the packaged set (alarm.wear_threshold 35, alarm.wear_warning 28)
    for row in rows.values():
        assert (row['threshold'], row['warning_level'], row['threshold_assumed']) == (
            35.0, 28.0, True)
    assert main(['fleet', '--history', v7_history, '--csv']) == 0
    table = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert {(r['threshold'], r['threshold_assumed']) for r in table} == {('35', 'yes')}
    with WearHistory(v7_history, init=False) as history:
        history.add_user(name='vic', role='viewer', password='viewer-pass-22')
    app = create_app(DashboardSettings(history=v7_history))
    with fastapi_testclient.TestClient(app) as client:
        assert login(client, 'vic', 'viewer-pass-22').status_code == 303
        api = {row['joint']: row for row in client.get('/api/fleet').json()['rows']}
        for joint, row in rows.items():  # the keys fleet --json has, named and valued alike
            assert {key: api[joint][key] for key in row if key != 'stale'} == {
                key: value for key, value in row.items() if key != 'stale'}
            assert api[joint]['text']['threshold'] == '35 (assumed)'
        fleet_page = client.get('/').text
        assert fleet_page.count('threshold 35 (assumed)') == 2
        joint = client.get('/api/robots/cell_1/joints/joint_2').json()
        assert (joint['threshold'], joint['threshold_assumed'], joint['threshold_text']) == (
            35.0, True, '35 (assumed)')
        page = client.get('/robots/cell_1/joints/joint_2').text
        assert '<dd id="f-threshold">35 (assumed)</dd>' in page
        assert 'id="threshold-note">Threshold assumed' in page
