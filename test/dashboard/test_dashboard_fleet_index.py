"""
The fleet page and ``/api/fleet`` read through the index give the full ranking, on both stores.

On the history of every state (``wear_testing.fleet_states``): the streamed ``/api/fleet``
holds every row in the order and with the ``state`` of
:func:`~robot_wear_monitor.fleet.ranking.fleet_view` of the whole fleet, as one JSON document;
its pages and the fleet page's rows are slices of it; the counts are those of the full list;
the robot search finds by prefix first and the page lists no robot.
"""

import re
import time

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.fleet.ranking import fleet_view
from robot_wear_monitor.fleet.states import STATES
from robot_wear_monitor.history import WearHistory
from wear_testing.fleet_history import login, PASSWORDS
from wear_testing.fleet_states import _fill

ROW = re.compile(r'<tr class="state-[^"]*" data-robot="([^"]*)" data-joint="([^"]*)"')


@pytest.fixture
def client(history_location):
    with WearHistory(history_location) as history:
        _fill(history)
        history.add_user(name='vic', role='viewer', password=PASSWORDS['vic'])
    app = create_app(DashboardSettings(history=history_location))
    with fastapi_testclient.TestClient(app) as made:
        assert login(made, 'vic').status_code == 303
        yield made


def _truth(history_location):
    with WearHistory(history_location) as history:
        views = fleet_view(history.fleet(), now_s=time.time())
    return [(v.state.robot, v.state.joint, v.condition) for v in views]


def test_the_streamed_api_and_the_pages_are_the_full_ranking(client, history_location):
    truth = _truth(history_location)
    answer = client.get('/api/fleet')
    assert answer.status_code == 200 and answer.headers['etag']
    fleet = answer.json()
    assert [(r['robot'], r['joint'], r['state']) for r in fleet['rows']] == truth
    assert fleet['counts'] == {s: sum(1 for *_, state in truth if state == s) for s in STATES}
    assert fleet['total'] == fleet['joints'] == len(truth) and fleet['robot_count'] == 5
    assert fleet['robots'] == sorted({r for r, _, _ in truth})
    assert client.get('/api/fleet', headers={'If-None-Match': answer.headers['etag']}
                      ).status_code == 304
    for page in (1, 2, 3, 4):
        paged = client.get('/api/fleet', params={'page': page, 'limit': 5}).json()
        assert [(r['robot'], r['joint'], r['state']) for r in paged['rows']] == \
            truth[5 * (page - 1):5 * page]
    html = client.get('/', params={'limit': 6, 'page': 2}).text
    assert ROW.findall(html) == [(r, j) for r, j, _ in truth[6:12]]
    for state in STATES:
        rows = client.get('/api/fleet', params={'state': state}).json()['rows']
        assert [(r['robot'], r['joint'], r['state']) for r in rows] == [
            row for row in truth if row[2] == state]
    assert client.get('/api/fleet', params={'robot': 'cell'}).status_code == 404


def test_the_robot_filter_is_a_search(client):
    found = client.get('/api/robots', params={'search': 'cell'}).json()
    assert found == {'search': 'cell', 'robots': ['cell_a', 'cell_b', 'cell_c', 'cell_d',
                                                  'arm_cell_e'], 'more': False}
    assert client.get('/api/robots', params={'search': 'cell', 'limit': 2}).json() == {
        'search': 'cell', 'robots': ['cell_a', 'cell_b'], 'more': True}
    html = client.get('/').text
    assert 'id="robot-filter"' in html and '5 robots, 16 joints' in html
    assert '<option value="cell_a"' not in html  # no list of every robot
    assert ROW.findall(client.get('/', params={'robot': 'cell_b'}).text) == [
        ('cell_b', 'planned'), ('cell_b', 'cannot_judge'), ('cell_b', 'stale')]
