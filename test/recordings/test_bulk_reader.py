"""
The bulk MCAP reader gives exactly what rosbags' message iteration gives, on every bag kind.

Own simulator bags, the foreign recorder's bags (shuffled joint order, absent joints, empty
efforts, zero stamps, dropped messages, files split in parts), an MCAP with zstd- and
lz4-compressed chunks and several topics, and the bags the bulk reader must leave to rosbags
(sqlite3, a cut-off recording): the chunks' arrays and the reader's counters are compared
number for number, and so are the replay summaries.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.recordings.bags import iter_joint_chunks
from robot_wear_monitor.recordings.bags.mcap_chunks import bulk_source
from wear_testing import foreign_recordings as foreign


def _read(bag, *, bulk, joints=None):
    stream = iter_joint_chunks(bag, joints=joints, chunk_messages=5000)
    stream.bulk = bulk
    arrays: dict[str, list] = {}
    for chunk in stream:
        for joint, part in chunk.items():
            arrays.setdefault(joint, []).append(np.stack([part.time_s, part.position_rad,
                                                          part.velocity_rad_s, part.effort]))
    merged = {joint: np.concatenate(parts, axis=1) for joint, parts in arrays.items()}
    return merged, stream


def _same(bag, *, expect_bulk, joints=None):
    fast, fast_stream = _read(bag, bulk=True, joints=joints)
    slow, slow_stream = _read(bag, bulk=False, joints=joints)
    assert fast_stream.bulk_read is expect_bulk and not slow_stream.bulk_read
    assert fast.keys() == slow.keys() and fast
    for joint in fast:
        np.testing.assert_array_equal(fast[joint], slow[joint])  # NaN == NaN here
    assert fast_stream.message_count == slow_stream.message_count
    assert fast_stream.rejections == slow_stream.rejections
    assert fast_stream.joints_seen == slow_stream.joints_seen
    assert fast_stream.zero_stamps == slow_stream.zero_stamps


@pytest.fixture(scope='module')
def simulated(tmp_path_factory):
    folder = tmp_path_factory.mktemp('bulk')
    bag = folder / 'simulated'
    assert main(['simulate', '--out', str(bag), '--experiments', '4', '--seed', '3']) == 0
    return bag


def test_the_simulators_bag_reads_the_same(simulated):
    _same(simulated, expect_bulk=True)
    _same(simulated, expect_bulk=True, joints=['joint_2', 'joint_5'])


@pytest.mark.parametrize('imperfections, split', [
    (foreign.Imperfections(), 1),
    (foreign.Imperfections(shuffle_order=True, absent_fraction=0.05,
                           effort_empty_fraction=0.02, zero_stamp_fraction=0.01,
                           drop_fraction=0.02, stamp_jitter_fraction=0.2), 1),
    (foreign.Imperfections(shuffle_order=True), 3),
])
def test_the_foreign_recorders_bags_read_the_same(tmp_path, imperfections, split):
    recording = foreign.generate(schedule=['shoulder', 'elbow'], imperfections=imperfections,
                                 seed=4)
    bag = foreign.write_bag(recording, tmp_path / 'foreign', split_files=split)
    _same(bag, expect_bulk=True)


@pytest.mark.parametrize('compression', ['zstd', 'lz4'])
def test_compressed_chunks_and_other_topics_read_the_same(tmp_path, simulated, compression):
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer
    source = next(simulated.glob('*.mcap'))
    bag = tmp_path / 'compressed'
    bag.mkdir()
    target = bag / 'compressed_0.mcap'
    with open(source, 'rb') as stream, open(target, 'wb') as out:
        reader = make_reader(stream)
        writer = Writer(out, chunk_size=200_000,
                        compression=getattr(CompressionType, compression.upper()))
        writer.start(profile='ros2', library='test')
        summary = reader.get_summary()
        schema_ids = {s.id: writer.register_schema(s.name, s.encoding, s.data)
                      for s in summary.schemas.values()}
        channel_ids = {c.id: writer.register_channel(c.topic, c.message_encoding,
                                                     schema_ids[c.schema_id], c.metadata)
                       for c in summary.channels.values()}
        other = writer.register_channel('/other', 'cdr', next(iter(schema_ids.values())))
        for k, (_, channel, message) in enumerate(reader.iter_messages()):
            writer.add_message(channel_ids[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
            if k % 7 == 0:  # a second topic interleaved: other sizes, other channel
                writer.add_message(other, message.log_time, message.data[:40],
                                   message.publish_time, k)
        writer.finish()
    metadata = (simulated / 'metadata.yaml').read_text().replace(
        source.name, target.name)
    (bag / 'metadata.yaml').write_text(metadata)
    assert bulk_source(bag, '/joint_states') is not None
    _same(bag, expect_bulk=True)


def test_bags_the_bulk_reader_leaves_to_rosbags(tmp_path):
    recording = foreign.generate(schedule=['shoulder'], seed=5)
    sqlite = foreign.write_bag(recording, tmp_path / 'sqlite', storage='sqlite3')
    assert bulk_source(sqlite, '/joint_states') is None
    _same(sqlite, expect_bulk=False)
    bag = foreign.write_bag(recording, tmp_path / 'cut')
    (bag / 'metadata.yaml').unlink()  # what a crash leaves: read by the recovery
    assert bulk_source(bag, '/joint_states') is None
    _same(bag, expect_bulk=False)


def test_the_replay_summary_is_the_same_either_way(simulated, tmp_path, monkeypatch):
    summaries = []
    for flag in ('1', '0'):
        monkeypatch.setenv('ROBOT_WEAR_MONITOR_BULK_READ', flag)
        out = tmp_path / f'summary{flag}.json'
        assert main(['replay', str(simulated), '--history', str(tmp_path / f'h{flag}.db'),
                     '--json-out', str(out), '--no-progress', '--joint', 'all']) == 0
        summary = json.loads(out.read_text())
        summaries.append(summary)
    assert summaries[0] == summaries[1] and summaries[0]['experiments']


def _bag_with_a_bad_chunk(simulated, folder):
    """Copy the simulated bag with its third chunk's record overwritten (a corrupt bag)."""
    import shutil
    bag = folder / 'bad_chunk'
    shutil.copytree(simulated, bag)
    chunk = bulk_source(bag, '/joint_states').chunks[2]
    with open(chunk.file, 'r+b') as handle:
        handle.seek(chunk.offset)
        handle.write(b'\x00' * 64)
    return bag


def test_a_bad_chunk_raises_where_it_is_reached(simulated, tmp_path):
    from robot_wear_monitor.recordings.bags import BagError
    bag = _bag_with_a_bad_chunk(simulated, tmp_path)
    stream = iter_joint_chunks(bag, joints=['joint_2'], chunk_messages=1000)
    good, _ = _read(simulated, bulk=True, joints=['joint_2'])
    seen = []
    with pytest.raises(BagError, match='corrupt or truncated bag: .*chunk at byte'):
        for chunk in stream:
            seen.append(chunk['joint_2'].time_s)
    assert 2000 <= sum(map(len, seen)) < good['joint_2'].shape[1]
    np.testing.assert_array_equal(np.concatenate(seen), good['joint_2'][0, :sum(map(len, seen))])


def test_the_chunks_from_rosbags_index_are_those_of_the_mcap_summary(simulated, tmp_path):
    from robot_wear_monitor.recordings.bags import open_reader
    from robot_wear_monitor.recordings.bags.mcap_chunks import bulk_source_of
    recording = foreign.generate(schedule=['shoulder', 'elbow'],
                                 imperfections=foreign.Imperfections(), seed=4)
    split = foreign.write_bag(recording, tmp_path / 'foreign', split_files=3)
    for bag in (simulated, split):
        reader = open_reader(bag)
        try:
            known, source = bulk_source_of(reader, '/joint_states')
        finally:
            reader.close()
        summary = bulk_source(bag, '/joint_states')
        assert known and source is not None and summary is not None
        assert source.chunks == summary.chunks and len(source.chunks) > 1
        assert source.channels == summary.channels
    sqlite = tmp_path / 'sqlite'
    assert main(['simulate', '--out', str(sqlite), '--experiments', '1', '--seed', '3',
                 '--storage', 'sqlite3']) == 0
    reader = open_reader(sqlite)
    try:
        assert bulk_source_of(reader, '/joint_states') == (False, None)
    finally:
        reader.close()
    assert bulk_source(sqlite, '/joint_states') is None
