"""
The maintenance decision at its moments: a reset, the triage order, re-escalation.

A reset starts a new life; the triage order with re-escalation; the notifications of both
(``fleet --json``, ``notify --once``).

The fleet of :mod:`wear_testing.fleet_history` (known values) in a real history, read back
through the command line and sent to a real HTTP receiver.
"""

from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
import json
import threading

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN
from robot_wear_monitor.history import AlarmEvent, open_history
from wear_testing.fleet_history import EXPERIMENTS, HOUR_S, make_fleet, record
import yaml

#: the fleet's experiments end an hour apart, the last one hour before NOW_S
NOW_S = 1_790_000_000.0
#: the fields of the old life's state that a reset clears
OLD_LIFE = ('wear', 'wear_low', 'wear_high', 'trend_wear', 'trend_low', 'trend_high',
            'crossing_experiments', 'crossing_time_s', 'alarm_since_s')


@pytest.fixture
def webhook():
    bodies: list = []

    class Handler(BaseHTTPRequestHandler):

        def do_POST(self) -> None:  # noqa: N802 - http.server's name
            bodies.append(json.loads(self.rfile.read(int(self.headers['Content-Length']))))
            self.send_response(200)
            self.send_header('Content-Length', '0')
            self.end_headers()

        def log_message(self, *args) -> None:
            pass

    server = ThreadingHTTPServer(('127.0.0.1', 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    server.bodies = bodies
    server.url = f'http://127.0.0.1:{server.server_address[1]}/hook'
    yield server
    server.shutdown()
    server.server_close()


def _config(tmp_path, webhook, **extra):
    document = {'webhooks': [{'name': 'ops', 'url': webhook.url}],
                'retry': {'attempts': 1, 'passes': 1}, **extra}
    path = tmp_path / 'notifications.yaml'
    path.write_text(yaml.safe_dump(document))
    return path


def _fleet_json(capsys, path, *more):
    capsys.readouterr()
    assert main(['fleet', '--history', str(path), '--now', str(NOW_S), '--json', *more]) == 0
    return json.loads(capsys.readouterr().out)


def _notify(capsys, path, config):
    capsys.readouterr()
    code = main(['notify', '--history', str(path), '--config', str(config), '--once',
                 '--now', str(NOW_S), '--json'])
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def _raise(history, robot, joint, *, k, wear, trend=None):
    """Store experiment k of (robot, joint) raising its alarm at w ``wear``."""
    rec = record(robot, joint, k, now_s=NOW_S)
    trend = wear if trend is None else trend
    rec = rec.__class__(**{**rec.__dict__, 'wear': wear, 'wear_low': wear - 5.0,
                           'wear_high': wear + 5.0, 'trend_wear': trend,
                           'trend_low': trend - 4.0, 'trend_high': trend + 4.0,
                           'stamp_s': NOW_S - HOUR_S + 60.0 * k, 'alarm_active': True})
    history.append(rec, events=[AlarmEvent(joint=joint, robot=robot, stamp_s=rec.stamp_s,
                                           event='raised', wear=wear, note='w-hat >= 35')])


def test_an_unacknowledged_alarm_ranks_above_an_older_acknowledged_one(tmp_path, capsys):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=NOW_S)
    with open_history(path) as history:
        # yesterday's alarm (w 41, the worst) is acknowledged; a newer one, lower, is not
        history.acknowledge_alarm(robot='press_line', joint='joint_2', user='mia',
                                  owner='ben', comment='gear box ordered')
        _raise(history, 'welder_7', 'joint_5', k=EXPERIMENTS, wear=36.0)
    rows = _fleet_json(capsys, path)
    assert [(r['robot'], r['joint'], r['alarm'], r['acknowledged']) for r in rows[:3]] == [
        ('welder_7', 'joint_5', True, False), ('press_line', 'joint_2', True, True),
        ('welder_7', 'joint_3', False, False)]
    assert rows[0]['wear'] < rows[1]['wear']  # the order is the triage's, not the wear's
    assert not rows[1]['reescalated'] and rows[1]['reescalated_reason'] is None


def test_a_reset_starts_a_new_life_and_notifies_resolved_once(tmp_path, capsys, webhook):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=NOW_S)
    config = _config(tmp_path, webhook)
    first = _notify(capsys, path, config)
    raised = [s for s in first if s['kind'] == 'alarm_raised']
    assert [(s['robot'], s['joint']) for s in raised] == [('press_line', 'joint_2')]
    before = _fleet_json(capsys, path)[0]
    assert (before['joint'], before['alarm'], before['crossing_experiments']) == (
        'joint_2', True, 0.0)  # latched, its trend past the threshold
    with open_history(path) as history:
        reset = history.reset_alarm(robot='press_line', joint='joint_2', user='mia',
                                    reason='gearbox replaced')
    rows = _fleet_json(capsys, path)
    [row] = [r for r in rows if (r['robot'], r['joint']) == ('press_line', 'joint_2')]
    assert {key: row[key] for key in OLD_LIFE} == dict.fromkeys(OLD_LIFE)
    assert (row['alarm'], row['acknowledged'], row['stale'], row['status_level'],
            row['valid']) == (False, False, False, 0, True)
    assert (row['life_started_s'], row['reset_by'], row['reset_reason'],
            row['experiments']) == (reset.stamp_s, 'mia', 'gearbox replaced', 0)
    assert rows[-1] == row  # nothing of it to judge yet: last
    # the notifier: the raise resolved (once), and the old life's forecast alert (issue 44:
    # a reset resolves all of the joint's alerts), nothing else of the old life
    webhook.bodies.clear()
    sent = _notify(capsys, path, config)
    assert [(s['kind'], s['joint']) for s in sent if s['robot'] == 'press_line'] == [
        ('alarm_resolved', 'joint_2'), ('forecast_resolved', 'joint_2')]
    [body, forecast] = [b for b in webhook.bodies if b['commonLabels']['robot'] == 'press_line']
    assert (forecast['status'], forecast['commonLabels']['alertname']) == (
        'resolved', 'WearForecastCrossing')
    alert = body['alerts'][0]
    assert (body['status'], alert['status'], alert['labels']['alertname']) == (
        'resolved', 'resolved', 'WearAlarmRaised')
    assert body['groupKey'] == raised[0]['event_key']  # it ends the alert that was sent
    assert 'reset by mia (gearbox replaced)' in alert['annotations']['summary']
    assert alert['endsAt'] != '0001-01-01T00:00:00Z'
    assert _notify(capsys, path, config) == []
    # the new life's first experiment: the joint is judged again, from the new life only
    with open_history(path) as history:
        fresh = record('press_line', 'joint_1', 0, now_s=NOW_S)
        history.append(fresh.__class__(**{**fresh.__dict__, 'joint': 'joint_2',
                                          'stamp_s': NOW_S - 60.0}))
    [row] = [r for r in _fleet_json(capsys, path) if r['joint'] == 'joint_2'
             and r['robot'] == 'press_line']
    assert (row['experiments'], row['wear'], row['alarm']) == (1, fresh.wear, False)
    assert row['life_started_s'] == reset.stamp_s


def test_a_reset_joint_is_stale_from_the_reset_on_by_the_usual_rule(tmp_path, capsys):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=NOW_S)
    with open_history(path) as history:
        reset = history.reset_alarm(robot='press_line', joint='joint_2', user='mia',
                                    reason='gearbox replaced', stamp_s=NOW_S)
    # usual interval 1 h: stale 3 h after the reset, not 3 h after the last experiment
    for hours, stale in ((2.9, False), (3.1, True)):
        capsys.readouterr()
        assert main(['fleet', '--history', path, '--json', '--now',
                     str(reset.stamp_s + hours * HOUR_S)]) == 0
        [row] = [r for r in json.loads(capsys.readouterr().out)
                 if r['joint'] == 'joint_2' and r['robot'] == 'press_line']
        assert row['stale'] is stale


@pytest.mark.parametrize('margin', [None, 3.0])
def test_an_acknowledged_alarm_is_reescalated_when_its_wear_rises_the_margin(
        tmp_path, capsys, webhook, margin):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=NOW_S)
    extra = {} if margin is None else {'reescalation_margin': margin}
    config = _config(tmp_path, webhook, **extra)
    used = DEFAULT_REESCALATION_MARGIN if margin is None else margin
    with open_history(path) as history:
        history.acknowledge_alarm(robot='press_line', joint='joint_2', user='mia',
                                  owner='ben', comment='gear box ordered')
        _raise(history, 'welder_7', 'joint_5', k=EXPERIMENTS, wear=36.0)
        at_ack = history.records(robot='press_line', joint='joint_2')[-1].trend_wear
    _notify(capsys, path, config)
    webhook.bodies.clear()
    option = [] if margin is None else ['--reescalation-margin', str(margin)]
    for rise, expected in ((used - 0.5, False), (used + 0.5, True)):
        with open_history(path) as history:
            rec = record('press_line', 'joint_2', EXPERIMENTS - 1, now_s=NOW_S)
            trend = at_ack + rise
            history.append(rec.__class__(**{**rec.__dict__, 'stamp_s': NOW_S - 30.0 + rise,
                                            'trend_wear': trend, 'wear': trend}))
        rows = _fleet_json(capsys, path, *option)
        assert rows[0]['joint'] == ('joint_2' if expected else 'joint_5')
        [row] = [r for r in rows if (r['robot'], r['joint']) == ('press_line', 'joint_2')]
        assert (row['acknowledged'], row['reescalated']) == (True, expected)
        sent = _notify(capsys, path, config)
        assert [s['kind'] for s in sent] == (['alarm_reescalated'] if expected else [])
    assert f'margin {used:g}' in row['reescalated_reason']
    assert 'trend w rose' in webhook.bodies[0]['alerts'][0]['annotations']['summary']
    assert _notify(capsys, path, config) == []  # once
    # an edit of the acknowledgement (a work order added) moves neither the baseline nor the
    # event: still re-escalated, and not notified again
    with open_history(path) as history:
        history.edit_acknowledgement(robot='press_line', joint='joint_2', user='mia',
                                     owner='ben', comment='gear box ordered',
                                     work_order='WO-17')
    [row] = [r for r in _fleet_json(capsys, path, *option)
             if (r['robot'], r['joint']) == ('press_line', 'joint_2')]
    assert (row['acknowledged'], row['reescalated']) == (True, True)
    assert _notify(capsys, path, config) == []


def test_an_acknowledged_alarm_is_reescalated_when_its_planned_date_passes(
        tmp_path, capsys, webhook):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=NOW_S)
    config = _config(tmp_path, webhook)
    with open_history(path) as history:
        history.acknowledge_alarm(robot='press_line', joint='joint_2', user='mia',
                                  owner='ben', comment='', planned_maintenance='2026-09-20')
        _raise(history, 'welder_7', 'joint_5', k=EXPERIMENTS, wear=36.0)
    # NOW_S is 2026-09-21T13:46:40Z: the planned day is over
    rows = _fleet_json(capsys, path)
    assert (rows[0]['joint'], rows[0]['reescalated']) == ('joint_2', True)
    assert rows[0]['reescalated_reason'] == (
        'the planned maintenance date 2026-09-20 has passed')
    capsys.readouterr()
    assert main(['fleet', '--history', path, '--json', '--now', '2026-09-20T23:00:00Z']) == 0
    rows = json.loads(capsys.readouterr().out)
    assert (rows[1]['joint'], rows[1]['reescalated']) == ('joint_2', False)
    sent = _notify(capsys, path, config)
    assert [s['kind'] for s in sent if s['robot'] == 'press_line'] == [
        'alarm_acknowledged', 'alarm_reescalated']  # the acknowledgement is notified too
