"""Exception types shared by the core: a user-facing input error, and how it echoes values."""

import os
from pathlib import Path
from typing import Any

#: The most characters of a value an error message echoes.
ECHO_LIMIT = 80


class InputError(ValueError):
    """
    Bad user input (file, value, bag, table); the message is one line that names what is wrong.

    The CLI prints it and exits with code 2; the nodes log it and keep running.
    """


def escaped(value: Any) -> str:
    """Return the text of ``value``, each unprintable character escaped as Python writes it."""
    text = str(value)
    return text if text.isprintable() else ''.join(
        c if c.isprintable() else repr(c)[1:-1] for c in text)


def shorten(value: Any, limit: int = ECHO_LIMIT) -> str:
    """Return ``repr``-free text of ``value`` cut to ``limit`` characters with an ellipsis."""
    text = escaped(str(value)[:limit + 1])
    return text if len(text) <= limit else text[:limit - 1] + '\u2026'


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
