"""The online loop: replay -> SQLite history -> `history --csv` -> `audit`; audit of a bag."""

import csv
import datetime
import json
import time

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.audit.data import load_audit_data
from robot_wear_monitor.experiment.simulation import read_truth_json, truth_path_for

SPEEDS = [2.1, 28.5, 35.1, 41.7]


@pytest.fixture(scope='module')
def replayed(tmp_path_factory):
    folder = tmp_path_factory.mktemp('history')
    bag = folder / 'bag'
    assert cli.main(['simulate', '--out', str(bag), '--experiments', '5', '--seed', '4']) == 0
    history = folder / 'h.sqlite3'
    assert cli.main(['replay', str(bag), '--out', str(folder / 'out'), '--json-out',
                     str(folder / 's.json'), '--history', str(history), '--joint', 'joint_2',
                     '--gear-ratio', '150', '--torque-scale', '10', '--no-progress']) == 0
    summary = json.loads((folder / 's.json').read_text())
    return folder, bag, history, summary


def test_history_exports_the_replayed_levels_for_audit(replayed, capsys):
    folder, _, history, summary = replayed
    levels_csv = folder / 'levels.csv'
    capsys.readouterr()
    assert cli.main(['history', str(history), '--csv', str(levels_csv), '--json']) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown['joint'] == 'joint_2'
    assert len(shown['estimates']) == len(summary['experiments']) == 5
    for stored, replayed_experiment in zip(shown['estimates'], summary['experiments']):
        assert stored['wear'] == pytest.approx(replayed_experiment['wear'], rel=1e-9)
    with levels_csv.open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 5 * len(SPEEDS)
    frictions = [f for e in summary['experiments'] for f in e['frictions']]
    assert [float(r['friction']) for r in rows] == pytest.approx(frictions, rel=1e-12)
    assert len({r['experiment'] for r in rows}) == 5
    table = load_audit_data(levels_csv, model='speed')
    distance = np.abs(table.numeric['speed'][:, None] - np.array(SPEEDS)[None, :])
    assert np.all(distance.min(axis=1) < 1.0)
    assert np.all(np.bincount(distance.argmin(axis=1), minlength=4) == 5)


def test_history_shows_what_the_estimate_reported_with_iso_times(replayed, capsys):
    _, _, history, summary = replayed
    capsys.readouterr()
    assert cli.main(['history', str(history)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith('times UTC')
    assert '95 % interval of w' in lines[1]
    rows = lines[2:2 + len(summary['experiments'])]
    for row, experiment in zip(rows, summary['experiments']):
        when = datetime.datetime.fromtimestamp(experiment['stamp_s'], datetime.timezone.utc)
        assert when.isoformat(timespec='seconds').replace('+00:00', 'Z') in row
        low, high = experiment['wear_interval']
        assert f'[{low:.1f}, {high:.1f}]' in row
        # the std column shows the estimate's own: '-' where it reported none
        std = experiment['wear_std']
        cells = row.split(']')[1].split()
        assert cells[0] == ('-' if std is None else f'{std:.2f}')
    capsys.readouterr()
    assert cli.main(['history', str(history), '--json']) == 0
    shown = json.loads(capsys.readouterr().out)
    assert [e['wear_std'] for e in shown['estimates']] == [
        pytest.approx(e['wear_std']) if e['wear_std'] is not None else None
        for e in summary['experiments']]
    assert all(e['valid'] and e['time'].endswith('Z') for e in shown['estimates'])


@pytest.fixture
def berlin_time(monkeypatch):
    """Local time is Berlin's (UTC+01:00 in January) for this test, then the host's again."""
    # the POSIX form of Europe/Berlin: needs no tz database on the host
    monkeypatch.setenv('TZ', 'CET-1CEST,M3.5.0,M10.5.0/3')
    time.tzset()
    yield datetime.timezone(datetime.timedelta(hours=1))
    monkeypatch.undo()
    time.tzset()


def test_history_local_times_carry_the_offset_and_the_columns_line_up(replayed, capsys,
                                                                      berlin_time):
    _, _, history, summary = replayed
    capsys.readouterr()
    assert cli.main(['history', str(history)]) == 0
    utc = capsys.readouterr().out.splitlines()
    assert cli.main(['history', str(history), '--local']) == 0
    local = capsys.readouterr().out.splitlines()
    assert local[0].endswith('times local')
    header, rows = local[1], local[2:2 + len(summary['experiments'])]
    assert len(rows) == len(summary['experiments']) == 5
    for row, experiment in zip(rows, summary['experiments']):
        when = datetime.datetime.fromtimestamp(experiment['stamp_s'], berlin_time)
        text = when.isoformat(timespec='seconds')
        assert text.endswith('+01:00')
        # the time under its header, the next column right-aligned under its (w)
        assert row.index(text) == header.index(' time ') + 1
        wear = f'{experiment["wear"]:.2f}'
        w_end = header.index(' w ') + 2
        assert row[w_end - len(wear) - 1:w_end] == ' ' + wear
        assert row.index('[') == header.index('95 % interval')
    # from the interval on, each line is the UTC table's: only the time column widened
    for plain, shifted in zip(utc[1:], local[1:]):
        assert shifted[local[1].index('95 %'):] == plain[utc[1].index('95 %'):]
    # every column of every row ends where its header ends (right-aligned numbers)
    for label in ('id', ' w', 'std w', 'T [degC]', 'p-value'):
        end = header.index(label) + len(label)
        assert all(row[end - 1] != ' ' and row[end] == ' ' for row in rows), label


def test_history_escapes_control_characters_in_names(tmp_path, capsys):
    from robot_wear_monitor.history import HistoryRecord, open_history
    path = tmp_path / 'h.sqlite3'
    with open_history(path, robot='r\x1b[2J') as stored:
        stored.append(HistoryRecord(
            joint='j\nfake line', stamp_s=1.0, speeds_rad_s=(2.1,), frictions=(0.1,),
            temperature_degc=40.0, temperature_std_degc=1.0, wear=1.0, wear_std=1.0, chi2=0.0,
            dof=0, p_value=float('nan'), temperature_at_bound=False, wear_at_bound=False,
            alarm_active=False, alarm_evidence=0.0, status_level=0, parameter_set='p'))
    assert cli.main(['history', str(path)]) == 0
    out = capsys.readouterr().out
    assert '\x1b' not in out and 'j\\nfake line' in out and 'r\\x1b[2J' in out


def test_history_bad_input_is_one_line_and_exit_2(replayed, capsys, tmp_path):
    _, _, history, _ = replayed
    assert cli.main(['history', str(tmp_path / 'none.sqlite3')]) == 2
    assert cli.main(['history', str(history), '--joint', 'joint_9']) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 2
    assert "no estimates for joint 'joint_9'" in error[1]


def test_audit_segments_a_simulated_bag_with_gear_ratio_and_torque_scale(replayed):
    _, bag, _, _ = replayed
    table = load_audit_data(bag, model='speed', joint='joint_2', gear_ratio=150.0,
                            torque_scale=10.0)
    speeds = table.numeric['speed']
    truth = read_truth_json(truth_path_for(bag))
    assert speeds.size == 5 * len(SPEEDS)
    for level_speed in speeds:
        assert np.min(np.abs(np.array(SPEEDS) - level_speed)) < 1.0
    true_levels = np.concatenate([np.asarray(t.friction_true, dtype=float)
                                  for t in truth])
    assert np.allclose(np.sort(table.numeric['friction']), np.sort(true_levels), atol=0.01)
