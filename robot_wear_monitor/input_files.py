"""
Input files read with a bound as they are read, and CSV rows with their line numbers.

A size from ``stat`` says nothing of a device or a pipe (``/dev/zero`` has size 0 and never
ends), so :func:`read_text_file` opens the file, refuses anything that is not a regular file
(a link is followed to what it names), and reads at most ``limit_bytes`` + 1 bytes: past the
limit is an error, whatever ``stat`` said.  Text must be UTF-8; an error names the file and
the line of the first bad byte.  :func:`csv_rows` gives a CSV text's rows with their line
numbers and turns the csv module's errors (a field over its 128 KiB limit, a NUL byte) into
the same kind of error.  Names that enter from a file are checked as the command line checks
them (:func:`check_robot_name`).
"""

from __future__ import annotations

import csv
import io
import os
import stat
from typing import Iterator

from robot_wear_monitor.errors import InputError, shorten

#: Bytes read at a time.
_CHUNK_BYTES = 1 << 16
#: The longest robot name (as ``--robot``).
MAX_ROBOT_NAME_CHARS = 128


def read_text_file(path: str | os.PathLike, *, what: str, limit_bytes: int,
                   error: type[InputError] = InputError) -> str:
    """
    Return the UTF-8 text of the regular file at ``path``, read with a bound.

    :param path: the file (a link is followed).
    :param what: what the file is, for messages (e.g. ``'manifest'``).
    :param limit_bytes: the most bytes it may hold.
    :param error: the :class:`InputError` type raised.
    :raises InputError: (``error``) no such file, not readable, not a regular file (a device,
        a pipe, a folder), over ``limit_bytes``, or not UTF-8 (naming the line).
    """
    name = shorten(os.fspath(path), 200)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, 'O_CLOEXEC', 0))
    except OSError as problem:  # "No such file or directory", "Permission denied", ...
        raise error(f'{name}: cannot read {what}: {problem.strerror}') from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = 'a folder' if stat.S_ISDIR(mode) else 'a device, pipe or socket'
            raise error(f'{name}: the {what} is {kind}, not a regular file')
        chunks = []
        total = 0
        while True:
            chunk = os.read(fd, min(_CHUNK_BYTES, limit_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit_bytes:
                raise error(f'{name}: the {what} holds more than the limit of '
                            f'{limit_bytes} bytes')
    except OSError as problem:
        raise error(f'{name}: cannot read {what}: {problem.strerror}') from None
    finally:
        os.close(fd)
    data = b''.join(chunks)
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as problem:
        line = data[:problem.start].count(b'\n') + 1
        raise error(f'{name}: line {line}: the {what} is not UTF-8 text') from None


def csv_rows(text: str, *, source: str,
             error: type[InputError] = InputError) -> Iterator[tuple[int, list[str]]]:
    """
    Yield (line number, row) of a CSV text; a csv module error names the source and line.

    :raises InputError: (``error``) a field over the csv module's limit (128 KiB), a NUL
        byte, or a quote the csv dialect cannot read.
    """
    reader = csv.reader(io.StringIO(text, newline=''))
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as problem:
            raise error(f'{shorten(source, 200)}: line {reader.line_num}: {problem}') from None
        yield reader.line_num, row


def check_robot_name(text: str, *, where: str = '',
                     error: type[InputError] = InputError) -> str:
    """
    Return a robot name stripped; the rule of ``--robot``: 1-128 printable characters.

    :raises InputError: (``error``) an empty, over-long or unprintable name, echoed escaped.
    """
    name = text.strip()
    if not name or len(name) > MAX_ROBOT_NAME_CHARS or not name.isprintable():
        raise error(f'{where}a robot name is 1-{MAX_ROBOT_NAME_CHARS} printable characters, '
                    f'got {shorten(text, 40)!r}')
    return name
