"""``simulate --joints all`` and wear that continues across recordings (issue 44, item 7)."""

import json

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.simulation import DEFAULT_JOINT_NAMES
from robot_wear_monitor.history import WearHistory

REPLAY = ['--joint', 'all', '--gear-ratio', '150', '--torque-scale', '10', '--no-progress']


@pytest.fixture(scope='module')
def plant(tmp_path_factory):
    """Two recordings of a 6-joint robot, the second continuing the first, in one history."""
    folder = tmp_path_factory.mktemp('plant')
    history = folder / 'h.sqlite3'
    assert cli.main(['simulate', '--out', str(folder / 'a'), '--experiments', '4', '--joints',
                     'all', '--wear-final', '40', '--seed', '1']) == 0
    assert cli.main(['replay', str(folder / 'a'), '--out', str(folder / 'out_a'),
                     '--history', str(history), *REPLAY]) == 0
    assert cli.main(['simulate', '--out', str(folder / 'b'), '--experiments', '4', '--joints',
                     'all', '--wear-final', '70', '--seed', '2', '--continue-from',
                     str(folder / 'a.truth.json')]) == 0
    assert cli.main(['replay', str(folder / 'b'), '--out', str(folder / 'out_b'),
                     '--history', str(history), *REPLAY]) == 0
    first = json.loads((folder / 'a.truth.json').read_text())
    second = json.loads((folder / 'b.truth.json').read_text())
    with WearHistory(history) as stored:
        records = {joint: stored.records(joint=joint) for joint in DEFAULT_JOINT_NAMES}
    return first, second, records


def test_every_joint_of_the_arm_is_tested_with_its_own_wear(plant):
    first, _, records = plant
    assert sorted(first['joints']) == sorted(DEFAULT_JOINT_NAMES)
    finals = [first['final_wear'][joint] for joint in DEFAULT_JOINT_NAMES]
    assert len({round(w, 3) for w in finals}) == 6  # its own wear each
    # joint_2 as the single-joint simulation (40), joint_4 half of it (a share of 0.5)
    assert first['final_wear']['joint_2'] == pytest.approx(40.0, abs=2.0)
    assert first['final_wear']['joint_4'] == pytest.approx(20.0, abs=2.0)
    for joint in DEFAULT_JOINT_NAMES:
        assert len(records[joint]) == 8  # 4 experiments of each recording, each joint
    # the estimates follow each joint's true wear (4 speed levels per experiment: noisy)
    errors = [r.wear - t['wear'] for joint in DEFAULT_JOINT_NAMES
              for r, t in zip(records[joint][:4], first['joints'][joint])]
    assert abs(np.mean(errors)) < 4.0 and np.sqrt(np.mean(np.square(errors))) < 10.0


def test_a_second_recording_continues_the_wear_and_the_time_of_the_first(plant):
    first, second, records = plant
    for joint in DEFAULT_JOINT_NAMES:
        before, after = first['joints'][joint], second['joints'][joint]
        # the true wear starts exactly where the first recording ended, then rises
        assert after[0]['wear'] == pytest.approx(before[-1]['wear'], abs=1e-9)
        assert after[-1]['wear'] > after[0]['wear'] + 5.0
        # one interval (3600 s) after the first recording's last sample, not at its start
        assert after[0]['start_time_s'] > before[-1]['end_time_s']
        stamps = [r.stamp_s for r in records[joint]]
        assert stamps == sorted(stamps)
    # in the history: the second recording's first estimates sit at the first one's end, not
    # back at a new joint's wear (about 1)
    jumps = [records[j][4].wear - first['final_wear'][j] for j in DEFAULT_JOINT_NAMES]
    assert abs(np.mean(jumps)) < 5.0
    starts = [records[j][0].wear for j in DEFAULT_JOINT_NAMES]
    assert np.mean([records[j][4].wear for j in DEFAULT_JOINT_NAMES]) > np.mean(starts) + 10.0


def test_bad_joints_and_continuations_are_named(tmp_path):
    with pytest.raises(InputError, match='joint_9'):
        cli_run(tmp_path, '--joints', 'joint_1,joint_9')
    (tmp_path / 'x.json').write_text('{"experiments": []}')
    with pytest.raises(InputError, match='not the truth file of a simulated recording'):
        cli_run(tmp_path, '--continue-from', str(tmp_path / 'x.json'))
    (tmp_path / 'y.json').write_text('{"final_wear": {"joint_2": 3.0}, "end_time_s": 1e9}')
    with pytest.raises(InputError, match='no wear of joint_1'):
        cli_run(tmp_path, '--joints', 'all', '--continue-from', str(tmp_path / 'y.json'))
    with pytest.raises(InputError, match='longer than a joint'):
        cli_run(tmp_path, '--joints', 'all', '--interval', '60')


def cli_run(tmp_path, *options):
    from robot_wear_monitor.cli import simulate
    import argparse
    parser = argparse.ArgumentParser()
    simulate.add_arguments(parser)
    args = parser.parse_args(['--out', str(tmp_path / 'bag'), '--experiments', '2', *options])
    return simulate.main(args)
