"""
The account audit: every change of an account is in the history, listed by ``dashboard audit``.

Every change of a user, role, password or token, from the command line or the Users page, is
recorded (never a secret).

On SQLite and PostgreSQL: the command line's changes (run as an operator runs them, in a
process of their own) come back from ``dashboard audit --json`` with ``cli:<login name>``,
the time and the action; the page's with the admin's name and ``web``; an admin reads them at
``/users/audit``, nobody else.
"""

import getpass
import json
import os
from pathlib import Path
import subprocess
import sys
import time

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.history import HistoryError, open_history
from wear_testing.fleet_history import csrf_of, login, make_fleet, PASSWORDS

REPO = Path(__file__).resolve().parents[2]


def _cli(*args: str, stdin: str = '') -> subprocess.CompletedProcess:
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    return subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', *args], input=stdin,
                          capture_output=True, text=True, env=env, timeout=120)


def test_the_command_lines_account_changes_are_listed_by_dashboard_audit(history_location):
    started = time.time()
    steps = [(('user', 'add', 'ana', '--role', 'viewer'), 'first password 1\n'),
             (('user', 'role', 'ana', '--role', 'maintainer'), ''),
             (('user', 'passwd', 'ana'), 'second password 2\n'),
             (('token', 'add', 'ana', '--label', 'CMMS'), ''),
             (('token', 'remove', 'ana', '--all'), ''),
             (('user', 'remove', 'ana'), '')]
    outputs = []
    for args, stdin in steps:
        done = _cli('dashboard', *args, '--history', history_location, stdin=stdin)
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout)
    token = outputs[3].split()[0]
    assert token.startswith('rwm_')
    listed = _cli('dashboard', 'audit', '--json', '--history', history_location)
    assert listed.returncode == 0, listed.stderr
    for secret in ('first password 1', 'second password 2', token):
        assert secret not in listed.stdout
    records = json.loads(listed.stdout)
    assert [r['action'] for r in records] == ['user_removed', 'tokens_removed', 'token_added',
                                              'password_changed', 'role_changed', 'user_added']
    me = f'cli:{getpass.getuser()}'
    for record in records:
        assert record['user'] == me and record['source'] == 'cli'
        assert record['target'] == 'ana'
        assert started - 1.0 <= record['time_s'] <= time.time()
    times = [r['time_s'] for r in records]
    assert times == sorted(times, reverse=True)
    assert records[4]['detail'] == 'viewer -> maintainer'
    assert 'CMMS' in records[2]['detail']
    table = _cli('dashboard', 'audit', '--limit', '2', '--history', history_location)
    assert table.returncode == 0 and len(table.stdout.strip().splitlines()) == 2
    assert 'user_removed' in table.stdout and me in table.stdout


def test_the_pages_account_changes_are_the_admins_and_only_admins_read_them(history_location):
    history = make_fleet(history_location)
    with open_history(history, init=False) as stored:
        stored.add_user(name='ada', role='admin', password='admin-pass-333')
    PASSWORDS['ada'] = 'admin-pass-333'
    try:
        app = create_app(DashboardSettings(history=history))
        with fastapi_testclient.TestClient(app) as client:
            assert login(client, 'vic').status_code == 303
            assert client.get('/users/audit').status_code == 403
            assert login(client, 'ada').status_code == 303
            token = csrf_of(client.get('/users').text)
            for path, data in (('/users/add', {'name': 'ben', 'role': 'viewer',
                                               'password': 'ben-secret-44'}),
                               ('/users/ben/role', {'role': 'maintainer'}),
                               ('/users/ben/password', {'password': 'ben-secret-55'}),
                               ('/users/ben/remove', {'confirm': 'yes'})):
                response = client.post(path, data={**data, 'csrf_token': token},
                                       follow_redirects=False)
                assert response.status_code == 303, path
            page = client.get('/users/audit')
            assert page.status_code == 200
            assert 'ben-secret' not in page.text
            for action in ('user_added', 'role_changed', 'password_changed', 'user_removed'):
                assert action in page.text
    finally:
        PASSWORDS.pop('ada')
    with open_history(history, init=False) as stored:
        records = stored.account_audit()
    web = [r for r in records if r.target == 'ben']
    assert [r.action for r in web] == ['user_removed', 'password_changed', 'role_changed',
                                       'user_added']
    assert all(r.user == 'ada' and r.source == 'web' for r in web)
    # a refused change leaves no record
    before = len(records)
    with open_history(history, init=False) as stored:
        with pytest.raises(HistoryError, match='no user'):
            stored.set_role(name='nobody', role='viewer')
        assert len(stored.account_audit()) == before
