"""
``robot-wear-monitor dashboard``: users from the command line, the host rule, a real start.

The password is read from stdin (never argv); a non-loopback ``--host`` without TLS or
``--insecure-http`` is refused with exit 2; the command serves the login page on the port given.
"""

import io
import os
from pathlib import Path
import socket
import subprocess
import sys
import time

import httpx
import pytest
from robot_wear_monitor.cli import main as cli_main
from robot_wear_monitor.dashboard.server import check_listen, is_loopback
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import make_fleet

REPO = Path(__file__).resolve().parents[2]


def _cli(*args: str, stdin: str = '') -> subprocess.CompletedProcess:
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    return subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', *args], input=stdin,
                          capture_output=True, text=True, env=env, timeout=120)


def test_users_added_listed_and_removed(tmp_path):
    history = str(tmp_path / 'h.sqlite3')
    added = _cli('dashboard', 'user', 'add', 'ana', '--role', 'maintainer', '--history',
                 history, stdin='a long password\n')
    assert added.returncode == 0, added.stderr
    assert 'ana' in added.stdout and 'a long password' not in added.stdout
    with open_history(history, init=False) as stored:
        assert stored.verify_user(name='ana', password='a long password').role == 'maintainer'
        assert stored.verify_user(name='ana', password='a long password\n') is None
    listed = _cli('dashboard', 'user', 'list', '--history', history)
    assert listed.returncode == 0 and 'ana  maintainer' in listed.stdout
    again = _cli('dashboard', 'user', 'add', 'ana', '--role', 'viewer', '--history', history,
                 stdin='another password\n')
    assert again.returncode == 2 and 'ana' in again.stderr
    short = _cli('dashboard', 'user', 'add', 'bob', '--role', 'viewer', '--history', history,
                 stdin='short\n')
    assert short.returncode == 2 and len(short.stderr.strip().splitlines()) == 1
    removed = _cli('dashboard', 'user', 'remove', 'ana', '--history', history)
    assert removed.returncode == 0
    with open_history(history, init=False) as stored:
        assert stored.users() == []


def test_no_password_on_the_command_line(tmp_path, capsys):
    history = str(tmp_path / 'h.sqlite3')
    assert cli_main(['dashboard', 'user', 'add', 'ana', '--role', 'viewer', '--history',
                     history, '--password', 'a long password']) == 2
    assert 'unrecognized arguments' in capsys.readouterr().err
    assert cli_main(['dashboard', 'user', 'add', 'ana', '--role', 'root', '--history',
                     history]) == 2
    assert cli_main(['dashboard', 'user', 'passwd', 'ana', '--password', 'a long password',
                     '--history', history]) == 2
    assert 'unrecognized arguments' in capsys.readouterr().err


def test_a_host_reachable_from_other_machines_needs_tls(tmp_path, capsys):
    history = make_fleet(str(tmp_path / 'h.sqlite3'))
    assert cli_main(['dashboard', '--history', history, '--host', '0.0.0.0']) == 2
    error = capsys.readouterr().err
    assert '--tls-cert' in error and '--insecure-http' in error
    assert cli_main(['dashboard', '--history', history, '--tls-cert', 'cert.pem']) == 2
    assert 'go together' in capsys.readouterr().err
    assert cli_main(['dashboard', '--history', str(tmp_path / 'none.sqlite3')]) == 2
    for host in ('127.0.0.1', '127.0.0.2', '::1', 'localhost'):
        assert is_loopback(host), host
        check_listen(host=host, tls_cert=None, tls_key=None, insecure_http=False)
    for host in ('0.0.0.0', '10.1.2.3', '::'):
        assert not is_loopback(host), host
        with pytest.raises(InputError):
            check_listen(host=host, tls_cert=None, tls_key=None, insecure_http=False)
        check_listen(host=host, tls_cert=None, tls_key=None, insecure_http=True)


def test_the_command_serves_the_login_page(tmp_path):
    history = make_fleet(str(tmp_path / 'h.sqlite3'))
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        port = sock.getsockname()[1]
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    process = subprocess.Popen([sys.executable, '-m', 'robot_wear_monitor.cli', 'dashboard',
                                '--history', history, '--port', str(port)], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while True:
            assert process.poll() is None, process.communicate()[1]
            try:
                response = httpx.get(f'http://127.0.0.1:{port}/login', timeout=2)
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline, 'the dashboard did not answer'
                time.sleep(0.2)
        assert response.status_code == 200 and 'name="username"' in response.text
        assert httpx.get(f'http://127.0.0.1:{port}/api/fleet').status_code == 401
    finally:
        process.terminate()
        _, err = process.communicate(timeout=30)
    assert f'127.0.0.1:{port}' in err


def test_a_taken_port_is_one_line_naming_the_port(tmp_path):
    history = make_fleet(str(tmp_path / 'h.sqlite3'))
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        result = _cli('dashboard', '--history', history, '--port', str(port))
    assert result.returncode == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith('robot-wear-monitor dashboard: error: --port ')
    assert f'127.0.0.1:{port} is already in use' in lines[0]
    assert 'dashboard of' not in result.stderr + result.stdout  # no start line before it
    assert 'errno' not in result.stderr.lower()


def test_a_new_password_and_role_from_the_command_line(tmp_path, monkeypatch, capsys):
    history = str(tmp_path / 'h.sqlite3')
    monkeypatch.setattr('sys.stdin', io.StringIO('first password\n'))
    assert cli_main(['dashboard', 'user', 'add', 'ana', '--role', 'viewer', '--history',
                     history]) == 0
    with open_history(history, init=False) as stored:
        session = stored.start_session(user='ana', lifetime_s=3600.0)
    monkeypatch.setattr('sys.stdin', io.StringIO('second password\n'))
    assert cli_main(['dashboard', 'user', 'passwd', 'ana', '--history', history]) == 0
    out = capsys.readouterr().out
    assert 'new password of ana stored; 1 session(s) ended' in out and 'second' not in out
    monkeypatch.setattr('sys.stdin', io.StringIO('short\n'))
    assert cli_main(['dashboard', 'user', 'passwd', 'ana', '--history', history]) == 2
    assert 'at least 8 characters' in capsys.readouterr().err
    assert cli_main(['dashboard', 'user', 'passwd', 'bob', '--history', history]) == 2
    assert "no user 'bob'" in capsys.readouterr().err
    assert cli_main(['dashboard', 'user', 'role', 'ana', '--role', 'admin', '--history',
                     history]) == 0
    assert 'user ana is now admin' in capsys.readouterr().out
    with open_history(history, init=False) as stored:
        assert stored.find_session(token=session.token) is None
        assert stored.verify_user(name='ana', password='first password') is None
        assert stored.verify_user(name='ana', password='second password').role == 'admin'


def test_api_tokens_from_the_command_line_are_shown_once(tmp_path, capsys):
    history = str(tmp_path / 'h.sqlite3')
    added = _cli('dashboard', 'user', 'add', 'ana', '--role', 'maintainer', '--history',
                 history, stdin='a long password\n')
    assert added.returncode == 0, added.stderr
    made = _cli('dashboard', 'token', 'add', 'ana', '--label', 'CMMS', '--history', history)
    assert made.returncode == 0, made.stderr
    token = made.stdout.strip()
    assert token.startswith('rwm_') and 'shown this once' in made.stderr
    with open_history(history, init=False) as stored:
        assert stored.find_token(token=token).user == 'ana'
    listed = _cli('dashboard', 'token', 'list', 'ana', '--history', history)
    assert listed.returncode == 0 and token not in listed.stdout + listed.stderr
    assert listed.stdout.startswith('1  ana  created ') and 'CMMS' in listed.stdout
    assert 'last used 20' in listed.stdout  # the find_token above used it
    assert token.encode() not in Path(history).read_bytes()
    assert cli_main(['dashboard', 'token', 'remove', 'ana', '--history', history]) == 2
    assert 'one of the arguments --id --all is required' in capsys.readouterr().err
    assert cli_main(['dashboard', 'token', 'remove', 'ana', '--id', '7', '--history',
                     history]) == 2
    assert "no token 7 of user 'ana'" in capsys.readouterr().err
    assert cli_main(['dashboard', 'token', 'add', 'bob', '--history', history]) == 2
    assert "no user 'bob'" in capsys.readouterr().err
    assert cli_main(['dashboard', 'token', 'remove', 'ana', '--id', '1', '--history',
                     history]) == 0
    assert '1 API token(s) of ana removed' in capsys.readouterr().out
    with open_history(history, init=False) as stored:
        assert stored.find_token(token=token) is None
    assert cli_main(['dashboard', 'token', 'list', '--history', history]) == 0
    assert 'no API tokens' in capsys.readouterr().out
    # a removed user's tokens go with them
    again = _cli('dashboard', 'token', 'add', 'ana', '--history', history).stdout.strip()
    assert _cli('dashboard', 'user', 'remove', 'ana', '--history', history).returncode == 0
    with open_history(history, init=False) as stored:
        assert stored.find_token(token=again) is None and stored.tokens() == []
