"""Exception types shared by the core: a user-facing input error, a missing path's message."""

import os
from pathlib import Path

from robot_wear_monitor.text import shorten


class InputError(ValueError):
    """
    Bad user input (file, value, bag, table); the message is one line that names what is wrong.

    The CLI prints it and exits with code 2; the nodes log it and keep running.
    """


#: What ``../shared`` is, said when a path under it is missing (the README's commands use it).
SHARED_DATA_HINT = ('../shared is the measured data kept beside the repository, not in it; '
                    'without it, run the same verb on simulated data (robot-wear-monitor '
                    'simulate --out wear_bag) or on the level tables in examples/')


def no_such_path_text(path: str | os.PathLike, *, what: str) -> str:
    """
    Return the one-line error for a missing input ``path``, e.g. ``x.csv: no such file``.

    A name ending in ``.csv`` or ``.csv.gz`` is a file whatever ``what`` says (a level table
    or a raw run, never a bag).  A path through a missing ``shared`` folder (``../shared/...``)
    says what that folder is and what to run without it.

    :param path: the path given.
    :param what: what was expected there (``bag``, ``file or folder``, ...).
    :return: the message, the path cut to 200 characters.
    """
    given = str(path)
    if given.lower().endswith(('.csv', '.csv.gz')):
        what = 'file'
    text = f'{shorten(given, 200)}: no such {what}'
    parts = Path(given).parts
    if 'shared' in parts:
        folder = Path(*parts[:parts.index('shared') + 1])
        if not folder.is_dir():
            text += f' ({SHARED_DATA_HINT})'
    return text
