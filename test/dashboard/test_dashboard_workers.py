"""
``dashboard --workers 2`` on one PostgreSQL history: what one worker does holds on the other.

Real processes (the command line, uvicorn's supervisor and two workers), a real PostgreSQL
server (the tests' own), real HTTP on 127.0.0.1, a webhook receiver of the test's own.  Every
request goes on a new connection, and the kernel hands each to whichever worker accepts it; the
workers name themselves in ``X-Dashboard-Worker`` (only with
``ROBOT_WEAR_MONITOR_DASHBOARD_WORKER_PID=1``), so the test knows which one answered and goes
on until both have.  Checked: a login through one worker is a session on both, and a logout
through one ends it on both; an acknowledgement written through one shows through the other
(the fleet's ETag moves there, the row is acknowledged); with two notifier loops each
notification reaches the receiver exactly once; failed logins spread over both workers hit
the limit at the configured count (5), and both refuse after it.  An SQLite history is
refused for more than one worker, with one line.
"""

import os
from pathlib import Path
import socket
import subprocess
import sys
import time

import httpx
import pytest
from robot_wear_monitor.cli import main as cli_main
from robot_wear_monitor.dashboard.auth import MAX_FAILURES
from robot_wear_monitor.dashboard.workers import WORKER_PID_ENV, WORKER_PID_HEADER
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import csrf_of, make_fleet, PASSWORDS
from wear_testing.webhook_receiver import webhook_receiver

REPO = Path(__file__).resolve().parents[2]
ALARMED = '/api/robots/press_line/joints/joint_2'
#: How long to go on before giving up on seeing both workers (the second may still start) [s].
BOTH_WITHIN_S = 120.0


@pytest.fixture()
def receiver():
    """Yield (URL, list of received JSON bodies) of a webhook receiver on 127.0.0.1."""
    with webhook_receiver() as hook:
        yield hook


class Workers:
    """The dashboard's address; requests on new connections, each answer's worker."""

    def __init__(self, base: str) -> None:
        self.base = base
        self.cookie = ''
        self.frozen = False  # keep the cookie whatever the answers set (a copied cookie)

    def request(self, method: str, path: str, **kwargs) -> tuple[httpx.Response, str]:
        """Send one request on a new connection (the cookie kept); return it and its worker."""
        headers = dict(kwargs.pop('headers', {}))
        if self.cookie:
            headers['Cookie'] = self.cookie
        with httpx.Client(base_url=self.base, timeout=10) as client:
            response = client.request(method, path, headers=headers, **kwargs)
        for value in response.headers.get_list('set-cookie'):
            if value.startswith('rwm_session=') and not self.frozen:
                self.cookie = value.split(';', 1)[0]
        return response, response.headers[WORKER_PID_HEADER]

    def on_each(self, method: str, path: str, **kwargs) -> dict[str, httpx.Response]:
        """Send the request until both workers have answered it; return an answer of each."""
        answers: dict[str, httpx.Response] = {}
        deadline = time.monotonic() + BOTH_WITHIN_S
        while time.monotonic() < deadline:
            response, pid = self.request(method, path, **kwargs)
            answers.setdefault(pid, response)
            if len(answers) == 2:
                return answers
            time.sleep(0.02)
        raise AssertionError(f'requests for {BOTH_WITHIN_S:g} s reached one worker only: '
                             f'{sorted(answers)}')

    def on_other(self, pid: str, method: str, path: str, **kwargs) -> httpx.Response:
        """Send the request until a worker other than ``pid`` answers; return its answer."""
        deadline = time.monotonic() + BOTH_WITHIN_S
        while time.monotonic() < deadline:
            response, answered = self.request(method, path, **kwargs)
            if answered != pid:
                return response
            time.sleep(0.02)
        raise AssertionError(f'requests for {BOTH_WITHIN_S:g} s reached worker {pid} only')

    def login(self, name: str, password: str) -> tuple[httpx.Response, str]:
        """Log in (the login form's CSRF token first); return the answer and its worker."""
        form, _ = self.request('GET', '/login')
        return self.request('POST', '/login', data={
            'username': name, 'password': password, 'csrf_token': csrf_of(form.text),
            'next': '/'})


def _start(history: str, config: Path, port: int, log: Path) -> subprocess.Popen:
    """Start the command; its output goes to ``log`` (a pipe nobody reads would fill up)."""
    env = {**os.environ, 'PYTHONPATH': str(REPO), WORKER_PID_ENV: '1'}
    env.pop('ROBOT_WEAR_MONITOR_DASHBOARD_SECRET', None)  # the parent makes the key
    with open(log, 'wb') as out:
        return subprocess.Popen(
            [sys.executable, '-m', 'robot_wear_monitor.cli', 'dashboard', '--history',
             history, '--port', str(port), '--workers', '2', '--notify', str(config),
             '--notify-interval-s', '1'], env=env, stdout=out, stderr=subprocess.STDOUT)


def _wait_ready(process: subprocess.Popen, base: str, log: Path) -> None:
    deadline = time.monotonic() + 90
    while True:
        assert process.poll() is None, log.read_text()[-3000:]
        try:
            if httpx.get(f'{base}/login', timeout=2).status_code == 200:
                return
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline, 'the dashboard did not answer'
        time.sleep(0.3)


def _kinds(received: list) -> list[tuple[str, str]]:
    """Return (status, alert name) of each received body's alerts."""
    return [(alert['status'], alert['labels']['alertname'])
            for body in received for alert in body['alerts']]


def test_two_workers_share_sessions_limits_notifications_and_news(
        tmp_path, postgresql_url, receiver):
    url, received = receiver
    history = make_fleet(postgresql_url)
    config = tmp_path / 'notifications.yaml'
    config.write_text(f'events: [alarm_raised]\nwebhooks:\n  - name: ops\n    url: {url}\n')
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        port = probe.getsockname()[1]
    base = f'http://127.0.0.1:{port}'
    log = tmp_path / 'dashboard.log'
    process = _start(history, config, port, log)
    try:
        _wait_ready(process, base, log)
        dash = Workers(base)
        # a session made through one worker holds on both (one key, sessions in the history)
        logged_in, _ = dash.login('mia', PASSWORDS['mia'])
        assert logged_in.status_code == 303, logged_in.text
        me = dash.on_each('GET', '/api/me')
        assert len(set(me)) == 2
        assert all(r.status_code == 200 and r.json()['name'] == 'mia' for r in me.values())
        csrf = next(iter(me.values())).json()['csrf_token']
        # the news: both workers give the fleet the same ETag; an acknowledgement through
        # one moves it on the other, whose row is acknowledged
        before = dash.on_each('GET', '/api/fleet')
        tags = {r.headers['etag'] for r in before.values()}
        assert len(tags) == 1, tags
        tag = tags.pop()
        assert all(dash.on_each('GET', '/api/fleet', headers={'If-None-Match': tag})[pid]
                   .status_code == 304 for pid in before)
        acked, writer = dash.request('POST', ALARMED + '/acknowledge', json={
            'owner': 'Team B', 'comment': 'through one worker'},
            headers={'X-CSRF-Token': csrf})
        assert acked.status_code == 200, acked.text
        other = dash.on_other(writer, 'GET', '/api/fleet', headers={'If-None-Match': tag})
        assert other.status_code == 200 and other.headers['etag'] != tag
        row = next(r for r in other.json()['rows']
                   if (r['robot'], r['joint']) == ('press_line', 'joint_2'))
        assert row['acknowledged'] and row['acknowledged_by'] == 'mia'
        # two notifier loops: the alarm and its acknowledgement, each sent exactly once
        deadline = time.monotonic() + 60
        while len(received) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(3.5)  # more passes of both loops: nothing is sent again
        kinds = _kinds(received)
        assert sorted(kinds) == [('firing', 'WearAlarmAcknowledged'),
                                 ('firing', 'WearAlarmRaised')], kinds
        with open_history(history, init=False) as stored:
            claims = [n['event_key'] for n in stored.notifications()]
        assert len(claims) == len(set(claims)) == 2, claims
        # a logout through one worker ends the session on both
        copied = dash.cookie
        out, _ = dash.request('POST', '/logout', data={'csrf_token': csrf})
        assert out.status_code == 303, out.text
        dash.cookie, dash.frozen = copied, True  # the cookie of before the logout, kept
        ended = dash.on_each('GET', '/api/me')
        assert all(r.status_code == 401 for r in ended.values()), \
            [r.status_code for r in ended.values()]
        # failed logins on both workers count together: the limit at MAX_FAILURES attempts
        dash.cookie, dash.frozen = '', False
        wrong: dict[str, int] = {}
        refused: set[str] = set()
        deadline = time.monotonic() + BOTH_WITHIN_S
        while time.monotonic() < deadline:
            answer, pid = dash.login('mia', 'not the password')
            if answer.status_code == 401:
                wrong[pid] = wrong.get(pid, 0) + 1
            else:
                assert answer.status_code == 429, answer.text
                assert sum(wrong.values()) == MAX_FAILURES
                refused.add(pid)
            if len(refused) == 2:
                break
        assert sum(wrong.values()) == MAX_FAILURES, wrong
        assert len(refused) == 2, 'one worker never refused'
        # a worker that counted fewer than MAX_FAILURES itself refused: the counts are shared
        assert any(wrong.get(pid, 0) < MAX_FAILURES for pid in refused)
        right, _ = dash.login('mia', PASSWORDS['mia'])
        assert right.status_code == 429  # the address is held back on every worker
    finally:
        process.terminate()
        process.wait(timeout=60)
    err = log.read_text()
    assert 'Traceback' not in err, err[-3000:]
    assert err.count('Started server process') == 2, err[-3000:]


def test_more_than_one_worker_needs_postgresql(tmp_path, capsys):
    history = make_fleet(str(tmp_path / 'h.sqlite3'))
    assert cli_main(['dashboard', '--history', history, '--workers', '2']) == 2
    error = capsys.readouterr().err
    assert '--workers 2 needs a PostgreSQL history' in error
    assert len(error.strip().splitlines()) == 1
    assert cli_main(['dashboard', '--history', history, '--workers', '0']) == 2
    assert 'argument --workers: must be >= 1 and <= 64, got 0' in capsys.readouterr().err
