"""
``dashboard --notify CONFIG``: the server process sends the fleet's notifications, once.

A webhook receiver on 127.0.0.1 (the test's own, stdlib ``http.server``) gets the alarm of the
known fleet while the app runs; a second app on the same history sends nothing again (the
history keeps what was sent).  The command line refuses a bad configuration before serving.
"""

import json
import time

from fastapi.testclient import TestClient
import pytest
from robot_wear_monitor.cli import main as cli_main
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.notifier import load_config
from wear_testing.fleet_history import make_fleet
from wear_testing.webhook_receiver import webhook_receiver


@pytest.fixture()
def receiver():
    """Yield (URL, list of received JSON bodies) of a webhook receiver on 127.0.0.1."""
    with webhook_receiver() as hook:
        yield hook


def _config(tmp_path, url: str):
    path = tmp_path / 'notifications.yaml'
    path.write_text(f'events: [alarm_raised]\nwebhooks:\n  - name: ops\n    url: {url}\n')
    return path


def _run_app(history: str, config, seconds: float, received: list, want: int) -> None:
    settings = DashboardSettings(history=history, notifications=load_config(str(config)))
    # passes 0.2 s apart for the test's pace; a site's interval is >= 1 s (the declared
    # setting's range, checked when the settings are made)
    settings.notify_interval_s = 0.2
    app = create_app(settings)
    with TestClient(app):
        deadline = time.monotonic() + seconds
        while len(received) < want and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.6)  # a few more passes: nothing is sent twice


def test_the_server_sends_the_alarm_once(tmp_path, receiver):
    url, received = receiver
    history = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    config = _config(tmp_path, url)
    _run_app(history, config, 20.0, received, want=1)
    assert len(received) == 1
    text = json.dumps(received[0])
    assert 'press_line' in text and 'joint_2' in text
    _run_app(history, config, 1.0, received, want=2)  # a restarted server
    assert len(received) == 1


def test_a_bad_configuration_stops_the_start(tmp_path, capsys):
    history = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    bad = tmp_path / 'bad.yaml'
    bad.write_text('webhooks:\n  - name: ops\n    url: ftp://nowhere\n')
    assert cli_main(['dashboard', '--history', history, '--notify', str(bad)]) == 2
    assert 'url' in capsys.readouterr().err


def test_the_settings_hold_the_configuration_once_and_the_pages_order_by_it(tmp_path):
    """``dashboard --notify``: one parsed configuration sends and sets the page's margin."""
    from types import SimpleNamespace

    from robot_wear_monitor.dashboard.views import reescalation_margin
    from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN
    path = tmp_path / 'notifications.yaml'
    path.write_text('events: [alarm_raised]\nreescalation_margin: 7.5\n'
                    'webhooks:\n  - name: ops\n    url: http://127.0.0.1:9/hook\n')
    settings = DashboardSettings(history=':memory:', notifications=load_config(str(path)))
    request = SimpleNamespace(app=SimpleNamespace(state=SimpleNamespace(settings=settings)))
    assert reescalation_margin(request) == 7.5
    assert not hasattr(settings, 'extra') and not hasattr(settings, 'notify_config')
    plain = SimpleNamespace(app=SimpleNamespace(state=SimpleNamespace(
        settings=DashboardSettings(history=':memory:'))))
    assert reescalation_margin(plain) == DEFAULT_REESCALATION_MARGIN != 7.5
