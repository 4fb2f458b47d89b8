"""
Input files read with a bound as they are read, and CSV rows with their line numbers.

A size from ``stat`` says nothing of a device or a pipe (``/dev/zero`` has size 0 and never
ends), so :func:`read_text_file` opens the file, refuses anything that is not a regular file
(a link is followed to what it names), and reads at most ``limit_bytes`` + 1 bytes: past the
limit is an error, whatever ``stat`` said.  Text must be UTF-8; an error names the file and
the line of the first bad byte.  :func:`csv_rows` gives a CSV text's rows with their line
numbers and turns the csv module's errors (a field over its 128 KiB limit, a NUL byte) into
the same kind of error.  :class:`TextLines` reads a file line by line (a ``.gz`` file
decompressed as it is read) with the same checks, a bound on the bytes (decompressed ones for
``.gz``: a gzip bomb is refused after ``limit_bytes``, not after it filled the memory) and on a
line's length; :func:`csv_file_rows` gives a CSV file's rows that way.  Names that enter from a
file are checked as the command line checks them (:func:`check_robot_name`).
"""

from __future__ import annotations

import codecs
import csv
import io
import os
import stat
from typing import Any, Iterator
import zlib

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.text import shorten

#: Bytes read at a time.
_CHUNK_BYTES = 1 << 16
#: The most characters of a line :class:`TextLines` reads unless told otherwise.
MAX_LINE_CHARS = 1 << 20
#: The largest level table read (text, decompressed for ``.csv.gz``) [bytes]: about 200 000
#: levels (a level is one row of some 100 bytes; a fleet's year is a few thousand).
MAX_LEVEL_TABLE_BYTES = 32 << 20
#: The largest raw run read (text, decompressed for ``.csv.gz``) [bytes]: about 6 million
#: samples of four columns (the KUKA runs are 1.4 MB each).
MAX_RAW_RUN_BYTES = 256 << 20
#: The most samples (rows) of a raw run: 5 million, 160 MB as four float64 columns (83 min
#: at 1 kHz; the short rows of a text within MAX_RAW_RUN_BYTES could make 1 GB of arrays).
MAX_RAW_RUN_SAMPLES = 5_000_000
#: The longest line of a raw run or a level table [characters] (a raw-run row is ~50).
MAX_TABLE_LINE_CHARS = 64 << 10
#: The largest PEM file read (a TLS certificate, its key, a CA bundle) [bytes].
MAX_PEM_BYTES = 1 << 20
#: The largest JSON file read (a truth file, an earlier ``--json-out`` summary) [bytes].
MAX_JSON_BYTES = 64 << 20
#: The longest robot name (as ``--robot``).
MAX_ROBOT_NAME_CHARS = 128


def _open_regular(path: str | os.PathLike, name: str, what: str,
                  error: type[InputError]) -> int:
    """Return a read descriptor of the regular file at ``path`` (a link is followed)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, 'O_CLOEXEC', 0))
    except OSError as problem:  # "No such file or directory", "Permission denied", ...
        raise error(f'{name}: cannot read {what}: {problem.strerror}') from None
    try:
        mode = os.fstat(fd).st_mode
    except OSError as problem:
        os.close(fd)
        raise error(f'{name}: cannot read {what}: {problem.strerror}') from None
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = 'a folder' if stat.S_ISDIR(mode) else 'a device, pipe or socket'
        raise error(f'{name}: the {what} is {kind}, not a regular file')
    return fd


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
    with TextLines(path, what=what, limit_bytes=limit_bytes, error=error,
                   gzip=False) as lines:
        return ''.join(lines.text())


def csv_rows(text: str, *, source: str,
             error: type[InputError] = InputError) -> Iterator[tuple[int, list[str]]]:
    """
    Yield (line number, row) of a CSV text; a csv module error names the source and line.

    :raises InputError: (``error``) a field over the csv module's limit (128 KiB), a NUL
        byte, or a quote the csv dialect cannot read.
    """
    yield from _numbered_rows(csv.reader(io.StringIO(text, newline='')),
                              name=shorten(source, 200), error=error)


def _numbered_rows(reader: Any, *, name: str,
                   error: type[InputError]) -> Iterator[tuple[int, list[str]]]:
    """Yield (line number, row) of a csv reader; its errors as ``error`` naming the line."""
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as problem:
            raise error(f'{name}: line {reader.line_num}: {problem}') from None
        yield reader.line_num, row


class TextLines:
    """
    The lines of a UTF-8 text file (``.gz``: decompressed), read with bounds as they are read.

    Iterating yields each line with its newline (the last one may lack it), :meth:`blocks`
    many whole lines at a time; :attr:`line_number` is the number of the line yielded last.
    The file is opened at once (a regular file only, as :func:`read_text_file`) and closed at
    the end, on an error or by :meth:`close` (a context manager too).

    :param path: the file; a name ending in ``.gz`` is read as gzip.
    :param what: what the file is, for messages (e.g. ``'level table'``).
    :param limit_bytes: the most bytes of text (decompressed ones for ``.gz``) it may hold.
    :param line_limit_chars: the most characters of a line (default 1 MiB).
    :param error: the :class:`InputError` type raised.
    :param gzip: read the file as gzip (default: when its name ends in ``.gz``).
    :raises InputError: (``error``, while reading) no such file, not a regular file, past a
        limit, not gzip data, or not UTF-8 (naming the line).
    """

    def __init__(self, path: str | os.PathLike, *, what: str, limit_bytes: int,
                 line_limit_chars: int = MAX_LINE_CHARS,
                 error: type[InputError] = InputError, gzip: bool | None = None) -> None:
        self.name = shorten(os.fspath(path), 200)
        self.what = what
        self.limit_bytes = int(limit_bytes)
        self.line_limit_chars = line_limit_chars
        self.error = error
        self.line_number = 0
        self.gzip = os.fspath(path).endswith('.gz') if gzip is None else gzip
        self._fd: int | None = _open_regular(path, self.name, what, error)

    def __enter__(self) -> 'TextLines':
        """Return the reader."""
        return self

    def __exit__(self, *exc: Any) -> None:
        """Close the file."""
        self.close()

    def close(self) -> None:
        """Close the file (again: nothing)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def fail(self, text: str) -> InputError:
        """Return the error ``<file>: line <n>: <text>`` of the line being read."""
        return self.error(f'{self.name}: line {max(self.line_number, 1)}: {text}')

    def _raw_chunks(self) -> Iterator[bytes]:
        """Yield the file's bytes; at most ``limit_bytes`` (+64 KiB of gzip framing)."""
        limit = self.limit_bytes + (_CHUNK_BYTES if self.gzip else 0)
        total = 0
        while self._fd is not None:
            try:
                chunk = os.read(self._fd, min(_CHUNK_BYTES, limit + 1 - total))
            except OSError as problem:
                raise self.error(f'{self.name}: cannot read {self.what}: '
                                 f'{problem.strerror}') from None
            if not chunk:
                return
            total += len(chunk)
            if total > limit:
                raise self.error(f'{self.name}: the {self.what} holds more than the limit of '
                                 f'{self.limit_bytes} bytes')
            yield chunk

    def _inflated(self, chunks: Iterator[bytes]) -> Iterator[bytes]:
        """Yield the decompressed bytes of gzip ``chunks`` (members one after another)."""
        inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
        fed = False
        try:
            for chunk in chunks:
                data = chunk
                fed = True
                while True:
                    out = inflater.decompress(data, _CHUNK_BYTES)
                    if out:
                        yield out
                    if inflater.eof:  # a member ends; another may follow
                        data = inflater.unused_data
                        inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
                        fed = bool(data)
                        if not data:
                            break
                        continue
                    data = inflater.unconsumed_tail
                    if not data and len(out) < _CHUNK_BYTES:
                        break
        except zlib.error as problem:
            raise self.error(f'{self.name}: the {self.what} is not gzip data ({problem})'
                             ) from None
        if fed:
            raise self.error(f'{self.name}: the {self.what} is cut (the gzip data ends early)')

    def text(self) -> Iterator[str]:
        """Yield the decoded text in pieces, bounded by ``limit_bytes`` (decompressed)."""
        chunks = self._raw_chunks()
        source = self._inflated(chunks) if self.gzip else chunks
        decoder = codecs.getincrementaldecoder('utf-8')()
        total = 0
        newlines = 0
        for data in source:
            total += len(data)
            if total > self.limit_bytes:
                raise self.error(f'{self.name}: the {self.what} holds more than the limit of '
                                 f'{self.limit_bytes} bytes'
                                 + (' decompressed' if self.gzip else ''))
            pending = len(decoder.getstate()[0])
            try:
                text = decoder.decode(data)
            except UnicodeDecodeError as problem:
                line = newlines + data[:max(problem.start - pending, 0)].count(b'\n') + 1
                raise self.error(f'{self.name}: line {line}: the {self.what} is not UTF-8 '
                                 'text') from None
            newlines += data.count(b'\n')
            yield text
        try:
            decoder.decode(b'', final=True)
        except UnicodeDecodeError:
            raise self.error(f'{self.name}: line {newlines + 1}: the {self.what} is not '
                             'UTF-8 text') from None

    def blocks(self) -> Iterator[tuple[int, str]]:
        """
        Yield (number of its first line, text) of whole lines, about 64 KiB at a time.

        Each block ends with a newline but the last one may not; no line is longer than
        ``line_limit_chars``.  Faster than the lines one by one for a table parser that takes
        many lines at once.
        """
        limit = self.line_limit_chars
        too_long = f'a line of a {self.what} has at most {limit} characters'
        lines_read = 0
        tail = ''
        try:
            for text in self.text():
                text = tail + text if tail else text
                cut = text.rfind('\n') + 1
                block, tail = text[:cut], text[cut:]
                if block:
                    if len(block) > limit:
                        lengths = [len(line) for line in block.split('\n')]
                        if max(lengths) > limit:
                            self.line_number = lines_read + next(
                                i for i, n in enumerate(lengths) if n > limit) + 1
                            raise self.fail(too_long)
                    yield lines_read + 1, block
                    lines_read += block.count('\n')
                if len(tail) > limit:
                    self.line_number = lines_read + 1
                    raise self.fail(too_long)
            if tail:
                yield lines_read + 1, tail
        finally:
            self.close()

    def __iter__(self) -> Iterator[str]:
        """Yield the lines, each with its newline (the last may lack it)."""
        for first, block in self.blocks():
            lines = block.split('\n')
            if lines[-1] == '':
                lines.pop()
                ends = '\n'
            else:
                ends = ''
            for offset, line in enumerate(lines):
                self.line_number = first + offset
                yield line + ('\n' if offset < len(lines) - 1 else ends)


def csv_file_rows(path: str | os.PathLike, *, what: str, limit_bytes: int,
                  line_limit_chars: int = MAX_LINE_CHARS,
                  error: type[InputError] = InputError) -> Iterator[tuple[int, list[str]]]:
    """
    Yield (line number, row) of a CSV file (``.gz``: decompressed), read as :class:`TextLines`.

    :raises InputError: (``error``) as :class:`TextLines` and :func:`csv_rows`.
    """
    lines = TextLines(path, what=what, limit_bytes=limit_bytes,
                      line_limit_chars=line_limit_chars, error=error)
    try:
        yield from _numbered_rows(csv.reader(lines), name=lines.name, error=error)
    finally:
        lines.close()


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
