"""
The decoder reads messages where they lie in their chunk exactly as it reads them one by one.

A chunk of same-size messages comes to the decoder as a strided view into the chunk's bytes
(:class:`~robot_wear_monitor.recordings.bags.mcap_chunks.RawRows`); when all of them share a
known layout they are read in place, otherwise in a decoding block.  Both ways, and a chunk
given in several pieces, must give the samples, stamps, tallies and joint order of the same
messages given as a list of bytes: checked on chunks of one layout, with zero stamps, with
mixed name orders and frame ids of the same size, and with an unusable layout (empty efforts).
"""

from __future__ import annotations

import numpy as np
from robot_wear_monitor.recordings.bags import encode_joint_states, MultiDecoder
from robot_wear_monitor.recordings.bags.mcap_chunks import RawRows

NAMES = ['joint_a', 'joint_b', 'joint_c']
#: bytes before each message in its record (an MCAP message record's opcode, length, header)
HEAD = 31


def _messages(rng, n, *, order=None, frame_id='base', zero=(), empty_effort=False):
    stamps = 100.0 + np.arange(n) * 1e-3 + rng.uniform(0, 1e-4, n)
    stamps[list(zero)] = 0.0
    values = [rng.normal(size=(n, 3)) for _ in range(3)]
    if empty_effort:
        values[2] = np.zeros((n, 0))
        raws = []
        for i in range(n):
            raws += encode_joint_states(stamps_s=stamps[i:i + 1], names=NAMES[:0],
                                        position=np.zeros((1, 0)), velocity=np.zeros((1, 0)),
                                        effort=values[2][i:i + 1], frame_id=frame_id)
        return raws
    name_order = None if order is None else np.tile(order, (n, 1))
    return encode_joint_states(stamps_s=stamps, names=NAMES, position=values[0],
                               velocity=values[1], effort=values[2], name_order=name_order,
                               frame_id=frame_id)


def _in_records(raws):
    """Lay same-size messages out as the records of a chunk; return the strided rows."""
    size = len(raws[0])
    stride = HEAD + size
    data = np.full(len(raws) * stride + 5, 0xA5, dtype=np.uint8)  # odd offset: unaligned
    for i, raw in enumerate(raws):
        data[5 + i * stride + HEAD:5 + (i + 1) * stride] = np.frombuffer(raw, dtype=np.uint8)
    return RawRows(data[5:].reshape(len(raws), stride)[:, HEAD:])


def _chunks(rng):
    n = 400
    plain = _messages(rng, n)
    mixed = _messages(rng, n)
    mixed[100:150] = _messages(rng, 50, order=[2, 0, 1])    # same size, other name order
    mixed[300:310] = _messages(rng, 10, frame_id='tool')    # same size, other frame id
    return [plain, _messages(rng, n, zero=[0, 7, 399]), mixed,
            _messages(rng, n, order=[1, 2, 0]), _messages(rng, n), plain[:1]]


def _same(a, b):
    assert list(a) == list(b)
    for joint in a:
        for key in ('time_s', 'position_rad', 'velocity_rad_s', 'effort'):
            np.testing.assert_array_equal(getattr(a[joint], key), getattr(b[joint], key))


def _tallies(decoder):
    return (decoder.messages, decoder.malformed, decoder.zero_stamps, list(decoder.seen),
            decoder.rejections())


def test_rows_in_place_read_like_bytes():
    for joints in (None, ['joint_b'], ['joint_c', 'missing']):
        rows, listed, pieces = MultiDecoder(joints), MultiDecoder(joints), MultiDecoder(joints)
        for raws in _chunks(np.random.default_rng(5)):
            receive = np.arange(len(raws), dtype=np.int64) * 1_000_000 + 7
            expected = listed.decode(list(raws), receive)
            _same(rows.decode(_in_records(raws), receive), expected)
            cut = max(1, len(raws) // 3)
            parts = [(receive[:cut], _in_records(raws[:cut]))]
            if cut < len(raws):
                parts.append((receive[cut:], list(raws[cut:])))
            _same(pieces.decode_pieces(parts), expected)
            assert _tallies(rows) == _tallies(listed) == _tallies(pieces)
        assert rows.zero_stamps == 3 and rows.rejections() == listed.rejections()


def test_unusable_layout_is_counted_in_place():
    rng = np.random.default_rng(6)
    empty = _messages(rng, 20, empty_effort=True)
    rows, listed = MultiDecoder(None), MultiDecoder(None)
    for raws in (empty, empty):  # the second one is read in place (a known layout)
        receive = np.arange(len(raws), dtype=np.int64)
        _same(rows.decode(_in_records(raws), receive), listed.decode(list(raws), receive))
    assert _tallies(rows) == _tallies(listed)
    assert rows.messages == 40
