"""
A week at a plant (issue 44): a reset at any time, the write API a maintenance system needs.

The plan's fleet (``wear_testing.fleet_history``: one latched alarm on press_line joint_2, the
other joints never alarmed) with FastAPI's TestClient and a maintainer's API token.
"""

import json
import time

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import csrf_of, EXPERIMENTS, login, make_fleet

ALARMED = '/api' + joint_url('press_line', 'joint_2')
NEVER_ALARMED = '/api' + joint_url('welder_7', 'joint_3')


@pytest.fixture()
def history(tmp_path) -> str:
    return make_fleet(str(tmp_path / 'fleet.sqlite3'))


@pytest.fixture()
def client(history):
    app = create_app(DashboardSettings(history=history))
    with fastapi_testclient.TestClient(app) as test_client:
        yield test_client


@pytest.fixture()
def bearer(history) -> dict[str, str]:
    with open_history(history, init=False) as stored:
        _, token = stored.add_token(user='mia', label='CMMS')
    return {'Authorization': f'Bearer {token}'}


def _fleet_json(history: str, capsys, *more: str) -> list[dict]:
    """Return the rows of ``robot-wear-monitor fleet --json`` (in-process)."""
    capsys.readouterr()
    assert main(['fleet', '--history', history, '--json', *more]) == 0
    return json.loads(capsys.readouterr().out)


def _row(rows: list[dict], robot: str, joint: str) -> dict:
    return next(r for r in rows if (r['robot'], r['joint']) == (robot, joint))


def test_a_joint_that_never_alarmed_takes_a_reset_and_starts_a_new_life(
        client, history, bearer, capsys):
    before = _row(_fleet_json(history, capsys), 'welder_7', 'joint_3')
    assert before['life_started_s'] is None and before['wear'] == 30.0 and not before['alarm']
    started = time.time()
    reset = client.post(NEVER_ALARMED + '/reset', headers=bearer,
                        json={'reason': 'gearbox replaced preventively', 'work_order': 'WO-7'})
    assert reset.status_code == 200, reset.text
    event = reset.json()
    assert (event['event'], event['user'], event['source'], event['work_order']) == (
        'reset', 'mia', 'api', 'WO-7')
    row = _row(_fleet_json(history, capsys), 'welder_7', 'joint_3')
    assert row['life_started_s'] is not None and started <= row['life_started_s'] <= time.time()
    assert row['wear'] is None and row['trend_wear'] is None and row['experiments'] == 0
    assert row['crossing_experiments'] is None and row['reset_by'] == 'mia'
    # nothing new since: a second reset (a double click, a second system) is refused
    again = client.post(NEVER_ALARMED + '/reset', headers=bearer, json={'reason': 'twice'})
    assert again.status_code == 409 and 'reset already' in again.json()['detail']
    with open_history(history, init=False) as stored:
        # the old life stays in the history; the reset resolved no alarm
        assert len(stored.records(joint='joint_3', robot='welder_7')) == EXPERIMENTS
        assert not stored.restore(joint='joint_3', robot='welder_7').alarm_active
        assert all(r[:2] != ('welder_7', 'joint_3') for r in stored.resolved_raises())
    # the latched alarm's reset still resolves its raise
    assert client.post(ALARMED + '/reset', headers=bearer,
                       json={'reason': 'gear replaced'}).status_code == 200
    with open_history(history, init=False) as stored:
        assert [r[:2] for r in stored.resolved_raises()] == [('press_line', 'joint_2')]


def test_the_joint_page_offers_the_reset_on_any_joint_and_the_form_records_it(
        client, history):
    assert login(client, 'mia').status_code == 303
    page = client.get(joint_url('welder_7', 'joint_3'))
    assert 'id="reset-form"' in page.text and 'Record the maintenance' in page.text
    token = csrf_of(page.text)
    unconfirmed = client.post(joint_url('welder_7', 'joint_3') + '/reset', data={
        'csrf_token': token, 'reason': 'bearing replaced'}, follow_redirects=False)
    assert unconfirmed.status_code == 303
    with open_history(history, init=False) as stored:
        assert stored.latch_event(joint='joint_3', robot='welder_7') is None  # not confirmed
    done = client.post(joint_url('welder_7', 'joint_3') + '/reset', data={
        'csrf_token': token, 'reason': 'bearing replaced', 'confirm': 'yes'},
        follow_redirects=True)
    assert done.status_code == 200 and 'a new life starts' in done.text
    assert 'id="reset-form"' not in done.text  # awaiting its first experiment
    with open_history(history, init=False) as stored:
        latch = stored.latch_event(joint='joint_3', robot='welder_7')
    assert (latch.event, latch.user, latch.source) == ('reset', 'mia', 'web')


def test_an_edit_changes_only_the_fields_it_sends(client, history, bearer):
    assert client.post(ALARMED + '/acknowledge', headers=bearer, json={
        'owner': 'Team B', 'comment': 'gearbox ordered', 'planned_maintenance': '2026-12-01',
        'allow_past_date': True,
        'work_order': 'WO-4711'}).status_code == 200
    edited = client.post(ALARMED + '/acknowledgement/edit', headers=bearer,
                         json={'owner': 'Team D'})
    assert edited.status_code == 200, edited.text
    event = edited.json()
    assert (event['owner'], event['note'], event['planned_maintenance'],
            event['work_order']) == ('Team D', 'gearbox ordered', '2026-12-01', 'WO-4711')
    assert event['changes'] == "owner: 'Team B' -> 'Team D'" and event['source'] == 'api'
    with open_history(history, init=False) as stored:
        current = stored.acknowledgement(joint='joint_2', robot='press_line')
    assert (current.owner, current.note, current.planned_maintenance, current.work_order) == (
        'Team D', 'gearbox ordered', '2026-12-01', 'WO-4711')
    cleared = client.post(ALARMED + '/acknowledgement/edit', headers=bearer,
                          json={'planned_maintenance': ''}).json()
    assert cleared['planned_maintenance'] == '' and cleared['owner'] == 'Team D'
    assert cleared['changes'] == "planned_maintenance: '2026-12-01' -> none"
    same = client.post(ALARMED + '/acknowledgement/edit', headers=bearer,
                       json={'owner': 'Team D'})
    assert same.status_code == 409 and 'changes nothing' in same.json()['detail']


def test_unknown_robot_or_joint_is_404_and_an_unknown_parameter_422(client, bearer):
    for url in ('/api' + joint_url('no_such_robot', 'joint_2'),
                '/api' + joint_url('press_line', 'joint_9')):
        for action, body in (('/reset', {'reason': 'x'}), ('/acknowledge', {'owner': 'x'}),
                             ('/acknowledgement/edit', {'owner': 'x'}),
                             ('/acknowledgement/withdraw', {'reason': 'x'})):
            answer = client.post(url + action, headers=bearer, json=body)
            assert answer.status_code == 404, (url, action, answer.text)
            assert 'no estimates of robot' in answer.json()['detail']
    assert client.get('/api/fleet?robot=no_such_robot', headers=bearer).status_code == 404
    misspelt = client.get('/api/fleet?stat=alarm', headers=bearer)
    assert misspelt.status_code == 422 and "'stat'" in misspelt.json()['detail']
    assert client.get('/api/fleet?state=alarm', headers=bearer).status_code == 200
    assert client.get('/api/alarms?robots=x', headers=bearer).status_code == 422


def test_openapi_takes_a_token_and_declares_the_bearer_scheme(client, bearer):
    assert client.get('/openapi.json').status_code == 401
    schema = client.get('/openapi.json', headers=bearer)
    assert schema.status_code == 200
    scheme = schema.json()['components']['securitySchemes']['apiToken']
    assert (scheme['type'], scheme['scheme']) == ('http', 'bearer')
    reset = schema.json()['paths']['/api/robots/{robot}/joints/{joint}/reset']['post']
    assert {'apiToken': []} in reset['security'] and '404' in reset['responses']


def test_a_polling_system_gets_the_events_stored_since_its_last_poll(client, history, bearer):
    first = client.get('/api/alarms', headers=bearer).json()
    assert [e['event'] for e in first] == ['raised']
    seen = max(e['wall_time_s'] for e in first)
    assert client.get(f'/api/alarms?since={seen}', headers=bearer).json() == []
    client.post(ALARMED + '/acknowledge', headers=bearer, json={'owner': 'Team B'})
    client.post(NEVER_ALARMED + '/reset', headers=bearer, json={'reason': 'replaced'})
    news = client.get(f'/api/alarms?since={seen}', headers=bearer).json()
    assert [(e['event'], e['joint']) for e in news] == [('reset', 'joint_3'),
                                                        ('acknowledged', 'joint_2')]


def test_an_acknowledged_alarm_past_its_planned_date_is_an_alarm_everywhere(
        client, history, bearer, capsys):
    assert client.post(ALARMED + '/acknowledge', headers=bearer, json={
        'owner': 'Team B', 'planned_maintenance': '2026-12-01',
        'allow_past_date': True}).status_code == 200
    acknowledged = _row(_fleet_json(history, capsys, '--now', '2026-11-30T12:00:00Z'),
                        'press_line', 'joint_2')
    assert (acknowledged['state'], acknowledged['reescalated']) == ('acknowledged', False)
    # the planned date passes: the same word in fleet --json, /api/fleet and the page
    late = _row(_fleet_json(history, capsys, '--now', '2026-12-02T12:00:00Z'),
                'press_line', 'joint_2')
    assert (late['state'], late['reescalated'], late['acknowledged']) == ('alarm', True, True)
    # the dashboard judges at its clock: move the planned date into the past instead
    with open_history(history, init=False) as stored:
        stored.edit_acknowledgement(joint='joint_2', robot='press_line', user='mia',
                                    planned_maintenance='2020-01-01')
    fleet = client.get('/api/fleet', headers=bearer).json()
    row = _row(fleet['rows'], 'press_line', 'joint_2')
    assert (row['state'], row['reescalated']) == ('alarm', True)
    assert fleet['counts']['alarm'] == 1 and fleet['counts']['acknowledged'] == 0
    assert [r['joint'] for r in client.get('/api/fleet?state=alarm',
                                           headers=bearer).json()['rows']] == ['joint_2']
    assert login(client, 'mia').status_code == 303
    page = client.get('/').text
    assert '<span class="count" data-state="alarm">1</span>' in page
    assert '<span class="count" data-state="acknowledged">0</span>' in page


def test_a_joint_at_the_warning_level_is_a_warning_and_a_reset_one_a_new_life(
        client, history, bearer, capsys):
    rows = _fleet_json(history, capsys)
    warned = _row(rows, 'welder_7', 'joint_3')  # w-hat 30 >= 28, the set's warning level
    assert (warned['state'], warned['alarm']) == ('warning', False)
    assert warned['warning_level'] == 28.0
    assert _row(rows, 'press_line', 'joint_1')['state'] == 'ok'  # w-hat 6, no crossing
    client.post(NEVER_ALARMED + '/reset', headers=bearer, json={'reason': 'replaced'})
    assert _row(_fleet_json(history, capsys), 'welder_7', 'joint_3')['state'] == 'new life'
    assert _row(client.get('/api/fleet', headers=bearer).json()['rows'], 'welder_7',
                'joint_3')['state'] == 'new life'


def test_judged_two_months_later_no_crossing_date_is_shown_passed_without_overdue(
        history, capsys):
    later = time.time() + 61 * 86400.0
    rows = _fleet_json(history, capsys, '--now', str(later))
    for row in rows:
        if row['alarm'] or row['crossing_time_s'] is None:
            continue
        assert row['crossing_time_s'] >= later or row['crossing_overdue'], row['joint']
    overdue = [r for r in rows if r['crossing_overdue']]
    assert {(r['robot'], r['joint']) for r in overdue} == {
        ('welder_7', 'joint_3'), ('<img src=x onerror=alert(1)>', 'joint_1')}
    assert all(r['state'] == 'stale' for r in overdue)  # no experiment for two months
    capsys.readouterr()
    assert main(['fleet', '--history', history, '--now', str(later)]) == 0
    table = capsys.readouterr().out
    assert 'overdue since' in table
    assert table.splitlines()[0].startswith('3 robots, 5 joints: 1 alarm, 4 stale')


def test_a_reescalation_is_written_to_the_alarm_log_once_by_whoever_sees_it_first(
        client, history, bearer):
    """Issue 44 (d): the audit trail shows a re-escalation, once, with who saw it."""
    refused = client.post(ALARMED + '/acknowledge', headers=bearer, json={
        'owner': 'Team B', 'planned_maintenance': '2020-01-01'})
    assert refused.status_code == 422 and 'has passed' in refused.json()['detail']
    assert client.post(ALARMED + '/acknowledge', headers=bearer, json={
        'owner': 'Team B', 'planned_maintenance': '2020-01-01',
        'allow_past_date': True}).status_code == 200
    # an edit keeping the passed date is not refused; one moving it to another passed date is
    assert client.post(ALARMED + '/acknowledgement/edit', headers=bearer, json={
        'owner': 'Team C'}).status_code == 200
    assert client.post(ALARMED + '/acknowledgement/edit', headers=bearer, json={
        'planned_maintenance': '2020-01-01', 'comment': 'late'}).status_code == 200
    assert client.post(ALARMED + '/acknowledgement/edit', headers=bearer, json={
        'planned_maintenance': '2021-01-01'}).status_code == 422
    with open_history(history, init=False) as stored:
        assert not [e for e in stored.events(joint='joint_2', robot='press_line')
                    if e.event == 'reescalated']
    for _ in range(2):  # the API sees it first; the second poll and the page add nothing
        assert client.get('/api/fleet', headers=bearer).status_code == 200
    assert login(client, 'mia').status_code == 303
    assert client.get('/').status_code == 200
    with open_history(history, init=False) as stored:
        logged = [e for e in stored.events(joint='joint_2', robot='press_line')
                  if e.event == 'reescalated']
    assert [(e.note, e.source) for e in logged] == [
        ('the planned maintenance date 2020-01-01 has passed', 'api')]
    kinds = [e['event'] for e in client.get('/api/alarms', headers=bearer).json()]
    assert kinds[0] == 'reescalated'
    log = client.get('/alarms')
    assert log.status_code == 200
    assert 're-escalated: the planned maintenance date 2020-01-01 has passed' in log.text


def test_the_acknowledge_form_refuses_a_passed_date_unless_its_box_is_ticked(client, history):
    assert login(client, 'mia').status_code == 303
    page = client.get(joint_url('press_line', 'joint_2'))
    assert 'id="ack-allow-past"' in page.text
    token = csrf_of(page.text)
    form = {'csrf_token': token, 'owner': 'Team B', 'comment': 'late entry',
            'planned_maintenance': '2020-01-01'}
    refused = client.post(joint_url('press_line', 'joint_2') + '/acknowledge', data=form,
                          follow_redirects=True)
    assert refused.status_code == 200 and '2020-01-01 has passed' in refused.text
    with open_history(history, init=False) as stored:
        assert stored.acknowledgement(joint='joint_2', robot='press_line') is None
    done = client.post(joint_url('press_line', 'joint_2') + '/acknowledge',
                       data={**form, 'allow_past_date': '1'}, follow_redirects=True)
    assert done.status_code == 200 and 'alarm acknowledged' in done.text
    with open_history(history, init=False) as stored:
        ack = stored.acknowledgement(joint='joint_2', robot='press_line')
    assert (ack.planned_maintenance, ack.source) == ('2020-01-01', 'web')


def test_acknowledged_by_is_the_first_acknowledger_and_edited_by_the_last_editor(
        client, history, bearer, capsys):
    """Issue 44: "acknowledged by" named the last editor with the first acknowledgement's time."""
    with open_history(history, init=False) as stored:
        stored.add_user(name='ben', role='maintainer', password='correct horse battery')
        first = stored.acknowledge_alarm(joint='joint_2', robot='press_line', user='ana',
                                         owner='Team B', comment='ordered')
        time.sleep(0.01)
        stored.edit_acknowledgement(joint='joint_2', robot='press_line', user='ben',
                                    owner='Team C')
    row = _row(_fleet_json(history, capsys), 'press_line', 'joint_2')
    assert (row['acknowledged_by'], row['edited_by']) == ('ana', 'ben')
    assert row['acknowledged_time_s'] == pytest.approx(first.wall_time_s)
    assert login(client, 'mia').status_code == 303
    page = client.get(joint_url('press_line', 'joint_2')).text
    assert '<b id="ack-by">ana</b>' in page and '<b id="ack-edited-by">ben</b>' in page


def test_after_a_reset_the_joint_page_shows_nothing_of_the_old_life(client, history, bearer):
    """Issue 44: no "last experiment" of the old life beside "experiments 0", no horizon text."""
    old = _row(client.get('/api/fleet', headers=bearer).json()['rows'], 'welder_7', 'joint_3')
    assert client.post(NEVER_ALARMED + '/reset', headers=bearer,
                       json={'reason': 'gearbox replaced'}).status_code == 200
    assert login(client, 'mia').status_code == 303
    page = client.get(joint_url('welder_7', 'joint_3')).text
    assert '<dd id="f-experiments">0</dd>' in page
    assert 'id="f-last">none since the reset' in page
    assert old['last_experiment'] not in page.split('id="f-last">')[1].split('</dd>')[0]
    crossing = page.split('id="f-crossing">')[1].split('</dd>')[0]
    assert crossing == 'no experiment since the reset'
