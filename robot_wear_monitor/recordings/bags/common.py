"""
What the bag modules share: the typestore, names, the error type, opening a bag.

The storage plugins (MCAP by default, sqlite3 on request) and opening a bag for reading with
rosbags (:class:`rosbags.rosbag2.Reader`), with a one-line :class:`BagError` for a bad bag.
"""

from __future__ import annotations

from functools import cache
import os
from pathlib import Path
from typing import Any, Literal, TYPE_CHECKING

from robot_wear_monitor.errors import InputError, no_such_path_text
from robot_wear_monitor.recordings.bags.message_types import monitor_typestore
from robot_wear_monitor.yaml_files import load_yaml_file
from rosbags.rosbag2 import Reader, StoragePlugin
from rosbags.typesys import get_typestore, Stores

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

    #: rosbags' whole ROS 2 Jazzy typestore (module ``__getattr__``: loaded on first use)
    TYPESTORE: Typestore


#: rosbags typestore of the ROS 2 Jazzy types the monitor reads and writes
#: (:mod:`.message_types`); what the package's own reading and writing use.
MONITOR_TYPESTORE = monitor_typestore()
JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'
JOINT_STATES_TOPIC = '/joint_states'
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
BAG_VERSION: Literal[9] = 9


@cache
def jazzy_typestore() -> Typestore:
    """Return rosbags' whole ROS 2 Jazzy typestore, loaded on first use (0.04 s) and kept."""
    return get_typestore(Stores.ROS2_JAZZY)


def typestore_of(msgtype: str) -> Typestore:
    """Return the store of ``msgtype``: the monitor's own, else rosbags' whole Jazzy store."""
    return MONITOR_TYPESTORE if msgtype in MONITOR_TYPESTORE.types else jazzy_typestore()


def __getattr__(name: str) -> Any:
    """``TYPESTORE``: rosbags' whole ROS 2 Jazzy typestore (:func:`jazzy_typestore`)."""
    if name == 'TYPESTORE':
        return jazzy_typestore()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


class BagError(InputError):
    """A bag cannot be read or written; the message is one line naming the bag and the problem."""


def storage_plugin(storage: str) -> StoragePlugin:
    """Return the rosbags storage plugin of ``mcap`` or ``sqlite3`` (BagError otherwise)."""
    try:
        return STORAGES[storage]
    except KeyError:
        raise BagError(f'unknown storage {storage!r} (expected mcap or sqlite3)') from None


def open_reader(path: str | os.PathLike) -> Reader:
    """Open a bag for reading with rosbags; BagError (one line) when it is missing or bad."""
    bag = Path(path)
    if not bag.exists():
        raise BagError(no_such_path_text(bag, what='bag'))
    if (bag / 'metadata.yaml').is_file():  # bounded, no aliases, before rosbags reads it
        load_yaml_file(bag / 'metadata.yaml', what='bag metadata', error=BagError)
    try:
        reader = Reader(bag)
        reader.open()
    except Exception as error:  # noqa: BLE001 - rosbags raises several types for bad bags
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise BagError(f'{bag}: cannot open bag: {message}') from None
    return reader


def joint_state_connections(reader: Reader, path: Any, topic: str) -> list:
    """Return the JointState connections of ``topic`` (BagError: no such topic or wrong type)."""
    connections = [c for c in reader.connections if c.topic == topic]
    if not connections:
        topics = ', '.join(sorted({c.topic for c in reader.connections})) or 'none'
        raise BagError(f'{path}: no topic {topic} (topics: {topics})')
    for connection in connections:
        if connection.msgtype != JOINT_STATE_TYPE:
            raise BagError(f'{path}: topic {topic} has type {connection.msgtype}, '
                           f'expected {JOINT_STATE_TYPE}')
    return connections
