"""
Decoding ``sensor_msgs/msg/JointState`` CDR with numpy, many messages at a time.

:func:`decode_joint_state` decodes one message.  :class:`MultiDecoder` decodes a chunk: the
messages are grouped by layout (same length and same bytes apart from the stamp and the float
arrays: same frame_id, names, name order and array lengths), matched word by word against the
recent layouts and otherwise grouped with ``np.unique``; each new layout is parsed once, and the
stamps and every requested joint's position/velocity/effort of all messages sharing float
offsets are read with one gather.  Messages of one size that all share a recent layout (a
chunk of a recording, usually) are checked and read where they lie in their chunk (a strided
view, :meth:`MultiDecoder._decode_one_layout`), without a copy.  A message is rejected for a
joint, counted by reason (:data:`READER_REASONS`), when it lacks the joint or an array, or an
array's length differs from the names.  The decoder is one algorithm (layout cache, grouping,
gather) and reads best whole.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from functools import lru_cache
import struct
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.recordings.bags.common import BagError


@dataclass(frozen=True)
class Layout:
    """Byte layout of one encoded JointState (offsets from the start of the buffer)."""

    little: bool
    frame_id: str
    names: tuple[str, ...]
    arrays: tuple[tuple[int, int], tuple[int, int], tuple[int, int]]  # (offset, count) x3
    size: int

    def structure_ranges(self) -> list[tuple[int, int]]:
        """
        Byte ranges [start, stop) that must match for a message to share this layout.

        Everything but the stamp and the float arrays: the encapsulation header, frame_id,
        names and the array lengths.
        """
        ranges, start = [], 0
        for skip_start, skip_stop in [(4, 12)] + [(o, o + 8 * n) for o, n in self.arrays]:
            if skip_start > start:
                ranges.append((start, skip_start))
            start = max(start, skip_stop)
        if start < self.size:
            ranges.append((start, self.size))
        return ranges


def parse_layout(raw: bytes | memoryview) -> Layout:
    """Parse the layout of one CDR JointState; raise ValueError if it is malformed."""
    data = bytes(raw)
    if len(data) < 16 or data[0] != 0 or data[1] not in (0, 1):
        raise ValueError('not a CDR message')
    little = data[1] == 1
    end = '<' if little else '>'
    offset = 12

    def u32() -> int:
        nonlocal offset
        offset = 4 + ((offset - 4 + 3) & ~3)
        (value,) = struct.unpack_from(end + 'I', data, offset)
        offset += 4
        return value

    def string() -> str:
        nonlocal offset
        length = u32()
        if length == 0 or offset + length > len(data):
            raise ValueError('bad string')
        text = data[offset:offset + length - 1].decode('utf-8')
        offset += length
        return text

    frame_id = string()
    count = u32()
    if count > len(data):
        raise ValueError('bad name count')
    names = tuple(string() for _ in range(count))
    arrays = []
    for _ in range(3):
        n = u32()
        if n:
            offset = 4 + ((offset - 4 + 7) & ~7)
        if offset + 8 * n > len(data):
            raise ValueError('array past the end')
        arrays.append((offset, n))
        offset += 8 * n
    if offset != len(data) and len(data) - offset > 3:
        raise ValueError('trailing bytes')
    if len(arrays) != 3:
        raise ValueError(f'{len(arrays)} float arrays, expected 3')
    return Layout(little=little, frame_id=frame_id, names=names,
                  arrays=(arrays[0], arrays[1], arrays[2]), size=len(data))


def decode_joint_state(raw: bytes | memoryview) -> tuple[float, str, list[str], FloatArray,
                                                         FloatArray, FloatArray]:
    """
    Decode one CDR JointState: (stamp [s], frame_id, names, position, velocity, effort).

    :raises BagError: the bytes are not a JointState.

    """
    try:
        layout = parse_layout(raw)
    except (ValueError, struct.error, UnicodeDecodeError) as error:
        raise BagError(f'malformed JointState message: {error}') from None
    data = bytes(raw)
    end = '<' if layout.little else '>'
    sec, nanosec = struct.unpack_from(end + 'iI', data, 4)
    values = [np.frombuffer(data, dtype=end + 'f8', count=n, offset=o).astype(np.float64)
              for o, n in layout.arrays]
    return sec + nanosec * 1e-9, layout.frame_id, list(layout.names), *values


#: Message rejection reasons of the reader, per joint, in the order they are checked.  They are
#: the message reasons of :func:`robot_wear_monitor.experiment.segmentation.pick_joint` plus
#: ``malformed`` (bytes that are no JointState).  Non-finite values are passed on (the segmenter
#: counts them as ``non_finite``).
READER_REASONS = ('malformed', 'joint_missing', 'missing_position', 'missing_velocity',
                  'missing_effort', 'length_mismatch')
#: Layouts remembered by one stream (forgotten between chunks when exceeded; tallies are kept).
_MAX_LAYOUTS = 4096


def _layout_reason(layout: Layout) -> str | None:
    """Return the reason no joint of a layout can be used (empty or short arrays), else None."""
    n = len(layout.names)
    counts = [count for _, count in layout.arrays]
    for reason, count in zip(('missing_position', 'missing_velocity', 'missing_effort'),
                             counts):
        if count == 0:
            return reason
    if any(count != n for count in counts):
        return 'length_mismatch'
    return None


@dataclass
class JointChunk:
    """
    One joint's usable samples of one chunk of messages, in bag order; shape (m,).

    :ivar time_s: header stamps [s] (the bag receive time where the header stamp is zero).
    :ivar position_rad: joint positions [rad].
    :ivar velocity_rad_s: joint velocities [rad/s].
    :ivar effort: efforts (as recorded).

    """

    time_s: FloatArray
    position_rad: FloatArray
    velocity_rad_s: FloatArray
    effort: FloatArray

    def __len__(self) -> int:
        """Return the number of samples."""
        return int(self.time_s.size)


def _record_size(size: int) -> int:
    """Bytes per message in a decoding block: 4 bytes before, padding to a multiple of 8."""
    return 4 + size + (-(size + 4)) % 8


def _padded(raw: bytes | memoryview) -> NDArray[np.uint64]:
    """Return one message as the 8-byte words of its record in a decoding block."""
    size = len(raw)
    data = bytes(4) + bytes(raw) + bytes(_record_size(size) - 4 - size)
    return np.frombuffer(data, dtype='<u8')


@lru_cache(maxsize=256)
def _identifying_words(size: int, arrays: tuple[tuple[int, int], ...]) -> NDArray[np.int64]:
    """Return the words of a record that are neither the stamp nor a float (read-only)."""
    skip = {1}
    for offset, count in arrays:
        if count:
            first = (offset + 4) // 8
            skip.update(range(first, first + count))
    words = np.array([w for w in range(_record_size(size) // 8) if w not in skip],
                     dtype=np.int64)
    words.setflags(write=False)
    return words


class _Known:
    """
    A parsed layout: the words that identify it, its joints and its message tally.

    In a decoding block every message starts 4 bytes into an 8-byte word, so that CDR's
    8-byte alignment (counted from after the 4-byte encapsulation header) falls on words: the
    stamp is word 1 and every float is one word.  The other words identify the layout.
    """

    __slots__ = ('layout', 'words', 'reference', 'reason', 'index', 'count', 'end',
                 'signature', 'raw', '_structure')

    def __init__(self, layout: Layout, raw: bytes | memoryview) -> None:
        self.layout = layout
        self.raw = bytes(raw)
        self._structure: list[tuple[int, int, str, Any]] | None = None
        self.words = _identifying_words(layout.size, layout.arrays)
        self.reference = _padded(raw)[self.words]
        self.reason = _layout_reason(layout)
        self.index: dict[str, int] = {}
        for i, name in enumerate(layout.names):
            self.index.setdefault(name, i)
        self.count = 0
        self.end = '<' if layout.little else '>'
        #: what layouts read together share: byte order and the first word of each array
        self.signature = (self.end, tuple((offset + 4) // 8 for offset, _ in layout.arrays))

    def key(self) -> tuple[int, bytes, bytes]:
        """Return the identity of the layout: size, identifying words and their bytes."""
        return self.layout.size, self.words.tobytes(), self.reference.tobytes()

    def matches(self, rows: NDArray[np.uint8]) -> NDArray[np.bool_]:
        """
        Return which messages share this layout; ``rows`` has shape (n, size), one per row.

        The bytes the identifying words hold (:meth:`Layout.structure_ranges`: all but the
        stamp and the floats) are compared field by field (8 bytes at a time, then 4, 2, 1):
        what comparing the words of a decoding block tells, without copying the messages into
        one.  The rows may be a strided view (each message where it lies in its record).
        """
        same = np.ones(rows.shape[0], dtype=bool)
        for start, width, dtype, reference in self._fields():
            same &= rows[:, start:start + width].view(dtype)[:, 0] == reference
        return same

    def _fields(self) -> list[tuple[int, int, str, Any]]:
        """Return the identifying bytes as (offset, width, dtype, reference value), kept."""
        if self._structure is None:
            fields = []
            for start, stop in self.layout.structure_ranges():
                for width, dtype in ((8, '<u8'), (4, '<u4'), (2, '<u2'), (1, 'u1')):
                    while stop - start >= width:
                        reference = np.frombuffer(self.raw, dtype=dtype, count=1,
                                                  offset=start)[0]
                        fields.append((start, width, dtype, reference))
                        start += width
            self._structure = fields
        return self._structure


class MultiDecoder:
    """
    Decode the joints of chunks of raw JointState messages, grouping them by layout.

    Messages of the same size are compared word-wise, outside the stamp and the float arrays,
    with the recent layouts of that size; the rest are grouped by those words (``np.unique``)
    and one message per new group is parsed.  Every joint of a layout is read in one pass.
    """

    def __init__(self, joints: Sequence[str] | None) -> None:
        """Decode for ``joints`` (None: every joint seen)."""
        self.requested = None if joints is None else list(dict.fromkeys(joints))
        self.seen: dict[str, None] = {}          # joint names in the order first seen
        self.known: list[_Known] = []            # every layout met (for the tallies)
        self.by_size: dict[int, list[_Known]] = {}
        self.by_key: dict[tuple[int, bytes, bytes], _Known] = {}
        self.malformed = 0
        self.zero_stamps = 0
        self.messages = 0
        self._forgotten: Counter = Counter()     # tallies of forgotten layouts

    # -- layouts

    def _lookup(self, raw: bytes | memoryview) -> _Known | None:
        """Return the layout of one message (parsing it when new), None if malformed."""
        try:
            layout = parse_layout(raw)
        except (ValueError, struct.error, UnicodeDecodeError):
            return None
        known = _Known(layout, raw)
        found = self.by_key.get(known.key())
        if found is None:
            found = known
            self.known.append(known)
            self.by_key[known.key()] = known
            for name in layout.names:
                if name not in self.seen:
                    self.seen[name] = None
        recent = self.by_size.setdefault(layout.size, [])
        if found not in recent:
            recent.insert(0, found)
            del recent[4:]
        return found

    def _forget(self) -> None:
        """Fold the tallies of the remembered layouts into ``_forgotten`` and forget them."""
        for known in self.known:
            self._forgotten[(tuple(known.index), known.reason)] += known.count
        self.known, self.by_size, self.by_key = [], {}, {}

    # -- tallies

    def rejections(self) -> dict[str, Counter]:
        """Return joint -> Counter(reason -> messages) for the requested or seen joints."""
        joints = self.requested if self.requested is not None else list(self.seen)
        result: dict[str, Counter] = {joint: Counter() for joint in joints}
        tallies = Counter(self._forgotten)
        for known in self.known:
            tallies[(tuple(known.index), known.reason)] += known.count
        present: Counter = Counter()
        for (names, reason), count in tallies.items():
            for joint in names:
                present[joint] += count
                if reason is not None and joint in result:
                    result[joint][reason] += count
        parsed = self.messages - self.malformed
        for joint, counter in result.items():
            if self.malformed:
                counter['malformed'] += self.malformed
            if parsed - present[joint]:
                counter['joint_missing'] += parsed - present[joint]
        return result

    # -- decoding

    def decode_pieces(self, pieces: Sequence[tuple[Any, Any]]) -> dict[str, JointChunk]:
        """
        Decode one chunk given in consecutive pieces of (bag times [ns], raw messages).

        The samples, tallies and joint order are those :meth:`decode` gives for the pieces
        joined into one chunk (each message is matched to its own layout wherever it sits);
        the pieces are decoded one by one and the joints' samples concatenated.
        """
        if len(pieces) == 1:
            return self.decode(pieces[0][1], pieces[0][0])
        parts = [self.decode(raws, receive_ns) for receive_ns, raws in pieces]
        joints = self.requested if self.requested is not None else list(self.seen)
        chunk = {}
        for name in joints:
            got = [part[name] for part in parts if name in part and len(part[name])]
            if len(got) == 1:
                chunk[name] = got[0]
                continue
            chunk[name] = JointChunk(
                *(np.concatenate([getattr(p, key) for p in got]) if got else np.zeros(0)
                  for key in ('time_s', 'position_rad', 'velocity_rad_s', 'effort')))
        return chunk

    def decode(self, raws: list, receive_ns: Any) -> dict[str, JointChunk]:
        """Decode one chunk; return joint -> its samples of the chunk, in bag order."""
        if len(self.known) > _MAX_LAYOUTS:
            self._forget()  # between chunks, so that no tally of this chunk is lost
        rows_of_one_size = getattr(raws, 'array', None)  # mcap_chunks.RawRows
        if rows_of_one_size is not None:
            one = self._decode_one_layout(rows_of_one_size, receive_ns)
            if one is not None:
                return one
        count = len(raws)
        self.messages += count
        time_s = np.zeros(count)
        receive = None
        before = len(self.seen)
        first_rows: dict[str, tuple[int, int]] = {}  # new joint -> (message, column)
        sizes = (np.full(count, rows_of_one_size.shape[1], dtype=np.int64)
                 if rows_of_one_size is not None
                 else np.fromiter(map(len, raws), dtype=np.int64, count=count))
        columns: dict[str, tuple[FloatArray, NDArray[np.bool_]]] = {}
        order = np.argsort(sizes, kind='stable')
        bounds = np.flatnonzero(np.diff(sizes[order])) + 1
        for rows in np.split(order, bounds):
            size = int(sizes[rows[0]])
            record = _record_size(size)
            if rows_of_one_size is not None:  # the same bytes as the join below
                block = np.zeros((rows.size, record), dtype=np.uint8)
                block[:, 4:4 + size] = rows_of_one_size
                data: Any = block
            else:
                after = bytes(record - 4 - size)
                data = bytes(4) + (after + bytes(4)).join([raws[i] for i in rows.tolist()]) \
                    + after
            words = np.frombuffer(data, dtype='<u8').reshape(rows.size, record // 8)
            layouts, assign = self._match(raws, rows, words, size)
            tally = np.bincount(assign[assign >= 0], minlength=len(layouts))
            for known, number in zip(layouts, tally.tolist()):
                known.count += number
            if len(self.seen) > before:
                for i, known in enumerate(layouts):
                    if tally[i]:
                        row = int(rows[int(np.argmax(assign == i))])
                        for name, column in known.index.items():
                            place = (row, column)
                            first_rows[name] = min(first_rows.get(name, place), place)
            # layouts with the same byte order and float offsets are read together
            groups: dict[tuple, list[int]] = {}
            for i, known in enumerate(layouts):
                if known.reason is None and tally[i]:
                    groups.setdefault(known.signature, []).append(i)
            for members in groups.values():
                self._read(layouts, members, assign, rows, data, record, count, receive_ns,
                           time_s, columns)
                receive = receive_ns
        del receive
        if len(self.seen) > before:  # new joints in the order of their first message
            names = list(self.seen)
            new = sorted(names[before:], key=lambda name: first_rows.get(name, (count, 0)))
            self.seen = dict.fromkeys(names[:before] + new)
        joints = self.requested if self.requested is not None else list(self.seen)
        chunk = {}
        for name in joints:
            if name in columns:
                values, used = columns[name]
                chunk[name] = JointChunk(time_s=time_s[used], position_rad=values[0, used],
                                         velocity_rad_s=values[1, used],
                                         effort=values[2, used])
            else:
                chunk[name] = JointChunk(time_s=np.zeros(0), position_rad=np.zeros(0),
                                         velocity_rad_s=np.zeros(0), effort=np.zeros(0))
        return chunk

    def _decode_one_layout(self, rows: NDArray[np.uint8],
                           receive_ns: Any) -> dict[str, JointChunk] | None:
        """
        Decode messages of one size that all share a recent layout, read where they lie.

        ``rows``: shape (n, size), one message per row (a strided view into a chunk is fine).
        The usual chunk of a recording: the layout :meth:`_match` would give every message
        (the first recent layout of the size that any message shares, shared by all), the
        same tallies, stamps and floats, without copying the messages into a decoding block.
        Returns None, having changed nothing, for any other chunk (:meth:`decode` then reads
        it in a block).
        """
        count, size = rows.shape
        for known in self.by_size.get(size, ()):
            same = known.matches(rows)
            if same.any():
                break
        else:
            return None
        if count == 0 or not same.all():
            return None
        self.messages += count
        known.count += count
        joints = self.requested if self.requested is not None else list(self.seen)
        chunk = {}
        usable = known.reason is None
        if usable:
            end = known.end
            sec = rows[:, 4:8].view(end + 'i4')[:, 0]
            nanosec = rows[:, 8:12].view(end + 'u4')[:, 0]
            time_s = sec + nanosec * 1e-9
            zero = (sec == 0) & (nanosec == 0)
            if zero.any():
                self.zero_stamps += int(np.count_nonzero(zero))
                received = np.asarray(receive_ns, dtype=np.int64)[zero]
                seconds, nanoseconds = np.divmod(received, 1_000_000_000)
                time_s[zero] = seconds + nanoseconds * 1e-9
        shared = False
        for name in joints:
            column = known.index.get(name) if usable else None
            if column is None:
                chunk[name] = JointChunk(time_s=np.zeros(0), position_rad=np.zeros(0),
                                         velocity_rad_s=np.zeros(0), effort=np.zeros(0))
                continue
            position, velocity, effort = (
                rows[:, offset + 8 * column:offset + 8 * column + 8].view(end + 'f8')[:, 0]
                .astype(np.float64) for offset, _ in known.layout.arrays)
            chunk[name] = JointChunk(time_s=time_s.copy() if shared else time_s,
                                     position_rad=position, velocity_rad_s=velocity,
                                     effort=effort)
            shared = True
        return chunk

    def _read(self, layouts: list[_Known], members: list[int], assign: NDArray[np.int64],
              rows: NDArray[np.int64], data: bytes, record: int, count: int,
              receive_ns: Any, time_s: FloatArray,
              columns: dict[str, tuple[FloatArray, NDArray[np.bool_]]]) -> None:
        """Read the stamps and the joints of the messages of layouts sharing float offsets."""
        first = layouts[members[0]]
        end = first.end
        # the common case, every message of the chunk in one layout: slices, no copies
        if len(members) == 1 and np.all(assign == members[0]):
            mine: Any = slice(None)
            where: Any = slice(None) if rows.size == count else rows
        else:
            mine = np.flatnonzero(np.isin(assign, members))
            where = rows[mine]
        ints = np.frombuffer(data, dtype=end + 'u4').reshape(rows.size, record // 4)
        sec = ints[mine, 2].view(end + 'i4')
        nanosec = ints[mine, 3]
        stamp = sec + nanosec * 1e-9
        zero = (sec == 0) & (nanosec == 0)
        if zero.any():
            self.zero_stamps += int(np.count_nonzero(zero))
            received = np.asarray(receive_ns, dtype=np.int64)[where][zero]
            seconds, nanoseconds = np.divmod(received, 1_000_000_000)
            stamp[zero] = seconds + nanoseconds * 1e-9
        time_s[where] = stamp
        names = list(dict.fromkeys(name for i in members for name in layouts[i].index))
        if self.requested is not None:
            names = [name for name in names if name in self.requested]
        if not names:
            return
        floats = np.frombuffer(data, dtype=end + 'f8').reshape(rows.size, record // 8)
        firsts = first.signature[1]
        lookup = np.full(len(layouts), -1, dtype=np.int64)
        for name in names:
            if name not in columns:
                columns[name] = (np.full((3, count), np.nan), np.zeros(count, dtype=bool))
            values, used = columns[name]
            for i in members:
                lookup[i] = layouts[i].index.get(name, -1)
            if isinstance(mine, slice):
                column = int(lookup[members[0]])
                for k in range(3):
                    values[k, where] = floats[:, firsts[k] + column]
                used[where] = True
                continue
            column_of = lookup[assign[mine]]
            has = column_of >= 0
            source, target, column_of = mine[has], where[has], column_of[has]
            for k in range(3):
                values[k, target] = floats[source, firsts[k] + column_of]
            used[target] = True

    def _match(self, raws: list, rows: NDArray[np.int64], words: NDArray[np.uint64],
               size: int) -> tuple[list[_Known], NDArray[np.int64]]:
        """Return the layouts of the messages of one size and each message's (-1: malformed)."""
        layouts: list[_Known] = []
        local: dict[int, int] = {}

        def number(known: _Known) -> int:
            if id(known) not in local:
                local[id(known)] = len(layouts)
                layouts.append(known)
            return local[id(known)]

        assign = np.full(rows.size, -1, dtype=np.int64)
        pending = np.ones(rows.size, dtype=bool)
        for known in list(self.by_size.get(size, ())):  # the recent layouts of this size
            same = np.all(words[:, known.words] == known.reference, axis=1) & pending
            if same.any():
                assign[same] = number(known)
                pending &= ~same
                if not pending.any():
                    return layouts, assign
        while pending.any():
            first = int(np.argmax(pending))
            found = self._lookup(raws[int(rows[first])])
            if found is None:
                self.malformed += 1
                pending[first] = False
                continue
            known = found
            left = np.flatnonzero(pending)
            keys = np.ascontiguousarray(words[np.ix_(left, known.words)])
            groups = keys.view(np.dtype((np.void, 8 * keys.shape[1]))).ravel()
            _, firsts, inverse = np.unique(groups, return_index=True, return_inverse=True)
            inverse = inverse.ravel()
            found_of = np.full(firsts.size, -1, dtype=np.int64)
            found_of[inverse[0]] = number(known)
            prefix = known.words.tobytes()
            parsed = 0
            for g in range(firsts.size):
                if found_of[g] >= 0:
                    continue
                found = self.by_key.get((size, prefix, keys[firsts[g]].tobytes()))
                if found is None:
                    if parsed >= 256:
                        continue  # a bag of same-size messages of other layouts: next round
                    parsed += 1
                    found = self._lookup(raws[int(rows[left[firsts[g]]])])
                    if found is None:
                        self.malformed += 1
                        pending[left[firsts[g]]] = False
                        continue
                    if not np.array_equal(found.words, known.words):
                        continue  # another layout of the same size: a later round
                found_of[g] = number(found)
            chosen = found_of[inverse]
            done = chosen >= 0
            assign[left[done]] = chosen[done]
            pending[left[done]] = False
        return layouts, assign
