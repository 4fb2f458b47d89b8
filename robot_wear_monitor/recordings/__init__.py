"""
Recordings: ROS 2 bags, message mapping, measured raw tables.

:func:`is_bag` lives here, beside no heavy import, so that a command can tell a bag from a
folder of bags before it loads rosbags or the batch machinery.
"""

from pathlib import Path

#: Files of a bag's storage (MCAP, sqlite3).
BAG_SUFFIXES = ('.mcap', '.db3')


def is_bag(path: Path) -> bool:
    """
    Return True when ``path`` is a recording the replay reads.

    A bag folder (``metadata.yaml``, or MCAP / sqlite3 files of an unfinished recording
    directly in it) or an MCAP file.
    """
    if path.is_file():
        return path.suffix == '.mcap'
    if not path.is_dir():
        return False
    if (path / 'metadata.yaml').is_file():
        return True
    return any(child.suffix in BAG_SUFFIXES and child.is_file() for child in path.iterdir())
