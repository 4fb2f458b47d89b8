"""
The guards around the dashboard, in the app (FastAPI's TestClient).

Bounded bodies, 422 for every bad value, the login limit that cannot be turned against the
owner, the cookie and HSTS, no location shown.

On SQLite and PostgreSQL where the store matters (the bad values never reach it: the alarm
is acknowledged by the good request after them).  The real server's guards (a 50 MB body,
300,000 keys, a half-sent request, a PostgreSQL restart) are in test_dashboard_faults.py.
"""

import json

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.auth import LoginLimiter
from robot_wear_monitor.dashboard.guards import MAX_BODY_BYTES, MAX_JSON_DEPTH, MAX_JSON_KEYS
from robot_wear_monitor.history import HistoryError, open_history, WearHistory
from wear_testing.fleet_history import csrf_of, login, make_fleet, PASSWORDS

ACK = '/api/robots/press_line/joints/joint_2/acknowledge'


@pytest.fixture()
def fleet(history_location) -> str:
    return make_fleet(history_location)


def _client(history: str, **settings):
    return fastapi_testclient.TestClient(create_app(DashboardSettings(history=history,
                                                                      **settings)))


def _token(history: str, user: str) -> dict[str, str]:
    with open_history(history, init=False) as stored:
        _, token = stored.add_token(user=user, label='test')
    return {'Authorization': f'Bearer {token}', 'Content-Type': 'application/json'}


@pytest.mark.parametrize('field', ['owner', 'comment', 'planned_maintenance', 'work_order'])
def test_non_finite_numbers_and_lone_surrogates_are_422_naming_the_field(fleet, field):
    headers = _token(fleet, 'mia')
    good = {'owner': 'Team B', 'comment': 'ordered', 'planned_maintenance': '',
            'work_order': 'WO-1'}
    with _client(fleet) as client:
        for bad in ('NaN', 'Infinity', '-Infinity', '1e999', '-1e999', '"\\ud800"',
                    '"ok \\udfff"', '[1, NaN]', '{"x": Infinity}'):
            body = json.dumps(good)[:-1] + f', "{field}": {bad}}}'  # the last key wins
            response = client.post(ACK, content=body, headers=headers)
            assert response.status_code == 422, (field, bad, response.text)
            detail = response.json()['detail']
            assert detail[0]['loc'][:2] == ['body', field], (bad, detail)
            assert '\ud800' not in response.text
        # a lone surrogate in a key is named, escaped
        body = json.dumps(good)[:-1] + ', "k\\ud800": 1}'
        response = client.post(ACK, content=body, headers=headers)
        assert response.status_code == 422
        assert response.json()['detail'][0]['loc'] == ['body', 'k\\ud800']
        # none of them reached the store: the good body acknowledges the alarm now
        response = client.post(ACK, json=good, headers=headers)
        assert response.status_code == 200, response.text
    with open_history(fleet, init=False) as stored:
        events = [e.event for e in stored.events(joint='joint_2', robot='press_line')]
    assert events.count('acknowledged') == 1


def test_a_bad_value_is_named_without_echoing_it(fleet):
    headers = _token(fleet, 'mia')
    with _client(fleet) as client:
        response = client.post(ACK, json={'owner': 5, 'comment': 'x' * 3000}, headers=headers)
    assert response.status_code == 422
    detail = response.json()['detail']
    assert ['body', 'owner'] in [d['loc'] for d in detail]
    assert all(set(d) == {'loc', 'msg', 'type'} for d in detail)
    assert 'xxxxxxxx' not in response.text  # the value given is not sent back


def test_bodies_are_bounded_before_authentication(fleet):
    with _client(fleet) as client:
        # no session, no token: refused for its size, before anything reads it
        big = client.post(ACK, content=b'x' * (MAX_BODY_BYTES + 1),
                          headers={'Content-Type': 'application/json'})
        assert big.status_code == 413
        chunked = client.post(ACK, content=iter([b'{"a":"' + b'x' * 40000,
                                                 b'x' * 40000 + b'"}']),
                              headers={'Content-Type': 'application/json'})
        assert chunked.status_code == 413
        login_body = client.post('/login', content=b'u=' + b'x' * (MAX_BODY_BYTES + 10),
                                 headers={'Content-Type':
                                          'application/x-www-form-urlencoded'})
        assert login_body.status_code == 413
        headers = _token(fleet, 'mia')
        wide = '{' + ','.join(f'"k{i}":0' for i in range(MAX_JSON_KEYS + 1)) + '}'
        assert len(wide) < MAX_BODY_BYTES
        assert client.post(ACK, content=wide, headers=headers).status_code == 413
        deep = '[' * (MAX_JSON_DEPTH + 2) + ']' * (MAX_JSON_DEPTH + 2)
        response = client.post(ACK, content=deep, headers=headers)
        assert response.status_code == 422 and 'nests deeper' in response.text
        deepest = '[' * 30000 + ']' * 30000  # Python's parser would recurse past its limit
        assert client.post(ACK, content=deepest, headers=headers).status_code == 422
        # the largest valid body passes: a 2000-character note of escaped characters
        note = '\u00e9"\\' * 666
        response = client.post(ACK, json={'owner': 'Team B', 'comment': note}, headers=headers)
        assert response.status_code == 200, response.text


class _From:
    """An ASGI wrapper that sets the peer address of every request (as a socket would)."""

    def __init__(self, app, address: str) -> None:
        self.app, self.address = app, address
        self.state = app.state

    async def __call__(self, scope, receive, send):
        if scope['type'] == 'http':
            scope = {**scope, 'client': (self.address, 40000)}
        await self.app(scope, receive, send)


def test_wrong_passwords_from_one_address_do_not_lock_the_owner_out(fleet):
    app = create_app(DashboardSettings(history=fleet, max_failures=5, window_s=600.0))
    with fastapi_testclient.TestClient(_From(app, '10.0.0.66')) as attacker:
        for _ in range(5):
            assert login(attacker, 'mia', 'wrong password').status_code == 401
        assert login(attacker, 'mia').status_code == 429  # that address waits
        # a forged X-Forwarded-For is not believed (no trusted proxy)
        token = csrf_of(attacker.get('/login').text)
        forged = attacker.post('/login', data={'username': 'mia', 'password': PASSWORDS['mia'],
                                               'csrf_token': token},
                               headers={'X-Forwarded-For': '10.9.9.9'}, follow_redirects=False)
        assert forged.status_code == 429
    with fastapi_testclient.TestClient(_From(app, '10.0.0.7')) as owner:
        assert login(owner, 'mia').status_code == 303  # the owner, from elsewhere


def test_a_trusted_proxy_names_the_client(fleet):
    app = create_app(DashboardSettings(history=fleet, max_failures=2, window_s=600.0,
                                       trusted_proxies=('10.0.0.1',)))
    with fastapi_testclient.TestClient(_From(app, '10.0.0.1')) as proxy:
        def attempt(client_ip: str, password: str) -> int:
            token = csrf_of(proxy.get('/login').text)
            return proxy.post('/login', data={'username': 'mia', 'password': password,
                                              'csrf_token': token},
                              headers={'X-Forwarded-For': f'1.2.3.4, {client_ip}'},
                              follow_redirects=False).status_code
        assert [attempt('192.0.2.9', 'wrong password') for _ in range(3)] == [401, 401, 429]
        assert attempt('192.0.2.10', PASSWORDS['mia']) == 303


def test_the_limiter_forgets_and_keeps_a_bounded_number_of_keys():
    now = [0.0]
    limiter = LoginLimiter(max_failures=3, window_s=60.0, clock=lambda: now[0], max_keys=100)
    for i in range(10000):  # a flood of names from many addresses
        limiter.failed(user=f'name{i}', address=f'10.{i // 256}.{i % 256}.1')
        assert len(limiter) <= 100
    now[0] = 61.0
    limiter.failed(user='x', address='10.255.255.1')
    assert len(limiter) == 2  # the expired keys went first
    for _ in range(3):
        limiter.failed(user='x', address='10.255.255.1')
    assert limiter.retry_after_s(user='x', address='10.255.255.1') > 0
    assert limiter.retry_after_s(user='x', address='10.255.255.2') == 0.0


def test_a_login_the_history_cannot_check_is_503_and_not_counted(fleet, monkeypatch):
    def fails(self, **_):
        raise HistoryError(f'{self.path}: cannot check the user: lost the connection')
    app = create_app(DashboardSettings(history=fleet, max_failures=2, window_s=600.0))
    with fastapi_testclient.TestClient(app) as client:
        monkeypatch.setattr(WearHistory, 'verify_user', fails)
        for _ in range(4):
            response = login(client, 'mia')
            assert response.status_code == 503
            assert fleet not in response.text and 'try again' in response.text
        monkeypatch.undo()
        assert login(client, 'mia').status_code == 303  # none of the four counted


def test_a_history_error_is_503_without_the_location(fleet, monkeypatch):
    def fails(self, **_):
        raise HistoryError(f'{self.path}: cannot read the fleet: lost the connection')
    with _client(fleet) as client:
        assert login(client, 'vic').status_code == 303
        monkeypatch.setattr(WearHistory, 'fleet_index', fails)  # what /api/fleet reads
        response = client.get('/api/fleet')
        assert response.status_code == 503, response.text
        assert 'lost the connection' in response.text
        assert fleet not in response.text and '127.0.0.1' not in response.text


def test_the_cookie_is_secure_behind_tls_and_hsts_only_over_own_tls(fleet):
    with _client(fleet) as plain:
        response = login(plain, 'vic')
        assert 'secure' not in response.headers['set-cookie'].lower()
        assert 'strict-transport-security' not in plain.get('/login').headers
    with _client(fleet, behind_tls=True) as proxied:
        response = proxied.get('/login')  # the login form's session (its CSRF token)
        assert '; secure' in response.headers['set-cookie'].lower()
        assert 'strict-transport-security' not in response.headers  # the proxy's business
    with fastapi_testclient.TestClient(create_app(DashboardSettings(history=fleet, https=True)),
                                       base_url='https://testserver') as tls:
        for path in ('/login', '/api/fleet'):
            assert tls.get(path).headers['strict-transport-security'].startswith('max-age=')


def test_a_refused_action_on_the_joint_page_does_not_show_the_location(fleet):
    # press_line joint_1 has no latched alarm: the history refuses the acknowledgement with a
    # message that starts with its own location (a path, or a URL)
    from robot_wear_monitor.dashboard.pages import joint_url
    with _client(fleet) as client:
        assert login(client, 'mia').status_code == 303
        page = joint_url('press_line', 'joint_1')
        token = csrf_of(client.get('/').text)
        response = client.post(page + '/acknowledge', data={'owner': 'Team B', 'comment': '',
                                                            'csrf_token': token},
                               follow_redirects=False)
        assert response.status_code == 303
        shown = client.get(page).text
    flash = shown.split('id="flash">', 1)[1].split('</p>', 1)[0]
    assert 'no latched alarm' in flash or 'alarm' in flash, flash
    host = fleet.split('@')[-1].split('/')[0] if '://' in fleet else fleet
    assert host not in flash and 'postgresql://' not in flash, flash
