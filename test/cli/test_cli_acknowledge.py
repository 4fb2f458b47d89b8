"""
``acknowledge`` and ``new-life``: the dashboard's writes from the command line (issue 44).

The plan's fleet (``wear_testing.fleet_history``: one latched alarm on press_line joint_2, the
other joints never alarmed); the events are read back from the dashboard's ``/api/alarms``
(FastAPI's TestClient, a maintainer's token), where they must carry the source ``cli``.
"""

import datetime
import json

from fastapi import testclient as fastapi_testclient
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import make_fleet


@pytest.fixture()
def history(tmp_path) -> str:
    return make_fleet(str(tmp_path / 'fleet.sqlite3'))


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def _api_alarms(history: str) -> list[dict]:
    with open_history(history, init=False) as stored:
        _, token = stored.add_token(user='mia', label='test')
    with fastapi_testclient.TestClient(create_app(DashboardSettings(history=history))) as client:
        answer = client.get('/api/alarms', headers={'Authorization': f'Bearer {token}'})
    assert answer.status_code == 200, answer.text
    return answer.json()


def _future(days: int) -> str:
    return (datetime.datetime.now(datetime.timezone.utc).date()
            + datetime.timedelta(days=days)).isoformat()


def test_an_acknowledgement_and_an_edit_from_the_cli_are_in_the_api_log_as_cli(
        history, capsys):
    planned = _future(10)
    code, out, err = _run(capsys, 'acknowledge', '--history', history, '--robot', 'press_line',
                          '--joint', 'joint_2', '--by', 'ana', '--owner', 'Team D',
                          '--comment', 'gearbox noise', '--planned-maintenance', planned,
                          '--work-order', 'WO-17', '--json')
    assert code == 0, err
    stored = json.loads(out)
    assert (stored['event'], stored['source'], stored['user'], stored['owner'],
            stored['planned_maintenance'], stored['work_order'], stored['note']) == (
        'acknowledged', 'cli', 'ana', 'Team D', planned, 'WO-17', 'gearbox noise')
    # an edit that gives only the owner keeps the comment, the planned date and the work order
    code, out, err = _run(capsys, 'acknowledge', '--edit', '--history', history, '--robot',
                          'press_line', '--joint', 'joint_2', '--by', 'bo', '--owner', 'Team E')
    assert code == 0, err
    assert out.startswith('acknowledgement edited: robot press_line joint joint_2 by bo')
    assert "changed: owner: 'Team D' -> 'Team E'" in out
    log = _api_alarms(history)
    edit, first = log[0], log[1]
    assert (edit['event'], edit['source'], edit['user'], edit['owner'], edit['note'],
            edit['planned_maintenance'], edit['work_order']) == (
        'acknowledgement_edited', 'cli', 'bo', 'Team E', 'gearbox noise', planned, 'WO-17'), edit
    assert edit['changes'] == "owner: 'Team D' -> 'Team E'"
    assert (first['event'], first['source'], first['owner']) == ('acknowledged', 'cli', 'Team D')
    with open_history(history, init=False) as stored_history:
        now = stored_history.acknowledgement(joint='joint_2', robot='press_line')
    assert (now.owner, now.note, now.planned_maintenance, now.work_order) == (
        'Team E', 'gearbox noise', planned, 'WO-17')


def test_the_cli_refuses_what_the_api_refuses(history, capsys):
    base = ('acknowledge', '--history', history, '--by', 'ana')
    # an unknown robot, an unknown joint: a clear error, exit code 2, nothing stored
    code, _, err = _run(capsys, *base, '--robot', 'no_such_robot', '--joint', 'joint_2')
    assert code == 2 and 'no_such_robot' in err and 'Traceback' not in err
    code, _, err = _run(capsys, *base, '--robot', 'press_line', '--joint', 'joint_9')
    assert code == 2 and 'joint_9' in err
    # no latched alarm on a joint that never alarmed (the API's 409)
    code, _, err = _run(capsys, *base, '--robot', 'welder_7', '--joint', 'joint_3')
    assert code == 2 and 'latched' in err
    # a planned date in the past: refused as the API refuses it, unless --allow-past-date
    past = _future(-3)
    code, _, err = _run(capsys, *base, '--robot', 'press_line', '--joint', 'joint_2',
                        '--planned-maintenance', past)
    assert code == 2 and f'planned_maintenance {past} has passed' in err
    assert [e['event'] for e in _api_alarms(history)] == ['raised']
    code, _, err = _run(capsys, *base, '--robot', 'press_line', '--joint', 'joint_2',
                        '--planned-maintenance', past, '--allow-past-date')
    assert code == 0, err
    # acknowledged already: an error naming who (use --edit)
    code, _, err = _run(capsys, *base, '--robot', 'press_line', '--joint', 'joint_2')
    assert code == 2 and "already acknowledged by 'ana'" in err


def test_new_life_from_the_cli_resets_a_joint_that_never_alarmed(history, capsys):
    code, out, err = _run(capsys, 'new-life', '--history', history, '--robot', 'welder_7',
                          '--joint', 'joint_3', '--by', 'cy', '--reason',
                          'gearbox replaced preventively', '--work-order', 'WO-7')
    assert code == 0, err
    assert out.startswith('new life: robot welder_7 joint joint_3 by cy (source cli')
    reset = _api_alarms(history)[0]
    assert (reset['event'], reset['source'], reset['user'], reset['note'],
            reset['work_order'], reset['robot'], reset['joint']) == (
        'reset', 'cli', 'cy', 'gearbox replaced preventively', 'WO-7', 'welder_7', 'joint_3')
    capsys.readouterr()
    assert main(['fleet', '--history', history, '--json']) == 0
    row = next(r for r in json.loads(capsys.readouterr().out)
               if (r['robot'], r['joint']) == ('welder_7', 'joint_3'))
    assert row['life_started_s'] is not None and row['wear'] is None
    assert row['reset_reason'] == 'gearbox replaced preventively'
    # a second reset with no experiment since: refused (the API's 409)
    code, _, err = _run(capsys, 'new-life', '--history', history, '--robot', 'welder_7',
                        '--joint', 'joint_3', '--by', 'cy', '--reason', 'again')
    assert code == 2 and 'Traceback' not in err
