"""ROS 2 bags: CDR encoding against rosbags, round trips, independent mcap readers, errors."""

import numpy as np
import pytest
from robot_wear_monitor.experiment.simulation import (JointSimConfig, ScenarioConfig,
                                                      simulate_scenario)
from robot_wear_monitor.recordings.bags import (atomic_bag_writer, BagError, decode_joint_state,
                                                encode_joint_states, JOINT_STATE_TYPE,
                                                read_joint_samples, TYPESTORE,
                                                write_joint_state_bag)
from rosbags.rosbag2 import Reader


@pytest.fixture(scope='module')
def scenario():
    config = ScenarioConfig(speeds_rad_s=(8.7, 41.7), wear=(0.0, 40.0),
                            temperature_degc=(35.0, 45.0), load=(0.5, 0.6),
                            experiment_interval_s=60.0,
                            joint=JointSimConfig(shuffle_joint_order=True, sample_rate_hz=100))
    return simulate_scenario(config=config, seed=5)


def _write(path, scenario, storage='mcap'):
    return write_joint_state_bag(path, stamps_s=scenario.time_s, names=scenario.joint_names,
                                 position=scenario.position_rad,
                                 velocity=scenario.velocity_rad_s, effort=scenario.effort,
                                 name_order=scenario.name_order, storage=storage)


def test_encoding_equals_rosbags_serialize(scenario):
    messages = encode_joint_states(stamps_s=scenario.time_s[:50], names=scenario.joint_names,
                                   position=scenario.position_rad[:50],
                                   velocity=scenario.velocity_rad_s[:50],
                                   effort=scenario.effort[:50],
                                   name_order=scenario.name_order[:50], frame_id='base')
    for raw, (stamp, names, q, v, e) in zip(messages, scenario.messages()):
        msg = TYPESTORE.deserialize_cdr(raw, JOINT_STATE_TYPE)
        assert bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE_TYPE)) == raw
        assert msg.name == names and np.array_equal(msg.effort, e)
        stamp_back = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        assert abs(stamp_back - stamp) < 1e-6


@pytest.mark.parametrize('lengths', [(0, 2, 2), (2, 0, 2), (2, 2, 0), (1, 3, 0)])
def test_decoder_agrees_with_rosbags_on_odd_layouts(lengths):
    types = TYPESTORE.types
    msg = types[JOINT_STATE_TYPE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=3, nanosec=5), frame_id='abc'),
        name=['a', 'bb'], position=np.arange(lengths[0], dtype=float),
        velocity=np.arange(lengths[1], dtype=float) + 1, effort=np.arange(lengths[2]) + 2.0)
    raw = TYPESTORE.serialize_cdr(msg, JOINT_STATE_TYPE)
    stamp, frame, names, q, v, e = decode_joint_state(raw)
    assert (frame, names) == ('abc', ['a', 'bb']) and stamp == pytest.approx(3 + 5e-9)
    for ours, theirs in ((q, msg.position), (v, msg.velocity), (e, msg.effort)):
        assert np.array_equal(ours, theirs)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_round_trip(tmp_path, scenario, storage):
    bag = _write(tmp_path / 'bag', scenario, storage)
    samples = read_joint_samples(bag, joint=scenario.joint)
    t, q, v, e = scenario.joint_samples()
    assert samples.message_count == t.size and not samples.rejections
    assert np.array_equal(samples.position_rad, q) and np.array_equal(samples.effort, e)
    assert np.array_equal(samples.velocity_rad_s, v)
    assert np.max(np.abs(samples.time_s - t)) < 1e-6
    with Reader(bag) as reader:
        for (_, _, raw), index in zip(reader.messages(), range(200)):
            msg = TYPESTORE.deserialize_cdr(raw, JOINT_STATE_TYPE)
            j = list(msg.name).index(scenario.joint)
            assert msg.effort[j] == e[index] and msg.position[j] == q[index]


def test_independent_mcap_readers_decode_the_same(tmp_path, scenario):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    bag = _write(tmp_path / 'bag', scenario)
    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        decoded = list(reader.iter_decoded_messages(topics=['/joint_states']))
    assert len(decoded) == scenario.n_samples
    for (_, channel, message, ros), (stamp, names, q, v, e) in zip(decoded,
                                                                   scenario.messages()):
        assert channel.topic == '/joint_states' and list(ros.name) == names
        assert np.array_equal(ros.position, q) and np.array_equal(ros.effort, e)
        assert abs(ros.header.stamp.sec + ros.header.stamp.nanosec * 1e-9 - stamp) < 1e-6
        assert message.log_time == ros.header.stamp.sec * 10 ** 9 + ros.header.stamp.nanosec


def test_atomic_writer_leaves_nothing_on_error(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_bag_writer(tmp_path / 'bag') as bag:
            bag.add_topic('/x', 'std_msgs/msg/Float64')
            bag.write('/x', TYPESTORE.types['std_msgs/msg/Float64'](data=1.0), 1)
            raise RuntimeError('boom')
    assert list(tmp_path.iterdir()) == []


def test_existing_bag_is_not_overwritten(tmp_path, scenario):
    bag = _write(tmp_path / 'bag', scenario)
    with pytest.raises(BagError, match='already exists'):
        _write(bag, scenario)


def test_bag_errors(tmp_path, scenario):
    with pytest.raises(BagError, match='no such bag'):
        read_joint_samples(tmp_path / 'missing', joint='joint_2')
    bag = _write(tmp_path / 'bag', scenario)
    with pytest.raises(BagError, match='no topic /other'):
        read_joint_samples(bag, joint='joint_2', topic='/other')
    with pytest.raises(BagError, match="joint 'elbow'"):
        read_joint_samples(bag, joint='elbow')
    (mcap_file,) = bag.glob('*.mcap')
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[:len(data) // 2])
    with pytest.raises(BagError, match='bag'):
        read_joint_samples(bag, joint='joint_2')
    mcap_file.write_bytes(b'not a bag at all' * 10)
    with pytest.raises(BagError):
        read_joint_samples(bag, joint='joint_2')
    with atomic_bag_writer(tmp_path / 'wrong') as writer:
        writer.add_topic('/joint_states', 'std_msgs/msg/Float64')
        writer.write('/joint_states', TYPESTORE.types['std_msgs/msg/Float64'](data=1.0), 1)
    with pytest.raises(BagError, match='has type std_msgs/msg/Float64'):
        read_joint_samples(tmp_path / 'wrong', joint='joint_2')


def test_message_level_rejections_are_counted(tmp_path):
    names = ['a', 'b']
    good = encode_joint_states(stamps_s=[0.0, 0.1], names=names, position=np.ones((2, 2)),
                               velocity=np.ones((2, 2)), effort=np.ones((2, 2)))
    types = TYPESTORE.types
    header = types['std_msgs/msg/Header'](stamp=types['builtin_interfaces/msg/Time'](
        sec=1, nanosec=0), frame_id='')
    no_effort = TYPESTORE.serialize_cdr(types[JOINT_STATE_TYPE](
        header=header, name=names, position=np.ones(2), velocity=np.ones(2),
        effort=np.zeros(0)), JOINT_STATE_TYPE)
    other = TYPESTORE.serialize_cdr(types[JOINT_STATE_TYPE](
        header=header, name=['c'], position=np.ones(1), velocity=np.ones(1),
        effort=np.ones(1)), JOINT_STATE_TYPE)
    with atomic_bag_writer(tmp_path / 'bag', storage='sqlite3') as writer:
        writer.add_topic('/joint_states', JOINT_STATE_TYPE)
        for i, raw in enumerate(good + [bytes(no_effort), bytes(other)]):
            writer.write('/joint_states', raw, i)
    samples = read_joint_samples(tmp_path / 'bag', joint='b')
    assert samples.message_count == 4 and samples.time_s.size == 2
    assert samples.rejections == {'missing_effort': 1, 'joint_missing': 1}
