"""
The dashboard's accounts and write API with FastAPI's TestClient (issue 36, items 4 and 6).

The write API acknowledges, edits, withdraws and resets with a per-user API token (or a cookie
session with its CSRF header), with the forms' role checks and audit trail; the joint page's
forms edit and withdraw an acknowledgement and carry a work order; the users page is an
admin's: a maintainer or viewer gets 403 on every route, and what an admin does there is what
the history then holds (a removed user's session and tokens are void at once).
"""

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import csrf_of, login, make_fleet

ADMIN, ADMIN_PASSWORD = 'ada', 'admin-pass-333'
URL = joint_url('press_line', 'joint_2')  # the plan's one latched alarm
API = '/api' + URL


@pytest.fixture()
def history(tmp_path) -> str:
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    with open_history(path, init=False) as stored:
        stored.add_user(name=ADMIN, role='admin', password=ADMIN_PASSWORD)
    return path


@pytest.fixture()
def client(history):
    app = create_app(DashboardSettings(history=history))
    with fastapi_testclient.TestClient(app) as test_client:
        yield test_client


def _token(history: str, user: str) -> dict[str, str]:
    with open_history(history, init=False) as stored:
        _, token = stored.add_token(user=user, label='CMMS')
    return {'Authorization': f'Bearer {token}'}


def _log(history: str) -> list[tuple[str, str, str, str]]:
    """Return the joint's alarm log, newest first: (event, user, note, work order)."""
    with open_history(history, init=False) as stored:
        return [(e.event, e.user, e.note, e.work_order)
                for e in stored.alarm_log(robot='press_line', joint='joint_2')]


def test_a_maintenance_system_acknowledges_edits_withdraws_and_resets_with_a_token(
        client, history):
    bearer = _token(history, 'mia')
    done = client.post(API + '/acknowledge', headers=bearer, json={
        'owner': 'Team B', 'comment': 'gearbox ordered', 'planned_maintenance': '2026-12-01',
        'allow_past_date': True,
        'work_order': 'WO-4711'})
    assert done.status_code == 200, done.text
    event = done.json()
    assert (event['event'], event['user'], event['owner'], event['work_order']) == (
        'acknowledged', 'mia', 'Team B', 'WO-4711')
    again = client.post(API + '/acknowledge', headers=bearer, json={'owner': 'Team C'})
    assert again.status_code == 409 and 'already acknowledged' in again.json()['detail']
    assert 'sqlite3' not in again.json()['detail']  # the history's path is not told
    bad = client.post(API + '/acknowledgement/edit', headers=bearer,
                      json={'owner': 'Team B', 'planned_maintenance': '1.12.2026'})
    assert bad.status_code == 422 and 'ISO date' in bad.json()['detail']
    assert client.post(API + '/acknowledgement/edit', headers=bearer,
                       json={'owner': 'Team B', 'extra': 1}).status_code == 422
    edited = client.post(API + '/acknowledgement/edit', headers=bearer, json={
        'owner': 'Team C', 'comment': 'gearbox ordered', 'planned_maintenance': '2026-12-08',
        'allow_past_date': True,
        'work_order': 'WO-4712'})
    assert edited.status_code == 200 and edited.json()['event'] == 'acknowledgement_edited'
    row = next(r for r in client.get('/api/fleet', headers=bearer).json()['rows']
               if (r['robot'], r['joint']) == ('press_line', 'joint_2'))
    assert row['acknowledged'] and row['planned_maintenance'] == '2026-12-08'
    withdrawn = client.post(API + '/acknowledgement/withdraw', headers=bearer,
                            json={'reason': 'order cancelled'})
    assert withdrawn.status_code == 200
    assert client.post(API + '/acknowledgement/withdraw', headers=bearer,
                       json={'reason': 'again'}).status_code == 409
    reset = client.post(API + '/reset', headers=bearer,
                        json={'reason': 'gearbox replaced', 'work_order': 'WO-4712'})
    assert reset.status_code == 200 and reset.json()['event'] == 'reset'
    assert client.post(API + '/reset', headers=bearer,
                       json={'reason': 'twice'}).status_code == 409
    # the audit trail is the forms': who, what, the work order, newest first
    assert _log(history)[:5] == [
        ('reset', 'mia', 'gearbox replaced', 'WO-4712'),
        ('acknowledgement_withdrawn', 'mia', 'order cancelled', 'WO-4712'),
        ('acknowledgement_edited', 'mia', 'gearbox ordered', 'WO-4712'),
        ('acknowledged', 'mia', 'gearbox ordered', 'WO-4711'),
        ('raised', '', 'w-hat >= 35', '')]
    with open_history(history, init=False) as stored:
        assert not stored.restore(joint='joint_2', robot='press_line').alarm_active
        used = stored.tokens(user='mia')[0]
    assert used.last_used_wall_time_s is not None
    exported = client.get('/api/alarms', headers=bearer).json()
    assert [e['work_order'] for e in exported[:2]] == ['WO-4712', 'WO-4712']


def test_a_token_acts_only_as_its_user_may(client, history):
    viewer = _token(history, 'vic')
    assert client.get('/api/fleet', headers=viewer).status_code == 200
    refused = client.post(API + '/acknowledge', headers=viewer, json={'owner': 'x'})
    assert refused.status_code == 403 and 'maintainer' in refused.json()['detail']
    for headers in ({}, {'Authorization': 'Bearer rwm_not-a-token-at-all-xxxxxxxx'},
                    {'Authorization': 'Bearer '}):
        answer = client.post(API + '/reset', headers=headers, json={'reason': 'x'})
        assert answer.status_code == 401, headers
    # a token is for the API only: a page does not take it
    page = client.get('/', headers=_token(history, 'mia'), follow_redirects=False)
    assert page.status_code == 303 and page.headers['location'].startswith('/login')
    # a token of a removed user dies with the user
    maintainer = _token(history, 'mia')
    assert client.get('/api/me', headers=maintainer).json() == {
        'name': 'mia', 'role': 'maintainer', 'csrf_token': ''}
    with open_history(history, init=False) as stored:
        stored.remove_user(name='mia')
    gone = client.post(API + '/acknowledge', headers=maintainer, json={'owner': 'x'})
    assert gone.status_code == 401
    # a role change counts at once: the viewer made admin may act with the same token
    with open_history(history, init=False) as stored:
        stored.set_role(name='vic', role='admin')
    assert client.post(API + '/acknowledge', headers=viewer,
                       json={'owner': 'Team B'}).status_code == 200
    assert _log(history)[0][:2] == ('acknowledged', 'vic')


def test_a_cookie_session_writes_through_the_api_with_its_csrf_header_only(client, history):
    assert login(client, 'mia').status_code == 303
    no_header = client.post(API + '/acknowledge', json={'owner': 'Team B'})
    assert no_header.status_code == 403 and 'X-CSRF-Token' in no_header.json()['detail']
    wrong = client.post(API + '/acknowledge', json={'owner': 'Team B'},
                        headers={'X-CSRF-Token': 'nonsense'})
    assert wrong.status_code == 403
    assert _log(history)[0][0] == 'raised'
    token = client.get('/api/me').json()['csrf_token']
    done = client.post(API + '/acknowledge', json={'owner': 'Team B'},
                       headers={'X-CSRF-Token': token})
    assert done.status_code == 200 and _log(history)[0][:2] == ('acknowledged', 'mia')


def test_the_joint_page_edits_and_withdraws_an_acknowledgement_with_a_work_order(
        client, history):
    assert login(client, 'mia').status_code == 303
    token = csrf_of(client.get(URL).text)
    client.post(URL + '/acknowledge', data={'owner': 'Team B', 'comment': 'ordered',
                                            'work_order': 'WO-1', 'csrf_token': token})
    page = client.get(URL).text
    assert 'id="edit-acknowledgement-form"' in page and 'value="WO-1"' in page
    assert 'id="ack-shown-work-order">WO-1<' in page
    assert 'id="acknowledge-form"' not in page
    edited = client.post(URL + '/acknowledgement/edit', data={
        'owner': 'Team C', 'comment': 'ordered', 'work_order': 'WO-2', 'csrf_token': token})
    assert 'acknowledgement edited' in edited.text
    assert 'id="ack-shown-owner">Team C<' in edited.text
    nothing = client.post(URL + '/acknowledgement/edit', data={
        'owner': 'Team C', 'comment': 'ordered', 'work_order': 'WO-2', 'csrf_token': token})
    assert 'changes nothing' in nothing.text
    withdrawn = client.post(URL + '/acknowledgement/withdraw',
                            data={'reason': 'wrong joint', 'csrf_token': token})
    assert 'acknowledgement withdrawn' in withdrawn.text
    assert 'id="acknowledge-form"' in withdrawn.text  # acknowledgeable again
    assert 'id="edit-acknowledgement-form"' not in withdrawn.text
    assert _log(history)[:3] == [
        ('acknowledgement_withdrawn', 'mia', 'wrong joint', 'WO-2'),
        ('acknowledgement_edited', 'mia', 'ordered', 'WO-2'),
        ('acknowledged', 'mia', 'ordered', 'WO-1')]
    log_page = client.get('/alarms').text
    assert 'acknowledgement_withdrawn' in log_page and 'WO-2' in log_page
    # a viewer sees the acknowledgement but may neither edit nor withdraw it
    client.post(URL + '/acknowledge', data={'owner': 'Team D', 'csrf_token': token})
    client.cookies.clear()
    assert login(client, 'vic').status_code == 303
    page = client.get(URL).text
    assert 'id="acknowledgement"' in page and 'edit-acknowledgement-form' not in page
    viewer_token = csrf_of(page)
    for path, data in (('/acknowledgement/edit', {'owner': 'vic'}),
                       ('/acknowledgement/withdraw', {'reason': 'no'})):
        answer = client.post(URL + path, data={**data, 'csrf_token': viewer_token})
        assert answer.status_code == 403, path
    assert _log(history)[0][:2] == ('acknowledged', 'mia')


def _admin(client):
    assert login(client, ADMIN, ADMIN_PASSWORD).status_code == 303
    return csrf_of(client.get('/users').text)


def test_an_admin_manages_the_users_from_the_page(client, history, tmp_path):
    token = _admin(client)
    page = client.get('/users').text
    assert 'data-user="mia"' in page and 'data-user="vic"' in page
    assert '<a href="/users"' in client.get('/').text  # the admin's menu has the page
    added = client.post('/users/add', data={'name': 'otto', 'role': 'viewer',
                                            'password': 'otto-pass-1', 'csrf_token': token})
    assert 'user otto added (viewer)' in added.text
    short = client.post('/users/add', data={'name': 'paul', 'role': 'viewer',
                                            'password': 'short', 'csrf_token': token})
    assert 'at least 8 characters' in short.text
    assert 'role is viewer, maintainer or admin' in client.post(
        '/users/add', data={'name': 'paul', 'role': 'root', 'password': 'long enough',
                            'csrf_token': token}).text
    assert 'otto is now maintainer' in client.post(
        '/users/otto/role', data={'role': 'maintainer', 'csrf_token': token}).text
    # a session of mia ends when the admin gives her a new password
    with fastapi_testclient.TestClient(client.app) as mia:
        assert login(mia, 'mia').status_code == 303
        assert mia.get('/api/me').status_code == 200
        done = client.post('/users/mia/password', data={'password': 'mia-new-pass',
                                                        'csrf_token': token})
        assert 'their sessions ended' in done.text
        assert mia.get('/api/me').status_code == 401
        assert login(mia, 'mia', 'mia-new-pass').status_code == 303
        bearer = _token(history, 'mia')
        # removing needs the box ticked; then her session and token end at once
        kept = client.post('/users/mia/remove', data={'csrf_token': token})
        assert 'not removed' in kept.text and mia.get('/api/me').status_code == 200
        removed = client.post('/users/mia/remove', data={'confirm': 'yes',
                                                         'csrf_token': token})
        assert 'user mia removed' in removed.text
        assert mia.get('/api/me').status_code == 401
        assert mia.get('/api/me', headers=bearer).status_code == 401
    # an admin neither removes nor demotes their own account from the page
    assert 'their own account' in client.post(
        f'/users/{ADMIN}/remove', data={'confirm': 'yes', 'csrf_token': token}).text
    assert 'their own account' in client.post(
        f'/users/{ADMIN}/role', data={'role': 'viewer', 'csrf_token': token}).text
    with open_history(history, init=False) as stored:
        assert [(u.name, u.role) for u in stored.users()] == [
            (ADMIN, 'admin'), ('otto', 'maintainer'), ('vic', 'viewer')]
        assert stored.verify_user(name='otto', password='otto-pass-1').role == 'maintainer'
    # the admin may act on alarms too
    assert client.post(URL + '/acknowledge', data={'owner': 'Team A', 'csrf_token': token},
                       follow_redirects=False).status_code == 303
    assert _log(history)[0][:2] == ('acknowledged', ADMIN)


@pytest.mark.parametrize('name', ['mia', 'vic'])
def test_only_an_admin_manages_users(client, history, name):
    assert login(client, name).status_code == 303
    assert client.get('/users').status_code == 403
    assert '<a href="/users"' not in client.get('/').text
    token = csrf_of(client.get('/').text)
    for path, data in (('/users/add', {'name': 'eve', 'role': 'admin',
                                       'password': 'eve-pass-12'}),
                       ('/users/vic/role', {'role': 'admin'}),
                       ('/users/vic/password', {'password': 'taken-over-1'}),
                       ('/users/vic/remove', {'confirm': 'yes'})):
        answer = client.post(path, data={**data, 'csrf_token': token})
        assert answer.status_code == 403, path
        assert 'only an admin' in answer.json()['detail']
    # without the CSRF token the request is refused before the role check
    assert client.post('/users/add', data={'name': 'eve', 'role': 'admin',
                                           'password': 'eve-pass-12'}).status_code == 403
    with open_history(history, init=False) as stored:
        assert [(u.name, u.role) for u in stored.users()] == [
            (ADMIN, 'admin'), ('mia', 'maintainer'), ('vic', 'viewer')]
        assert stored.verify_user(name='vic', password='taken-over-1') is None
