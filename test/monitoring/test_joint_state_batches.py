"""
The friction node's drained batches, without ROS: the replay's experiments, bit for bit.

:class:`JointStateBatches` takes the serialised /joint_states messages a node drains from its
queue.  Fed a bag's own CDR bytes in batches of any size (the node's 50 at 1 kHz, odd and
random sizes), it must give the experiments of ``replay`` on that bag, float for float, on
the independent generator's recordings (one joint; two joints under ``joints: [all]``).  Bad
messages must be counted as the per-message path counts them.
"""

import numpy as np
import pytest
from robot_wear_monitor.monitoring.joint_state_batches import JointStateBatches
from robot_wear_monitor.monitoring.joints import JointExperiments
from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
from robot_wear_monitor.monitoring.replay import replay_bag
from robot_wear_monitor.recordings.bags import iter_raw_messages, MONITOR_TYPESTORE
from wear_testing import foreign_recordings as foreign
from wear_testing import independent_robot as robot

TS = MONITOR_TYPESTORE


@pytest.fixture(scope='module')
def one_joint_bag(tmp_path_factory):
    recording = robot.generate_wear_test(n_experiments=3, wear_start=10.0, wear_end=50.0,
                                         seed=21, rate_hz=1000.0)
    return robot.write_bag(tmp_path_factory.mktemp('one') / 'bag', recording), recording


def _batch_sizes(n, kind):
    if kind == 'random':
        return np.random.default_rng(3).integers(1, 400, size=n).tolist()
    return [kind] * n


def _drained(configuration, bag, kind):
    """Return the batches' experiments (end of stream flushed, as the replay) and services."""
    messages = list(iter_raw_messages(bag))
    experiments = JointExperiments(configuration.experiment, source='test')
    batches = JointStateBatches(experiments)
    done, start = [], 0
    for size in _batch_sizes(len(messages), kind):
        part = messages[start:start + size]
        if not part:
            break
        done += batches.add([raw for _, raw in part], [ns for ns, _ in part])
        start += size
    assert batches.messages == len(messages)
    done += experiments.finish()
    return done, experiments


def _replayed(configuration, bag):
    result = replay_bag(bag, out_bag=None, configuration=configuration)
    return [(u.joint, u.stamp_s, u.speeds_rad_s, u.frictions) for u in result.updates]


def _published(done):
    """Return the friction_levels a node publishes: (joint, stamp, speeds, frictions)."""
    rows = [(service.joint, experiment.end_time_s, tuple(experiment.speeds_rad_s),
             tuple(experiment.frictions)) for service, experiment in done]
    return sorted(rows, key=lambda row: row[1])


@pytest.mark.parametrize('kind', [50, 7, 1000, 'random'])
def test_batches_of_any_size_give_the_replays_friction_levels_bit_for_bit(one_joint_bag, kind):
    bag, recording = one_joint_bag
    configuration = MonitorConfig.load()
    expected = _replayed(configuration, bag)
    assert len(expected) == 3
    done, experiments = _drained(configuration, bag, kind)
    assert _published(done) == sorted(expected, key=lambda row: row[1])  # == on floats
    service = experiments.services['joint_2']
    assert service.messages == len(recording.stamps_s)
    for got, truth in zip(_published(done), recording.truth):
        assert got[3] == pytest.approx(tuple(truth.friction_true), abs=0.005)


def test_two_joints_under_all_give_the_replays_levels(tmp_path):
    arm = foreign.default_joints()
    protocol = foreign.Protocol(plateau_s=0.5, ramp_s=0.15, dwell_s=0.2, bump_s=0.4,
                                idle_gap_s=2.0, lead_in_s=0.5)
    recording = foreign.generate(schedule=['shoulder', 'wrist_3', 'shoulder'], joints=arm,
                                 protocol=protocol, seed=5)
    bag = foreign.write_bag(recording, tmp_path / 'bag')
    config = tmp_path / 'config.yaml'
    config.write_text('friction_experiment_node:\n  ros__parameters:\n    joints: [all]\n'
                      '    shoulder: {gear_ratio: 120.0, torque_scale: 2000.0}\n'
                      '    wrist_3: {gear_ratio: 1.0, torque_scale: 20.0}\n'
                      'wear_estimator_node:\n  ros__parameters:\n    joints: [all]\n')
    configuration = MonitorConfig.load(config_file=config)
    expected = _replayed(configuration, bag)
    assert {row[0] for row in expected} == {'shoulder', 'wrist_3'}
    done, experiments = _drained(configuration, bag, 50)
    assert _published(done) == sorted(expected, key=lambda row: row[1])
    assert set(experiments.services) >= {'shoulder', 'wrist_3'}


def _joint_state(stamp_s, names, position, velocity, effort):
    msg = TS.types['sensor_msgs/msg/JointState'](
        header=TS.types['std_msgs/msg/Header'](
            stamp=TS.types['builtin_interfaces/msg/Time'](
                sec=int(stamp_s // 1), nanosec=int(round(stamp_s % 1 * 1e9))), frame_id=''),
        name=list(names), position=np.asarray(position, dtype=float),
        velocity=np.asarray(velocity, dtype=float), effort=np.asarray(effort, dtype=float))
    return msg


def test_bad_messages_are_counted_as_the_per_message_path_counts_them():
    recording = robot.generate_wear_test(n_experiments=1, wear_start=30.0, wear_end=30.0,
                                         seed=7, rate_hz=250.0)
    names = list(recording.names)
    t0 = recording.stamps_s[0] - 100.0
    zeros = [0.0] * len(names)
    msgs = [_joint_state(t0, names, zeros, zeros[:3], zeros),                  # unequal
            _joint_state(t0 + 0.01, names, zeros, [float('nan')] * 6, zeros),  # NaN
            _joint_state(t0 + 0.02, names[2:], zeros[2:], zeros[2:], zeros[2:]),  # no joint
            _joint_state(t0 + 0.03, names, zeros, zeros, zeros),
            _joint_state(t0 + 0.025, names, zeros, zeros, zeros),              # backwards
            _joint_state(t0 + 5.0, names, zeros, [], zeros)]                   # no velocity
    msgs += [_joint_state(*fields) for fields in robot.messages(recording)]
    raws = [TS.serialize_cdr(m, 'sensor_msgs/msg/JointState') for m in msgs]
    values = MonitorConfig.load().experiment

    one_by_one = JointExperiments(values, source='test')
    for m in msgs:
        one_by_one.add_joint_state(stamp_s=m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                                   name=m.name, position=m.position, velocity=m.velocity,
                                   effort=m.effort)
    drained = JointExperiments(values, source='test')
    batches = JointStateBatches(drained)
    for start in range(0, len(raws), 50):
        batches.add(raws[start:start + 50], np.zeros(len(raws[start:start + 50])))
    batches.add([b'\x00\x01garbage', b''], [0, 0])  # no JointState: counted, no exception
    expected, got = one_by_one.services['joint_2'], drained.services['joint_2']
    assert got.levels == expected.levels
    rejected = got.all_rejections()
    assert rejected.pop('malformed') == 2
    assert rejected == expected.all_rejections()
    assert {reason: rejected[reason] for reason in ('length_mismatch', 'non_finite',
                                                    'joint_missing', 'time_not_increasing',
                                                    'missing_velocity')} == dict.fromkeys(
        ('length_mismatch', 'non_finite', 'joint_missing', 'time_not_increasing',
         'missing_velocity'), 1)
    assert got.messages == expected.messages + 2 == len(msgs) + 2


def test_a_zero_stamp_takes_the_reception_time():
    names = ['joint_2']
    raws = [TS.serialize_cdr(_joint_state(0.0, names, [0.0], [0.01 * k], [0.0]),
                             'sensor_msgs/msg/JointState') for k in range(1, 4)]
    experiments = JointExperiments(MonitorConfig.load().experiment, source='test')
    batches = JointStateBatches(experiments)
    batches.add(raws, [5_000_000_000, 5_001_000_000, 5_002_000_000])
    service = experiments.services['joint_2']
    assert service.messages == 3 and not service.all_rejections()
    assert batches.decoder.zero_stamps == 3
