"""Replay of simulated bags: the alarm, the output bag (rosbags and mcap), bad bags and params."""

import json
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario, simulate_scenario,
                                                      truth_path_for, write_truth_json)
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.monitoring.topics import OUTPUT_TOPICS
from robot_wear_monitor.recordings.bags import BagError, write_joint_state_bag
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
TOPICS = {('/' + t).replace('//', '/'): msgtype for t, msgtype in OUTPUT_TOPICS.items()}


def _write_scenario(path, *, n_experiments, seed, storage='mcap'):
    scenario = simulate_scenario(
        config=accelerated_wear_scenario(n_experiments=n_experiments, seed=seed), seed=seed)
    write_joint_state_bag(path, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort, storage=storage)
    write_truth_json(truth_path_for(path), scenario)
    return scenario


@pytest.fixture(scope='module')
def replayed(tmp_path_factory):
    """Replay a 100-experiment accelerated wear scenario through the CLI."""
    folder = tmp_path_factory.mktemp('replay')
    bag = folder / 'scenario'
    scenario = _write_scenario(bag, n_experiments=100, seed=11)
    out = folder / 'out'
    code = cli.main([
        'replay', str(bag), '--out', str(out), '--json-out', str(folder / 's.json'),
        '--plot', str(folder / 'trend.png'), '--joint', 'joint_2', '--gear-ratio', '150',
        '--torque-scale', '10', '--no-progress', '--history', str(folder / 'h.sqlite3'),
        '--truth', str(folder / 'scenario.truth.json')])
    assert code == 0
    summary = json.loads((folder / 's.json').read_text())
    return scenario, summary, out, folder


def test_alarm_within_two_experiments_of_the_true_crossing(replayed):
    scenario, summary, _, _ = replayed
    true_wear = np.array([t.wear for t in scenario.truth])
    experiments = summary['experiments']
    assert len(experiments) == len(scenario.truth) == 100
    assert [e['truth']['k'] for e in experiments] == list(range(100))
    crossing = int(np.argmax(true_wear >= 35.0))
    assert true_wear[crossing] >= 35.0 > true_wear[:crossing].max()
    first = summary['first_alarm']['index'] - 1  # index counts experiments from 1
    assert first <= crossing + 2
    assert true_wear[first] >= 25.0, 'alarm while the true wear was below 25'
    alarms = [e['alarm'] for e in experiments]
    assert not any(alarms[:first]) and all(alarms[first:])  # latched


def test_estimates_follow_the_truth(replayed):
    scenario, summary, _, _ = replayed
    wear = np.array([e['wear'] for e in summary['experiments']])
    true_wear = np.array([t.wear for t in scenario.truth])
    worn = true_wear >= 30
    assert np.all(np.abs(wear[worn] - true_wear[worn]) < 15)
    assert np.median(np.abs(wear - true_wear)) < 8


def test_output_bag_decodes_with_rosbags(replayed):
    _, summary, out, _ = replayed
    counts = {}
    with Reader(out) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == TOPICS
        wears = []
        for connection, _, raw in reader.messages():
            msg = TYPESTORE.deserialize_cdr(raw, connection.msgtype)
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
            if connection.topic == '/wear':
                wears.append(msg.data)
            if connection.topic == '/friction_levels':
                assert msg.velocity.size == msg.effort.size == 4
    assert set(counts.values()) == {100}
    assert wears == [e['wear'] for e in summary['experiments']]


def test_output_bag_decodes_with_mcap(replayed):
    _, summary, out, _ = replayed
    [mcap_file] = list(Path(out).glob('*.mcap'))
    alarms, levels = [], []
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            if channel.topic == '/wear_alarm':
                alarms.append(msg.data)
            if channel.topic == '/diagnostics':
                levels.append(msg.status[0].level)
            if channel.topic == '/friction_levels':
                levels_msg = msg
                levels.append(None)
    assert alarms == [e['alarm'] for e in summary['experiments']]
    assert list(levels_msg.effort) == summary['experiments'][-1]['frictions']
    assert max(v for v in levels if v is not None) == 2  # ERROR once the alarm is latched


def test_summary_plot_and_history_written(replayed):
    _, summary, _, folder = replayed
    assert (folder / 'trend.png').stat().st_size > 10_000
    assert summary['rejections'] == {k: v for k, v in summary['rejections'].items()
                                     if not k.startswith('friction_levels_')}
    from robot_wear_monitor.history import WearHistory
    with WearHistory(folder / 'h.sqlite3') as history:
        assert len(history.records(joint='joint_2')) == 100
        assert history.restore(joint='joint_2').alarm_active


@pytest.fixture(scope='module')
def small_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp('small')
    bag = folder / 'small_sqlite'
    _write_scenario(bag, n_experiments=3, seed=5, storage='sqlite3')
    return bag


def test_sqlite3_input_bag_replays(small_bag, tmp_path):
    experiment, estimator = replay_parameters()
    result = replay_bag(small_bag, out_bag=tmp_path / 'o', experiment_parameters=experiment,
                        estimator_parameters=estimator, storage='sqlite3')
    assert len(result.updates) == 3
    with Reader(tmp_path / 'o') as reader:
        assert reader.message_count == 3 * 6  # friction_levels and 5 outputs per experiment


def _broken_bags(small_bag, folder):
    """Return (name, bag path) of a truncated, a corrupt and an empty-folder bag."""
    import shutil
    mcap_bag = folder / 'mcap_bag'
    _write_scenario(mcap_bag, n_experiments=1, seed=2)
    [data] = list(mcap_bag.glob('*.mcap'))
    truncated = folder / 'truncated'
    shutil.copytree(mcap_bag, truncated)
    target = truncated / data.name
    target.write_bytes(data.read_bytes()[:data.stat().st_size // 2])
    corrupt = folder / 'corrupt'
    shutil.copytree(mcap_bag, corrupt)
    blob = bytearray((corrupt / data.name).read_bytes())
    blob[100:4000] = b'\x00' * 3900
    (corrupt / data.name).write_bytes(bytes(blob))
    empty = folder / 'empty'
    empty.mkdir()
    return [('truncated', truncated), ('corrupt', corrupt), ('empty', empty),
            ('missing', folder / 'nope')]


def test_bad_bags_exit_2_and_leave_no_output(small_bag, tmp_path, capsys):
    for name, bag in _broken_bags(small_bag, tmp_path):
        out = tmp_path / f'out_{name}'
        code = cli.main(['replay', str(bag), '--out', str(out), '--no-progress'])
        err = capsys.readouterr().err
        assert code == 2, name
        assert 'replay: error:' in err and '\n' == err[-1] and err.count('\n') == 1, err
        assert not out.exists()
        assert not list(tmp_path.glob(f'.out_{name}*'))


def test_bag_without_the_joint_or_with_a_wrong_type(small_bag, tmp_path, capsys):
    code = cli.main(['replay', str(small_bag), '--out', str(tmp_path / 'o1'), '--joint',
                     'joint_9', '--no-progress'])
    assert code == 2 and "joint 'joint_9' is in no message" in capsys.readouterr().err
    wrong = tmp_path / 'wrong'
    from robot_wear_monitor.recordings.bags import atomic_bag_writer
    with atomic_bag_writer(wrong) as writer:
        writer.add_topic('/joint_states', 'std_msgs/msg/Float64')
        writer.write('/joint_states', TYPESTORE.types['std_msgs/msg/Float64'](data=1.0), 1)
    code = cli.main(['replay', str(wrong), '--out', str(tmp_path / 'o2'), '--no-progress'])
    assert code == 2 and 'expected sensor_msgs/msg/JointState' in capsys.readouterr().err
    assert not (tmp_path / 'o1').exists() and not (tmp_path / 'o2').exists()
    with pytest.raises(BagError):
        replay_bag(wrong, out_bag=None, experiment_parameters=replay_parameters()[0],
                   estimator_parameters=replay_parameters()[1])


@pytest.mark.parametrize('args, match', [
    (['--gear-ratio', '-2'], 'argument --gear-ratio: must be > 0'),
    (['--torque-scale', '0'], 'argument --torque-scale: must be > 0'),
    (['--params', 'no_such.yaml'], 'cannot read parameter file'),
])
def test_bad_parameters_exit_2(small_bag, tmp_path, capsys, args, match):
    out = tmp_path / 'o'
    assert cli.main(['replay', str(small_bag), '--out', str(out), '--no-progress'] + args) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()


def test_existing_output_is_not_replaced_without_overwrite(small_bag, tmp_path, capsys):
    out = tmp_path / 'o'
    out.mkdir()
    assert cli.main(['replay', str(small_bag), '--out', str(out), '--no-progress']) == 2
    assert 'already exists' in capsys.readouterr().err


def test_batch_replay_path_equals_the_streaming_node_path(tmp_path):
    """Replay segments a recording in one batch; the node feeds samples one by one: same result."""
    from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
    experiment_params, _ = replay_parameters(joint='joint_2', gear_ratio=150.0,
                                             torque_scale=10.0)
    scenario = simulate_scenario(
        config=accelerated_wear_scenario(n_experiments=6, seed=5), seed=5)
    time_s, position_rad, velocity_rad_s, effort = scenario.joint_samples()
    effort = effort.copy()
    effort[len(effort) // 3] = np.nan  # a bad sample is rejected the same way on both paths
    streaming = FrictionExperimentService.from_node_parameters(experiment_params)
    streamed = []
    for t, q, v, e in zip(time_s, position_rad, velocity_rad_s, effort):
        streamed.extend(streaming.add_sample(time_s=float(t), position_rad=float(q),
                                             velocity_rad_s=float(v), effort=float(e)))
    streamed.extend(streaming.finish())
    batch = FrictionExperimentService.from_node_parameters(experiment_params)
    batched = batch.add_recording(time_s=time_s, position_rad=position_rad,
                                  velocity_rad_s=velocity_rad_s, effort=effort)
    batched.extend(batch.finish())
    assert len(streamed) >= 5
    assert batched == streamed
    assert batch.all_rejections() == streaming.all_rejections()
    assert batch.all_rejections()['non_finite'] == 1
    assert streaming.rejected_total == sum(streaming.all_rejections().values()) >= 1


def test_replay_reads_nothing_beside_the_bag_and_a_named_bad_truth_is_an_error(
        tmp_path, capsys):
    bag = tmp_path / 'small'
    scenario = _write_scenario(bag, n_experiments=3, seed=4)
    beside = truth_path_for(bag)
    beside.write_text(json.dumps({'speeds_rad_s': [1.0, 2.0]}))  # another tool's file
    args = ['replay', str(bag), '--joint', 'joint_2', '--gear-ratio', '150',
            '--torque-scale', '10', '--no-progress']
    assert cli.main(args + ['--out', str(tmp_path / 'out'), '--json-out',
                            str(tmp_path / 's.json')]) == 0
    summary = json.loads((tmp_path / 's.json').read_text())
    assert len(summary['experiments']) == len(scenario.truth) == 3
    assert all('truth' not in entry for entry in summary['experiments'])
    capsys.readouterr()
    assert cli.main(args + ['--out', str(tmp_path / 'out2'), '--truth', str(beside)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'not a truth file' in err
    assert not (tmp_path / 'out2').exists()


def test_a_killed_replays_partial_output_is_removed_by_the_next_run(tmp_path, capsys):
    import os
    import subprocess
    import sys
    bag = tmp_path / 'small'
    _write_scenario(bag, n_experiments=2, seed=5)
    out = tmp_path / 'out'
    gone = subprocess.run([sys.executable, '-c', 'import os; print(os.getpid())'],
                          capture_output=True, text=True, check=True)
    dead = tmp_path / f'.out.partial-{int(gone.stdout)}'   # what kill -9 leaves behind
    (dead / 'out').mkdir(parents=True)
    (dead / 'out' / 'out_0.mcap').write_bytes(b'\x89MCAP0\r\n')
    alive = tmp_path / f'.out.partial-{os.getppid()}'       # a writer that still runs
    alive.mkdir()
    dead_json = tmp_path / f'.s.json.tmp-{int(gone.stdout)}'
    dead_json.write_text('{')
    args = ['replay', str(bag), '--out', str(out), '--json-out', str(tmp_path / 's.json'),
            '--joint', 'joint_2', '--gear-ratio', '150', '--torque-scale', '10',
            '--no-progress']
    assert cli.main(args) == 0
    err = capsys.readouterr().err
    assert not dead.exists() and alive.is_dir() and not dead_json.exists()
    assert f'removed {dead}' in err and 'killed' in err
    assert (out / 'metadata.yaml').is_file()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith('.')) == \
        [alive.name]


def test_a_recording_replayed_twice_into_one_history_is_stored_once(tmp_path, capsys):
    from robot_wear_monitor.history import WearHistory
    bag = tmp_path / 'small'
    scenario = _write_scenario(bag, n_experiments=4, seed=6)
    history = tmp_path / 'h.sqlite3'
    args = ['replay', str(bag), '--joint', 'joint_2', '--gear-ratio', '150',
            '--torque-scale', '10', '--no-progress', '--history', str(history)]
    assert cli.main(args + ['--out', str(tmp_path / 'first')]) == 0
    first = capsys.readouterr().out
    assert 'already in the history' not in first
    assert cli.main(args + ['--out', str(tmp_path / 'second'), '--json-out',
                            str(tmp_path / 's.json')]) == 0
    second = capsys.readouterr().out
    assert '0 experiments from' in second and '4 already in the history (skipped' in second
    summary = json.loads((tmp_path / 's.json').read_text())
    assert summary['rejections']['friction_levels_already_in_history'] == 4
    store = WearHistory(history)
    try:
        records = store.records(joint='joint_2')
        assert len(records) == len(scenario.truth) == 4
        assert len({r.stamp_s for r in records}) == 4
    finally:
        store.close()


def test_two_replays_writing_one_history_at_once_store_each_experiment_once(tmp_path):
    import os
    import subprocess
    import sys

    from robot_wear_monitor.history import WearHistory
    root = Path(__file__).resolve().parents[2]
    bag = tmp_path / 'small'
    scenario = _write_scenario(bag, n_experiments=6, seed=8)
    history = tmp_path / 'h.sqlite3'
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(root)] + [p for p in [os.environ.get('PYTHONPATH')] if p]))
    runs = [subprocess.Popen(
        [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag), '--joint',
         'joint_2', '--gear-ratio', '150', '--torque-scale', '10', '--no-progress',
         '--history', str(history), '--out', str(tmp_path / f'out{i}'), '--json-out',
         str(tmp_path / f's{i}.json')], cwd=root, env=env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True) for i in range(2)]
    for run in runs:
        out, err = run.communicate(timeout=120)
        assert run.returncode == 0, out + err
    summaries = [json.loads((tmp_path / f's{i}.json').read_text()) for i in range(2)]
    estimated = sum(len(s['experiments']) for s in summaries)
    skipped = sum(s['rejections'].get('friction_levels_already_in_history', 0)
                  for s in summaries)
    assert estimated + skipped == 2 * len(scenario.truth)
    store = WearHistory(history)
    try:
        records = store.records(joint='joint_2')
    finally:
        store.close()
    assert len(records) == len(scenario.truth) == 6
    assert len({round(r.stamp_s, 6) for r in records}) == 6


@pytest.fixture(scope='module')
def independent_bags(tmp_path_factory):
    """Write recordings of the independent generator: Table V, other speeds, no plateau."""
    from wear_testing import independent_robot as robot
    folder = tmp_path_factory.mktemp('no_experiment')
    bags = {}
    for name, settings in (('table_v', {}), ('other_speeds', {'speeds_rad_s': (35.84, 40.84)}),
                           ('no_plateau', {'plateau_s': 0.1})):
        recording = robot.generate_wear_test(n_experiments=2, seed=2, rate_hz=250.0,
                                             **settings)
        bags[name] = robot.write_bag(folder / name, recording)
    return bags


@pytest.mark.parametrize('bag, extra, reason', [
    ('table_v', ['--joint', 'joint_1'], 'never moves'),
    ('table_v', ['--joint', 'joint_9'], 'joints seen: joint_1, joint_2'),
    ('other_speeds', ['--config', 'TABLE_V_CONFIG'],
     'at 35.8, 40.8 rad/s, but none formed an experiment of the configured speeds '
     '[2.1, 28.5, 35.1, 41.7]'),
    ('no_plateau', [], 'no constant-speed plateau of 0.2 s'),
])
def test_a_recording_without_experiments_exits_2_and_says_why(
        independent_bags, tmp_path, capsys, bag, extra, reason):
    out = tmp_path / 'out'
    if 'TABLE_V_CONFIG' in extra:  # speeds configured: a filter
        config = tmp_path / 'table_v.yaml'
        config.write_text('friction_experiment_node:\n  ros__parameters:\n'
                          '    experiment_speeds_rad_s: [2.1, 28.5, 35.1, 41.7]\n')
        extra = [str(config) if e == 'TABLE_V_CONFIG' else e for e in extra]
    code = cli.main(['replay', str(independent_bags[bag]), '--out', str(out), '--json-out',
                     str(tmp_path / 's.json'), '--no-progress', *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and reason in err, err
    assert not out.exists() and not (tmp_path / 's.json').exists()


def test_unconfigured_speeds_are_found_in_the_recording(independent_bags, tmp_path, capsys):
    """The issue's case: a design the config does not know is found and estimated."""
    from wear_testing import independent_robot as robot
    recording = robot.generate_wear_test(n_experiments=2, seed=2, rate_hz=250.0,
                                         speeds_rad_s=(35.84, 40.84))
    summary_path = tmp_path / 's.json'
    code = cli.main(['replay', str(independent_bags['other_speeds']), '--out',
                     str(tmp_path / 'out'), '--json-out', str(summary_path), '--no-progress'])
    assert code == 0, capsys.readouterr().err
    summary = json.loads(summary_path.read_text())
    assert len(summary['experiments']) == len(recording.truth) == 2
    for entry, truth in zip(summary['experiments'], recording.truth):
        assert entry['speeds_rad_s'] == pytest.approx(truth.speeds_rad_s, abs=0.05)
        assert entry['frictions'] == pytest.approx(truth.friction_true, abs=3e-3)
    joint = summary['joints'][0]
    assert joint['levels_per_speed_rad_s'] == {'35.8': 2, '40.8': 2}
    assert joint['experiments'] == 2 and joint['no_experiment'] is None
    assert joint['speeds_configured_rad_s'] == []
