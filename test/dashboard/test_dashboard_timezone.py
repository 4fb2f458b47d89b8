"""
The plant's clock on the dashboard (issue 44): ``display_timezone`` on the pages, UTC in the API.

The plan's fleet (``wear_testing.fleet_history``) written so that its last experiments (and
the raise of press_line joint_2) are at 11:30 UTC on a winter day and 10:30 UTC on a summer
day: 12:30 in Stockholm both times, CET in winter and CEST in summer.
"""

import datetime
import re

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.errors import InputError
from wear_testing.fleet_history import HOUR_S, login, make_fleet

WINTER_S = datetime.datetime(2026, 1, 15, 11, 30, tzinfo=datetime.timezone.utc).timestamp()
SUMMER_S = datetime.datetime(2026, 7, 15, 10, 30, tzinfo=datetime.timezone.utc).timestamp()


def _client(history: str, **settings):
    return fastapi_testclient.TestClient(create_app(DashboardSettings(history=history,
                                                                      **settings)))


@pytest.mark.parametrize('last_s, day, iso, shown', [
    (WINTER_S, '2026-01-15', '2026-01-15T11:30:00Z', '2026-01-15 12:30 CET'),
    (SUMMER_S, '2026-07-15', '2026-07-15T10:30:00Z', '2026-07-15 12:30 CEST')])
def test_the_pages_show_the_plants_clock_and_the_api_stays_utc(tmp_path, last_s, day, iso,
                                                               shown):
    history = make_fleet(str(tmp_path / 'fleet.sqlite3'), now_s=last_s + HOUR_S)
    with _client(history, display_timezone='Europe/Stockholm') as client:
        assert login(client, 'vic').status_code == 303
        page = client.get('/').text
        assert f'LATCHED since <span class="t">{shown}</span>' in page
        assert f'<td class="c-last"><span class="t">{shown}</span>' in page
        assert iso not in page and 'Europe/Stockholm' in page  # the footer names the zone
        fleet = client.get('/api/fleet').json()
        row = next(r for r in fleet['rows'] if r['robot'] == 'press_line'
                   and r['joint'] == 'joint_2')
        # the machine's fields as before; the words the page shows in the plant's zone
        assert (row['last_stamp_s'], row['last_experiment'], row['alarm_since']) == (
            last_s, iso, iso)
        assert row['text']['alarm'] == f'LATCHED since {shown}'
        assert row['text']['last'].startswith(shown)
        events = client.get('/api/alarms').json()
        assert (events[0]['time'], events[0]['time_text'], events[0]['event_time_s']) == (
            iso, shown, last_s)
        log = client.get('/alarms').text
        assert shown in log and iso not in log
        joint = client.get(joint_url('press_line', 'joint_2')).text
        assert shown in joint and day in joint
    with _client(history, display_timezone='Europe/Stockholm') as client:
        # the users page and the account audit (an admin's): on the plant's clock too
        from robot_wear_monitor.history import open_history
        with open_history(history, init=False) as stored:
            stored.add_user(name='ada', role='admin', password='admin-pass-333')
        assert login(client, 'ada', 'admin-pass-333').status_code == 303
        users = client.get('/users').text
        assert '<th>created</th>' in users and 'Z</td>' not in users
        assert re.search(r'\d{4}-\d{2}-\d{2} \d{2}:\d{2} CES?T', users)
    with _client(history) as client:  # the default: UTC, ISO 8601, as before the setting
        assert login(client, 'vic').status_code == 303
        page = client.get('/').text
        assert f'LATCHED since <span class="t">{iso}</span>' in page and shown not in page
        plain = client.get('/api/fleet').json()
    # only the words differ between the two: every machine field is the same
    for zoned, utc in zip(fleet['rows'], plain['rows']):
        assert {k: v for k, v in zoned.items() if k not in ('text', 'acknowledged_at_text')} \
            == {k: v for k, v in utc.items() if k not in ('text', 'acknowledged_at_text')}


def test_a_bad_zone_stops_the_start_with_a_clear_error(tmp_path, capsys):
    history = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    with pytest.raises(InputError, match=r'display_timezone: not an IANA time zone name.*'
                                         r"got 'Mars/Olympus_Mons'"):
        create_app(DashboardSettings(history=history, display_timezone='Mars/Olympus_Mons'))
    capsys.readouterr()
    assert main(['dashboard', '--history', history, '--display-timezone',
                 '../../etc/passwd']) == 2
    err = capsys.readouterr().err
    assert '--display-timezone' in err and "'../../etc/passwd'" in err
