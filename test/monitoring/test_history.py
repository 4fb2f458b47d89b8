"""Tests of the SQLite wear history: atomic rows, restore of trend and latched alarm."""

import math
from pathlib import Path
import sqlite3

import pytest

from robot_wear_monitor.monitoring.history import (AlarmEvent, HistoryError, HistoryRecord,
                                                   SCHEMA_VERSION, WearHistory)


def _record(k, *, wear=10.0, alarm=False, evidence=0.0, joint='joint_2'):
    return HistoryRecord(joint=joint, stamp_s=100.0 + k, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=float('nan'), chi2=1.0,
                         dof=0, p_value=float('nan'), temperature_at_bound=False,
                         wear_at_bound=False, alarm_active=alarm, alarm_evidence=evidence,
                         status_level=0, parameter_set='p')


def test_records_survive_reopening_in_order(tmp_path):
    path = tmp_path / 'h.sqlite3'
    with WearHistory(path) as history:
        for k in range(3):
            history.append(_record(k, wear=float(k)))
        history.append(_record(9, joint='joint_3'))
    with WearHistory(path) as history:
        records = history.records(joint='joint_2')
        assert [r.wear for r in records] == [0.0, 1.0, 2.0]
        assert records[0].speeds_rad_s == (2.1, 28.5)
        assert math.isnan(records[0].p_value) and math.isnan(records[0].wear_std)
        assert [r.wear for r in history.records(joint='joint_2', limit=2)] == [1.0, 2.0]
        assert len(history.records(joint='joint_3')) == 1
    mode = sqlite3.connect(path).execute('PRAGMA journal_mode').fetchone()[0]
    assert mode == 'wal'


def test_restore_latched_alarm_and_reset(tmp_path):
    path = tmp_path / 'h.sqlite3'
    with WearHistory(path) as history:
        history.append(_record(0, wear=20.0, evidence=1.0))
        last = history.append(_record(1, wear=36.0, alarm=True, evidence=4.0), events=[
            AlarmEvent(joint='joint_2', stamp_s=101.0, event='raised', wear=36.0)])
    with WearHistory(path) as history:
        state = history.restore(joint='joint_2')
        assert state.alarm_active and state.alarm_evidence == 4.0
        assert state.last_event.estimate_id == last
        history.record_event(AlarmEvent(joint='joint_2', stamp_s=102.0, event='reset',
                                        wear=None, estimate_id=last))
    with WearHistory(path) as history:
        state = history.restore(joint='joint_2')
        assert not state.alarm_active and state.alarm_evidence == 0.0
        assert [e.event for e in history.events(joint='joint_2')] == ['raised', 'reset']
        assert not history.restore(joint='other').alarm_active


def test_failed_transaction_leaves_nothing(tmp_path):
    with WearHistory(tmp_path / 'h.sqlite3') as history:
        with pytest.raises(sqlite3.IntegrityError):
            history.append(_record(0), events=[AlarmEvent(joint='joint_2', stamp_s=1.0,
                                                          event='bogus', wear=1.0)])
        assert history.records(joint='joint_2') == ()


def test_unknown_schema_version_and_garbage_are_clear_errors(tmp_path):
    path = tmp_path / 'h.sqlite3'
    WearHistory(path).close()
    with sqlite3.connect(path) as conn:
        conn.execute('UPDATE schema_version SET version = ?', (SCHEMA_VERSION + 1,))
    with pytest.raises(HistoryError, match='schema version'):
        WearHistory(path)
    garbage = tmp_path / 'garbage.sqlite3'
    garbage.write_bytes(b'not a database' * 100)
    with pytest.raises(HistoryError, match='not a usable'):
        WearHistory(garbage)


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


def test_processes_opening_a_new_history_at_once_all_succeed(tmp_path):
    # WAL needs a moment of exclusive access when the file is created; SQLite reports that as
    # "database is locked" without waiting, so opening retries (it failed in about 3 % of
    # opens of six racing processes before)
    import subprocess
    import sys
    root = Path(__file__).resolve().parents[2]
    path = tmp_path / 'shared.sqlite3'
    code = ('import sys; sys.path.insert(0, sys.argv[1]); '
            'from robot_wear_monitor.monitoring.history import WearHistory; '
            'h = WearHistory(sys.argv[2]); h.close(); print("ok")')
    runs = [subprocess.Popen([sys.executable, '-c', code, str(root), str(path)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for _ in range(6)]
    for run in runs:
        out, err = run.communicate(timeout=60)
        assert run.returncode == 0 and out.strip() == 'ok', err
