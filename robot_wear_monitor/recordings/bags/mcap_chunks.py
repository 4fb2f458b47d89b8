"""
The raw messages of one topic of a finished MCAP bag, a whole chunk at a time.

rosbags iterates an MCAP bag message by message (a heap merge over its message sources, a few
Python calls per message); for replay that is most of the reading time.  This module reads the
same messages in bulk, taking the summary (channels and the chunk index) from the one rosbags
read when it opened the bag (:func:`bulk_source_of`), or from the ``mcap`` package
(:func:`bulk_source`):

* each chunk is read with one ``read``, decompressed in one call (``zstandard``, ``lz4``) and
  its records are split with numpy when the messages after the first one sit at a fixed stride
  (the usual case: one JointState layout, one channel); otherwise record by record;
* the messages of the topic's channels are returned in log-time order (ties: in file order),
  chunk after chunk, as one :class:`RawBatch` per chunk (views into the chunk's bytes);

:func:`bulk_source` says whether a bag qualifies: a finished rosbag2 folder of MCAP files (no
file-level compression) whose files have a summary with a chunk index, and whose chunks do not
overlap in time across the bag; anything else returns None and the caller reads with rosbags
(a recording cut off by a crash goes through :mod:`.recovery` as before).  The messages, their
order and their bag times are those rosbags yields (tested on every kind of bag the tests make).
"""

from __future__ import annotations

from dataclasses import dataclass
import os
from pathlib import Path
import struct
from typing import Any, Generator, Iterator, Optional

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.yaml_files import load_yaml_file

_MESSAGE = 0x05
_CHUNK = 0x06
_RECORD_HEAD = 9          # opcode (1) + length (8)
_MESSAGE_HEAD = 22        # channel (2) + sequence (4) + log time (8) + publish time (8)
_CHUNK_HEAD = struct.Struct('<QQQI')  # start, end, uncompressed size, crc


class RawRows:
    """
    Messages of one size as the rows of a uint8 array (count, size): a sequence of bytes.

    What a chunk of same-size records gives without a Python object per message; indexing
    gives one message (a memoryview), slicing a :class:`RawRows`, and :attr:`array` is read by
    the decoder in one numpy step.
    """

    def __init__(self, array: NDArray[np.uint8]) -> None:
        """Keep the (count, size) array (a view into the chunk's bytes is fine)."""
        self.array = array

    def __len__(self) -> int:
        """Return the number of messages."""
        return int(self.array.shape[0])

    def __getitem__(self, index: Any) -> Any:
        """Return message ``index`` (memoryview), or a :class:`RawRows` for a slice."""
        if isinstance(index, slice):
            return RawRows(self.array[index])
        return memoryview(self.array[index])

    def __iter__(self) -> Iterator[memoryview]:
        """Iterate over the messages (memoryviews)."""
        return (memoryview(row) for row in self.array)


@dataclass
class RawBatch:
    """
    The messages of the topic in one chunk: bag times [ns] and CDR bytes, in log-time order.

    ``raws``: a list of memoryviews, or a :class:`RawRows` when the chunk's messages of the
    topic are records of one size (the usual case).
    """

    log_time_ns: NDArray[np.int64]
    raws: Any


@dataclass(frozen=True)
class _Chunk:
    file: Path
    offset: int
    length: int
    start_ns: int
    end_ns: int
    compression: str


class BulkSource:
    """The chunks of a bag's MCAP files that hold the topic, in time order (see the module)."""

    def __init__(self, chunks: list[_Chunk], channels: dict[Path, set[int]]) -> None:
        """Keep the chunks (sorted, non-overlapping) and each file's channel ids of the topic."""
        self.chunks = chunks
        self.channels = channels

    def __iter__(self) -> Iterator[RawBatch]:
        """Yield one :class:`RawBatch` per chunk that holds messages of the topic."""
        records = self._records()
        try:
            for chunk, record in records:
                batch = _split_chunk(record, chunk, self.channels[chunk.file])
                if batch is not None:
                    yield batch
        finally:
            records.close()  # the files are closed

    def _records(self) -> Generator[tuple[_Chunk, bytes], None, None]:
        """Yield each chunk with its record's bytes, read with one ``read``."""
        handles: dict[Path, Any] = {}
        try:
            for chunk in self.chunks:
                handle = handles.get(chunk.file)
                if handle is None:
                    handle = handles[chunk.file] = open(chunk.file, 'rb')
                handle.seek(chunk.offset)
                yield chunk, handle.read(chunk.length)
        finally:
            for handle in handles.values():
                handle.close()


def _decompress(data: memoryview, compression: str, size: int) -> bytes | memoryview:
    if compression == '':
        return data
    if compression == 'zstd':
        # deferred import: start-up time (zstandard: compressed chunks only)
        import zstandard
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == 'lz4':
        # deferred import: start-up time (lz4: compressed chunks only)
        import lz4.frame  # type: ignore[import-untyped]
        return lz4.frame.decompress(data)
    raise InputError(f'unknown MCAP chunk compression {compression[:20]!r}')


def _split_chunk(record: bytes, chunk: _Chunk, channels: set[int]) -> Optional[RawBatch]:
    """Return the messages of ``channels`` in a chunk record read whole (InputError: bad)."""
    if len(record) != chunk.length or record[0] != _CHUNK:
        raise InputError(f'{chunk.file}: chunk at byte {chunk.offset} is cut or not a chunk')
    _, _, size, _ = _CHUNK_HEAD.unpack_from(record, _RECORD_HEAD)
    at = _RECORD_HEAD + _CHUNK_HEAD.size
    (name_length,) = struct.unpack_from('<I', record, at)
    at += 4 + name_length
    (data_length,) = struct.unpack_from('<Q', record, at)
    at += 8
    # a view, not a copy: an uncompressed chunk's messages are views into the bytes read
    data = _decompress(memoryview(record)[at:at + data_length], chunk.compression, size)
    if len(data) != size:
        raise InputError(f'{chunk.file}: chunk at byte {chunk.offset} decompresses to '
                         f'{len(data)} bytes, its header says {size}')
    return split_records(data, channels)


def split_records(data: bytes | memoryview, channels: set[int]) -> Optional[RawBatch]:
    """Return the messages of ``channels`` among a chunk's records (None when there are none)."""
    view = memoryview(data)
    unpack = struct.unpack_from
    starts: list[int] = []
    ends: list[int] = []
    times: list[int] = []
    at, total = 0, len(data)
    while at + _RECORD_HEAD <= total:
        opcode = data[at]
        (length,) = unpack('<Q', data, at + 1)
        body = at + _RECORD_HEAD
        if body + length > total:
            raise InputError(f'a record of {length} bytes runs past the end of its chunk')
        if opcode == _MESSAGE:
            fixed = _fixed_stride(data, at, length)
            if fixed is not None and not starts:
                rows = _stride_rows(fixed, data, channels)
                if rows is not None:
                    return rows
            if fixed is not None:
                _take_stride(fixed, data, channels, starts, ends, times)
                break
            channel, _, log_time = unpack('<HIQ', data, body)
            if channel in channels:
                starts.append(body + _MESSAGE_HEAD)
                ends.append(body + length)
                times.append(log_time)
        at = body + length
    if not starts:
        return None
    log_time = np.asarray(times, dtype=np.int64)
    order = np.argsort(log_time, kind='stable')
    if np.any(np.diff(order) != 1):
        starts = [starts[i] for i in order.tolist()]
        ends = [ends[i] for i in order.tolist()]
        log_time = log_time[order]
    return RawBatch(log_time_ns=log_time,
                    raws=[view[s:e] for s, e in zip(starts, ends)])


def _fixed_stride(data: bytes | memoryview, at: int,
                  length: int) -> Optional[tuple[int, int, int]]:
    """Return (first, stride, count) when every record from ``at`` on is a message of one size."""
    stride = _RECORD_HEAD + length
    rest = len(data) - at
    if rest % stride or rest // stride < 2:
        return None
    count = rest // stride
    rows = np.frombuffer(data, dtype=np.uint8, count=count * stride, offset=at).reshape(
        count, stride)
    if np.any(rows[:, 0] != _MESSAGE):
        return None
    lengths = rows[:, 1:_RECORD_HEAD].view('<u8')[:, 0]  # a strided view, no copy
    if np.any(lengths != length):
        return None
    return at, stride, count


def _record_rows(fixed: tuple[int, int, int], data: bytes | memoryview,
                 channels: set[int]) -> tuple[NDArray, NDArray, NDArray]:
    """Return a run of same-size records as byte rows, their log times [ns] and topic mask."""
    at, stride, count = fixed
    rows = np.frombuffer(data, dtype=np.uint8, count=count * stride, offset=at).reshape(
        count, stride)
    head = _RECORD_HEAD
    channel = rows[:, head:head + 2].view('<u2')[:, 0]  # strided views, no copy
    log_time = rows[:, head + 6:head + 14].view('<u8')[:, 0].astype(np.int64)
    if len(channels) == 1:
        keep = channel == next(iter(channels))
    else:
        keep = np.isin(channel, np.fromiter(channels, dtype=np.uint16, count=len(channels)))
    return rows, log_time, keep


def _stride_rows(fixed: tuple[int, int, int], data: bytes | memoryview,
                 channels: set[int]) -> Optional[RawBatch]:
    """
    Return the messages of a chunk that is one run of same-size records, as rows.

    None when the run has no message of ``channels`` (or the caller should list them one by
    one); the order is the log-time order (stable), as :func:`split_records` gives it.
    """
    rows, log_time, keep = _record_rows(fixed, data, channels)
    head = _RECORD_HEAD
    if not keep.any():
        return None
    payload = rows[:, head + _MESSAGE_HEAD:]
    if not keep.all():
        payload, log_time = payload[keep], log_time[keep]
    if np.any(log_time[1:] < log_time[:-1]):  # else the stable order is the file's
        order = np.argsort(log_time, kind='stable')
        payload, log_time = payload[order], log_time[order]
    return RawBatch(log_time_ns=log_time, raws=RawRows(payload))


def _take_stride(fixed: tuple[int, int, int], data: bytes | memoryview, channels: set[int],
                 starts: list[int], ends: list[int], times: list[int]) -> None:
    """Add the messages of a run of same-size message records (numpy, no per-record parsing)."""
    at, stride, count = fixed
    rows, log_time, keep = _record_rows(fixed, data, channels)
    head = _RECORD_HEAD
    first = at + head + _MESSAGE_HEAD + stride * np.flatnonzero(keep)
    starts.extend(first.tolist())
    ends.extend((first + (stride - head - _MESSAGE_HEAD)).tolist())
    times.extend(log_time[keep].tolist())


def bulk_source_of(reader: Any, topic: str) -> tuple[bool, Optional[BulkSource]]:
    """
    Return (whether rosbags showed its index, the bulk reader of ``topic`` or None).

    rosbags reads each MCAP file's summary (channels and chunk index) when it opens a bag;
    this takes the same chunks from it that :func:`bulk_source` takes from the ``mcap``
    package, under the same conditions, so that the summary is read once and ``mcap`` is not
    loaded.  (False, None) when the open reader does not show that index (sqlite3 storage,
    or another rosbags version): :func:`bulk_source` then decides.
    """
    storages = getattr(getattr(reader, 'storage', None), 'storages', None)
    if not storages or not all(isinstance(getattr(storage, 'chunks', None), list)
                               for storage in storages):
        return False, None
    if getattr(reader, 'compression_format', None):
        return True, None
    chunks: list[_Chunk] = []
    channels: dict[Path, set[int]] = {}
    for storage in storages:
        file, found, index = storage.path, storage.channels, storage.chunks
        if not index:
            return True, None  # no summary with a chunk index
        mine = {i for i, channel in found.items() if channel.topic == topic}
        channels[Path(file)] = mine
        for entry in index:
            if entry.compression not in ('', 'zstd', 'lz4'):
                return True, None
            if entry.message_index_offsets and not mine & set(entry.message_index_offsets):
                continue  # no message of the topic in this chunk (by its message index)
            chunks.append(_Chunk(file=Path(file), offset=entry.chunk_start_offset,
                                 length=entry.chunk_length,
                                 start_ns=entry.message_start_time,
                                 end_ns=entry.message_end_time,
                                 compression=entry.compression))
    return True, _in_time_order(chunks, channels)


def bulk_source(path: str | os.PathLike, topic: str) -> Optional[BulkSource]:
    """
    Return the bulk reader of ``topic`` in the bag at ``path``, or None when it does not apply.

    None for: an MCAP file given directly or a folder without ``metadata.yaml`` (unfinished:
    :mod:`.recovery` reads it), sqlite3 storage, file-level compression, a file without a
    summary or chunk index, a chunk compression other than none/zstd/lz4, and chunks that
    overlap in time (rosbags then merges them message by message).
    """
    bag = Path(path)
    metadata = bag / 'metadata.yaml'
    if not bag.is_dir() or not metadata.is_file():
        return None
    try:
        info = load_yaml_file(metadata, what='bag metadata')['rosbag2_bagfile_information']
        if info.get('storage_identifier') != 'mcap' or info.get('compression_format'):
            return None
        files = [bag / name for name in info['relative_file_paths']]
    except (InputError, KeyError, TypeError):
        return None
    # deferred import: start-up time (mcap: MCAP bags only)
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    chunks: list[_Chunk] = []
    channels: dict[Path, set[int]] = {}
    for file in files:
        try:
            with open(file, 'rb') as stream:
                summary = make_reader(stream).get_summary()
        except (OSError, McapError, struct.error, ValueError):
            return None
        if summary is None or not summary.chunk_indexes:
            return None
        mine = {i for i, channel in summary.channels.items() if channel.topic == topic}
        channels[file] = mine
        for index in summary.chunk_indexes:
            if index.compression not in ('', 'zstd', 'lz4'):
                return None
            if index.message_index_offsets and not mine & set(index.message_index_offsets):
                continue  # no message of the topic in this chunk (by its message index)
            chunks.append(_Chunk(file=file, offset=index.chunk_start_offset,
                                 length=index.chunk_length,
                                 start_ns=index.message_start_time,
                                 end_ns=index.message_end_time,
                                 compression=index.compression))
    return _in_time_order(chunks, channels)


def _in_time_order(chunks: list[_Chunk], channels: dict[Path, set[int]]
                   ) -> Optional[BulkSource]:
    """Return the source of the chunks in time order; None when two overlap in time."""
    chunks.sort(key=lambda c: (c.start_ns, c.end_ns))
    if any(a.end_ns >= b.start_ns for a, b in zip(chunks, chunks[1:])):
        return None
    return BulkSource(chunks, channels)
