"""ROS 2 bags of ``sensor_msgs/msg/JointState``: atomic writing and a fast reader, via rosbags.

All bag container I/O goes through ``rosbags`` with the ROS 2 Jazzy typestore
(:data:`TYPESTORE`); storage is MCAP by default, sqlite3 on request.

Writing: :func:`atomic_bag_writer` writes into a temporary sibling folder and renames it to the
target only when the ``with`` block ends without an error (on an error the temporary folder is
removed, so nothing half-written is left).  JointState messages are encoded to CDR with numpy
(:func:`encode_joint_states`), one template per name order, checked against rosbags'
``serialize_cdr`` in the tests.

Reading: :func:`read_joint_samples` iterates the raw messages with rosbags and decodes the fields
it needs with numpy: messages are grouped by layout (same length and same bytes apart from the
stamp and the float arrays: same frame_id, names and array lengths), each layout is parsed once,
and the stamps and the joint's position/velocity/effort of all messages of a layout are read as
columns of one array.  Messages that fit no layout are parsed one by one.  Message-level
problems are counted like the streaming segmenter counts them (see
:func:`robot_wear_monitor.experiment.segmentation.pick_joint`).

Times are the header stamps (sec + nanosec) in seconds.
"""

from __future__ import annotations

from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field
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
from robot_wear_monitor.experiment.segmentation import pick_joint

FloatArray = NDArray[np.float64]

#: rosbags typestore of ROS 2 Jazzy.
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'
JOINT_STATES_TOPIC = '/joint_states'
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
BAG_VERSION = 9
_MAX_LAYOUTS = 64


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
        rejections: messages not used, reason -> count (reasons of ``pick_joint``).

    """

    time_s: FloatArray
    position_rad: FloatArray
    velocity_rad_s: FloatArray
    effort: FloatArray
    message_count: int
    rejections: Counter = field(default_factory=Counter)
    recovery: Optional['Recovery'] = None


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


def _layout_reason(layout: _Layout, joint: str) -> str | int:
    """Return the joint's index in a layout, or the reason the layout's messages are unusable."""
    if joint not in layout.names:
        return 'joint_missing'
    n = len(layout.names)
    counts = [count for _, count in layout.arrays]
    for reason, count in zip(('missing_position', 'missing_velocity', 'missing_effort'),
                             counts):
        if count == 0:
            return reason
    if any(count != n for count in counts):
        return 'length_mismatch'
    return layout.names.index(joint)


class _ChunkDecoder:
    """Decode one joint from chunks of raw JointState messages, grouping them by layout."""

    def __init__(self, joint: str) -> None:
        self.joint = joint
        self.layouts: list[tuple[_Layout, NDArray[np.uint8], str | int]] = []
        self.rejections: Counter = Counter()
        self.seen_joint = False
        self.parts: list[tuple[FloatArray, FloatArray]] = []  # (time (m,), values (3, m))

    def decode(self, raws: list[bytes]) -> None:
        count = len(raws)
        time_s = np.full(count, np.nan)
        values = np.full((3, count), np.nan)
        used = np.zeros(count, dtype=bool)
        sizes = np.fromiter((len(r) for r in raws), dtype=np.int64, count=count)
        pending = np.ones(count, dtype=bool)
        known = 0
        blocks: dict[int, tuple[NDArray[np.int64], NDArray[np.uint8]]] = {}
        while pending.any():
            if known < len(self.layouts):
                layout, reference, reason = self.layouts[known]
                known += 1
            elif len(self.layouts) < _MAX_LAYOUTS:
                first = int(np.argmax(pending))
                try:
                    layout = _parse_layout(raws[first])
                except (ValueError, struct.error, UnicodeDecodeError):
                    self.rejections['malformed'] += 1
                    pending[first] = False
                    continue
                reference = np.frombuffer(bytes(raws[first]), dtype=np.uint8)
                reason = _layout_reason(layout, self.joint)
                self.seen_joint = self.seen_joint or self.joint in layout.names
                self.layouts.append((layout, reference, reason))
                known += 1
            else:
                break
            if layout.size not in blocks:
                rows = np.flatnonzero(sizes == layout.size)
                data = b''.join([raws[i] for i in rows])
                blocks[layout.size] = rows, np.frombuffer(data, np.uint8).reshape(rows.size, -1)
            rows, block = blocks[layout.size]
            same = pending[rows]
            for start, stop in layout.structure_ranges():
                same &= np.all(block[:, start:stop] == reference[start:stop], axis=1)
            if not same.any():
                continue
            mine, block_mine = rows[same], block[same]
            pending[mine] = False
            if isinstance(reason, str):
                self.rejections[reason] += mine.size
                continue
            end = '<' if layout.little else '>'
            sec = np.ascontiguousarray(block_mine[:, 4:8]).view(end + 'i4').ravel()
            nanosec = np.ascontiguousarray(block_mine[:, 8:12]).view(end + 'u4').ravel()
            time_s[mine] = sec + nanosec * 1e-9
            for k, (offset, _) in enumerate(layout.arrays):
                first_byte = offset + 8 * reason
                values[k, mine] = np.ascontiguousarray(
                    block_mine[:, first_byte:first_byte + 8]).view(end + 'f8').ravel()
            used[mine] = True
        for i in np.flatnonzero(pending):  # too many layouts: one by one
            try:
                stamp, _, names, position, velocity, effort = decode_joint_state(raws[i])
            except BagError:
                self.rejections['malformed'] += 1
                continue
            picked = pick_joint(name=names, position=position, velocity=velocity,
                                effort=effort, joint=self.joint)
            self.seen_joint = self.seen_joint or self.joint in names
            if isinstance(picked, str):
                self.rejections[picked] += 1
                continue
            time_s[i] = stamp
            values[:, i] = picked
            used[i] = True
        self.parts.append((time_s[used], values[:, used]))


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
                          ) -> Iterator[bytes]:
    """Yield the CDR bytes of every complete message on ``topic``, record by record.

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
                            yield record.data
                    elif isinstance(record, Footer):
                        break
                else:
                    state['cut'] = True
        except BagError:
            raise
        except (McapError, EOFError, struct.error, ValueError, OSError):
            state['cut'] = True  # the incomplete record at the cut


def read_joint_samples(path: str | os.PathLike, *, joint: str,
                       topic: str = JOINT_STATES_TOPIC, chunk_messages: int = 32768,
                       progress: Callable[[int, int], None] | None = None,
                       recover: bool = True) -> JointSamples:
    """Read one joint's samples from the JointState messages of a bag (fast path).

    Raw messages are taken from rosbags in chunks of ``chunk_messages`` and decoded with numpy
    (see the module docstring).  ``progress(read, total)`` is called after each chunk with the
    number of messages read so far and the topic's message count (for a progress bar).

    An unfinished recording (a bag folder with MCAP files but no ``metadata.yaml``, or an MCAP
    file given directly: what a killed recorder leaves) is read record by record up to its
    last complete message; ``JointSamples.recovery`` then says how much was read and where the
    recording stops.  With ``recover`` false a recording whose end is cut is refused.

    Raises:
        BagError: the bag is missing, corrupt or truncated, the topic is absent or has another
            type, or no message carries the joint; a cut recording when ``recover`` is false.

    """
    bag = Path(path)
    unfinished = _unfinished_mcap_files(bag) if bag.exists() else None
    decoder = _ChunkDecoder(joint)
    count = 0
    reader = None if unfinished is not None else _open_reader(path)
    state = {'count': 0, 'last_ns': -1, 'cut': False, 'types': {}}
    collecting = gc.isenabled()
    gc.disable()  # the chunk holds many small objects; the collector would rescan them
    try:
        if reader is not None:
            connections = _connections(reader, path, topic)
            total = sum(int(getattr(c, 'msgcount', 0) or 0) for c in connections)
            source: Iterator[Any] = (raw for _, _, raw in
                                     reader.messages(connections=connections))
        else:
            total = 0
            source = _iter_unfinished_mcap(bag, unfinished[0], topic, state)
        chunk: list[bytes] = []
        try:
            for raw in source:
                chunk.append(raw)
                if len(chunk) >= chunk_messages:
                    decoder.decode(chunk)
                    count += len(chunk)
                    chunk = []
                    if progress is not None:
                        progress(count, total)
        except BagError:
            raise
        except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise BagError(f'{path}: corrupt or truncated bag: {message}') from None
        if chunk:
            decoder.decode(chunk)
            count += len(chunk)
        if progress is not None:
            progress(count, max(total, count))
    finally:
        if collecting:
            gc.enable()
        if reader is not None:
            reader.close()
    if unfinished is not None and state['cut'] and not recover:
        raise BagError(f'{bag}: unfinished recording ({unfinished[1]}; the last record is '
                       f'cut); refused (strict)')
    if unfinished is not None and topic not in state['types']:
        topics = ', '.join(sorted(state['types'])) or 'none'
        raise BagError(f'{path}: no topic {topic} in the unfinished recording (topics: '
                       f'{topics})')
    if count == 0:
        raise BagError(f'{path}: topic {topic} has no messages')
    if not decoder.seen_joint:
        seen = sorted({name for layout, _, _ in decoder.layouts for name in layout.names})
        shown = ', '.join(seen[:12]) + (', ...' if len(seen) > 12 else '')
        raise BagError(f'{path}: joint {joint!r} is in no message on {topic} (joints seen: '
                       f'{shown or "none"})')
    times = [p[0] for p in decoder.parts]
    values = np.concatenate([p[1] for p in decoder.parts], axis=1)
    recovery = None if unfinished is None else Recovery(
        files=tuple(str(f) for f in unfinished[0]), messages=count,
        last_stamp_s=state['last_ns'] * 1e-9, complete=not state['cut'],
        reason=unfinished[1] + ('; the last record is cut' if state['cut'] else ''))
    return JointSamples(time_s=np.concatenate(times), position_rad=values[0],
                        velocity_rad_s=values[1], effort=values[2], message_count=count,
                        rejections=decoder.rejections, recovery=recovery)


def iter_joint_states(path: str | os.PathLike, *, topic: str = JOINT_STATES_TOPIC
                      ) -> Iterator[tuple[int, float, list[str], FloatArray, FloatArray,
                                          FloatArray]]:
    """Yield (bag time [ns], stamp [s], names, position, velocity, effort) per message.

    The per-message path (for a streaming replay); malformed messages raise BagError.
    """
    for timestamp, raw in iter_raw_messages(path, topic=topic):
        stamp, _, names, position, velocity, effort = decode_joint_state(raw)
        yield timestamp, stamp, names, position, velocity, effort
