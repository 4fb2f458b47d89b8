"""
Recordings cut off by a crash, read up to their last complete message.

MCAP files without ``metadata.yaml`` (or an MCAP file given directly) are read record by record
with the ``mcap`` package (:class:`Recovery` says where the reading stopped).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import struct
from typing import Iterator, Sequence

from robot_wear_monitor.recordings.bags.common import BagError, JOINT_STATE_TYPE


@dataclass(frozen=True)
class Recovery:
    """
    What was read from an unfinished recording (a recorder killed before it closed the bag).

    :ivar files: the MCAP files read.
    :ivar messages: complete messages recovered on the topic.
    :ivar last_stamp_s: bag time of the last complete message [s] (where the recording stops).
    :ivar complete: the files end with their footer (nothing was lost, e.g. an MCAP file
        given directly); False: the recording stops at ``last_stamp_s``.
    :ivar reason: how the recording was read (no metadata.yaml, a file given directly, a cut).

    """

    files: tuple[str, ...]
    messages: int
    last_stamp_s: float
    complete: bool
    reason: str


#: The JointState schema name as MCAP writers spell it, with or without ``/msg/``.
_JOINT_STATE_SCHEMA = JOINT_STATE_TYPE.replace('/msg/', '/')


def unfinished_mcap_files(path: Path) -> tuple[list[Path], str] | None:
    """Return the MCAP files of a recording rosbags cannot open as a bag, and why; else None."""
    if path.is_file() and path.suffix == '.mcap':
        return [path], 'an MCAP file given directly (no bag metadata)'
    if path.is_dir() and not (path / 'metadata.yaml').is_file():
        files = sorted(path.glob('*.mcap'))
        if files:
            return files, 'no metadata.yaml (the recorder did not close the bag)'
    return None


def iter_unfinished_mcap(path: Path, files: Sequence[Path], topic: str, state: dict
                         ) -> Iterator[tuple[int, bytes]]:
    """
    Yield (log time [ns], CDR bytes) of every complete message on ``topic``, in order.

    A recorder killed mid-write leaves an MCAP without summary and footer, often with a cut
    chunk at the end; the mcap stream reader reads the file record by record, and reading stops
    at the first incomplete record.  ``state`` receives ``count``, ``last_ns``, ``cut`` and the
    channel types seen (``types``).  A channel of ``topic`` of another type than JointState
    raises BagError when it appears.
    """
    # deferred import: start-up time (mcap: a damaged MCAP only)
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
