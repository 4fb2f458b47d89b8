"""
The dashboard's server with FastAPI's TestClient: API vs the history, roles, CSRF, limits.

The history is written with known values (fleet_history.py); the API must tell what the history
holds, in the order of ``fleet``; a viewer may not change anything; every POST needs the CSRF
token; failed logins are limited per user and per address; names are escaped in the HTML.
"""

import csv
from dataclasses import replace
from html import escape as html_escape, unescape as html_unescape
import io
import math
from pathlib import Path
import re
import time

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.auth import LoginLimiter
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.fleet.ranking import fleet_view
from robot_wear_monitor.history import AlarmEvent, open_history
from wear_testing.fleet_history import (csrf_of, EXPERIMENTS, login, make_fleet, ORDER,
                                        PASSWORDS, PLAN, record, wear_of, XSS_ROBOT)


@pytest.fixture()
def history(tmp_path) -> str:
    return make_fleet(str(tmp_path / 'fleet.sqlite3'))


@pytest.fixture()
def app(history):
    return create_app(DashboardSettings(history=history, max_failures=3, window_s=600.0))


@pytest.fixture()
def client(app):
    with fastapi_testclient.TestClient(app) as test_client:
        yield test_client


def _as(client, name):
    assert login(client, name).status_code == 303
    return client


def test_nothing_but_the_login_answers_without_a_session(client):
    for path in ('/', '/alarms', '/docs', joint_url('welder_7', 'joint_3'),
                 '/vendor/plotly.min.js', '/static/fleet.js'):
        response = client.get(path, follow_redirects=False)
        assert response.status_code == 303, path
        assert response.headers['location'].startswith('/login?next=')
    for path in ('/api/fleet', '/api/alarms', '/openapi.json', '/alarms.csv',
                 '/api' + joint_url('welder_7', 'joint_3')):
        assert client.get(path).status_code == 401, path
    assert client.get('/login').status_code == 200
    assert client.get('/static/dashboard.css').status_code == 200
    # a POST without a session changes nothing
    assert client.post(joint_url('press_line', 'joint_2') + '/reset',
                       data={'reason': 'x'}).status_code == 401


def test_session_cookie_is_httponly_and_samesite_strict(client):
    response = login(client, 'vic')
    cookie = response.headers['set-cookie'].lower()
    assert 'httponly' in cookie and 'samesite=strict' in cookie
    assert response.headers['location'] == '/'
    assert "script-src 'self'" in client.get('/').headers['content-security-policy']


def test_fleet_api_tells_the_history_in_the_order_of_fleet(client, history):
    _as(client, 'vic')
    payload = client.get('/api/fleet').json()
    with open_history(history, init=False) as stored:
        truth = fleet_view(stored.fleet(), now_s=time.time())
    assert [(r['robot'], r['joint']) for r in payload['rows']] == ORDER
    assert [(v.state.robot, v.state.joint) for v in truth] == ORDER
    for row in payload['rows']:
        final, half, crossing, _ = PLAN[(row['robot'], row['joint'])]
        assert row['wear'] == pytest.approx(final)
        assert row['wear_high'] == pytest.approx(final + half)
        assert row['experiments'] == EXPERIMENTS
        assert row['alarm'] == (final > 35.0)
        assert row['crossing_experiments'] == (None if math.isnan(crossing) else crossing)
    # warnings: welder_7 joint_3 (w-hat 30 >= the set's warning level 28) and the XSS robot's
    # joint_1 (crossing in 12 experiments of an hour: within the 30-day horizon)
    assert payload['counts'] == {'alarm': 1, 'acknowledged': 0, 'cannot judge': 0,
                                 'stale': 0, 'warning': 2, 'new life': 0, 'ok': 2}
    assert sorted(payload['robots']) == sorted({r for r, _ in PLAN})
    only = client.get('/api/fleet', params={'robot': 'welder_7'}).json()['rows']
    assert [(r['robot'], r['joint']) for r in only] == [
        ('welder_7', 'joint_3'), ('welder_7', 'joint_5')]
    alarms = client.get('/api/fleet', params={'state': 'alarm'}).json()['rows']
    assert [(r['robot'], r['joint']) for r in alarms] == [('press_line', 'joint_2')]
    assert client.get('/api/fleet', params={'state': 'bogus'}).status_code == 422


def test_fleet_page_lists_the_rows_worst_first(client):
    _as(client, 'vic')
    html = client.get('/').text
    robots = re.findall(r'<tr class="state-[^"]*" data-robot="([^"]*)" data-joint="([^"]*)"',
                        html)
    escaped = [(r.replace('<', '&lt;').replace('>', '&gt;'), j) for r, j in ORDER]
    assert robots == escaped


#: Joints added to the plan's fleet so that every state shows: (robot, joint): (the plan's joint
#: copied, its state).  palletiser_9's joint_4 has had no experiment for ten hours (stale).
MORE = {('press_line', 'joint_6'): (('press_line', 'joint_2'), 'acknowledged'),
        ('palletiser_9', 'joint_4'): (('press_line', 'joint_1'), 'stale'),
        ('palletiser_9', 'joint_6'): (('welder_7', 'joint_5'), 'cannot judge')}
ROW = re.compile(r'<tr class="state-([^" ]*)( stale)?" data-robot="([^"]*)" data-joint="([^"]*)"')


def _more_states(history: str) -> dict[tuple[str, str], str]:
    """Add :data:`MORE` to the plan's history; return the state of every joint."""
    now_s = time.time()
    with open_history(history) as stored:
        for (robot, joint), ((plan_robot, plan_joint), state) in MORE.items():
            for k in range(EXPERIMENTS):
                rec = replace(record(plan_robot, plan_joint, k, now_s=now_s - 10 * 3600.0
                                     if state == 'stale' else now_s), robot=robot, joint=joint)
                if state == 'cannot judge' and k == EXPERIMENTS - 1:
                    rec = replace(rec, invalid_reason='temperature 38 degC outside the model')
                events = ()
                if rec.alarm_active:
                    events = (AlarmEvent(joint=joint, robot=robot, stamp_s=rec.stamp_s,
                                         event='raised', wear=rec.wear, note='w-hat >= 35'),)
                stored.append(rec, events=events)
        stored.acknowledge_alarm(joint='joint_6', robot='press_line', user='mia',
                                 owner='Team B', comment='gearbox ordered')
    # w-hat >= the set's warning level 28, or a crossing within the 30-day horizon: warning
    states = {key: 'alarm' if PLAN[key][0] > 35.0 else 'warning'
              if PLAN[key][0] >= 28.0 or PLAN[key][2] > 0 else 'ok' for key in PLAN}
    states.update({key: state for key, (_, state) in MORE.items()})
    return states


def _fleet_rows(html: str) -> list[tuple[str, str, str]]:
    """Return the fleet page's rows as (robot, joint, state), names unescaped."""
    return [(robot.replace('&lt;', '<').replace('&gt;', '>'), joint, state.replace('-', ' '))
            for state, _, robot, joint in ROW.findall(html)]


def _counts(html: str) -> dict[str, int]:
    """Return the counts per state at the top of the fleet page."""
    return {state: int(count) for state, count in re.findall(
        r'<span class="count" data-state="([^"]*)">(\d+)</span>', html)}


def test_fleet_page_filters_by_robot_and_by_state(client, history):
    states = _more_states(history)
    _as(client, 'vic')
    everything = _fleet_rows(client.get('/').text)
    assert sorted(everything) == sorted((r, j, s) for (r, j), s in states.items())
    assert {s for _, _, s in everything} == {'alarm', 'acknowledged', 'cannot judge',
                                             'stale', 'warning', 'ok'}
    whole = {'alarm': 1, 'acknowledged': 1, 'cannot judge': 1, 'stale': 1, 'warning': 2,
             'new life': 0, 'ok': 2}
    assert _counts(client.get('/').text) == whole
    robots = sorted({r for r, _ in states})
    assert len(robots) == 4
    for robot in robots:
        html = client.get('/', params={'robot': robot}).text
        rows = _fleet_rows(html)
        # only that robot's rows, all of them, in the order of the whole fleet
        assert rows == [row for row in everything if row[0] == robot], robot
        assert rows and _counts(html) == whole, robot  # the counts are the whole fleet's
        # the robot filter is a search box holding the robot (escaped), not a list of robots
        assert f'list="robot-choices" value="{html_escape(robot)}"' in html, robot
        assert '<option' not in html.split('id="robot-choices"')[1].split('</datalist>')[0]
    for state, count in whole.items():
        html = client.get('/', params={'state': state}).text
        rows = _fleet_rows(html)
        assert rows == [row for row in everything if row[2] == state], state
        assert len(rows) == count, state
        assert _counts(html) == whole, state
    both = _fleet_rows(client.get('/', params={'robot': 'palletiser_9', 'state': 'stale'}).text)
    assert both == [('palletiser_9', 'joint_4', 'stale')]
    none = client.get('/', params={'robot': 'welder_7', 'state': 'acknowledged'}).text
    assert _fleet_rows(none) == [] and 'match the filter' in none
    # an unknown state filters nothing; an unknown robot shows no row
    assert _fleet_rows(client.get('/', params={'state': 'bogus'}).text) == everything
    assert _fleet_rows(client.get('/', params={'robot': 'nobody'}).text) == []


def test_joint_api_tells_every_experiment_of_the_joint(client, history):
    _as(client, 'vic')
    payload = client.get('/api' + joint_url('welder_7', 'joint_5')).json()
    with open_history(history, init=False) as stored:
        records = stored.records(joint='joint_5', robot='welder_7')
    assert [e['id'] for e in payload['experiments']] == [r.id for r in records]
    assert [e['wear'] for e in payload['experiments']] == [
        pytest.approx(wear_of(18.0, k)) for k in range(EXPERIMENTS)]
    assert [e['temperature_degc'] for e in payload['experiments']] == [
        pytest.approx(38.0 + k) for k in range(EXPERIMENTS)]
    # p = 0.002 on the last experiment: its model check fails, the others pass
    assert [e['model_check_failed'] for e in payload['experiments']] == \
        [False] * (EXPERIMENTS - 1) + [True]
    assert payload['threshold'] == 35.0 and payload['model_note'] is None
    assert len(payload['friction']) == 5
    assert payload['friction'][-1]['speeds_rad_s'] == [12.0, 28.5, 41.7]
    assert client.get('/api' + joint_url('welder_7', 'nope')).status_code == 404


def test_forecast_cone_meets_the_threshold_at_the_stored_crossing(client):
    _as(client, 'vic')
    payload = client.get('/api' + joint_url('welder_7', 'joint_3')).json()
    cone = payload['forecast']
    last = payload['experiments'][-1]
    spacing = 3600.0
    assert cone['crossing_experiments'] == 4.0
    assert cone['crossing_time_s'] == pytest.approx(last['stamp_s'] + 4 * spacing)
    # the band's upper edge reaches the threshold earlier, the lower one later
    assert cone['crossing_low_experiments'] < 4.0 < cone['crossing_high_experiments']
    assert max(cone['wear']) == pytest.approx(35.0)


def test_unknown_parameter_set_falls_back_and_says_so(client, history):
    with open_history(history) as stored:
        stored.append(replace(record('welder_7', 'joint_5', 0, now_s=time.time()),
                              joint='joint_9', parameter_set='my_own_set'))
    _as(client, 'vic')
    payload = client.get('/api' + joint_url('welder_7', 'joint_9')).json()
    assert "'my_own_set' is not known here" in payload['model_note']
    assert payload['friction'][0]['model_frictions'] is not None
    assert 'is not known here' in client.get(joint_url('welder_7', 'joint_9')).text


def test_etag_gives_304_until_the_history_changes(client, history):
    _as(client, 'vic')
    first = client.get('/api/fleet')
    tag = first.headers['etag']
    assert client.get('/api/fleet', headers={'If-None-Match': tag}).status_code == 304
    with open_history(history) as stored:
        stored.append(record('welder_7', 'joint_3', EXPERIMENTS, now_s=time.time() + 3600.0))
    changed = client.get('/api/fleet', headers={'If-None-Match': tag})
    assert changed.status_code == 200
    row = next(r for r in changed.json()['rows'] if r['joint'] == 'joint_3')
    assert row['experiments'] == EXPERIMENTS + 1


def test_login_is_rate_limited_per_user(client):
    for _ in range(3):
        assert login(client, 'mia', 'wrong password').status_code == 401
    refused = login(client, 'mia')  # the right password, too late
    assert refused.status_code == 429 and 'Retry-After' in refused.headers
    assert 'too many failed logins' in refused.text


def test_login_is_rate_limited_per_address():
    limiter = LoginLimiter(max_failures=2, window_s=60.0, clock=lambda: 100.0)
    limiter.failed(user='a', address='10.0.0.1')
    limiter.failed(user='b', address='10.0.0.1')
    assert limiter.retry_after_s(user='c', address='10.0.0.1') == pytest.approx(60.0)
    assert limiter.retry_after_s(user='c', address='10.0.0.2') == 0.0
    now = [100.0]
    later = LoginLimiter(max_failures=1, window_s=60.0, clock=lambda: now[0])
    later.failed(user='a', address='x')
    now[0] = 161.0
    assert later.retry_after_s(user='a', address='x') == 0.0


def test_many_users_from_one_address_are_limited(client):
    for name in ('ann', 'bob', 'cid'):
        assert login(client, name, 'wrong password 1').status_code == 401
    assert login(client, 'vic').status_code == 429


def test_post_without_csrf_token_is_refused(client, history):
    token = csrf_of(client.get('/login').text)
    no_token = client.post('/login', data={'username': 'mia', 'password': PASSWORDS['mia']},
                           follow_redirects=False)
    assert no_token.status_code == 403
    wrong = client.post('/login', data={'username': 'mia', 'password': PASSWORDS['mia'],
                                        'csrf_token': token + 'x'}, follow_redirects=False)
    assert wrong.status_code == 403
    _as(client, 'mia')
    url = joint_url('press_line', 'joint_2')
    assert client.post(url + '/reset', data={'reason': 'new gearbox'}).status_code == 403
    assert client.post(url + '/acknowledge', data={'owner': 'x', 'comment': 'y'}
                       ).status_code == 403
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active


def test_viewer_cannot_reset_or_acknowledge(client, history):
    _as(client, 'vic')
    url = joint_url('press_line', 'joint_2')
    page = client.get(url).text
    assert 'reset-form' not in page and 'acknowledge-form' not in page
    token = csrf_of(page)
    assert client.post(url + '/reset', data={'reason': 'new gearbox', 'csrf_token': token}
                       ).status_code == 403
    assert client.post(url + '/acknowledge', data={'owner': 'vic', 'comment': 'seen',
                                                   'csrf_token': token}).status_code == 403
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active
        assert [e.event for e in stored.alarm_log()] == ['raised']


def test_maintainer_acknowledges_then_resets(client, history):
    _as(client, 'mia')
    url = joint_url('press_line', 'joint_2')
    token = csrf_of(client.get(url).text)
    done = client.post(url + '/acknowledge', data={
        'owner': 'Team B', 'comment': 'gearbox ordered', 'planned_maintenance': '2026-12-01',
        'allow_past_date': True,
        'csrf_token': token}, follow_redirects=False)
    assert done.status_code == 303
    with open_history(history, init=False) as stored:
        row = next(r for r in stored.fleet() if r.joint == 'joint_2' and r.robot == 'press_line')
        assert row.alarm and row.acknowledged and row.acknowledged_by == 'mia'
        assert row.planned_maintenance == '2026-12-01'
    fleet = client.get('/api/fleet').json()
    first = fleet['rows'][0]
    assert first['state'] == 'acknowledged' and first['acknowledged_by'] == 'mia'
    assert 'acknowledged by mia' in client.get('/').text
    # a reset needs a reason: refused without one, the alarm stays
    client.post(url + '/reset', data={'reason': '  ', 'csrf_token': token})
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active
    # a reset needs its confirmation too: refused without the box ticked, the alarm stays
    refused = client.post(url + '/reset', data={'reason': 'gearbox replaced',
                                                'csrf_token': token})
    assert 'tick' in refused.text and 'the maintenance is done' in refused.text
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active
        assert stored.alarm_log()[0].event == 'acknowledged'
    client.post(url + '/reset', data={'reason': 'gearbox replaced', 'csrf_token': token,
                                      'confirm': 'yes'})
    with open_history(history, init=False) as stored:
        state = stored.restore(joint='joint_2', robot='press_line')
        log = stored.alarm_log()
    assert not state.alarm_active and state.alarm_evidence == 0.0
    assert [(e.event, e.user, e.note) for e in log[:2]] == [
        ('reset', 'mia', 'gearbox replaced'), ('acknowledged', 'mia', 'gearbox ordered')]
    api_log = client.get('/api/alarms').json()
    assert [(e['event'], e['user'], e['note']) for e in api_log] == [
        ('reset', 'mia', 'gearbox replaced'), ('acknowledged', 'mia', 'gearbox ordered'),
        ('raised', '', 'w-hat >= 35')]
    assert 'gearbox replaced' in client.get('/alarms').text
    assert 'gearbox replaced' in client.get(url).text


def test_a_removed_maintainer_can_no_longer_reset(client, history):
    _as(client, 'mia')
    url = joint_url('press_line', 'joint_2')
    token = csrf_of(client.get(url).text)
    with open_history(history) as stored:
        stored.remove_user(name='mia')
    # the removal ended the session (server-side): the reset is refused as unauthenticated
    assert client.post(url + '/reset', data={'reason': 'gearbox replaced',
                                             'csrf_token': token}).status_code == 401
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active


def test_alarm_log_csv_holds_the_log(client, history):
    _as(client, 'mia')
    url = joint_url('press_line', 'joint_2')
    token = csrf_of(client.get(url).text)
    client.post(url + '/reset', data={'reason': '=cmd|calc, "quoted"', 'csrf_token': token,
                                      'confirm': 'yes', 'work_order': 'WO-17'})
    response = client.get('/alarms.csv')
    assert response.headers['content-type'].startswith('text/csv')
    rows = list(csv.reader(io.StringIO(response.text)))
    assert rows[0] == ['id', 'time', 'robot', 'joint', 'event', 'wear', 'user', 'owner',
                       'planned_maintenance', 'note', 'note_text', 'work_order', 'source',
                       'changes']
    assert rows[1][11] == 'WO-17' and rows[2][11] == ''
    assert rows[1][12] == 'web' and rows[2][12] == ''  # the form's reset; the monitor's raise
    with open_history(history, init=False) as stored:
        log = stored.alarm_log()
    assert [int(r[0]) for r in rows[1:]] == [e.id for e in log]
    assert (rows[1][4], rows[1][6]) == ('reset', 'mia')
    assert rows[1][9] == "'=cmd|calc, \"quoted\""  # no formula for a spreadsheet
    assert rows[1][10] == 'reset by mia: =cmd|calc, "quoted"'  # the note in words
    assert rows[2][4] == 'raised' and float(rows[2][5]) == pytest.approx(41.0)


def test_names_are_escaped_in_every_page(client):
    _as(client, 'mia')
    for path in ('/', joint_url(XSS_ROBOT, 'joint_1'), '/alarms'):
        html = client.get(path).text
        assert '<img src=x' not in html, path
    html = client.get('/').text
    assert '&lt;img src=x onerror=alert(1)&gt;' in html
    joint = client.get(joint_url(XSS_ROBOT, 'joint_1'))
    assert joint.status_code == 200 and '&lt;img src=x onerror=alert(1)&gt;' in joint.text


def test_everything_is_served_locally(client):
    _as(client, 'vic')
    pages = [client.get(p).text for p in ('/', '/docs', '/alarms',
                                          joint_url('welder_7', 'joint_3'))]
    for html in pages:
        for url in re.findall(r'(?:src|href)="([^"]*)"', html):
            url = html_unescape(url)  # as a browser reads the attribute
            assert url.startswith('/'), url
            assert client.get(url).status_code == 200, url
    assert client.get('/openapi.json').json()['paths'].keys() >= {
        '/api/fleet', '/api/robots/{robot}/joints/{joint}', '/api/alarms'}
    static = Path(__file__).resolve().parents[2] / 'robot_wear_monitor' / 'dashboard'
    for path in list(static.glob('static/*')) + list(static.glob('templates/*')):
        text = path.read_text().replace('http://www.w3.org/2000/svg', '')
        assert 'http://' not in text and 'https://' not in text, path


def test_logout_ends_the_session(client):
    _as(client, 'vic')
    token = csrf_of(client.get('/').text)
    assert client.post('/logout', data={'csrf_token': token},
                       follow_redirects=False).status_code == 303
    assert client.get('/api/fleet').status_code == 401


def test_same_story_on_sqlite_and_postgresql(history_location):
    """The API's order, an acknowledge and a reset on both stores of the history."""
    make_fleet(history_location)
    app = create_app(DashboardSettings(history=history_location))
    with fastapi_testclient.TestClient(app) as client:
        _as(client, 'mia')
        rows = client.get('/api/fleet').json()['rows']
        assert [(r['robot'], r['joint']) for r in rows] == ORDER
        url = joint_url('press_line', 'joint_2')
        token = csrf_of(client.get(url).text)
        client.post(url + '/acknowledge', data={'owner': 'B', 'comment': 'ordered',
                                                'csrf_token': token})
        assert client.get('/api/fleet').json()['rows'][0]['state'] == 'acknowledged'
        client.post(url + '/reset', data={'reason': 'replaced', 'csrf_token': token,
                                          'confirm': 'yes'})
        after = {(r['robot'], r['joint']): r for r in client.get('/api/fleet').json()['rows']}
        reset = after[('press_line', 'joint_2')]
        assert not reset['alarm'] and reset['state'] == 'new life'
        assert [e['event'] for e in client.get('/api/alarms').json()] == [
            'reset', 'acknowledged', 'raised']
    with open_history(history_location, init=False) as stored:
        assert not stored.restore(joint='joint_2', robot='press_line').alarm_active


def test_the_alarm_log_is_newest_first_by_event_time_whatever_the_replay_order(
        client, history):
    # two recordings replayed in the other order: the later experiments stored first
    with open_history(history) as stored:
        base = stored.records(robot='welder_7', joint='joint_3')[-1]
        for robot, days in (('cell_late', 2.0), ('cell_early', 0.0)):
            rec = replace(base, id=None, robot=robot, stamp_s=base.stamp_s - 10 * 86400.0
                          + days * 86400.0, wear=40.0)
            note = ('trend P(w >= 35) = 0.214 >= 0.15; trend w 33.1 [30.2, 36.1], w-hat 40'
                    if robot == 'cell_late' else 'w-hat 40 >= 35, evidence 12.5')
            stored.append(rec, events=[AlarmEvent(joint='joint_3', robot=robot, event='raised',
                                                  stamp_s=rec.stamp_s, wear=40.0, note=note)])
        ids = {e.robot: e.id for e in stored.alarm_log() if e.robot.startswith('cell_')}
    assert ids['cell_late'] < ids['cell_early']  # row order: the late one first
    _as(client, 'vic')
    log = client.get('/api/alarms').json()
    picked = [e for e in log if e['robot'].startswith('cell_')]
    assert [e['robot'] for e in picked] == ['cell_late', 'cell_early']
    times = [e['event_time_s'] for e in log]
    assert times == sorted(times, reverse=True)
    assert picked[0]['time'] == time.strftime('%Y-%m-%dT%H:%M:%SZ',
                                              time.gmtime(picked[0]['stamp_s']))
    assert picked[0]['note_text'] == ("the trend's chance of w >= 35 reached 21 % (rule: 15 %); "
                                      'trend w 33.1 [95 %: 30.2, 36.1], latest w-hat 40')
    assert picked[1]['note_text'] == 'w-hat 40 reached the wear threshold 35 (alarm evidence 12.5)'
    page = client.get('/alarms').text
    assert page.index('cell_late') < page.index('cell_early')
    assert 'chance of w &gt;= 35 reached 21 % (rule: 15 %)' in page
