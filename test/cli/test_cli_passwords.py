"""
No history password is ever printed: both URL forms, every verb that shows a location.

A PostgreSQL history given as ``postgresql://USER:PASSWORD@HOST/DB`` or with ``?password=`` is
shown with ``***`` in the one-bag replay summary, the ``dashboard`` and ``notify`` start lines,
and the ``fleet``/``history`` errors for an unknown robot; the command line's output guard
replaces the password in anything else it prints.  The test server uses trust
authentication, so a URL with any password connects.
"""

import os
import select
import socket
import subprocess
import sys
import time

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.history import open_history
from robot_wear_monitor.history.passwords import location_secrets, redact_location
from wear_testing.paths import console_script, REPO_ROOT

PASSWORD = 'Pa55-w0rd%21s3cret'  # percent-encoded '!' : printed neither raw nor decoded
DECODED = 'Pa55-w0rd!s3cret'


def _with_password(url: str, form: str) -> str:
    scheme, rest = url.split('://', 1)
    if form == 'userinfo':
        user, host = rest.split('@', 1)
        return f'{scheme}://{user}:{PASSWORD}@{host}'
    return f'{url}?sslmode=disable&password={PASSWORD}'


def _assert_hidden(text: str) -> None:
    assert PASSWORD not in text and DECODED not in text, text
    assert 's3cret' not in text, text


def test_a_location_is_shown_without_its_password_in_both_forms():
    for form in ('userinfo', 'query'):
        url = _with_password('postgresql://wear@db.example.invalid:5432/fleet', form)
        shown = redact_location(url)
        _assert_hidden(shown)
        assert '***' in shown and 'db.example.invalid' in shown and 'wear' in shown
        assert PASSWORD in location_secrets(url) and DECODED in location_secrets(url)
    assert redact_location('/var/lib/wear/h.sqlite3') == '/var/lib/wear/h.sqlite3'
    assert location_secrets('/var/lib/wear/h.sqlite3') == []


@pytest.fixture
def fleet_url(postgresql_url, tmp_path):
    """Return the URL of a history holding robot r1's joint_2 (made by a one-bag replay)."""
    bag = tmp_path / 'run.bag'
    assert main(['simulate', '--out', str(bag), '--experiments', '3', '--seed', '1']) == 0
    return postgresql_url, bag


@pytest.mark.parametrize('form', ['userinfo', 'query'])
def test_no_password_in_replay_fleet_and_history_outputs(fleet_url, form, capsys):
    url, bag = fleet_url
    location = _with_password(url, form)
    outputs = []
    capsys.readouterr()
    assert main(['replay', str(bag), '--history', location, '--init', '--robot', 'r1',
                 '--no-progress']) == 0
    outputs.append(capsys.readouterr())
    assert main(['fleet', '--history', location, '--robot', 'nobody']) == 2
    outputs.append(capsys.readouterr())
    assert main(['history', location, '--robot', 'nobody']) == 2
    outputs.append(capsys.readouterr())
    text = '\n'.join(o.out + o.err for o in outputs)
    _assert_hidden(text)
    assert text.count('***') >= 3  # the summary line and both errors name the location
    with open_history(url, init=False) as history:  # the replay did write there
        assert list(history.robots()) == ['r1']


def _first_lines(command, *, stream, count, timeout_s=60.0):
    """Start ``command``; return its first ``count`` lines of ``stream`` and stop it."""
    env = {**os.environ, 'PYTHONUNBUFFERED': '1'}
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=env, cwd=REPO_ROOT)
    pipe = process.stderr if stream == 'stderr' else process.stdout
    lines = []
    deadline = time.monotonic() + timeout_s
    try:
        while len(lines) < count and time.monotonic() < deadline:
            ready, _, _ = select.select([pipe], [], [], 0.5)
            if ready:
                line = pipe.readline()
                if not line:
                    break
                lines.append(line)
    finally:
        process.terminate()
        try:
            rest_out, rest_err = process.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            rest_out, rest_err = process.communicate()
    return ''.join(lines), rest_out + rest_err


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return int(probe.getsockname()[1])


@pytest.mark.parametrize('form', ['userinfo', 'query'])
def test_no_password_in_the_dashboard_and_notify_start_lines(fleet_url, form, tmp_path):
    url, bag = fleet_url
    assert main(['replay', str(bag), '--history', url, '--init', '--no-progress']) == 0
    location = _with_password(url, form)
    started, rest = _first_lines(
        [console_script('robot-wear-monitor'), 'dashboard', '--history', location, '--port',
         str(_free_port())], stream='stderr', count=2)
    assert 'dashboard of postgresql://' in started, started + rest
    _assert_hidden(started + rest)
    config = tmp_path / 'notify.yaml'
    config.write_text('webhooks:\n  - url: http://127.0.0.1:9/hook\n', encoding='utf-8')
    started, rest = _first_lines(
        [console_script('robot-wear-monitor'), 'notify', '--history', location, '--config',
         str(config), '--interval-s', '3600'], stream='stdout', count=1)
    assert started.startswith('notify: postgresql://'), started + rest
    _assert_hidden(started + rest)


def test_the_guard_hides_a_password_that_a_command_prints_anywhere(capsys, monkeypatch):
    # a library message that echoes the location (here: a fleet over a server that refuses
    # the connection) passes through the guard
    location = f'postgresql://wear:{PASSWORD}@127.0.0.1:{_free_port()}/fleet'
    capsys.readouterr()
    assert main(['fleet', '--history', location]) == 2
    captured = capsys.readouterr()
    _assert_hidden(captured.out + captured.err)
    assert sys.stdout is not None and 'error' in captured.err


def test_argparse_messages_print_no_password_for_any_verb():
    # argparse echoes the words of a mistake: a mistyped option, a missing or an invalid value
    # next to a URL with a password; the guard is on before the parsing (every verb's parser,
    # through the main entry, each in its own process as an operator would run it)
    from robot_wear_monitor.cli import VERBS
    commands = []
    for verb in VERBS:
        url, query = (_with_password('postgresql://rwm@db.example.invalid:5432/fleet', form)
                      for form in ('userinfo', 'query'))
        commands += [[verb, '--histroy', url], [verb, '--histroy', query],
                     [verb, url, '--history'], [verb, f'--history={query}', '--port', url]]
    results = []
    for start in range(0, len(commands), 8):  # eight at a time: a machine of a few cores
        batch = [subprocess.Popen([sys.executable, '-m', 'robot_wear_monitor.cli', *argv],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  cwd=REPO_ROOT, stdin=subprocess.DEVNULL)
                 for argv in commands[start:start + 8]]
        results += [(argv, *process.communicate(timeout=120), process.returncode)
                    for argv, process in zip(commands[start:start + 8], batch)]
    for argv, out, err, code in results:
        assert code == 2, (argv, err)
        assert 'error:' in err, (argv, err)
        _assert_hidden(out + err)
    # the messages that echo the URL still show where it pointed
    echoed = [err for argv, _, err, _ in results
              if argv[1] == '--histroy' and 'unrecognized arguments: --histroy post' in err]
    assert len(echoed) >= 4  # verbs without required options echo the URL
    assert all('db.example.invalid' in err and ':***@' in err or 'password=***' in err
               for err in echoed)
