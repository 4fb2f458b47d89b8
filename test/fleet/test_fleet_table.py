"""
``fleet``'s text table (issue 44): it fits the terminal, the plant's clock, JSON in UTC.

Long texts go on a detail line, ``--display-timezone`` shows the plant's clock, ``--wide``
keeps one line per joint.

A history of known stamps: two joints with a latched alarm (one acknowledged with a long
note, a long owner and a work order) and long robot names.
"""

import datetime
import json
import math
import re

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, open_history

HOUR_S = 3600.0
#: the last experiments: 2026-01-15 11:30 UTC (winter, CET = UTC+1) and 2026-07-15 10:30 UTC
#: (summer, CEST = UTC+2): both 12:30 in Stockholm
WINTER_S = datetime.datetime(2026, 1, 15, 11, 30, tzinfo=datetime.timezone.utc).timestamp()
SUMMER_S = datetime.datetime(2026, 7, 15, 10, 30, tzinfo=datetime.timezone.utc).timestamp()
LONG_ROBOT = 'stamping_press_line_north_hall_building_7_cell_12_robot_3_left_arm_spare'
OTHER_ROBOT = 'welding_cell_south_hall_building_2_line_4_robot_11_main_arm'
NOTE = ('gearbox noise heard by the night shift at every start of the press cycle; the '
        'spare gearbox is ordered from the supplier in Gothenburg and arrives on Tuesday, '
        'the replacement needs the crane of hall 7 and two fitters for a full shift') * 2
OWNER = 'Maintenance team D of the north hall (fitters Anna Lindqvist and Bo Svensson)'


def _record(robot, joint, stamp_s, *, wear, alarm):
    return HistoryRecord(joint=joint, robot=robot, stamp_s=stamp_s, speeds_rad_s=(12.0, 28.5),
                         frictions=(0.08, 0.09), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=3.0, chi2=1.0, dof=1,
                         p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=alarm, alarm_evidence=0.0, status_level=0,
                         parameter_set='abb_irb6620_joint2', wear_low=wear - 8.0,
                         wear_high=wear + 8.0, trend_wear=wear, trend_low=wear - 8.0,
                         trend_high=wear + 8.0, crossing_experiments=math.nan,
                         threshold=35.0, warning_level=28.0)


@pytest.fixture()
def history(tmp_path) -> str:
    path = str(tmp_path / 'plant.sqlite3')
    with open_history(path) as stored:
        for robot, joint, last, wear in ((LONG_ROBOT, 'joint_2', WINTER_S, 41.0),
                                         (OTHER_ROBOT, 'joint_5', SUMMER_S, 12.0)):
            for k in range(4):
                stamp = last - (3 - k) * HOUR_S
                alarm = wear > 35.0 and k == 3
                stored.append(_record(robot, joint, stamp, wear=wear, alarm=alarm),
                              events=[AlarmEvent(joint=joint, robot=robot, stamp_s=stamp,
                                                 event='raised', wear=wear)] if alarm else [])
        stored.acknowledge_alarm(joint='joint_2', robot=LONG_ROBOT, user='ana', owner=OWNER,
                                 comment=NOTE, work_order='WO-2026-000417-GEARBOX')
    return path


def _run(capsys, *argv):
    capsys.readouterr()
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def _column(lines, header, name):
    """Return the text of column ``name`` of a row's lines (its cells wrapped in it)."""
    start = header.index(name)
    end = min((header.index(h) for h in re.findall(r'\S+', header) if header.index(h) > start),
              default=None)
    return ''.join(line[start:end].strip() for line in lines)


@pytest.mark.parametrize('columns', [80, 100, 132])
def test_no_line_is_wider_than_the_terminal_and_every_value_is_there(history, capsys,
                                                                     monkeypatch, columns):
    monkeypatch.setenv('COLUMNS', str(columns))
    code, out, err = _run(capsys, 'fleet', '--history', history, '--now', str(SUMMER_S))
    assert code == 0, err
    lines = out.splitlines()
    assert max(len(line) for line in lines) <= columns, max(lines, key=len)
    header = lines[1]
    assert header.startswith('robot')
    first = next(i for i, line in enumerate(lines) if line.startswith(LONG_ROBOT[:6]))
    # the first row (the acknowledged alarm): its lines up to the detail line
    row = []
    for line in lines[first:]:
        if line.startswith('    '):
            break
        row.append(line)
    assert _column(row, header, 'robot') == LONG_ROBOT
    assert _column(row, header, 'state') == 'ACKNOWLEDGED'
    flat = ' '.join(out.split())
    for text in (NOTE, OWNER, 'WO-2026-000417-GEARBOX', 'acknowledged by ana'):
        assert ' '.join(text.split()) in flat
    # the second robot's name, whole in its column
    second = [line for line in lines[first:] if not line.startswith('    ')][len(row):]
    assert _column(second, header, 'robot') == OTHER_ROBOT


def test_a_terminal_narrower_than_80_gets_80(history, capsys, monkeypatch):
    monkeypatch.setenv('COLUMNS', '40')
    code, out, _ = _run(capsys, 'fleet', '--history', history, '--now', str(SUMMER_S))
    assert code == 0 and max(len(line) for line in out.splitlines()) <= 80


def test_wide_is_one_line_per_joint_with_every_text(history, capsys, monkeypatch):
    monkeypatch.setenv('COLUMNS', '100')
    code, out, _ = _run(capsys, 'fleet', '--history', history, '--now', str(SUMMER_S),
                        '--wide')
    lines = out.splitlines()
    assert code == 0 and len(lines) == 4  # the summary, the header, two joints
    assert LONG_ROBOT in lines[2] and NOTE.strip()[:100] in lines[2]
    assert 'WO-2026-000417-GEARBOX' in lines[2] and OTHER_ROBOT in lines[3]


def test_times_in_the_plants_zone_winter_and_summer_json_unchanged(history, capsys,
                                                                   monkeypatch):
    monkeypatch.setenv('COLUMNS', '100')
    base = ('fleet', '--history', history, '--now', str(SUMMER_S))
    code, out, _ = _run(capsys, *base)
    assert code == 0
    assert '2026-01-15T11:30:00Z' in out and '2026-07-15T10:30:00Z' in out  # UTC by default
    code, out, err = _run(capsys, *base, '--display-timezone', 'Europe/Stockholm')
    assert code == 0, err
    flat = ' '.join(out.split())
    # the same 12:30 on the plant's clock: CET in winter, CEST in summer
    assert '2026-01-15 12:30 CET' in flat and '2026-07-15 12:30 CEST' in flat
    assert 'LATCHED since 2026-01-15 12:30 CET' in flat
    assert 'T11:30:00Z' not in out and 'T10:30:00Z' not in out
    # machine outputs stay UTC: the JSON is the same whatever the zone
    code, plain, _ = _run(capsys, *base, '--json')
    code, zoned, _ = _run(capsys, *base, '--json', '--display-timezone', 'Europe/Stockholm')
    assert json.loads(zoned) == json.loads(plain)
    assert {r['last_stamp_s'] for r in json.loads(plain)} == {WINTER_S, SUMMER_S}


def test_a_bad_zone_is_a_clear_error(history, capsys):
    code, out, err = _run(capsys, 'fleet', '--history', history, '--display-timezone',
                          'Europe/Stokholm\x1b[31m')
    assert code == 2 and out == ''
    assert '--display-timezone' in err and 'not an IANA time zone name' in err
    assert "'Europe/Stokholm\\x1b[31m'" in err and '\x1b' not in err
    code, _, err = _run(capsys, 'fleet', '--history', history, '--local',
                        '--display-timezone', 'Europe/Stockholm')
    assert code == 2 and 'not both' in err
