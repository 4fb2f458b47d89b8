"""``history --alarms``: the fleet's alarm log for audits (text, CSV, JSON), names escaped."""

import csv
import io
import json

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.cli.history import ALARM_LOG_COLUMNS
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory
from robot_wear_monitor.text import iso_time

#: the experiments' stamps, in the past: the alarm log orders a raise by its experiment's time
#: and an acknowledgement or a reset by its wall time (now)
T0_S = 1.7e9
#: a joint name from a hostile recording: an escape sequence and a forged line
HOSTILE_JOINT = 'j\x1b[31m\nFORGED LINE'


def _record(robot, joint, k, *, wear):
    return HistoryRecord(joint=joint, stamp_s=T0_S + 3600.0 * k, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=3.0, chi2=1.0, dof=0,
                         p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=wear >= 35.0, alarm_evidence=0.0, status_level=0,
                         parameter_set='p', robot=robot)


@pytest.fixture
def history_path(tmp_path):
    path = tmp_path / 'fleet.sqlite3'
    with WearHistory(path) as history:
        for k, (robot, joint, wear) in enumerate((('r1', 'joint_2', 40.0),
                                                  ('r2', HOSTILE_JOINT, 50.0))):
            history.append(_record(robot, joint, k, wear=wear),
                           events=[AlarmEvent(joint=joint, stamp_s=T0_S + 3600.0 * k,
                                              event='raised', wear=wear, robot=robot,
                                              note='w above the threshold')])
        history.acknowledge_alarm(joint=HOSTILE_JOINT, robot='r2', user='ana', owner='ben',
                                  comment='order, "gear" box', planned_maintenance='2026-12-01',
                                  work_order='WO-9')
        history.reset_alarm(joint='joint_2', robot='r1', user='cy', reason='gear replaced',
                            stamp_s=T0_S + 7200.0)
    return path


def _run(capsys, *args):
    capsys.readouterr()
    code = main(['history', *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_alarm_log_as_json_is_newest_first_with_who_and_why(history_path, capsys):
    code, out, _ = _run(capsys, history_path, '--alarms', '--json')
    assert code == 0
    rows = json.loads(out)['alarms']
    assert [(r['robot'], r['joint'], r['event'], r['user']) for r in rows] == [
        ('r1', 'joint_2', 'reset', 'cy'), ('r2', HOSTILE_JOINT, 'acknowledged', 'ana'),
        ('r2', HOSTILE_JOINT, 'raised', ''), ('r1', 'joint_2', 'raised', '')]
    assert all(set(ALARM_LOG_COLUMNS) <= set(r) for r in rows)
    assert rows[0]['time'] == iso_time(rows[0]['wall_time_s']) and rows[0]['time'].endswith('Z')
    assert rows[0]['event_time_s'] == rows[0]['wall_time_s'] and rows[0]['stamp_s'] == \
        T0_S + 7200.0
    assert rows[0]['note'] == 'gear replaced' and rows[0]['wear'] is None
    assert (rows[1]['owner'], rows[1]['planned_maintenance'], rows[1]['work_order']) == (
        'ben', '2026-12-01', 'WO-9')
    assert rows[0]['work_order'] == ''
    assert rows[3]['wear'] == 40.0 and rows[3]['time'] == '2023-11-14T22:13:20Z'
    code, out, _ = _run(capsys, history_path, '--alarms', '--json', '--robot', 'r2')
    assert [r['event'] for r in json.loads(out)['alarms']] == ['acknowledged', 'raised']
    code, out, _ = _run(capsys, history_path, '--alarms', '--json', '--joint', 'joint_2',
                        '--last', '1')
    assert [r['event'] for r in json.loads(out)['alarms']] == ['reset']


def test_the_alarm_log_as_csv_on_stdout_and_to_a_file(history_path, tmp_path, capsys):
    code, out, _ = _run(capsys, history_path, '--alarms', '--csv')
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert tuple(rows[0]) == ALARM_LOG_COLUMNS
    assert [r['event'] for r in rows] == ['reset', 'acknowledged', 'raised', 'raised']
    assert rows[1]['joint'] == HOSTILE_JOINT  # CSV quotes it; the text is kept as stored
    assert rows[1]['note'] == 'order, "gear" box' and rows[1]['planned_maintenance'] == \
        '2026-12-01'
    assert ALARM_LOG_COLUMNS[-3:] == ('work_order', 'source', 'changes')
    assert rows[1]['work_order'] == 'WO-9'
    assert rows[0]['wear'] == '' and float(rows[2]['wear']) == 50.0
    ids = [int(r['id']) for r in rows]
    assert ids == sorted(ids, reverse=True)
    target = tmp_path / 'audit' / 'alarms.csv'
    target.parent.mkdir()
    code, out, _ = _run(capsys, history_path, '--alarms', '--csv', target)
    assert code == 0 and out.strip() == f'4 alarm events written to {target}'
    with target.open(newline='') as stream:
        assert list(csv.DictReader(stream)) == rows


def test_the_alarm_log_table_escapes_control_characters(history_path, capsys):
    code, out, _ = _run(capsys, history_path, '--alarms')
    assert code == 0
    lines = out.splitlines()
    assert lines[0] == '4 alarm event(s), newest first; times UTC'
    assert lines[1].split() == ['id', 'time', 'robot', 'joint', 'event', 'wear', 'user',
                                'owner', 'planned', 'work_order', 'note']
    assert len(lines) == 2 + 4  # the newline in the joint's name forged no line
    assert '\x1b' not in out and not any(line.startswith('FORGED') for line in lines)
    assert '\\x1b[31m\\nFORGED LINE' in lines[3]
    assert 'acknowledged' in lines[3] and '2026-12-01' in lines[3] and 'ana' in lines[3]
    assert 'WO-9' in lines[3]
    assert 'gear replaced' in lines[2] and 'cy' in lines[2]


def test_bad_alarm_log_options_are_one_line_errors(history_path, tmp_path, capsys):
    code, _, err = _run(capsys, history_path, '--alarms', '--csv', '--json')
    assert code == 2 and '--csv or --json, not both' in err
    code, _, err = _run(capsys, history_path, '--csv')  # the levels need a file
    assert code == 2 and '--csv needs the file to write the levels to' in err
    code, _, err = _run(capsys, tmp_path / 'missing.db', '--alarms')
    assert code == 2 and 'no such wear history database' in err
    code, out, _ = _run(capsys, history_path, '--alarms', '--robot', 'nobody')
    assert code == 0 and out.splitlines() == [
        '0 alarm event(s), newest first; times UTC',
        'id  time  robot  joint  event  wear  user  owner  planned  work_order  note']


@pytest.mark.parametrize('start', ['=', '+', '-', '@', '\uff1d', '\uff0b', '\uff0d', '\uff20'])
def test_csv_exports_of_the_command_line_carry_no_live_formula(tmp_path, capsys, start):
    # a robot, a user, an owner and a comment that a spreadsheet would run as formulas
    formula = start + 'HYPERLINK("http://attacker.invalid","click")'
    path = tmp_path / 'hostile.sqlite3'
    with WearHistory(path) as history:
        history.append(_record(formula, 'joint_2', 0, wear=40.0),
                       events=[AlarmEvent(joint='joint_2', stamp_s=T0_S, event='raised',
                                          wear=40.0, robot=formula, note=formula)])
        history.acknowledge_alarm(joint='joint_2', robot=formula, user=formula, owner=formula,
                                  comment=formula, planned_maintenance='2026-12-01')
    alarms_csv, fleet_csv = tmp_path / 'alarms.csv', tmp_path / 'fleet.csv'
    assert _run(capsys, path, '--alarms', '--csv', alarms_csv)[0] == 0
    assert main(['fleet', '--history', str(path), '--csv', str(fleet_csv)]) == 0
    for written in (alarms_csv, fleet_csv):
        rows = list(csv.DictReader(io.StringIO(written.read_text(encoding='utf-8'))))
        assert rows
        cells = [cell for row in rows for cell in row.values() if cell]
        # every text cell that held the formula is neutralised by a leading apostrophe
        assert not [cell for cell in cells if cell[:1] == start], written.name
        assert ("'" + formula) in cells, written.name
    # numbers stay numbers: the wear is written as a number, not as text
    fleet_row = next(csv.DictReader(io.StringIO(fleet_csv.read_text(encoding='utf-8'))))
    assert float(fleet_row['wear']) == pytest.approx(40.0)
    alarm_rows = list(csv.DictReader(io.StringIO(alarms_csv.read_text(encoding='utf-8'))))
    assert {float(r['wear']) for r in alarm_rows if r['wear']} == {40.0}


def test_the_text_shows_the_plants_clock_and_the_json_stays_utc(history_path, capsys):
    # the raise of r1 joint_2 at 2023-11-14T22:13:20Z is 23:13 CET in Stockholm (winter)
    code, out, err = _run(capsys, history_path, '--alarms', '--display-timezone',
                          'Europe/Stockholm')
    assert code == 0, err
    assert out.splitlines()[0].endswith('times Europe/Stockholm')
    raised = next(line for line in out.splitlines() if 'raised' in line and 'joint_2' in line)
    assert raised.split()[1:4] == ['2023-11-14', '23:13', 'CET'], raised
    assert 'Z ' not in out
    code, plain, _ = _run(capsys, history_path, '--alarms', '--json')
    code, zoned, _ = _run(capsys, history_path, '--alarms', '--json', '--display-timezone',
                          'Europe/Stockholm')
    assert json.loads(zoned) == json.loads(plain)
    # the estimates of a joint too
    code, out, _ = _run(capsys, history_path, '--robot', 'r1', '--joint', 'joint_2',
                        '--display-timezone', 'Asia/Kolkata')
    assert code == 0 and '2023-11-15 03:43 IST' in out
