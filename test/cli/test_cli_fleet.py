"""The fleet from the command line: simulate, replay many bags, fleet, history per robot."""

import csv
import io
import json

import pytest
from robot_wear_monitor.cli import main

HOUR_S = 3600
EXPERIMENTS = 8
NOW_S = 1.8e9
#: robot -> final wear of its simulated bag (robot_3 raises the alarm, robot_1 stays low)
ROBOTS = {'robot_1': 5.0, 'robot_2': 20.0, 'robot_3': 70.0}


@pytest.fixture(scope='module')
def fleet_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp('cli_fleet')
    lines = ['robot,bag']
    start = int(NOW_S - EXPERIMENTS * HOUR_S)
    for seed, (robot, wear) in enumerate(ROBOTS.items(), start=1):
        assert main(['simulate', '--out', str(root / f'bag_{robot}'), '--experiments',
                     str(EXPERIMENTS), '--wear-final', str(wear), '--seed', str(seed),
                     '--start-time', str(start)]) == 0
        lines.append(f'{robot},bag_{robot}')
    (root / 'manifest.csv').write_text('\n'.join(lines) + '\n')
    history = root / 'history.sqlite3'
    assert main(['replay', '--manifest', str(root / 'manifest.csv'), '--history', str(history),
                 '--workers', '2', '--no-progress']) == 0
    return root


def _fleet_json(capsys, *args):
    capsys.readouterr()
    assert main(['fleet', *args, '--json']) == 0
    return json.loads(capsys.readouterr().out)


def test_fleet_is_worst_first_with_every_robot(fleet_dir, capsys):
    rows = _fleet_json(capsys, '--history', str(fleet_dir / 'history.sqlite3'), '--now',
                       str(NOW_S))
    assert [r['robot'] for r in rows][0] == 'robot_3'
    assert rows[0]['alarm'] is True
    assert {r['robot'] for r in rows} == set(ROBOTS)
    assert all(r['experiments'] == EXPERIMENTS and not r['stale'] for r in rows)
    # past the usual interval the joints are stale
    late = _fleet_json(capsys, '--history', str(fleet_dir / 'history.sqlite3'), '--now',
                       str(NOW_S + 10 * HOUR_S))
    assert all(r['stale'] for r in late)
    only = _fleet_json(capsys, '--history', str(fleet_dir / 'history.sqlite3'), '--robot',
                       'robot_1')
    assert [r['robot'] for r in only] == ['robot_1']


def test_fleet_text_and_csv_have_no_nan(fleet_dir, capsys):
    capsys.readouterr()
    assert main(['fleet', '--history', str(fleet_dir / 'history.sqlite3'), '--now',
                 str(NOW_S)]) == 0
    text = capsys.readouterr().out
    assert text.splitlines()[0].startswith('3 robots, 3 joints: 1 alarm, 2 warning')
    assert text.splitlines()[2].startswith('robot_3')
    assert 'nan' not in text
    assert main(['fleet', '--history', str(fleet_dir / 'history.sqlite3'), '--csv']) == 0
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert [r['robot'] for r in rows][0] == 'robot_3' and rows[0]['alarm'] == 'latched'


def test_rerun_skips_every_bag_and_a_bad_bag_fails_alone(fleet_dir, tmp_path, capsys):
    manifest = tmp_path / 'm.csv'
    broken = tmp_path / 'broken'
    broken.mkdir()
    (broken / 'metadata.yaml').write_text('not: a bag\n')
    text = (fleet_dir / 'manifest.csv').read_text().replace('bag_', str(fleet_dir) + '/bag_')
    manifest.write_text(text + f'robot_9,{broken}\n')
    capsys.readouterr()
    code = main(['replay', '--manifest', str(manifest), '--history',
                 str(fleet_dir / 'history.sqlite3'), '--no-progress', '--json'])
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert code == 2
    assert (summary['skipped'], summary['failed'], summary['done']) == (3, 1, 0)
    assert f'failed: {broken} (robot robot_9)' in captured.err


def test_history_names_the_robot(fleet_dir, capsys):
    history = str(fleet_dir / 'history.sqlite3')
    assert main(['history', history]) == 2
    assert 'choose one with --robot' in capsys.readouterr().err
    assert main(['history', history, '--robot', 'robot_3', '--json']) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload['robot'] == 'robot_3' and payload['alarm_active'] is True
    assert len(payload['estimates']) == EXPERIMENTS


def test_many_bag_options_are_checked(fleet_dir, capsys):
    manifest = str(fleet_dir / 'manifest.csv')
    assert main(['replay', '--manifest', manifest]) == 2
    assert 'need --history' in capsys.readouterr().err
    assert main(['replay', '--manifest', manifest, '--history', 'x.sqlite3', '--workers',
                 '2', '--dask', 'tcp://127.0.0.1:1']) == 2
    assert 'choose one' in capsys.readouterr().err
    assert main(['fleet', '--history', str(fleet_dir / 'history.sqlite3'), '--now',
                 'nan']) == 2
