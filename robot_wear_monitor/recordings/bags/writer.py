"""
Writing ROS 2 bags of JointState messages, atomically.

:func:`atomic_bag_writer` writes into a temporary sibling folder and renames it to the target
only when the ``with`` block ends without an error (nothing half-written is left);
:func:`encode_joint_states` encodes JointState messages to CDR with numpy, one template per name
order (checked against rosbags' ``serialize_cdr`` in the tests); :func:`write_joint_state_bag`
writes a whole recording.
"""

from __future__ import annotations

from contextlib import contextmanager
import os
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.atomic_files import (output_lock, remove_stale_partials,
                                             staging_folder)
from robot_wear_monitor.recordings.bags.cdr import Layout, parse_layout
from robot_wear_monitor.recordings.bags.common import (BAG_VERSION, BagError, JOINT_STATE_TYPE,
                                                       JOINT_STATES_TOPIC, MONITOR_TYPESTORE,
                                                       storage_plugin, typestore_of)
from robot_wear_monitor.yaml_files import shorten
from rosbags.rosbag2 import Writer


class BagWriter:
    """Topics and messages of a bag being written (see :func:`atomic_bag_writer`)."""

    def __init__(self, writer: Writer) -> None:
        """Wrap an open rosbags writer."""
        self._writer = writer
        #: topic -> (connection, serializer of its type, type): one look-up per message written
        self._topics: dict[str, tuple[Any, Callable[[Any, str], Any], str]] = {}
        self.message_count = 0
        #: staging copies of killed writers of the same bag, removed before this one started
        self.removed_stale: list[Path] = []

    def add_topic(self, topic: str, msgtype: str) -> None:
        """Declare ``topic`` with the message type ``msgtype`` (a Jazzy type name)."""
        declared = self._topics.get(topic)
        if declared is not None:
            if declared[2] != msgtype:
                raise BagError(f'topic {topic} already has type {declared[2]}')
            return
        store = typestore_of(msgtype)  # the monitor's types, else rosbags' whole Jazzy store
        if msgtype not in store.types:
            raise BagError(f'unknown message type {shorten(msgtype)!r} in the ROS 2 Jazzy '
                           'typestore')
        connection = self._writer.add_connection(topic, msgtype, typestore=store)
        self._topics[topic] = (connection, store.serialize_cdr, msgtype)

    def write(self, topic: str, msg: Any, timestamp_ns: int) -> None:
        """Write a typestore message object (or CDR bytes) on a declared topic."""
        entry = self._topics.get(topic)
        if entry is None:
            raise BagError(f'topic {topic} was not added before writing')
        connection, serialize, msgtype = entry
        data = bytes(msg) if isinstance(msg, (bytes, bytearray, memoryview)) else \
            serialize(msg, msgtype)
        self._writer.write(connection, int(timestamp_ns), data)
        self.message_count += 1

    def write_raw_many(self, topic: str, messages: Sequence[bytes],
                       timestamps_ns: Sequence[int]) -> None:
        """Write many CDR-encoded messages on a declared topic (bag times in ns)."""
        entry = self._topics.get(topic)
        if entry is None:
            raise BagError(f'topic {topic} was not added before writing')
        connection, write = entry[0], self._writer.write
        for data, stamp in zip(messages, timestamps_ns):
            write(connection, int(stamp), data)
        self.message_count += len(messages)


@contextmanager
def atomic_bag_writer(path: str | os.PathLike, *, storage: str = 'mcap',
                      overwrite: bool = False) -> Iterator[BagWriter]:
    """
    Write a bag folder atomically: into a temporary sibling, renamed on success.

    :param path: the bag folder to create.
    :param storage: ``'mcap'`` (default) or ``'sqlite3'``.
    :param overwrite: replace an existing bag at ``path`` (only once the new one is complete).

    :raises BagError: ``path`` exists and ``overwrite`` is false, or the bag cannot be written.

    """
    plugin = storage_plugin(storage)
    target = Path(path)
    if target.exists() and not overwrite:
        raise BagError(f'{target}: already exists (choose another path, or --overwrite to '
                       'replace it)')
    if not target.parent.is_dir():
        raise BagError(f'{target}: the folder {target.parent} does not exist')
    with output_lock(target, what='bag'), staging_folder(target) as staging:
        stale = remove_stale_partials(target)
        temporary = staging / target.name  # rosbags names the storage file after the folder
        writer = Writer(temporary, version=BAG_VERSION, storage_plugin=plugin)
        try:
            writer.open()
            bag_writer = BagWriter(writer)
            bag_writer.removed_stale = stale
            yield bag_writer
            writer.close()
            if target.is_symlink():
                raise BagError(f'{target}: is a symbolic link; refusing to replace it')
            if target.exists():
                os.replace(target, staging / '.old')
            os.replace(temporary, target)
        except BaseException:
            try:
                writer.close()
            except Exception:  # noqa: BLE001 - the original error is what matters
                pass
            raise


def _template(names: Sequence[str], frame_id: str) -> tuple[bytes, Layout]:
    n = len(names)
    header = MONITOR_TYPESTORE.types['std_msgs/msg/Header'](
        stamp=MONITOR_TYPESTORE.types['builtin_interfaces/msg/Time'](sec=0, nanosec=0),
        frame_id=frame_id)
    prototype = MONITOR_TYPESTORE.types[JOINT_STATE_TYPE](
        header=header, name=list(names), position=np.zeros(n), velocity=np.zeros(n),
        effort=np.zeros(n))
    raw = bytes(MONITOR_TYPESTORE.serialize_cdr(prototype, JOINT_STATE_TYPE))
    return raw, parse_layout(raw)


def _split_stamps(stamps_s: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Return (sec, nanosec) of float stamps [s], rounded to the nanosecond."""
    sec = np.floor(stamps_s).astype(np.int64)
    nanosec = np.round((stamps_s - sec) * 1e9).astype(np.int64)
    carry = nanosec >= 1_000_000_000
    return sec + carry, np.where(carry, nanosec - 1_000_000_000, nanosec)


def encode_joint_states(*, stamps_s: Sequence[float] | FloatArray, names: Sequence[str],
                        position: Any, velocity: Any, effort: Any,
                        name_order: Any = None, frame_id: str = '') -> list[bytes]:
    """
    Encode JointState messages to CDR (little endian) with numpy.

    :param stamps_s: header stamps [s], shape (n,).
    :param names: joint names, the column order of the arrays, length J.
    :param position: positions [rad], shape (n, J).
    :param velocity: velocities [rad/s], shape (n, J).
    :param effort: efforts, shape (n, J).
    :param name_order: optional per-message column permutation, shape (n, J).
    :param frame_id: header frame_id.

    :return: One ``bytes`` per message, identical to rosbags' ``serialize_cdr``.

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
        raw, layout = _template([names[int(c)] for c in columns], frame_id)
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


def write_joint_state_bag(path: str | os.PathLike, *, stamps_s: Sequence[float] | FloatArray,
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
