"""
What guards the dashboard's sessions and its login (issue 37).

* Sessions are kept server-side: a cookie copied before the logout gets 401 from the API and
  a redirect to the login from the pages, and cannot act; a removed user's session is refused
  at once; the session's lifetime is as before (12 h).
* A login attempt is counted before its password check: 40 parallel wrong logins for one
  user run at most :data:`MAX_FAILURES` argon2 checks (a real uvicorn server, real threads).
* ``/login`` refuses a multipart body and a body over 64 kB before reading it.
"""

import asyncio
from concurrent.futures import ThreadPoolExecutor
import socket
import threading
import time

from fastapi import testclient as fastapi_testclient
import httpx
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.auth import LoginBodyLimit, MAX_FAILURES, SESSION_MAX_AGE_S
from robot_wear_monitor.dashboard.guards import BodyGuard, MAX_BODY_BYTES
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.history import open_history, WearHistory
from wear_testing.fleet_history import csrf_of, login, make_fleet, PASSWORDS


@pytest.fixture()
def history(tmp_path) -> str:
    return make_fleet(str(tmp_path / 'fleet.sqlite3'))


def _client(history):
    return fastapi_testclient.TestClient(create_app(DashboardSettings(history=history)))


def test_a_cookie_copied_before_logout_is_worth_nothing_after_it(history):
    app = create_app(DashboardSettings(history=history))  # one server, two browsers
    with fastapi_testclient.TestClient(app) as user, fastapi_testclient.TestClient(app) as thief:
        assert login(user, 'mia').status_code == 303
        url = joint_url('press_line', 'joint_2')
        token = csrf_of(user.get(url).text)
        thief.cookies.update(user.cookies)  # the copy
        assert thief.get('/api/fleet').status_code == 200  # the copy works while logged in
        assert user.post('/logout', data={'csrf_token': token},
                         follow_redirects=False).status_code == 303
        assert thief.get('/api/fleet').status_code == 401
        page = thief.get('/', follow_redirects=False)
        assert page.status_code == 303 and page.headers['location'].startswith('/login')
        acted = thief.post(url + '/acknowledge', data={'csrf_token': token, 'owner': 'x',
                                                       'comment': 'after logout'})
        assert acted.status_code == 401
    with open_history(history, init=False) as stored:
        assert not [e for e in stored.alarm_log() if e.event == 'acknowledged']


def test_a_removed_users_session_is_refused_at_once(history):
    with _client(history) as viewer:
        assert login(viewer, 'vic').status_code == 303
        assert viewer.get('/api/fleet').status_code == 200
        with open_history(history) as stored:
            stored.remove_user(name='vic')
        assert viewer.get('/api/fleet').status_code == 401


def test_a_session_lasts_its_lifetime_and_no_longer(history):
    with WearHistory(history) as stored:
        session = stored.start_session(user='vic', lifetime_s=SESSION_MAX_AGE_S, now_s=1000.0)
        assert session is not None and session.role == 'viewer'
        assert stored.find_session(token=session.token, now_s=1000.0 + 11.9 * 3600) is not None
        assert stored.find_session(token=session.token, now_s=1000.0 + 12.1 * 3600) is None
        assert stored.find_session(token='not-a-session-token-at-all') is None
        assert stored.start_session(user='nobody', lifetime_s=60.0) is None
    assert SESSION_MAX_AGE_S == 12 * 3600


def _free_port():
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def test_forty_parallel_wrong_logins_run_at_most_five_password_checks(history, monkeypatch):
    import uvicorn
    checks = []
    original = WearHistory.verify_user

    def counted(self, *, name, password):
        checks.append(name)
        time.sleep(0.05)  # argon2 takes a while: the attempts overlap
        return original(self, name=name, password=password)
    monkeypatch.setattr(WearHistory, 'verify_user', counted)
    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(create_app(DashboardSettings(history=history)),
                                           host='127.0.0.1', port=port, log_level='warning'))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    base = f'http://127.0.0.1:{port}'
    try:
        deadline = time.monotonic() + 30
        while not server.started:
            assert time.monotonic() < deadline, 'the server did not start'
            time.sleep(0.05)

        def attempt(_):
            with httpx.Client(base_url=base, timeout=60) as client:
                token = csrf_of(client.get('/login').text)
                return client.post('/login', data={'username': 'mia', 'password': 'wrong!!!!',
                                                   'csrf_token': token, 'next': '/'}).status_code
        with ThreadPoolExecutor(max_workers=40) as pool:
            statuses = list(pool.map(attempt, range(40)))
    finally:
        server.should_exit = True
        thread.join(timeout=30)
    assert len(checks) <= MAX_FAILURES, len(checks)
    assert statuses.count(401) == len(checks) and statuses.count(429) == 40 - len(checks)
    assert PASSWORDS['mia'] != 'wrong!!!!'


def test_login_refuses_multipart_and_large_bodies_before_reading_them(history):
    with _client(history) as client:
        token = csrf_of(client.get('/login').text)
        multipart = client.post('/login', data={'username': 'mia', 'csrf_token': token},
                                files={'upload': ('small.bin', b'\0' * 2_000)})
        assert multipart.status_code == 415
        # a body over the limit of every request (guards.BodyGuard) is 413 whatever its kind
        big = client.post('/login', data={'username': 'mia', 'csrf_token': token},
                          files={'upload': ('big.bin', b'\0' * 200_000)})
        assert big.status_code == 413
        large = client.post('/login', content=b'username=mia&password=' + b'x' * 70_000,
                            headers={'content-type': 'application/x-www-form-urlencoded'})
        assert large.status_code == 413
        assert login(client, 'mia').status_code == 303  # an ordinary login still works

    # the ASGI guards answer without calling receive (nothing of the body is read): the login's
    # multipart refusal, and the outer guard's size limit of every body
    assert _guard_status([(b'content-type', b'multipart/form-data; boundary=x'),
                          (b'content-length', b'400000000')]) == 415
    assert _guard_status([(b'content-type', b'application/x-www-form-urlencoded'),
                          (b'content-length', str(MAX_BODY_BYTES + 1).encode())],
                         guard=BodyGuard) == 413


def _guard_status(headers, body=None, *, guard=LoginBodyLimit):
    """
    Return the status ``guard`` answers a ``/login`` POST with, app untouched.

    ``body`` None: the body must not be read at all.
    """
    sent = []

    async def receive():
        assert body is not None, 'the body was read'
        return {'type': 'http.request', 'body': body, 'more_body': False}

    async def send(message):
        sent.append(message)

    async def app(scope, receive_, send_):
        raise AssertionError('the request reached the app')
    scope = {'type': 'http', 'method': 'POST', 'path': '/login', 'headers': headers}
    asyncio.run(guard(app)(scope, receive, send))
    return sent[0]['status']


def test_a_new_login_in_the_same_browser_ends_the_session_it_had(history):
    app = create_app(DashboardSettings(history=history))
    with fastapi_testclient.TestClient(app) as browser, \
            fastapi_testclient.TestClient(app) as thief:
        assert login(browser, 'vic').status_code == 303
        thief.cookies.update(browser.cookies)  # vic's session, copied
        assert thief.get('/api/fleet').status_code == 200
        assert login(browser, 'mia').status_code == 303  # another user, same browser
        assert browser.get('/api/me').json()['name'] == 'mia'
        assert thief.get('/api/fleet').status_code == 401


def test_a_chunked_or_ambiguous_login_body_is_refused_before_the_app_reads_it(history):
    with _client(history) as client:
        def chunks():
            for _ in range(4):
                yield b'username=mia&password=' + b'x' * 20_000
        chunked = client.post('/login', content=chunks(),
                              headers={'content-type': 'application/x-www-form-urlencoded'})
        assert chunked.status_code == 413

    # two Content-Types: the guard cannot know which one a parser takes
    assert _guard_status([(b'content-type', b'multipart/form-data; boundary=B'),
                          (b'content-type', b'application/x-www-form-urlencoded')],
                         guard=BodyGuard) == 400
    assert _guard_status([(b'content-type', b'application/x-www-form-urlencoded'),
                          (b'content-length', b'10'), (b'content-length', b'99')],
                         guard=BodyGuard) == 400


def test_the_last_admin_cannot_be_removed_or_demoted_from_the_page(history):
    from robot_wear_monitor.history import HistoryError
    with WearHistory(history) as stored:
        stored.add_user(name='ada', role='admin', password='admin-pass-333')
        stored.add_user(name='bea', role='admin', password='admin-pass-444')
        stored.set_role(name='bea', role='viewer', keep_an_admin=True)  # ada is left
        with pytest.raises(HistoryError, match='last admin'):
            stored.set_role(name='ada', role='viewer', keep_an_admin=True)
        with pytest.raises(HistoryError, match='last admin'):
            stored.remove_user(name='ada', keep_an_admin=True)
        assert {u.name: u.role for u in stored.users()}['ada'] == 'admin'
        stored.remove_user(name='ada')  # the command line may (it needs no admin)
        assert 'ada' not in {u.name for u in stored.users()}
