"""
Reading JointState samples from ROS 2 bags, chunk by chunk, so that memory stays flat.

:func:`iter_joint_chunks` streams the samples of several joints (or all) chunk by chunk;
:func:`read_joints` and :func:`read_joint_samples` concatenate the chunks.  Raw messages come
from rosbags (MCAP or sqlite3, a bag split into several files) or, for an unfinished MCAP
recording, from :mod:`.recovery`; they are decoded by :mod:`.cdr`.  Times are the header stamps
(sec + nanosec) in seconds; a message whose header stamp is zero is given its bag receive time
instead (counted, and said once in the stream's notes).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
import gc
import os
from pathlib import Path
from typing import Any, Callable, Generator, Iterator, Optional, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.recordings.bags.cdr import decode_joint_state, JointChunk, MultiDecoder
from robot_wear_monitor.recordings.bags.common import (BagError, joint_state_connections,
                                                       JOINT_STATE_TYPE, JOINT_STATES_TOPIC,
                                                       MONITOR_TYPESTORE, open_reader)
from robot_wear_monitor.recordings.bags.mcap_chunks import (bulk_source, bulk_source_of,
                                                            BulkSource)
from robot_wear_monitor.recordings.bags.recovery import (iter_unfinished_mcap, Recovery,
                                                         unfinished_mcap_files)


@dataclass
class JointSamples:
    """
    Samples of one joint read from a bag, in bag order; arrays have shape (n,).

    :ivar time_s: header stamps [s].
    :ivar position_rad: joint positions [rad].
    :ivar velocity_rad_s: joint velocities [rad/s].
    :ivar effort: efforts (as recorded).
    :ivar message_count: JointState messages on the topic.
    :ivar recovery: set when the recording was unfinished and read up to its cut.
    :ivar rejections: messages not used, reason -> count (:data:`READER_REASONS`).
    :ivar zero_stamps: messages whose header stamp is zero (read at their bag receive time).
    :ivar notes: one-line remarks on the reading (the zero-stamp fallback, said once).

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


def _corrupt(path: str | os.PathLike, error: Exception) -> BagError:
    """Return the BagError of a bag the storage library failed to read (its first line)."""
    message = str(error).splitlines()[0] if str(error) else type(error).__name__
    return BagError(f'{path}: corrupt or truncated bag: {message}')


def iter_raw_messages(path: str | os.PathLike, *, topic: str = JOINT_STATES_TOPIC,
                      msgtype: str | None = JOINT_STATE_TYPE) -> Iterator[tuple[int, bytes]]:
    """Yield (bag time [ns], CDR bytes) of a topic, raising BagError for unreadable bags."""
    reader = open_reader(path)
    try:
        if msgtype == JOINT_STATE_TYPE:
            connections = joint_state_connections(reader, path, topic)
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
            raise _corrupt(path, error) from None
    finally:
        reader.close()


def recorded_topics(path: str | os.PathLike) -> dict[str, str]:
    """Return topic -> ROS type of every topic recorded in a bag (BagError if unreadable)."""
    reader = open_reader(path)
    try:
        return {c.topic: c.msgtype for c in reader.connections}
    finally:
        reader.close()


def iter_recorded_messages(path: str | os.PathLike, *, topics: Sequence[str]
                           ) -> Iterator[tuple[str, int, bytes]]:
    """
    Yield (topic, bag time [ns], CDR bytes) of ``topics`` in bag-time order.

    The bytes are the serialized messages as recorded (CDR with its encapsulation header),
    which is what an rclpy publisher sends as a raw message.
    """
    reader = open_reader(path)
    try:
        connections = [c for c in reader.connections if c.topic in set(topics)]
        try:
            for connection, timestamp, raw in reader.messages(connections=connections):
                yield connection.topic, timestamp, raw
        except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
            raise _corrupt(path, error) from None
    finally:
        reader.close()


# --------------------------------------------------------------------------- scalar topics

#: Scalar message types :func:`read_scalar_topic` reads, and the field holding the value.
SCALAR_FIELDS = {'sensor_msgs/msg/Temperature': 'temperature', 'std_msgs/msg/Float64': 'data',
                 'std_msgs/msg/Float32': 'data'}


def read_scalar_topic(path: str | os.PathLike, *, topic: str
                      ) -> tuple[FloatArray, FloatArray, str]:
    """
    Return (time [s], value, type) of a scalar topic of a bag, e.g. a joint temperature.

    ``sensor_msgs/msg/Temperature`` gives ``temperature`` [degC] at its header stamp;
    ``std_msgs/msg/Float64`` and ``Float32`` give ``data`` at the bag time.  Samples are sorted
    by time; non-finite values are dropped.

    :raises BagError: the bag is unreadable, the topic is absent, empty or of another type.

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
        msg = MONITOR_TYPESTORE.deserialize_cdr(raw, msgtype)
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


def _batched(pairs: Iterator[tuple[int, Any]], size: int) -> Generator[list, None, None]:
    """Yield [(bag times [ns], CDR bytes)] of up to ``size`` messages from a message iterator."""
    stamps: list = []
    raws: list = []
    for stamp, raw in pairs:
        stamps.append(stamp)
        raws.append(raw)
        if len(raws) >= size:
            yield [(stamps, raws)]
            stamps, raws = [], []
    if raws:
        yield [(stamps, raws)]


def _bulk_batches(bulk: BulkSource, size: int) -> Generator[list, None, None]:
    """
    Yield the pieces (bag times [ns], CDR bytes) of ``size`` messages at a time, chunk by chunk.

    The batches are those of the message-by-message path (``size`` each, the last one shorter),
    so that the chunks a reader yields do not depend on how the bag is read; each batch comes
    as the consecutive pieces of the MCAP chunks it spans (views into the chunks' bytes, not
    joined: the decoder reads them where they lie).
    """
    pieces: list = []
    held = 0
    for batch in bulk:
        times, raws = batch.log_time_ns, batch.raws
        while held + len(raws) >= size:
            take = size - held
            pieces.append((times[:take], raws[:take]))
            yield pieces
            pieces, held = [], 0
            times, raws = times[take:], raws[take:]
        if len(raws):
            pieces.append((times, raws))
            held += len(raws)
    if pieces:
        yield pieces


class JointStream:
    """
    Chunks of the samples of several joints of a bag; see :func:`iter_joint_chunks`.

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
        #: read finished MCAP bags chunk by chunk (:mod:`.mcap_chunks`) when they qualify
        self.bulk = os.environ.get('ROBOT_WEAR_MONITOR_BULK_READ', '1') != '0'
        #: whether the last iteration used the bulk reader
        self.bulk_read = False
        self.recovery: Recovery | None = None
        self.total_messages = 0
        bag = Path(path)
        self._unfinished = unfinished_mcap_files(bag) if bag.exists() else None
        #: (known, source): the chunks of a finished MCAP bag, from the index rosbags read on
        #: opening it (not known: :func:`.mcap_chunks.bulk_source` reads the summary)
        self._bulk_source: tuple[bool, BulkSource | None] = (False, None)
        if self._unfinished is None:
            reader = open_reader(path)
            try:
                connections = joint_state_connections(reader, path, topic)
                self.total_messages = sum(int(getattr(c, 'msgcount', 0) or 0)
                                          for c in connections)
                self._bulk_source = bulk_source_of(reader, topic)
            finally:
                reader.close()
        self._decoder = MultiDecoder(self.joints)

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
        self._decoder = MultiDecoder(self.joints)
        self.recovery = None
        path, topic = self.path, self.topic
        unfinished = self._unfinished
        state = {'count': 0, 'last_ns': -1, 'cut': False, 'types': {}}
        reader = bulk = None
        if unfinished is None and self.bulk:  # the topic and its type were checked on opening
            known, bulk = self._bulk_source
            if not known:
                bulk = bulk_source(path, topic)
        if unfinished is None and bulk is None:
            reader = open_reader(path)
        self.bulk_read = bulk is not None
        batches: Generator[list, None, None] | None = None
        try:
            if bulk is not None:
                batches = _bulk_batches(bulk, self.chunk_messages)
            elif reader is not None:
                connections = joint_state_connections(reader, path, topic)
                batches = _batched(((t, raw) for _, t, raw in
                                    reader.messages(connections=connections)),
                                   self.chunk_messages)
            else:
                assert unfinished is not None  # no reader: the recording is unfinished
                batches = _batched(iter_unfinished_mcap(Path(path), unfinished[0], topic,
                                                        state), self.chunk_messages)
            total = self.total_messages
            for chunk, messages in self._decoded(batches, gc.isenabled()):
                if self.progress is not None:
                    self.progress(messages, max(total, messages))
                yield chunk
        finally:
            if batches is not None:
                batches.close()  # the bag files it opened are closed now, not when collected
            if reader is not None:
                reader.close()
        self._finish(unfinished, state)

    def _decoded(self, batches: Iterator[list], collecting: bool
                 ) -> Iterator[tuple[dict[str, JointChunk], int]]:
        """Yield each decoded chunk with the messages read so far (BagError: a bad bag)."""
        path, decoder = self.path, self._decoder
        while True:
            gc.disable()  # the chunk holds many small objects; the collector rescans them
            try:
                pieces = next(batches, None)
            except BagError:
                raise
            except Exception as error:  # noqa: BLE001 - truncated/corrupt storage
                raise _corrupt(path, error) from None
            finally:
                if collecting:
                    gc.enable()
            if not pieces:
                return
            yield decoder.decode_pieces(pieces), decoder.messages

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
        """Return the requested joints that no message read so far carries."""
        return [j for j in self.joints or () if j not in self._decoder.seen]


def iter_joint_chunks(path: str | os.PathLike, *, joints: Sequence[str] | None = None,
                      topic: str = JOINT_STATES_TOPIC, chunk_messages: int = 32768,
                      progress: Callable[[int, int], None] | None = None,
                      recover: bool = True, require_joints: bool = True) -> JointStream:
    """
    Stream the samples of several joints of a bag chunk by chunk (flat memory).

    Raw messages are taken from rosbags in chunks of ``chunk_messages`` and decoded with numpy
    (see the module docstring); each chunk yields joint -> :class:`JointChunk`.  A message
    is usable for a joint when it names the joint and its position, velocity and effort arrays
    are as long as its names; otherwise it is counted for that joint under a reason of
    :data:`READER_REASONS`.  A message whose header stamp is zero gets its bag receive time
    (counted in ``zero_stamps``, said once in ``notes``).  Storage (MCAP, sqlite3) and bags
    split into several files are rosbags' business; an unfinished MCAP recording is read up
    to its last complete message (``recovery``, see :func:`read_joint_samples`).

    :param path: the bag folder (or an unfinished recording, see :class:`Recovery`).
    :param joints: the joints to read; None: every joint, as each is first seen.
    :param topic: the JointState topic.
    :param chunk_messages: messages per chunk.
    :param progress: ``progress(read, total)`` after each chunk.
    :param recover: read an unfinished recording whose end is cut (False: refuse it).
    :param require_joints: raise when a requested joint is in no message (at the end of the
        iteration); False leaves it with no samples (see ``joints_missing``).

    :raises BagError: at the call, the bag is missing or unreadable, the topic is absent (the
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
    """
    Read several joints' samples at once: joint -> :class:`JointSamples` (whole arrays).

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
    """
    Read one joint's samples from the JointState messages of a bag (fast path).

    The chunks of :func:`iter_joint_chunks` for this joint, concatenated.
    ``progress(read, total)`` is called after each chunk with the number of messages read so
    far and the topic's message count (for a progress bar).

    An unfinished recording (a bag folder with MCAP files but no ``metadata.yaml``, or an MCAP
    file given directly: what a killed recorder leaves) is read record by record up to its
    last complete message; ``JointSamples.recovery`` then says how much was read and where the
    recording stops.  With ``recover`` false a recording whose end is cut is refused.

    :raises BagError: the bag is missing, corrupt or truncated, the topic is absent or has another
        type, or no message carries the joint; a cut recording when ``recover`` is false.

    """
    stream = iter_joint_chunks(path, joints=[joint], topic=topic,
                               chunk_messages=chunk_messages, progress=progress,
                               recover=recover)
    return _concatenate(stream, [chunk[joint] for chunk in stream], joint)


def iter_joint_states(path: str | os.PathLike, *, topic: str = JOINT_STATES_TOPIC
                      ) -> Iterator[tuple[int, float, list[str], FloatArray, FloatArray,
                                          FloatArray]]:
    """
    Yield (bag time [ns], stamp [s], names, position, velocity, effort) per message.

    The per-message path (for a streaming replay); malformed messages raise BagError.
    """
    for timestamp, raw in iter_raw_messages(path, topic=topic):
        stamp, _, names, position, velocity, effort = decode_joint_state(raw)
        yield timestamp, stamp, names, position, velocity, effort
