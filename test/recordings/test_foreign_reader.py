"""
The multi-joint bag reader on foreign recordings, item by item of issue 8 point 5.

Recordings come from ``test/wear_testing/foreign_recordings.py`` (an independent generator: its own
trajectory, noise, protocol and rosbags writing).  Every test compares what the reader returns
with what the generator wrote: the samples per joint (bit for bit), the stamps, the message
count and the rejections per joint and reason.
"""

import numpy as np
import pytest
from robot_wear_monitor.experiment.segmentation import segment_batch, SegmenterConfig
from robot_wear_monitor.recordings.bags import (BagError, iter_joint_chunks, JOINT_STATE_TYPE,
                                                read_joint_samples, read_joints, READER_REASONS,
                                                TYPESTORE)
from wear_testing import foreign_recordings as fr

SCHEDULE = ('shoulder', 'wrist_3', 'elbow', 'shoulder')


def _recording(seed=0, schedule=SCHEDULE, **imperfections):
    return fr.generate(schedule=list(schedule), seed=seed,
                       imperfections=fr.Imperfections(**imperfections))


def _read_all(bag, joints=None, **options):
    stream = iter_joint_chunks(bag, joints=joints, **options)
    parts = {}
    chunks = 0
    for chunk in stream:
        chunks += 1
        for joint, samples in chunk.items():
            parts.setdefault(joint, []).append(samples)
    arrays = {joint: {field: np.concatenate([getattr(p, field) for p in pieces])
                      for field in ('time_s', 'position_rad', 'velocity_rad_s', 'effort')}
              for joint, pieces in parts.items()}
    return stream, arrays, chunks


def _check(recording, stream, arrays, joints=None):
    """Assert the reader returned what the generator wrote, per joint, and counted the rest."""
    assert stream.message_count == len(recording)
    for joint in joints or recording.joint_names:
        expected = recording.expected_samples(joint)
        got = arrays[joint]
        assert got['time_s'].size == expected['time_s'].size, joint
        for field in ('position_rad', 'velocity_rad_s', 'effort'):
            assert np.array_equal(got[field], expected[field]), (joint, field)
        assert np.array_equal(got['time_s'], expected['time_s']), joint
        assert dict(stream.rejections[joint]) == recording.expected_rejections(joint), joint
        assert set(stream.rejections[joint]) <= set(READER_REASONS)


@pytest.mark.parametrize('rate_hz', [100.0, 1000.0])
def test_rates_jitter_and_dropped_messages(tmp_path, rate_hz):
    recording = _recording(rate_hz=rate_hz, stamp_jitter_fraction=0.2, drop_fraction=0.05,
                           schedule=('shoulder', 'wrist_3'))
    assert recording.dropped > 0
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, _ = _read_all(bag)
    _check(recording, stream, arrays)
    # the stamps are the jittered header stamps, not the receive times and not a grid
    time_s = arrays['shoulder']['time_s']
    steps = np.diff(time_s)
    period = 1.0 / rate_hz
    assert np.all(steps > 0) and np.std(steps[steps < 1.5 * period]) > 0.05 * period
    assert np.count_nonzero(steps > 1.5 * period) >= 0.5 * recording.dropped
    assert stream.stamp_source == 'header' and stream.notes == [] and stream.zero_stamps == 0


def test_joint_order_differs_between_messages(tmp_path):
    recording = _recording(shuffle_order=True)
    assert len({tuple(row) for row in recording.order[:500]}) > 100
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, _ = _read_all(bag)
    _check(recording, stream, arrays)
    assert not any(stream.rejections[j] for j in recording.joint_names)


def test_joints_absent_from_some_messages(tmp_path):
    recording = _recording(absent_fraction=0.05, shuffle_order=True)
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, _ = _read_all(bag)
    _check(recording, stream, arrays)
    for joint in recording.joint_names:
        assert stream.rejections[joint]['joint_missing'] == \
            np.count_nonzero(~recording.present(joint)) > 0


def test_effort_empty_in_some_messages(tmp_path):
    recording = _recording(effort_empty_fraction=0.03)
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, _ = _read_all(bag, joints=['shoulder', 'wrist_3'])
    _check(recording, stream, arrays, joints=['shoulder', 'wrist_3'])
    assert set(arrays) == {'shoulder', 'wrist_3'} and set(stream.rejections) == set(arrays)
    assert stream.rejections['shoulder'] == {
        'missing_effort': int(np.count_nonzero(recording.effort_empty))}


@pytest.mark.parametrize('fraction', [1.0, 0.1])
def test_zero_header_stamps_fall_back_to_the_receive_time(tmp_path, fraction):
    recording = _recording(zero_stamp_fraction=fraction, schedule=('elbow',))
    zero = int(np.count_nonzero(recording.stamp_ns == 0))
    assert zero > 0
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, chunks = _read_all(bag, chunk_messages=997)
    assert chunks > 2
    _check(recording, stream, arrays)
    assert stream.zero_stamps == zero
    assert stream.stamp_source == ('receive_time' if fraction == 1.0 else 'mixed')
    assert len(stream.notes) == 1 and f'{zero} of {len(recording)}' in stream.notes[0]
    assert 'receive time' in stream.notes[0] and str(bag) in stream.notes[0]
    samples = read_joint_samples(bag, joint='elbow')
    assert samples.zero_stamps == zero and samples.notes == stream.notes


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
@pytest.mark.parametrize('split_files', [1, 3])
def test_storages_and_bags_split_in_files(tmp_path, storage, split_files):
    recording = _recording(shuffle_order=True, absent_fraction=0.01, schedule=('elbow',),
                           rate_hz=250.0)
    bag = fr.write_bag(recording, tmp_path / 'bag', storage=storage, split_files=split_files)
    suffix = '.mcap' if storage == 'mcap' else '.db3'
    assert len(list(bag.glob('*' + suffix))) == split_files
    stream, arrays, _ = _read_all(bag)
    _check(recording, stream, arrays)
    assert stream.total_messages == len(recording)


@pytest.mark.parametrize('rate_hz', [100.0, 400.0, 1000.0])
def test_everything_at_once_and_the_experiments_are_found(tmp_path, rate_hz):
    """All of point 5 in one bag; the segmenter on the reader's samples finds the truth."""
    recording = fr.generate(
        schedule=['shoulder', 'elbow', 'wrist_3', 'shoulder', 'elbow'], seed=4,
        window_drift_rad=0.04,
        imperfections=fr.Imperfections(rate_hz=rate_hz, stamp_jitter_fraction=0.1,
                                       drop_fraction=0.01, shuffle_order=True,
                                       absent_fraction=0.005, effort_empty_fraction=0.005,
                                       zero_stamp_fraction=0.02, interrupt_experiment=1))
    bag = fr.write_bag(recording, tmp_path / 'bag', storage='sqlite3', split_files=2)
    stream, arrays, _ = _read_all(bag)
    _check(recording, stream, arrays)
    assert recording.joints['wrist_3'].gear_ratio == 1.0
    for joint in ('shoulder', 'elbow', 'wrist_3'):
        spec = recording.joints[joint]
        got = arrays[joint]
        result = segment_batch(**got, config=SegmenterConfig(
            joint=joint, gear_ratio=spec.gear_ratio, torque_scale=spec.torque_scale))
        truth = [level for e in recording.experiments_of(joint) for level in e.levels
                 if level.complete]
        assert len(result.levels) == len(truth), joint
        for found, level in zip(result.levels, truth):
            assert found.speed_rad_s == pytest.approx(level.speed_rad_s, rel=0.01)
            assert found.friction == pytest.approx(level.tau_f, abs=2e-3)
            assert level.forward_s[0] - 0.1 <= found.start_time_s <= level.backward_s[1]
    broken = [e for e in recording.experiments if e.interrupted]
    assert len(broken) == 1 and broken[0].joint == 'elbow'
    assert [lv.complete for lv in broken[0].levels] == [True, False]
    truth = recording.truth_dict()
    assert truth['format'] == 'foreign_recordings/1' and len(truth['experiments']) == 5


def test_joints_appear_in_the_order_first_seen(tmp_path):
    recording = _recording(schedule=('wrist_3',))
    # the first messages name the joints backwards, later ones forwards
    recording.order[:50] = recording.order[:50, ::-1]
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream = iter_joint_chunks(bag)
    first = next(iter(stream))
    assert list(first) == list(reversed(recording.joint_names))
    assert stream.joints_seen == list(reversed(recording.joint_names))


def test_chunks_are_bounded_and_concatenate_to_read_joint_samples(tmp_path):
    recording = _recording(shuffle_order=True, schedule=('shoulder',))
    bag = fr.write_bag(recording, tmp_path / 'bag')
    seen = []
    stream = iter_joint_chunks(bag, joints=['shoulder'], chunk_messages=1000,
                               progress=lambda read, total: seen.append((read, total)))
    sizes = []
    for chunk in stream:
        assert list(chunk) == ['shoulder']
        sizes.append(len(chunk['shoulder']))
    assert max(sizes) <= 1000 and len(sizes) == -(-len(recording) // 1000)
    assert seen[-1] == (len(recording), len(recording)) and len(seen) == len(sizes)
    samples = read_joint_samples(bag, joint='shoulder')
    expected = recording.expected_samples('shoulder')
    assert np.array_equal(samples.effort, expected['effort'])
    assert np.array_equal(samples.time_s, expected['time_s'])
    assert samples.message_count == len(recording) and not samples.rejections


def test_errors_name_the_bag_and_list_what_there_is(tmp_path):
    recording = _recording(schedule=('shoulder',))
    bag = fr.write_bag(recording, tmp_path / 'bag')
    with pytest.raises(BagError, match=r'no topic /js \(topics: /joint_states\)'):
        iter_joint_chunks(bag, topic='/js')
    stream = iter_joint_chunks(bag, joints=['shoulder', 'knee'])
    with pytest.raises(BagError) as error:
        for _ in stream:
            pass
    message = str(error.value)
    assert str(bag) in message and "'knee'" in message and '\n' not in message
    assert 'joints seen: ' + ', '.join(recording.joint_names) in message
    stream = iter_joint_chunks(bag, joints=['shoulder', 'knee'], require_joints=False)
    chunks = list(stream)
    assert stream.joints_missing == ['knee'] and all(len(c['knee']) == 0 for c in chunks)
    assert stream.rejections['knee'] == {'joint_missing': len(recording)}


def test_malformed_messages_are_counted_for_every_joint(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    recording = _recording(schedule=('shoulder',))
    writer = Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection('/joint_states', JOINT_STATE_TYPE, typestore=TYPESTORE)
    rows = range(300)
    for row in rows:
        writer.write(connection, int(recording.receive_ns[row]), fr._serialize(recording, row))
    for k in range(3):
        writer.write(connection, int(recording.receive_ns[300 + k]), b'\x00\x01\x00\x00junk')
    writer.close()
    stream, arrays, _ = _read_all(tmp_path / 'bag')
    assert stream.message_count == 303
    for joint in recording.joint_names:
        assert stream.rejections[joint] == {'malformed': 3}
        assert arrays[joint]['time_s'].size == 300


def test_new_joints_are_ordered_by_their_first_message_whatever_its_size(tmp_path):
    recording = _recording(schedule=('wrist_3',))
    wrist_3 = recording.joint_names.index('wrist_3')
    # the first messages lack wrist_3; later, smaller ones carry it but lack two other joints
    recording.order[:100, wrist_3] = -1
    recording.order[100:200, :2] = -1
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream = iter_joint_chunks(bag)
    first = next(iter(stream))
    assert list(first) == list(recording.joint_names) == stream.joints_seen
    for _ in stream:
        pass
    _check(recording, stream, {j: {f: getattr(c, f) for f in ('time_s', 'position_rad',
                                                              'velocity_rad_s', 'effort')}
                               for j, c in first.items()})


def test_big_endian_messages(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    recording = _recording(schedule=('shoulder',), shuffle_order=True)
    writer = Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.SQLITE3)
    writer.open()
    connection = writer.add_connection('/joint_states', JOINT_STATE_TYPE, typestore=TYPESTORE)
    for row in range(len(recording)):
        message = TYPESTORE.deserialize_cdr(fr._serialize(recording, row), JOINT_STATE_TYPE)
        raw = TYPESTORE.serialize_cdr(message, JOINT_STATE_TYPE, little_endian=row % 3 != 0)
        writer.write(connection, int(recording.receive_ns[row]), bytes(raw))
    writer.close()
    stream, arrays, _ = _read_all(tmp_path / 'bag')
    _check(recording, stream, arrays)


def test_read_joints_concatenates_the_chunks(tmp_path):
    recording = _recording(absent_fraction=0.02, effort_empty_fraction=0.01,
                           zero_stamp_fraction=0.01, schedule=('elbow',))
    bag = fr.write_bag(recording, tmp_path / 'bag', storage='sqlite3')
    samples = read_joints(bag, chunk_messages=1234)
    assert list(samples) == list(recording.joint_names)
    for joint, read in samples.items():
        expected = recording.expected_samples(joint)
        for field in ('time_s', 'position_rad', 'velocity_rad_s', 'effort'):
            assert np.array_equal(getattr(read, field), expected[field])
        assert dict(read.rejections) == recording.expected_rejections(joint)
        assert read.message_count == len(recording) and len(read.notes) == 1
    chosen = read_joints(bag, joints=['elbow', 'nowhere'], require_joints=False)
    assert list(chosen) == ['elbow', 'nowhere'] and chosen['nowhere'].time_s.size == 0


def test_layouts_forgotten_between_chunks_keep_their_tallies(tmp_path, monkeypatch):
    from robot_wear_monitor.recordings.bags import cdr
    monkeypatch.setattr(cdr, '_MAX_LAYOUTS', 20)
    recording = _recording(shuffle_order=True, absent_fraction=0.05, effort_empty_fraction=0.02,
                           schedule=('elbow',))
    bag = fr.write_bag(recording, tmp_path / 'bag')
    stream, arrays, chunks = _read_all(bag, chunk_messages=500)
    assert chunks > 3 and len(stream._decoder.known) < 600
    _check(recording, stream, arrays)


def test_truth_file_bags_without_motion_and_without_the_topic(tmp_path):
    import json
    recording = _recording(schedule=('shoulder', 'shoulder', 'shoulder'))
    truth = json.loads(recording.write_truth(tmp_path / 'truth.json').read_text())
    assert [e['wear'] for e in truth['experiments']] == \
        [e.wear for e in recording.experiments]
    assert truth['experiments'][0]['levels'][0]['tau_f'] == \
        recording.experiments[0].levels[0].tau_f
    over = recording.first_experiment_over('shoulder', 20.0)
    assert over is not None and over.wear >= 20.0 and over.joint_experiment == 1
    still = fr.generate(schedule=[], hold_s=5.0)
    bag = fr.write_bag(still, tmp_path / 'still')
    stream, arrays, _ = _read_all(bag)
    _check(still, stream, arrays)
    assert not any(np.any(arrays[j]['velocity_rad_s']) for j in still.joint_names)
    other = fr.write_bag(still, tmp_path / 'other', topic='/arm/joint_states')
    with pytest.raises(BagError, match=r'no topic /joint_states \(topics: /arm/joint_states\)'):
        iter_joint_chunks(other)


def test_an_unfinished_recording_gives_a_prefix_of_every_joint(tmp_path):
    # big enough for several MCAP chunks: a cut keeps the complete chunks before it
    recording = _recording(shuffle_order=True, absent_fraction=0.01, rate_hz=1000.0,
                           schedule=('elbow', 'shoulder', 'wrist_3'))
    bag = fr.write_bag(recording, tmp_path / 'bag')
    (source,) = bag.glob('*.mcap')
    cut = tmp_path / 'cut'
    cut.mkdir()
    data = source.read_bytes()
    (cut / source.name).write_bytes(data[:int(len(data) * 0.7)])
    stream, arrays, _ = _read_all(cut)
    recovery = stream.recovery
    assert recovery is not None and not recovery.complete
    assert 0 < recovery.messages == stream.message_count < len(recording)
    assert recovery.last_stamp_s == recording.receive_ns[recovery.messages - 1] * 1e-9
    kept = recovery.messages
    for joint in recording.joint_names:
        expected = recording.expected_samples(joint)
        got = arrays[joint]
        size = got['time_s'].size
        assert size == np.count_nonzero(recording.present(joint)[:kept])
        for field in ('time_s', 'position_rad', 'velocity_rad_s', 'effort'):
            assert np.array_equal(got[field], expected[field][:size])
    with pytest.raises(BagError, match='refused'):
        list(iter_joint_chunks(cut, recover=False))
