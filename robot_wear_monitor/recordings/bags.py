"""ROS 2 bags of ``sensor_msgs/msg/JointState``: atomic writing and a fast reader, via rosbags.

All bag container I/O goes through ``rosbags`` with the ROS 2 Jazzy typestore
(:data:`TYPESTORE`); storage is MCAP by default, sqlite3 on request.

Writing: :func:`atomic_bag_writer` writes into a temporary sibling folder and renames it to the
target only when the ``with`` block ends without an error (on an error the temporary folder is
removed, so nothing half-written is left).  JointState messages are encoded to CDR with numpy
(:func:`encode_joint_states`), one template per name order, checked against rosbags'
``serialize_cdr`` in the tests.

Reading: :func:`iter_joint_chunks` streams the samples of several joints (or all) chunk by
chunk, so memory stays flat; :func:`read_joints` and :func:`read_joint_samples` concatenate the
chunks.  Raw messages come from rosbags (MCAP or sqlite3, a bag split into several files, or an
unfinished MCAP recording read record by record) and are decoded with numpy: the messages of a
chunk are grouped by layout (same length and same bytes apart from the stamp and the float
arrays: same frame_id, names, name order and array lengths), matched word by word against the
recent layouts and otherwise grouped with ``np.unique``; each new layout is parsed once, and
the stamps and every requested joint's position/velocity/effort of all messages sharing float
offsets are read with one gather.  A message is rejected for a joint, counted by reason
(:data:`READER_REASONS`, the message reasons of
:func:`robot_wear_monitor.experiment.segmentation.pick_joint` plus ``malformed``), when it lacks
the joint or an array, or an array's length differs from the names.

Times are the header stamps (sec + nanosec) in seconds; a message whose header stamp is zero is
given its bag receive time instead (counted, and said once in the stream's notes).
"""

from __future__ import annotations

from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
import gc
import os
from pathlib import Path
import shutil
import struct
from typing import Any, Callable, Iterator, Optional, Sequence

import numpy as np
from numpy.typing import NDArray
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

from robot_wear_monitor.atomic_files import remove_stale_partials
from robot_wear_monitor.errors import InputError

FloatArray = NDArray[np.float64]

#: rosbags typestore of ROS 2 Jazzy.
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'
JOINT_STATES_TOPIC = '/joint_states'
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
BAG_VERSION = 9


class BagError(InputError):
    """A bag cannot be read or written; the message is one line naming the bag and the problem."""


# --------------------------------------------------------------------------- writing

class BagWriter:
    """Topics and messages of a bag being written (see :func:`atomic_bag_writer`)."""

    def __init__(self, writer: Writer) -> None:
        """Wrap an open rosbags writer."""
        self._writer = writer
        self._connections: dict[str, Any] = {}
        self._types: dict[str, str] = {}
        self.message_count = 0
        #: staging copies of killed writers of the same bag, removed before this one started
        self.removed_stale: list[Path] = []

    def add_topic(self, topic: str, msgtype: str) -> None:
        """Declare ``topic`` with the message type ``msgtype`` (a Jazzy type name)."""
        if topic in self._connections:
            if self._types[topic] != msgtype:
                raise BagError(f'topic {topic} already has type {self._types[topic]}')
            return
        if msgtype not in TYPESTORE.types:
            raise BagError(f'unknown message type {msgtype!r} in the ROS 2 Jazzy typestore')
        self._connections[topic] = self._writer.add_connection(topic, msgtype,
                                                               typestore=TYPESTORE)
        self._types[topic] = msgtype

    def write(self, topic: str, msg: Any, timestamp_ns: int) -> None:
        """Write a typestore message object (or CDR bytes) on a declared topic."""
        if topic not in self._connections:
            raise BagError(f'topic {topic} was not added before writing')
        data = msg if isinstance(msg, (bytes, bytearray, memoryview)) else \
            TYPESTORE.serialize_cdr(msg, self._types[topic])
        self._writer.write(self._connections[topic], int(timestamp_ns), data)
        self.message_count += 1

    def write_raw_many(self, topic: str, messages: Sequence[bytes],
                       timestamps_ns: Sequence[int]) -> None:
        """Write many CDR-encoded messages on a declared topic (bag times in ns)."""
        connection = self._connections.get(topic)
        if connection is None:
            raise BagError(f'topic {topic} was not added before writing')
        write = self._writer.write
        for data, stamp in zip(messages, timestamps_ns):
            write(connection, int(stamp), data)
        self.message_count += len(messages)


def _storage(storage: str) -> StoragePlugin:
    try:
        return STORAGES[storage]
    except KeyError:
        raise BagError(f'unknown storage {storage!r} (expected mcap or sqlite3)') from None


@contextmanager
def atomic_bag_writer(path: str | os.PathLike, *, storage: str = 'mcap',
                      overwrite: bool = False) -> Iterator[BagWriter]:
    """Write a bag folder atomically: into a temporary sibling, renamed on success.

    Args:
        path: the bag folder to create.
        storage: ``'mcap'`` (default) or ``'sqlite3'``.
        overwrite: replace an existing bag at ``path`` (only once the new one is complete).

    Raises:
        BagError: ``path`` exists and ``overwrite`` is false, or the bag cannot be written.

    """
    plugin = _storage(storage)
    target = Path(path)
    if target.exists() and not overwrite:
        raise BagError(f'{target}: already exists (choose another path or overwrite)')
    if not target.parent.is_dir():
        raise BagError(f'{target}: the folder {target.parent} does not exist')
    stale = remove_stale_partials(target)
    staging = target.with_name(f'.{target.name}.partial-{os.getpid()}')
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir()
    temporary = staging / target.name  # rosbags names the storage file after the folder
    writer = Writer(temporary, version=BAG_VERSION, storage_plugin=plugin)
    try:
        writer.open()
        bag_writer = BagWriter(writer)
        bag_writer.removed_stale = stale
        yield bag_writer
        writer.close()
        if target.exists():
            old = staging / '.old'
            os.replace(target, old)
            os.replace(temporary, target)
        else:
            os.replace(temporary, target)
    except BaseException:
        try:
            writer.close()
        except Exception:  # noqa: BLE001 - the original error is what matters
            pass
        raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


# --------------------------------------------------------------------------- CDR layout

@dataclass(frozen=True)
class _Layout:
    """Byte layout of one encoded JointState (offsets from the start of the buffer)."""

    little: bool
    frame_id: str
    names: tuple[str, ...]
    arrays: tuple[tuple[int, int], tuple[int, int], tuple[int, int]]  # (offset, count) x3
    size: int

    def structure_ranges(self) -> list[tuple[int, int]]:
        """Byte ranges [start, stop) that must match for a message to share this layout.

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


def _parse_layout(raw: bytes | memoryview) -> _Layout:
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
    return _Layout(little=little, frame_id=frame_id, names=names, arrays=tuple(arrays),
                   size=len(data))


def decode_joint_state(raw: bytes | memoryview) -> tuple[float, str, list[str], FloatArray,
                                                         FloatArray, FloatArray]:
    """Decode one CDR JointState: (stamp [s], frame_id, names, position, velocity, effort).

    Raises:
        BagError: the bytes are not a JointState.

    """
    try:
        layout = _parse_layout(raw)
    except (ValueError, struct.error, UnicodeDecodeError) as error:
        raise BagError(f'malformed JointState message: {error}') from None
    data = bytes(raw)
    end = '<' if layout.little else '>'
    sec, nanosec = struct.unpack_from(end + 'iI', data, 4)
    values = [np.frombuffer(data, dtype=end + 'f8', count=n, offset=o).astype(np.float64)
              for o, n in layout.arrays]
    return sec + nanosec * 1e-9, layout.frame_id, list(layout.names), *values


def _template(names: Sequence[str], frame_id: str) -> tuple[bytes, _Layout]:
    n = len(names)
    header = TYPESTORE.types['std_msgs/msg/Header'](
        stamp=TYPESTORE.types['builtin_interfaces/msg/Time'](sec=0, nanosec=0),
        frame_id=frame_id)
    prototype = TYPESTORE.types[JOINT_STATE_TYPE](
        header=header, name=list(names), position=np.zeros(n), velocity=np.zeros(n),
        effort=np.zeros(n))
    raw = bytes(TYPESTORE.serialize_cdr(prototype, JOINT_STATE_TYPE))
    return raw, _parse_layout(raw)


def _split_stamps(stamps_s: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Return (sec, nanosec) of float stamps [s], rounded to the nanosecond."""
    sec = np.floor(stamps_s).astype(np.int64)
    nanosec = np.round((stamps_s - sec) * 1e9).astype(np.int64)
    carry = nanosec >= 1_000_000_000
    return sec + carry, np.where(carry, nanosec - 1_000_000_000, nanosec)


def encode_joint_states(*, stamps_s: Sequence[float], names: Sequence[str],
                        position: Any, velocity: Any, effort: Any,
                        name_order: Any = None, frame_id: str = '') -> list[bytes]:
    """Encode JointState messages to CDR (little endian) with numpy.

    Args:
        stamps_s: header stamps [s], shape (n,).
        names: joint names, the column order of the arrays, length J.
        position: positions [rad], shape (n, J).
        velocity: velocities [rad/s], shape (n, J).
        effort: efforts, shape (n, J).
        name_order: optional per-message column permutation, shape (n, J).
        frame_id: header frame_id.

    Returns:
        One ``bytes`` per message, identical to rosbags' ``serialize_cdr``.

    """
    stamps = np.asarray(stamps_s, dtype=np.float64)
    arrays = [np.asarray(a, dtype='<f8') for a in (position, velocity, effort)]
    n, j = stamps.size, len(names)
    for array in arrays:
        if array.shape != (n, j):
            raise BagError(f'encode_joint_states: expected arrays of shape {(n, j)}, '
                           f'got {array.shape}')
    sec, nanosec = _split_stamps(stamps)
    if np.any(sec < -2 ** 31) or np.any(sec >= 2 ** 31):
        raise BagError('encode_joint_states: stamps out of the int32 seconds range')
    if name_order is None:
        groups = [(np.arange(n), np.arange(j))]
    else:
        order = np.asarray(name_order, dtype=np.int64)
        unique, inverse = np.unique(order, axis=0, return_inverse=True)
        groups = [(np.flatnonzero(inverse.ravel() == g), unique[g]) for g in range(len(unique))]
    out: list[bytes | None] = [None] * n
    for rows, columns in groups:
        raw, layout = _template([names[c] for c in columns], frame_id)
        block = np.tile(np.frombuffer(raw, dtype=np.uint8), (rows.size, 1))
        block[:, 4:8] = sec[rows].astype('<i4').view(np.uint8).reshape(-1, 4)
        block[:, 8:12] = nanosec[rows].astype('<u4').view(np.uint8).reshape(-1, 4)
        for (offset, count), array in zip(layout.arrays, arrays):
            values = np.ascontiguousarray(array[rows][:, columns])
            block[:, offset:offset + 8 * count] = values.view(np.uint8).reshape(rows.size, -1)
        data = block.tobytes()
        size = layout.size
        for i, row in enumerate(rows.tolist()):
            out[row] = data[i * size:(i + 1) * size]
    return out  # type: ignore[return-value]


def write_joint_state_bag(path: str | os.PathLike, *, stamps_s: Sequence[float],
                          names: Sequence[str], position: Any, velocity: Any, effort: Any,
                          name_order: Any = None, topic: str = JOINT_STATES_TOPIC,
                          storage: str = 'mcap', overwrite: bool = False,
                          frame_id: str = '') -> Path:
    """Write JointState samples as a bag (bag time = header stamp); see encode_joint_states."""
    messages = encode_joint_states(stamps_s=stamps_s, names=names, position=position,
                                   velocity=velocity, effort=effort, name_order=name_order,
                                   frame_id=frame_id)
    sec, nanosec = _split_stamps(np.asarray(stamps_s, dtype=np.float64))
    timestamps = (sec * 1_000_000_000 + nanosec).tolist()
    with atomic_bag_writer(path, storage=storage, overwrite=overwrite) as bag:
        bag.add_topic(topic, JOINT_STATE_TYPE)
        bag.write_raw_many(topic, messages, timestamps)
    return Path(path)


# --------------------------------------------------------------------------- reading

@dataclass
class JointSamples:
    """Samples of one joint read from a bag, in bag order; arrays have shape (n,).

    Attributes:
        time_s: header stamps [s].
        position_rad: joint positions [rad].
        velocity_rad_s: joint velocities [rad/s].
        effort: efforts (as recorded).
        message_count: JointState messages on the topic.
        recovery: set when the recording was unfinished and read up to its cut.
        rejections: messages not used, reason -> count (:data:`READER_REASONS`).
        zero_stamps: messages whose header stamp is zero (read at their bag receive time).
        notes: one-line remarks on the reading (the zero-stamp fallback, said once).

    """

    time_s: FloatArray
    position_rad: FloatArray
    velocity_rad_s: FloatArray
    effort: FloatArray
    message_count: int
    rejections: Counter = field(default_factory=Counter)
    recovery: Optional['Recovery'] = None
    zero_stamps: int = 0
    notes: list[str] = field(default_factory=list)


def _open_reader(path: str | os.PathLike) -> Reader:
    bag = Path(path)
    if not bag.exists():
        raise BagError(f'{bag}: no such bag')
    try:
        reader = Reader(bag)
        reader.open()
    except Exception as error:  # noqa: BLE001 - rosbags raises several types for bad bags
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise BagError(f'{bag}: cannot open bag: {message}') from None
    return reader


def _connections(reader: Reader, path: Any, topic: str) -> list:
    connections = [c for c in reader.connections if c.topic == topic]
    if not connections:
        topics = ', '.join(sorted({c.topic for c in reader.connections})) or 'none'
        raise BagError(f'{path}: no topic {topic} (topics: {topics})')
    for connection in connections:
        if connection.msgtype != JOINT_STATE_TYPE:
            raise BagError(f'{path}: topic {topic} has type {connection.msgtype}, '
                           f'expected {JOINT_STATE_TYPE}')
    return connections


def iter_raw_messages(path: str | os.PathLike, *, topic: str = JOINT_STATES_TOPIC,
                      msgtype: str | None = JOINT_STATE_TYPE) -> Iterator[tuple[int, bytes]]:
    """Yield (bag time [ns], CDR bytes) of a topic, raising BagError for unreadable bags."""
    reader = _open_reader(path)
    try:
        if msgtype == JOINT_STATE_TYPE:
            connections = _connections(reader, path, topic)
        else:
            connections = [c for c in reader.connections if c.topic == topic]
            if not connections:
                raise BagError(f'{path}: no topic {topic}')
        try:
            for _, timestamp, raw in reader.messages(connections=connections):
                yield timestamp, raw
        except BagError:
            raise
        except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise BagError(f'{path}: corrupt or truncated bag: {message}') from None
    finally:
        reader.close()


def recorded_topics(path: str | os.PathLike) -> dict[str, str]:
    """Return topic -> ROS type of every topic recorded in a bag (BagError if unreadable)."""
    reader = _open_reader(path)
    try:
        return {c.topic: c.msgtype for c in reader.connections}
    finally:
        reader.close()


def iter_recorded_messages(path: str | os.PathLike, *, topics: Sequence[str]
                           ) -> Iterator[tuple[str, int, bytes]]:
    """Yield (topic, bag time [ns], CDR bytes) of ``topics`` in bag-time order.

    The bytes are the serialized messages as recorded (CDR with its encapsulation header),
    which is what an rclpy publisher sends as a raw message.
    """
    reader = _open_reader(path)
    try:
        connections = [c for c in reader.connections if c.topic in set(topics)]
        try:
            for connection, timestamp, raw in reader.messages(connections=connections):
                yield connection.topic, timestamp, raw
        except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise BagError(f'{path}: corrupt or truncated bag: {message}') from None
    finally:
        reader.close()


# --------------------------------------------------------------------------- scalar topics

#: Scalar message types :func:`read_scalar_topic` reads, and the field holding the value.
SCALAR_FIELDS = {'sensor_msgs/msg/Temperature': 'temperature', 'std_msgs/msg/Float64': 'data',
                 'std_msgs/msg/Float32': 'data'}


def read_scalar_topic(path: str | os.PathLike, *, topic: str
                      ) -> tuple[FloatArray, FloatArray, str]:
    """Return (time [s], value, type) of a scalar topic of a bag, e.g. a joint temperature.

    ``sensor_msgs/msg/Temperature`` gives ``temperature`` [degC] at its header stamp;
    ``std_msgs/msg/Float64`` and ``Float32`` give ``data`` at the bag time.  Samples are sorted
    by time; non-finite values are dropped.

    Raises:
        BagError: the bag is unreadable, the topic is absent, empty or of another type.

    """
    topics = recorded_topics(path)
    if topic not in topics:
        raise BagError(f'{path}: no topic {topic} (topics: {", ".join(sorted(topics))})')
    msgtype = topics[topic]
    if msgtype not in SCALAR_FIELDS:
        raise BagError(f'{path}: topic {topic} has type {msgtype}; expected one of '
                       f'{", ".join(SCALAR_FIELDS)}')
    name = SCALAR_FIELDS[msgtype]
    times, values = [], []
    for _, timestamp, raw in iter_recorded_messages(path, topics=[topic]):
        msg = TYPESTORE.deserialize_cdr(raw, msgtype)
        stamp = getattr(msg, 'header', None)
        times.append(stamp.stamp.sec + 1e-9 * stamp.stamp.nanosec if stamp is not None
                     else timestamp * 1e-9)
        values.append(float(getattr(msg, name)))
    time_s, value = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    keep = np.isfinite(time_s) & np.isfinite(value)
    if not np.any(keep):
        raise BagError(f'{path}: topic {topic} has no finite value')
    order = np.argsort(time_s[keep], kind='stable')
    return time_s[keep][order], value[keep][order], msgtype


# --------------------------------------------------------------------------- unfinished MCAP

@dataclass(frozen=True)
class Recovery:
    """What was read from an unfinished recording (a recorder killed before it closed the bag).

    Attributes:
        files: the MCAP files read.
        messages: complete messages recovered on the topic.
        last_stamp_s: bag time of the last complete message [s] (where the recording stops).
        complete: the files end with their footer (nothing was lost, e.g. an MCAP file
            given directly); False: the recording stops at ``last_stamp_s``.
        reason: how the recording was read (no metadata.yaml, a file given directly, a cut).

    """

    files: tuple[str, ...]
    messages: int
    last_stamp_s: float
    complete: bool
    reason: str


#: The JointState schema name as MCAP writers spell it, with or without ``/msg/``.
_JOINT_STATE_SCHEMA = JOINT_STATE_TYPE.replace('/msg/', '/')


def _unfinished_mcap_files(path: Path) -> tuple[list[Path], str] | None:
    """Return the MCAP files of a recording rosbags cannot open as a bag, and why; else None."""
    if path.is_file() and path.suffix == '.mcap':
        return [path], 'an MCAP file given directly (no bag metadata)'
    if path.is_dir() and not (path / 'metadata.yaml').is_file():
        files = sorted(path.glob('*.mcap'))
        if files:
            return files, 'no metadata.yaml (the recorder did not close the bag)'
    return None


def _iter_unfinished_mcap(path: Path, files: Sequence[Path], topic: str, state: dict
                          ) -> Iterator[tuple[int, bytes]]:
    """Yield (log time [ns], CDR bytes) of every complete message on ``topic``, in order.

    A recorder killed mid-write leaves an MCAP without summary and footer, often with a cut
    chunk at the end; the mcap stream reader reads the file record by record, and reading stops
    at the first incomplete record.  ``state`` receives ``count``, ``last_ns``, ``cut`` and the
    channel types seen (``types``).  A channel of ``topic`` of another type than JointState
    raises BagError when it appears.
    """
    from mcap.exceptions import McapError
    from mcap.records import Channel, Footer, Message, Schema
    from mcap.stream_reader import StreamReader
    for file in files:
        channels: dict[int, str] = {}
        schemas: dict[int, str] = {}
        try:
            with open(file, 'rb') as handle:
                for record in StreamReader(handle, record_size_limit=1 << 30).records:
                    if isinstance(record, Schema):
                        schemas[record.id] = record.name
                    elif isinstance(record, Channel):
                        channels[record.id] = record.topic
                        msgtype = schemas.get(record.schema_id, '')
                        state['types'][record.topic] = msgtype
                        if record.topic == topic and msgtype and \
                                msgtype.replace('/msg/', '/') != _JOINT_STATE_SCHEMA:
                            raise BagError(f'{path}: topic {topic} has type {msgtype}, '
                                           f'expected {JOINT_STATE_TYPE}')
                    elif isinstance(record, Message):
                        if channels.get(record.channel_id) == topic:
                            state['count'] += 1
                            state['last_ns'] = max(state['last_ns'], record.log_time)
                            yield record.log_time, record.data
                    elif isinstance(record, Footer):
                        break
                else:
                    state['cut'] = True
        except BagError:
            raise
        except (McapError, EOFError, struct.error, ValueError, OSError):
            state['cut'] = True  # the incomplete record at the cut


# --------------------------------------------------------------------------- multi-joint reader

#: Message rejection reasons of the reader, per joint, in the order they are checked.  They are
#: the message reasons of :func:`robot_wear_monitor.experiment.segmentation.pick_joint` plus
#: ``malformed`` (bytes that are no JointState).  Non-finite values are passed on (the segmenter
#: counts them as ``non_finite``).
READER_REASONS = ('malformed', 'joint_missing', 'missing_position', 'missing_velocity',
                  'missing_effort', 'length_mismatch')
#: Layouts remembered by one stream (forgotten between chunks when exceeded; tallies are kept).
_MAX_LAYOUTS = 4096


def _layout_reason(layout: _Layout) -> str | None:
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
    """One joint's usable samples of one chunk of messages, in bag order; shape (m,).

    Attributes:
        time_s: header stamps [s] (the bag receive time where the header stamp is zero).
        position_rad: joint positions [rad].
        velocity_rad_s: joint velocities [rad/s].
        effort: efforts (as recorded).

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
    """A parsed layout: the words that identify it, its joints and its message tally.

    In a decoding block every message starts 4 bytes into an 8-byte word, so that CDR's
    8-byte alignment (counted from after the 4-byte encapsulation header) falls on words: the
    stamp is word 1 and every float is one word.  The other words identify the layout.
    """

    __slots__ = ('layout', 'words', 'reference', 'reason', 'index', 'count', 'end',
                 'signature')

    def __init__(self, layout: _Layout, raw: bytes | memoryview) -> None:
        self.layout = layout
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


class _MultiDecoder:
    """Decode the joints of chunks of raw JointState messages, grouping them by layout.

    Messages of the same size are compared word-wise, outside the stamp and the float arrays,
    with the recent layouts of that size; the rest are grouped by those words (``np.unique``)
    and one message per new group is parsed.  Every joint of a layout is read in one pass.
    """

    def __init__(self, joints: Sequence[str] | None) -> None:
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
            layout = _parse_layout(raw)
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
        result = {joint: Counter() for joint in joints}
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

    def decode(self, raws: list, receive_ns: list[int]) -> dict[str, JointChunk]:
        """Decode one chunk; return joint -> its samples of the chunk, in bag order."""
        if len(self.known) > _MAX_LAYOUTS:
            self._forget()  # between chunks, so that no tally of this chunk is lost
        count = len(raws)
        self.messages += count
        time_s = np.zeros(count)
        receive = None
        before = len(self.seen)
        first_rows: dict[str, tuple[int, int]] = {}  # new joint -> (message, column)
        sizes = np.fromiter(map(len, raws), dtype=np.int64, count=count)
        columns: dict[str, tuple[FloatArray, NDArray[np.bool_]]] = {}
        order = np.argsort(sizes, kind='stable')
        bounds = np.flatnonzero(np.diff(sizes[order])) + 1
        for rows in np.split(order, bounds):
            size = int(sizes[rows[0]])
            record = _record_size(size)
            after = bytes(record - 4 - size)
            data = bytes(4) + (after + bytes(4)).join([raws[i] for i in rows.tolist()]) + after
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

    def _read(self, layouts: list[_Known], members: list[int], assign: NDArray[np.int64],
              rows: NDArray[np.int64], data: bytes, record: int, count: int,
              receive_ns: list[int], time_s: FloatArray,
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
            known = self._lookup(raws[int(rows[first])])
            if known is None:
                self.malformed += 1
                pending[first] = False
                continue
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


class JointStream:
    """Chunks of the samples of several joints of a bag; see :func:`iter_joint_chunks`.

    Iterating yields one ``dict`` per chunk of messages: joint name -> :class:`JointChunk`
    (the samples of that joint in the chunk, in bag order; empty arrays when the chunk has
    none).  The keys are the requested joints, or with ``joints=None`` every joint seen so far
    in the order first seen.  Only one chunk is held at a time.

    Attributes (complete after the iteration; updated chunk by chunk):
        path: the bag.
        topic: the topic read.
        joints: the requested joints (None: every joint seen).
        message_count: messages on the topic read so far.
        total_messages: the topic's message count from the bag metadata (0 when unknown).
        rejections: joint -> Counter(reason -> messages), reasons of :data:`READER_REASONS`.
        joints_seen: names of every joint in any message, in the order first seen.
        zero_stamps: messages whose header stamp is zero (their bag receive time is used).
        stamp_source: ``'header'``, ``'receive_time'`` (every stamp was zero) or ``'mixed'``.
        notes: one-line remarks on the reading (the zero-stamp fallback, said once).
        recovery: a :class:`Recovery` when the recording was unfinished, else None.

    """

    def __init__(self, path: str | os.PathLike, *, joints: Sequence[str] | None,
                 topic: str, chunk_messages: int,
                 progress: Callable[[int, int], None] | None, recover: bool,
                 require_joints: bool) -> None:
        """Check the bag and the topic (BagError); nothing is read before iterating."""
        if isinstance(joints, str):
            joints = [joints]
        if joints is not None and not joints:
            raise BagError(f'{path}: no joint requested')
        if int(chunk_messages) < 1:
            raise BagError(f'{path}: chunk_messages must be >= 1, got {chunk_messages}')
        self.path = path
        self.topic = topic
        self.joints = None if joints is None else list(dict.fromkeys(joints))
        self.chunk_messages = int(chunk_messages)
        self.progress = progress
        self.recover = recover
        self.require_joints = require_joints
        self.recovery: Recovery | None = None
        self.total_messages = 0
        bag = Path(path)
        self._unfinished = _unfinished_mcap_files(bag) if bag.exists() else None
        if self._unfinished is None:
            reader = _open_reader(path)
            try:
                connections = _connections(reader, path, topic)
                self.total_messages = sum(int(getattr(c, 'msgcount', 0) or 0)
                                          for c in connections)
            finally:
                reader.close()
        self._decoder = _MultiDecoder(self.joints)

    # -- figures

    @property
    def message_count(self) -> int:
        """Messages on the topic read so far."""
        return self._decoder.messages

    @property
    def rejections(self) -> dict[str, Counter]:
        """Joint -> Counter(reason -> messages not usable for that joint)."""
        return self._decoder.rejections()

    @property
    def joints_seen(self) -> list[str]:
        """Every joint name met in a message, in the order first seen."""
        return list(self._decoder.seen)

    @property
    def zero_stamps(self) -> int:
        """Messages whose header stamp is zero (read at their bag receive time)."""
        return self._decoder.zero_stamps

    @property
    def stamp_source(self) -> str:
        """``'header'``, ``'receive_time'`` (all stamps zero) or ``'mixed'``."""
        zero = self._decoder.zero_stamps
        if zero == 0:
            return 'header'
        usable = self._decoder.messages - self._decoder.malformed
        return 'receive_time' if zero >= usable else 'mixed'

    @property
    def notes(self) -> list[str]:
        """One-line remarks on the reading (currently: the zero-stamp fallback)."""
        zero = self._decoder.zero_stamps
        if not zero:
            return []
        return [f'{self.path}: {zero} of {self._decoder.messages} messages on {self.topic} '
                f'have a zero header stamp; their bag receive time is used instead']

    # -- reading

    def __iter__(self) -> Iterator[dict[str, JointChunk]]:
        """Read the bag from its start (a new iteration starts over)."""
        self._decoder = _MultiDecoder(self.joints)
        self.recovery = None
        path, topic = self.path, self.topic
        unfinished = self._unfinished
        state = {'count': 0, 'last_ns': -1, 'cut': False, 'types': {}}
        reader = None
        if unfinished is None:
            reader = _open_reader(path)
        collecting = gc.isenabled()
        try:
            if reader is not None:
                connections = _connections(reader, path, topic)
                source: Iterator[Any] = ((t, raw) for _, t, raw in
                                         reader.messages(connections=connections))
            else:
                source = _iter_unfinished_mcap(Path(path), unfinished[0], topic, state)
            total = self.total_messages
            raws: list = []
            stamps: list = []
            size = self.chunk_messages
            decoder = self._decoder
            while True:
                gc.disable()  # the chunk holds many small objects; the collector rescans them
                try:
                    for stamp, raw in source:
                        raws.append(raw)
                        stamps.append(stamp)
                        if len(raws) >= size:
                            break
                except BagError:
                    raise
                except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
                    message = str(error).splitlines()[0] if str(error) \
                        else type(error).__name__
                    raise BagError(f'{path}: corrupt or truncated bag: {message}') from None
                finally:
                    if collecting:
                        gc.enable()
                if not raws:
                    break
                chunk = decoder.decode(raws, stamps)
                raws, stamps = [], []
                if self.progress is not None:
                    self.progress(decoder.messages, max(total, decoder.messages))
                yield chunk
        finally:
            if reader is not None:
                reader.close()
        self._finish(unfinished, state)

    def _finish(self, unfinished: tuple[list[Path], str] | None, state: dict) -> None:
        """Check the end of the reading: cut recordings, absent topic, unseen joints."""
        path, topic, decoder = self.path, self.topic, self._decoder
        if unfinished is not None and state['cut'] and not self.recover:
            raise BagError(f'{path}: unfinished recording ({unfinished[1]}; the last record '
                           f'is cut); refused (strict)')
        if unfinished is not None and topic not in state['types']:
            topics = ', '.join(sorted(state['types'])) or 'none'
            raise BagError(f'{path}: no topic {topic} in the unfinished recording (topics: '
                           f'{topics})')
        if unfinished is not None:
            self.recovery = Recovery(
                files=tuple(str(f) for f in unfinished[0]), messages=decoder.messages,
                last_stamp_s=state['last_ns'] * 1e-9, complete=not state['cut'],
                reason=unfinished[1] + ('; the last record is cut' if state['cut'] else ''))
        if decoder.messages == 0:
            raise BagError(f'{path}: topic {topic} has no messages')
        missing = [j for j in self.joints or () if j not in decoder.seen]
        if missing and self.require_joints:
            seen = list(decoder.seen)
            shown = ', '.join(seen[:12]) + (', ...' if len(seen) > 12 else '')
            names = ', '.join(repr(j) for j in missing)
            raise BagError(f'{path}: joint {names} is in no message on {topic} (joints seen: '
                           f'{shown or "none"})')

    @property
    def joints_missing(self) -> list[str]:
        """Requested joints that no message read so far carries."""
        return [j for j in self.joints or () if j not in self._decoder.seen]


def iter_joint_chunks(path: str | os.PathLike, *, joints: Sequence[str] | None = None,
                      topic: str = JOINT_STATES_TOPIC, chunk_messages: int = 32768,
                      progress: Callable[[int, int], None] | None = None,
                      recover: bool = True, require_joints: bool = True) -> JointStream:
    """Stream the samples of several joints of a bag chunk by chunk (flat memory).

    Raw messages are taken from rosbags in chunks of ``chunk_messages`` and decoded with numpy
    (see the module docstring); each chunk yields joint -> :class:`JointChunk`.  A message
    is usable for a joint when it names the joint and its position, velocity and effort arrays
    are as long as its names; otherwise it is counted for that joint under a reason of
    :data:`READER_REASONS`.  A message whose header stamp is zero gets its bag receive time
    (counted in ``zero_stamps``, said once in ``notes``).  Storage (MCAP, sqlite3) and bags
    split into several files are rosbags' business; an unfinished MCAP recording is read up
    to its last complete message (``recovery``, see :func:`read_joint_samples`).

    Args:
        path: the bag folder (or an unfinished recording, see :class:`Recovery`).
        joints: the joints to read; None: every joint, as each is first seen.
        topic: the JointState topic.
        chunk_messages: messages per chunk.
        progress: ``progress(read, total)`` after each chunk.
        recover: read an unfinished recording whose end is cut (False: refuse it).
        require_joints: raise when a requested joint is in no message (at the end of the
            iteration); False leaves it with no samples (see ``joints_missing``).

    Raises:
        BagError: at the call, the bag is missing or unreadable, the topic is absent (the
            message lists the topics) or has another type; during the iteration, the bag is
            corrupt or truncated; at its end, the topic has no message, a requested joint is
            in no message (the message lists the joints seen), or a cut recording when
            ``recover`` is false.

    """
    return JointStream(path, joints=joints, topic=topic, chunk_messages=chunk_messages,
                       progress=progress, recover=recover, require_joints=require_joints)


def _concatenate(stream: JointStream, parts: list[JointChunk], joint: str) -> JointSamples:
    return JointSamples(
        time_s=np.concatenate([p.time_s for p in parts]),
        position_rad=np.concatenate([p.position_rad for p in parts]),
        velocity_rad_s=np.concatenate([p.velocity_rad_s for p in parts]),
        effort=np.concatenate([p.effort for p in parts]), message_count=stream.message_count,
        rejections=stream.rejections[joint], recovery=stream.recovery,
        zero_stamps=stream.zero_stamps, notes=stream.notes)


def read_joints(path: str | os.PathLike, *, joints: Sequence[str] | None = None,
                topic: str = JOINT_STATES_TOPIC, chunk_messages: int = 32768,
                progress: Callable[[int, int], None] | None = None, recover: bool = True,
                require_joints: bool = True) -> dict[str, JointSamples]:
    """Read several joints' samples at once: joint -> :class:`JointSamples` (whole arrays).

    The chunks of :func:`iter_joint_chunks` concatenated per joint (every joint seen with
    ``joints=None``, in the order first seen); each entry carries the stream's message count,
    recovery, zero-stamp count and notes, and its own rejections.  Arguments and errors are
    those of :func:`iter_joint_chunks`.
    """
    stream = iter_joint_chunks(path, joints=joints, topic=topic, chunk_messages=chunk_messages,
                               progress=progress, recover=recover,
                               require_joints=require_joints)
    parts: dict[str, list[JointChunk]] = {}
    for chunk in stream:
        for joint, samples in chunk.items():
            parts.setdefault(joint, []).append(samples)
    names = stream.joints if stream.joints is not None else stream.joints_seen
    empty = [JointChunk(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))]
    return {joint: _concatenate(stream, parts.get(joint, empty), joint) for joint in names}


def read_joint_samples(path: str | os.PathLike, *, joint: str,
                       topic: str = JOINT_STATES_TOPIC, chunk_messages: int = 32768,
                       progress: Callable[[int, int], None] | None = None,
                       recover: bool = True) -> JointSamples:
    """Read one joint's samples from the JointState messages of a bag (fast path).

    The chunks of :func:`iter_joint_chunks` for this joint, concatenated.
    ``progress(read, total)`` is called after each chunk with the number of messages read so
    far and the topic's message count (for a progress bar).

    An unfinished recording (a bag folder with MCAP files but no ``metadata.yaml``, or an MCAP
    file given directly: what a killed recorder leaves) is read record by record up to its
    last complete message; ``JointSamples.recovery`` then says how much was read and where the
    recording stops.  With ``recover`` false a recording whose end is cut is refused.

    Raises:
        BagError: the bag is missing, corrupt or truncated, the topic is absent or has another
            type, or no message carries the joint; a cut recording when ``recover`` is false.

    """
    stream = iter_joint_chunks(path, joints=[joint], topic=topic,
                               chunk_messages=chunk_messages, progress=progress,
                               recover=recover)
    return _concatenate(stream, [chunk[joint] for chunk in stream], joint)


def iter_joint_states(path: str | os.PathLike, *, topic: str = JOINT_STATES_TOPIC
                      ) -> Iterator[tuple[int, float, list[str], FloatArray, FloatArray,
                                          FloatArray]]:
    """Yield (bag time [ns], stamp [s], names, position, velocity, effort) per message.

    The per-message path (for a streaming replay); malformed messages raise BagError.
    """
    for timestamp, raw in iter_raw_messages(path, topic=topic):
        stamp, _, names, position, velocity, effort = decode_joint_state(raw)
        yield timestamp, stamp, names, position, velocity, effort
