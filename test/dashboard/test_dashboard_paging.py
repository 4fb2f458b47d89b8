"""
The fleet at a glance, on the server: pages of a large fleet, one bar scale, the crossing in days.

A fleet of 57 joints with known upper bounds of w (the fleet's order is theirs, highest first)
is paged with ``?page=`` and ``?limit=``: each page must hold the right rows in the fleet's
order and say how many there are; ``/api/fleet`` sends every row unless asked for a page.  The
bars of the plan's fleet (fleet_history.py) share one scale, 0 to 1.5 x the threshold.
"""

from dataclasses import replace
import datetime
import re
import time

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.history import AlarmEvent, open_history
from wear_testing.fleet_history import EXPERIMENTS, login, make_fleet, ORDER, record

#: Joints of the large fleet: joint j{i} of robot r{i % 4} has w-hat 0.5 i + 0.75 (no ties).
JOINTS = 57
ROW = re.compile(r'<tr class="state-[^"]*" data-robot="([^"]*)" data-joint="([^"]*)"')


def _wear(index: int) -> float:
    return 0.5 * index + 0.75


@pytest.fixture()
def large(tmp_path) -> str:
    """Return a history of :data:`JOINTS` joints with two experiments each, no crossings."""
    path = make_fleet(str(tmp_path / 'large.sqlite3'))
    now_s = time.time()
    with open_history(path) as stored:
        for index in range(JOINTS):
            wear = _wear(index)
            for k in (EXPERIMENTS - 2, EXPERIMENTS - 1):
                stored.append(replace(record('press_line', 'joint_1', k, now_s=now_s),
                                      robot=f'r{index % 4}', joint=f'j{index:02d}', wear=wear,
                                      wear_low=wear - 2.0, wear_high=wear + 2.0))
    return path


@pytest.fixture()
def client(large):
    with fastapi_testclient.TestClient(create_app(DashboardSettings(history=large))) as made:
        assert login(made, 'vic').status_code == 303
        yield made


def _truth(robot=None) -> list[tuple[str, str]]:
    """Return the large fleet's rows in the fleet's order: the plan's, then w-hat down."""
    ours = [(f'r{i % 4}', f'j{i:02d}') for i in sorted(range(JOINTS), key=_wear, reverse=True)]
    # the plan's joints with a crossing come before the rest; those without by upper bound
    whole = ORDER[:3] + sorted(ORDER[3:] + ours, key=lambda key: -_upper(key))
    return [key for key in whole if robot is None or key[0] == robot]


def _upper(key: tuple[str, str]) -> float:
    plan_upper = {('welder_7', 'joint_5'): 18.0 + 12.0, ('press_line', 'joint_1'): 6.0 + 5.0}
    if key in plan_upper:
        return plan_upper[key]
    return _wear(int(key[1][1:])) + 2.0


def _page_rows(html: str) -> list[tuple[str, str]]:
    return [(r.replace('&lt;', '<').replace('&gt;', '>'), j) for r, j in ROW.findall(html)]


def test_api_fleet_pages_only_when_asked(client):
    truth = _truth()
    assert len(truth) == JOINTS + 5
    whole = client.get('/api/fleet').json()
    assert [(r['robot'], r['joint']) for r in whole['rows']] == truth
    assert (whole['total'], whole['page'], whole['pages'], whole['limit'], whole['first']) == \
        (len(truth), 1, 1, None, 1)
    for page in (1, 2, 7):
        got = client.get('/api/fleet', params={'page': page, 'limit': 10}).json()
        assert [(r['robot'], r['joint']) for r in got['rows']] == \
            truth[(page - 1) * 10:page * 10], page
        assert (got['total'], got['pages'], got['page'], got['limit'], got['first']) == \
            (62, 7, page, 10, (page - 1) * 10 + 1)
        # the whole fleet's: 1 alarm, 4 warnings (w-hat >= 28 or a crossing near)
        assert got['joints'] == 62 and got['counts']['ok'] == 57
        assert got['counts']['warning'] == 4 and got['counts']['alarm'] == 1
    last = client.get('/api/fleet', params={'page': 7, 'limit': 10}).json()['rows']
    assert len(last) == 2  # 62 rows: the seventh page holds two
    past = client.get('/api/fleet', params={'page': 99, 'limit': 10}).json()
    assert past['page'] == 7 and [r['joint'] for r in past['rows']] == [r['joint'] for r in last]
    one_robot = client.get('/api/fleet', params={'robot': 'r1', 'limit': 5, 'page': 2}).json()
    assert [(r['robot'], r['joint']) for r in one_robot['rows']] == _truth('r1')[5:10]
    assert one_robot['total'] == len(_truth('r1')) == 14 and one_robot['pages'] == 3
    alarm = client.get('/api/fleet', params={'state': 'alarm', 'limit': 10}).json()
    assert (alarm['total'], alarm['pages'], [r['joint'] for r in alarm['rows']]) == \
        (1, 1, ['joint_2'])
    for bad in ({'page': 0}, {'limit': 0}, {'limit': 'ten'}):
        assert client.get('/api/fleet', params=bad).status_code == 422, bad


def test_fleet_page_shows_one_page_with_links_to_the_others(client):
    truth = _truth()
    html = client.get('/').text  # 100 rows a page by default: all 62 on one page
    assert _page_rows(html) == truth
    assert 'rows 1&ndash;62 of 62' in html and 'rel="next"' not in html
    html = client.get('/', params={'limit': 25}).text
    assert _page_rows(html) == truth[:25]
    assert 'rows 1&ndash;25 of 62' in html
    assert '<a href="/?page=2&amp;limit=25" rel="next">' in html
    assert '<a href="/?page=3&amp;limit=25" rel="page">3</a>' in html
    html = client.get('/', params={'limit': 25, 'page': 3}).text
    assert _page_rows(html) == truth[50:]
    assert 'rows 51&ndash;62 of 62' in html and 'rel="next"' not in html
    assert '<a href="/?page=2&amp;limit=25" rel="prev">' in html
    html = client.get('/', params={'robot': 'r2', 'limit': 4, 'page': 2}).text
    assert _page_rows(html) == _truth('r2')[4:8]
    assert '<a href="/?robot=r2&amp;page=3&amp;limit=4" rel="next">' in html
    assert client.get('/', params={'limit': 100000}).status_code == 422  # at most 1000


def test_every_bar_has_one_scale_and_a_value_past_it_is_clipped(tmp_path):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    now_s = time.time()
    with open_history(path) as stored:
        for k in range(EXPERIMENTS):
            rec = replace(record('press_line', 'joint_2', k, now_s=now_s), joint='joint_9')
            if k == EXPERIMENTS - 1:
                rec = replace(rec, wear=58.0, wear_low=50.0, wear_high=66.0)
            stored.append(rec, events=(AlarmEvent(
                joint='joint_9', robot='press_line', stamp_s=rec.stamp_s, event='raised',
                wear=rec.wear, note='w-hat >= 35'),) if rec.alarm_active else ())
    with fastapi_testclient.TestClient(create_app(DashboardSettings(history=path))) as made:
        assert login(made, 'vic').status_code == 303
        rows = made.get('/api/fleet').json()['rows']
        html = made.get('/').text
    assert len(rows) == 6
    for row in rows:  # the threshold w = 35 at two thirds of every bar: 0 to 52.5
        bar = row['bar']
        assert row['threshold'] == 35.0 and bar['scale_max'] == pytest.approx(52.5)
        assert bar['threshold'] == pytest.approx(66.67)
        if row['joint'] == 'joint_9':
            assert bar['clipped'] and bar['wear'] == 100.0 and bar['high'] == 100.0
            assert bar['low'] == pytest.approx(100 * 50 / 52.5, abs=0.01)
            assert row['text']['wear'] == '58.0 [50.0, 66.0]'  # the number that is clipped
        else:
            assert not bar['clipped']
            assert bar['wear'] == pytest.approx(100 * row['wear'] / 52.5, abs=0.01)
            assert bar['high'] == pytest.approx(100 * row['wear_high'] / 52.5, abs=0.01)
    body = html.split('<tbody id="fleet-rows">')[1].split('</tbody>')[0]
    assert body.count('x1="66.67" x2="66.67"') == 6
    assert body.count('class="clip" points="94,1 100,7 94,13" visibility="visible"') == 1


def test_the_crossing_is_in_days_with_its_date(client):
    rows = {(r['robot'], r['joint']): r for r in client.get('/api/fleet').json()['rows']}
    soon = rows[('welder_7', 'joint_3')]  # 4 experiments an hour apart ahead
    assert soon['usual_interval_s'] == pytest.approx(3600.0)
    assert soon['crossing_days'] == pytest.approx(4 / 24)
    date = datetime.datetime.fromtimestamp(soon['last_stamp_s'] + 4 * 3600.0,
                                           tz=datetime.timezone.utc).date().isoformat()
    assert soon['crossing_date'] == date
    assert soon['text']['crossing'] == f'in 4 experiments \u2248 0.2 days (~{date})'
    crossed = rows[('press_line', 'joint_2')]
    assert crossed['crossing_days'] is None and crossed['text']['crossing'].startswith('crossed')
    assert rows[('r0', 'j00')]['crossing_days'] is None
    html = client.get('/').text
    assert f'in 4 experiments \u2248 0.2 days (~<span class="t">{date}</span>)' in html
