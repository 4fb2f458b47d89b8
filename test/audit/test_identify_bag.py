"""
``identify`` on a recorded bag: temperature and load from topics the user names.

The recording comes from the independent generator (``test/wear_testing/independent_robot.py``, its
own trajectory and noise); the bag, with ``/joint_temperature`` (sensor_msgs/Temperature) and
``/load_estimate`` (std_msgs/Float64) beside ``/joint_states``, is written here with rosbags.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.model.params import load_parameter_set
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores
from wear_testing import independent_robot as robot

PAPER_SPEEDS = (2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1)
TS = get_typestore(Stores.ROS2_JAZZY)


def _write(path: Path, recording, *, temperature=True, load=True) -> Path:
    """Write joint states plus temperature and load topics at 2 Hz (held per experiment)."""
    joint_state = TS.types['sensor_msgs/msg/JointState']
    header = TS.types['std_msgs/msg/Header']
    stamp = TS.types['builtin_interfaces/msg/Time']

    def hdr(ns):
        return header(stamp=stamp(sec=int(ns // 1_000_000_000),
                                  nanosec=int(ns % 1_000_000_000)), frame_id='joint_2')
    start, end = recording.stamps_ns[0], recording.stamps_ns[-1]
    ticks = np.arange(start, end + 1, 500_000_000)
    starts = np.array([t.start_s for t in recording.truth])
    which = np.clip(np.searchsorted(starts, ticks * 1e-9, side='right') - 1, 0, None)
    with Writer(path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP) as bag:
        states = bag.add_connection('/joint_states', 'sensor_msgs/msg/JointState', typestore=TS)
        for i in range(len(recording)):
            msg = joint_state(header=hdr(recording.stamps_ns[i]), name=list(recording.names),
                              position=recording.position[i], velocity=recording.velocity[i],
                              effort=recording.effort[i])
            bag.write(states, int(recording.stamps_ns[i]),
                      TS.serialize_cdr(msg, 'sensor_msgs/msg/JointState'))
        if temperature:
            topic = bag.add_connection('/joint_temperature', 'sensor_msgs/msg/Temperature',
                                       typestore=TS)
            cls = TS.types['sensor_msgs/msg/Temperature']
            for tick, k in zip(ticks, which):
                msg = cls(header=hdr(tick), temperature=recording.truth[k].temperature_degc,
                          variance=0.0)
                bag.write(topic, int(tick), TS.serialize_cdr(msg, 'sensor_msgs/msg/Temperature'))
        if load:
            topic = bag.add_connection('/load_estimate', 'std_msgs/msg/Float64', typestore=TS)
            cls = TS.types['std_msgs/msg/Float64']
            for tick, k in zip(ticks, which):
                bag.write(topic, int(tick), TS.serialize_cdr(cls(data=recording.truth[k].load),
                                                             'std_msgs/msg/Float64'))
    return path


@pytest.fixture(scope='module')
def baseline(tmp_path_factory):
    rng = np.random.default_rng(21)
    n = 12
    recording = robot.generate_wear_test(
        n_experiments=n, wears=[0.0] * n, seed=21, rate_hz=250.0, speeds_rad_s=PAPER_SPEEDS,
        temperatures_degc=list(np.linspace(30.0, 50.0, n)[rng.permutation(n)]),
        loads=list(rng.uniform(0.3, 0.7, n)), gap_s=15.0)
    folder = tmp_path_factory.mktemp('identify_bag')
    return recording, _write(folder / 'baseline', recording), folder


BAG_ARGS = ['--joint', 'joint_2', '--gear-ratio', '150', '--torque-scale', '10']


def test_identify_reads_temperature_and_load_from_named_topics(baseline, tmp_path, capsys):
    recording, bag, _ = baseline
    out, report = tmp_path / 'set.yaml', tmp_path / 'report.json'
    code = cli.main(['identify', str(bag), *BAG_ARGS, '--temperature-topic',
                     '/joint_temperature', '--load-topic', '/load_estimate', '--out', str(out),
                     '--json-out', str(report)])
    assert code == 0, capsys.readouterr().err
    result = json.loads(report.read_text())
    nominal = result['nominal']
    # every pass pair of the 12 experiments x 12 speeds became a level, grouped by the gaps
    assert nominal['n_levels'] == 144 and nominal['n_experiments'] == 12
    temps = [t.temperature_degc for t in recording.truth]
    assert nominal['temperature_range_degc'] == pytest.approx([min(temps), max(temps)])
    loads = [t.load for t in recording.truth]
    assert nominal['load_range'] == pytest.approx([min(loads), max(loads)])
    # the held-out error is the generator's level error sigma of (9b), nothing more
    assert 0.8 * robot.SIGMA_9B < nominal['held_out_error']['std'] < 1.3 * robot.SIGMA_9B
    params = load_parameter_set(out)
    assert params.temperature_min_degc == pytest.approx(min(temps))
    # the identified nominal model predicts the generator's friction at a new condition
    speeds = np.array([8.7, 35.1, 133.5])
    truth = robot.nominal_friction(speeds, 0.55, 38.0)
    from robot_wear_monitor.model.friction import nominal_friction
    assert np.max(np.abs(nominal_friction(speeds, 0.55, 38.0, params.model) - truth)) < 4e-3


def test_identify_from_a_bag_says_what_is_missing(baseline, tmp_path, capsys):
    _, bag, folder = baseline
    out = tmp_path / 'set.yaml'
    assert cli.main(['identify', str(bag), *BAG_ARGS, '--out', str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and '--temperature-topic' in err
    assert cli.main(['identify', str(bag), *BAG_ARGS, '--temperature-topic', '/nope',
                     '--load-topic', '/load_estimate', '--out', str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'no topic /nope' in err and '/joint_temperature' in err
    assert cli.main(['identify', str(bag), *BAG_ARGS, '--temperature-topic', '/joint_states',
                     '--load-topic', '/load_estimate', '--out', str(out)]) == 2
    assert 'expected one of' in capsys.readouterr().err
    assert not out.exists()
