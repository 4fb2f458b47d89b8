"""The fleet view: worst first, stale joints, crossing dates, table/CSV/JSON without 'nan'."""

import json
import math

import pytest
from robot_wear_monitor.fleet.fleet_table import fleet_table
from robot_wear_monitor.fleet.ranking import fleet_csv_rows, fleet_view, STALE_FACTOR
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory
from robot_wear_monitor.text import iso_time

HOUR_S = 3600.0
T0_S = 1.75e9


def _record(robot, joint, k, *, wear, low, high, crossing=math.nan, interval_s=HOUR_S):
    return HistoryRecord(joint=joint, stamp_s=T0_S + k * interval_s, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=math.nan, chi2=1.0,
                         dof=0, p_value=math.nan, temperature_at_bound=False,
                         wear_at_bound=False, alarm_active=False, alarm_evidence=0.0,
                         status_level=0, parameter_set='p', robot=robot, wear_low=low,
                         wear_high=high, trend_wear=wear, trend_low=low, trend_high=high,
                         crossing_experiments=crossing)


def _fleet(tmp_path):
    """Five joints whose order is known: alarm, crossing in 3, in 8, highest bound, lowest."""
    history = WearHistory(tmp_path / 'fleet.sqlite3')
    plan = {  # (robot, joint): (wear, low, high, crossing)
        ('r1', 'j1'): (20.0, 10.0, 30.0, math.nan),
        ('r1', 'j2'): (30.0, 22.0, 38.0, 8.0),
        ('r2', 'j1'): (25.0, 15.0, 45.0, math.nan),
        ('r2', 'j2'): (33.0, 28.0, 40.0, 3.0),
        ('r3', 'j1'): (38.0, 30.0, 46.0, math.nan),
    }
    for (robot, joint), (wear, low, high, crossing) in plan.items():
        for k in range(4):
            history.append(_record(robot, joint, k, wear=wear, low=low, high=high,
                                   crossing=crossing))
    history.record_event(AlarmEvent(joint='j1', stamp_s=T0_S + 3 * HOUR_S, event='raised',
                                    wear=38.0, robot='r3'))
    return history


def test_worst_first_alarm_then_crossing_then_upper_bound(tmp_path):
    with _fleet(tmp_path) as history:
        rows = fleet_view(history.fleet(), now_s=T0_S + 4 * HOUR_S)
    assert [(r.state.robot, r.state.joint) for r in rows] == [
        ('r3', 'j1'), ('r2', 'j2'), ('r1', 'j2'), ('r2', 'j1'), ('r1', 'j1')]
    assert rows[0].state.alarm and not any(r.state.alarm for r in rows[1:])
    assert not any(r.stale for r in rows)
    # crossing in 3 experiments an hour apart, after the last experiment
    assert rows[1].crossing_time_s == T0_S + 3 * HOUR_S + 3 * HOUR_S
    assert rows[3].crossing_time_s is None


def test_a_joint_is_stale_past_its_usual_interval(tmp_path):
    with _fleet(tmp_path) as history:
        last = T0_S + 3 * HOUR_S
        fresh = fleet_view(history.fleet(), now_s=last + STALE_FACTOR * HOUR_S - 1)
        late = fleet_view(history.fleet(), now_s=last + STALE_FACTOR * HOUR_S + 1)
    assert not any(r.stale for r in fresh)
    assert all(r.stale for r in late)


def test_json_csv_and_table_say_it_without_nan(tmp_path):
    with _fleet(tmp_path) as history:
        rows = fleet_view(history.fleet(robot='r1'), now_s=T0_S + 4 * HOUR_S)
    payload = json.loads(json.dumps([r.as_json() for r in rows], allow_nan=False))
    assert [p['joint'] for p in payload] == ['j2', 'j1']
    for key in ('robot', 'joint', 'wear', 'wear_low', 'wear_high', 'alarm', 'experiments',
                'last_stamp_s', 'crossing_experiments', 'stale'):
        assert key in payload[0]
    assert payload[1]['crossing_experiments'] is None
    assert payload[0]['experiments'] == 4
    table = fleet_table(rows)
    csv_rows = fleet_csv_rows(rows)
    # the rows (the header's planned_mainte-nan-ce is a word)
    for text in (table, '\n'.join(','.join(r) for r in csv_rows[1:])):
        assert 'nan' not in text.lower() and 'inf' not in text.lower().replace('info', '')
    assert 'not within the forecast horizon' in table
    assert 'in 8 experiments' in table
    assert iso_time(T0_S + 3 * HOUR_S) in table


def test_iso_time_is_utc_with_z():
    assert iso_time(0.0) == '1970-01-01T00:00:00Z'
    assert iso_time(math.nan) == '-'


def test_an_outage_does_not_stretch_the_usual_interval(tmp_path):
    """Hourly experiments, a nine-day outage, hourly again: the usual interval stays 1 h."""
    from robot_wear_monitor.history import open_history
    stamps = [T0_S + k * HOUR_S for k in range(10)]
    stamps += [stamps[-1] + 9 * 86400.0 + k * HOUR_S for k in range(6)]
    with open_history(tmp_path / 'outage.sqlite3', robot='r1') as history:
        for k, stamp in enumerate(stamps):
            history.append(HistoryRecord(
                joint='j1', stamp_s=stamp, speeds_rad_s=(10.0,), frictions=(0.1,),
                temperature_degc=40.0, temperature_std_degc=1.0, wear=20.0, wear_std=2.0,
                chi2=1.0, dof=1, p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                alarm_active=False, alarm_evidence=0.0, status_level=0, parameter_set='p',
                trend_wear=20.0, crossing_experiments=100.0))
        [row] = history.fleet()
    mean = (stamps[-1] - stamps[0]) / (len(stamps) - 1)
    assert mean > 14 * HOUR_S  # the mean the outage stretched
    assert row.usual_interval_s == pytest.approx(HOUR_S)
    [view] = fleet_view([row], now_s=stamps[-1] + 3.5 * HOUR_S)
    assert view.stale  # 3 usual intervals of an hour, not of 14
    assert view.crossing_time_s == pytest.approx(stamps[-1] + 100 * HOUR_S)
    assert view.as_json()['usual_interval_basis'].startswith('median of the last 15 intervals')
