"""
ROS 2 bags of ``sensor_msgs/msg/JointState`` with rosbags: atomic writing and a fast reader.

One module per job: :mod:`.common` (the typestore, names, the error type, opening a bag),
:mod:`.message_types` (the Jazzy types the monitor reads and writes),
:mod:`.writer` (atomic bag writing, CDR encoding with numpy), :mod:`.cdr` (decoding JointState
messages by layout, many at a time), :mod:`.recovery` (recordings cut off by a crash),
:mod:`.mcap_chunks` (finished MCAP bags read a chunk at a time) and :mod:`.reader` (the
chunked JointState stream and the other topic readers).  The names below
are the package's API: ``from robot_wear_monitor.recordings.bags import X`` works for each.
"""

from typing import Any, TYPE_CHECKING

from robot_wear_monitor.recordings.bags.cdr import (decode_joint_state, JointChunk, Layout,
                                                    MultiDecoder, parse_layout, READER_REASONS)
from robot_wear_monitor.recordings.bags.common import (BAG_VERSION, BagError, jazzy_typestore,
                                                       joint_state_connections, JOINT_STATE_TYPE,
                                                       JOINT_STATES_TOPIC, MONITOR_TYPESTORE,
                                                       open_reader, storage_plugin, STORAGES)
from robot_wear_monitor.recordings.bags.reader import (iter_joint_chunks, iter_joint_states,
                                                       iter_raw_messages, iter_recorded_messages,
                                                       JointSamples, JointStream,
                                                       read_joint_samples, read_joints,
                                                       read_scalar_topic, recorded_topics,
                                                       SCALAR_FIELDS)
from robot_wear_monitor.recordings.bags.recovery import (iter_unfinished_mcap, Recovery,
                                                         unfinished_mcap_files)
from robot_wear_monitor.recordings.bags.writer import (atomic_bag_writer, BagWriter,
                                                       encode_joint_states, write_joint_state_bag)

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

    #: rosbags' whole ROS 2 Jazzy typestore (module ``__getattr__``: loaded on first use)
    TYPESTORE: Typestore

__all__ = ['atomic_bag_writer', 'BAG_VERSION', 'BagError', 'BagWriter', 'decode_joint_state',
           'encode_joint_states', 'iter_joint_chunks', 'iter_joint_states', 'iter_raw_messages',
           'iter_recorded_messages', 'iter_unfinished_mcap', 'jazzy_typestore',
           'joint_state_connections',
           'JOINT_STATE_TYPE', 'JOINT_STATES_TOPIC', 'JointChunk', 'JointSamples', 'JointStream',
           'Layout', 'MONITOR_TYPESTORE', 'MultiDecoder', 'open_reader', 'parse_layout',
           'read_joint_samples', 'read_joints', 'read_scalar_topic', 'READER_REASONS',
           'recorded_topics', 'Recovery', 'SCALAR_FIELDS', 'storage_plugin', 'STORAGES',
           'TYPESTORE', 'unfinished_mcap_files', 'write_joint_state_bag']


def __getattr__(name: str) -> Any:
    """``TYPESTORE``: rosbags' whole ROS 2 Jazzy typestore, loaded on first use."""
    if name == 'TYPESTORE':
        return jazzy_typestore()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
