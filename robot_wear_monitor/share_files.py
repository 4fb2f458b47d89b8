"""
The folders the package installs beside its code: ``config/`` and ``examples/``.

``setup.py`` installs them as data files under ``<prefix>/share/robot_wear_monitor/`` (pip and
colcon alike, as ROS packages do); a source checkout has them at the repository's root.  The
code finds them from wherever it runs, so that a verb works in any folder
(``robot-wear-monitor examples`` copies the example files there).
"""

from __future__ import annotations

from pathlib import Path
import sys

from robot_wear_monitor.errors import InputError

PACKAGE_NAME = 'robot_wear_monitor'


def share_folders(name: str) -> list[Path]:
    """
    Return where the package's folder ``name`` (``config``, ``examples``) may be, in order.

    The ament share directory (colcon install on a ROS host), ``<prefix>/share`` of the running
    interpreter (pip install), the ``share`` folder of the prefix this module is installed in
    (colcon install without ament_index_python), and the source tree.
    """
    candidates = []
    try:  # pragma: no cover - only on a ROS 2 host
        # deferred import: optional extra 'ros' (ament_index_python)
        from ament_index_python.packages import get_package_share_directory
        candidates.append(Path(get_package_share_directory(PACKAGE_NAME)) / name)
    except Exception:  # noqa: BLE001 - ament may be absent or the package not indexed
        pass
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE_NAME / name)
    here = Path(__file__).resolve()
    # <prefix>/lib/pythonX.Y/site-packages/robot_wear_monitor/share_files.py -> <prefix>/share
    candidates.extend(parent / 'share' / PACKAGE_NAME / name for parent in here.parents)
    candidates.append(here.parents[1] / name)  # the source tree
    return candidates


def packaged_file(folder: str, file_name: str, *,
                  error: type[InputError] = InputError) -> Path:
    """
    Return the path of the packaged ``folder/file_name``, wherever the package is installed.

    :raises error: no candidate of :func:`share_folders` holds the file (the message lists
        them).
    """
    candidates = share_folders(folder)
    for candidate in candidates:
        path = candidate / file_name
        if path.is_file():
            return path
    raise error(f'the packaged {file_name} was not found in '
                + ', '.join(str(c) for c in candidates))
