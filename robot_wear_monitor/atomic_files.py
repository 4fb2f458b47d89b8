"""
Safe file output: staged at an unpredictable name, renamed into place, never through a link.

Every output of the package (texts, JSON, CSV, YAML, figures, bag folders) goes through here:

* the staging file or folder is made by :func:`tempfile.mkstemp` / :func:`tempfile.mkdtemp`
  in the target's folder (``O_CREAT | O_EXCL``, a random name ``.<name>.<random>.tmp`` or
  ``.partial``, mode 0600), so a link planted at a guessed name is never followed;
* the writer holds an advisory lock (:func:`fcntl.flock`) on the staging file (a folder: on its
  ``.owner`` file) while it writes, which is how a later writer tells a dead writer's leftovers
  (removed, :func:`remove_stale_partials`) from a running one's (kept);
* the finished file gets the mode the target had (a new one: 0666 less the umask), is flushed
  to disk and renamed over the target with :func:`os.replace`;
* a target that is a symbolic link is refused (:class:`OutputError`), as is a target whose folder
  is missing or not writable (:func:`check_writable`, which the command line calls for every
  output before it reads the first sample);
* an operating-system failure (a full disk, a read-only file system) is an :class:`OutputError`
  naming the path and the reason; the staging copy is removed and the target is unchanged.
"""

from __future__ import annotations

from contextlib import contextmanager
import errno
import fcntl
import json
import os
from pathlib import Path
import re
import shutil
import stat
import tempfile
from typing import Any, Iterator

from robot_wear_monitor.errors import InputError

#: Suffixes of staging files and folders (after ``.<name>.<random>``).
FILE_SUFFIX = '.tmp'
FOLDER_SUFFIX = '.partial'
#: The file in a staging folder its writer holds locked.
OWNER_FILE = '.owner'


class OutputError(InputError):
    """An output cannot be written: the message names the path and the reason (exit 2)."""


def _reason(error: OSError) -> str:
    return error.strerror or type(error).__name__


def _refuse_link(target: Path) -> None:
    if target.is_symlink():
        raise OutputError(f'{target}: is a symbolic link; refusing to write through or replace '
                          'it (name the real file)')


def check_writable(path: str | os.PathLike, *, what: str = 'output', folder: bool = False
                   ) -> Path:
    """
    Check before any work that ``path`` can be written; return it as a Path.

    Its folder must exist and be writable, it must not be a symbolic link, and an existing
    target must be a file (``folder``: a folder) that may be replaced.

    :raises OutputError: naming ``what`` (the user's option, e.g. ``--json-out``), the path and
        why.

    """
    target = Path(path)
    _refuse_link(target)
    parent = target.parent if str(target.parent) else Path('.')
    if not parent.is_dir():
        raise OutputError(f'{what} {target}: the folder {parent} does not exist')
    if not os.access(parent, os.W_OK | os.X_OK) or not _can_create_in(parent):
        raise OutputError(f'{what} {target}: the folder {parent} is not writable')
    if target.exists():
        if folder != target.is_dir():
            raise OutputError(f'{what} {target}: is a folder, not a file' if target.is_dir()
                              else f'{what} {target}: is a file, not a folder')
    return target


def check_writable_file(path: str | os.PathLike, *, what: str) -> Path:
    """Check that an existing file can be opened for writing in place (a database)."""
    target = check_writable(path, what=what)
    if target.exists():
        try:
            with open(target, 'r+b'):
                pass
        except OSError as error:
            raise OutputError(f'{what} {target}: the file is not writable '
                              f'({_reason(error)})') from None
    return target


def _can_create_in(folder: Path) -> bool:
    """
    Return True when a file can be made in ``folder``.

    A real probe: root, read-only mounts and immutable folders fool :func:`os.access`.
    """
    try:
        handle, name = tempfile.mkstemp(prefix='.write-probe.', suffix=FILE_SUFFIX, dir=folder)
    except OSError:
        return False
    os.close(handle)
    os.unlink(name)
    return True


def _new_file_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextmanager
def staged_file(path: str | os.PathLike) -> Iterator[Path]:
    """
    Yield a locked staging path beside ``path``; on success it replaces ``path``.

    For writers that take a path (matplotlib's ``savefig``): write to the yielded path inside
    the block.  On an error the staging file is removed and ``path`` is unchanged.
    """
    target = Path(path)
    _refuse_link(target)
    remove_stale_partials(target)
    parent = target.parent if str(target.parent) else Path('.')
    try:
        handle, name = tempfile.mkstemp(prefix=f'.{target.name}.', suffix=FILE_SUFFIX,
                                        dir=parent)
    except OSError as error:
        raise OutputError(f'{target}: cannot write ({_reason(error)})') from None
    staging = Path(name)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield staging
        mode = stat.S_IMODE(target.stat().st_mode) if target.exists() else _new_file_mode()
        os.chmod(staging, mode)
        with open(staging, 'rb') as written:
            os.fsync(written.fileno())
        _refuse_link(target)
        os.replace(staging, target)
    except OSError as error:
        raise OutputError(f'{target}: cannot write ({_reason(error)})') from None
    finally:
        os.close(handle)
        if staging.exists() and not staging.is_symlink():
            staging.unlink()


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a staging file and :func:`os.replace`."""
    target = Path(path)
    with staged_file(target) as staging:
        with open(staging, 'wb') as stream:
            stream.write(data)
    return target


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a staging file and :func:`os.replace`."""
    return write_bytes_atomic(path, text.encode('utf-8'))


def write_json_atomic(path: str | os.PathLike, payload: Any) -> Path:
    """Write ``payload`` as valid JSON (no NaN or inf: ValueError) to ``path`` atomically."""
    return write_text_atomic(path, json.dumps(payload, indent=1, allow_nan=False) + '\n')


def save_figure(figure: Any, path: str | os.PathLike, *, dpi: int) -> Path:
    """Save a matplotlib ``figure`` at ``path`` through a staging file (format from the suffix)."""
    target = Path(path)
    with staged_file(target) as staging:
        figure.savefig(staging, dpi=dpi, format=target.suffix.lstrip('.').lower() or 'png')
    return target


@contextmanager
def staging_folder(path: str | os.PathLike) -> Iterator[Path]:
    """
    Yield a new, locked staging folder beside ``path`` (removed when the block ends).

    The caller moves what it made into place (a bag folder) before the block ends.
    """
    target = Path(path)
    _refuse_link(target)
    parent = target.parent if str(target.parent) else Path('.')
    try:
        folder = Path(tempfile.mkdtemp(prefix=f'.{target.name}.', suffix=FOLDER_SUFFIX,
                                       dir=parent))
        owner = os.open(folder / OWNER_FILE, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except OSError as error:
        raise OutputError(f'{target}: cannot write ({_reason(error)})') from None
    try:
        fcntl.flock(owner, fcntl.LOCK_EX)
        os.write(owner, f'{os.getpid()}\n'.encode())
        yield folder
    finally:
        os.close(owner)
        shutil.rmtree(folder, ignore_errors=True)


#: Suffix of the lock file of an output (``.<name>.lock`` beside it, removed when released).
LOCK_SUFFIX = '.lock'


@contextmanager
def output_lock(path: str | os.PathLike, *, what: str = 'output') -> Iterator[None]:
    """
    Be the only writer of the output ``path`` while the block runs, or raise OutputError.

    An advisory lock (:func:`fcntl.flock`) on ``.<name>.lock`` beside the output, opened
    without following a link; a second writer of the same output gets "in use by process N"
    (exit 2) instead of both reporting success.  The lock file is removed on release; a writer
    that finds its locked file replaced meanwhile locks the new one.
    """
    target = Path(path)
    parent = target.parent if str(target.parent) else Path('.')
    lock_path = parent / f'.{target.name}{LOCK_SUFFIX}'
    while True:
        try:
            handle = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
        except OSError as error:
            raise OutputError(f'{what} {target}: cannot lock it ({_reason(error)})') from None
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(handle, 32).decode(errors='replace').strip() or 'another process'
            os.close(handle)
            raise OutputError(f'{what} {target}: in use by process {holder} (another writer '
                              'of the same output); try again when it has finished') from None
        try:
            same = os.fstat(handle).st_ino == os.stat(lock_path, follow_symlinks=False).st_ino
        except OSError:
            same = False
        if same:
            break
        os.close(handle)  # the file was removed and made anew meanwhile: lock the new one
    try:
        os.ftruncate(handle, 0)
        os.write(handle, f'{os.getpid()}\n'.encode())
        yield
    finally:
        try:
            os.unlink(lock_path)
        except OSError:
            pass
        os.close(handle)


def _process_is_gone(pid: int) -> bool:
    """Return True when no process ``pid`` exists (a permission error means it exists)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OSError):
        return False
    return False


def _writer_is_gone(entry: Path) -> bool:
    """Return True when nobody holds the lock of a staging file or folder (its writer died)."""
    lock_path = entry / OWNER_FILE if entry.is_dir() else entry
    try:
        handle = os.open(lock_path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError as error:
        # a folder without its owner file is a leftover of the moment between mkdtemp and
        # the lock; a vanished entry is gone already
        return error.errno == errno.ENOENT and entry.is_dir()
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(handle)
    return True


def remove_stale_partials(path: str | os.PathLike) -> list[Path]:
    """
    Remove what killed writers of ``path`` left behind; return the removed paths.

    Staging entries ``.<name>.<random>.tmp`` / ``.partial`` are removed when no writer holds
    their lock; those of earlier releases (``.<name>.tmp-<pid>``, ``.<name>.partial-<pid>``)
    when their process is gone.  A symbolic link at such a name is removed as a link (never
    followed); a running writer's entry is never touched.
    """
    target = Path(path)
    name = re.escape(target.name)
    current = re.compile(rf'^\.{name}\.[^/]+({re.escape(FILE_SUFFIX)}|'
                         rf'{re.escape(FOLDER_SUFFIX)})$')
    legacy = re.compile(rf'^\.{name}\.(partial|tmp)-(\d+)$')
    removed: list[Path] = []
    parent = target.parent if str(target.parent) else Path('.')
    try:
        entries = list(parent.iterdir())
    except OSError:
        return removed
    for entry in entries:
        old = legacy.match(entry.name)
        if old:
            if int(old.group(2)) == os.getpid() or not _process_is_gone(int(old.group(2))):
                continue
        elif not current.match(entry.name):
            continue
        elif not entry.is_symlink() and not _writer_is_gone(entry):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    return removed
