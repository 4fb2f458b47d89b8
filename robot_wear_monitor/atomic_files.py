"""Atomic file output: write to a temporary sibling, then rename, so nothing is half-written."""

from __future__ import annotations

import json
import os
from pathlib import Path
import re
import shutil
from typing import Any


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` via a temporary sibling file and ``os.replace``."""
    target = Path(path)
    remove_stale_partials(target)
    temporary = target.with_name(f'.{target.name}.tmp-{os.getpid()}')
    try:
        temporary.write_text(text, encoding='utf-8')
        os.replace(temporary, target)
    finally:
        if temporary.exists():
            temporary.unlink()
    return target


def write_json_atomic(path: str | os.PathLike, payload: Any) -> Path:
    """Write ``payload`` as valid JSON (no NaN or inf: ValueError) to ``path`` atomically."""
    return write_text_atomic(path, json.dumps(payload, indent=1, allow_nan=False) + '\n')


def _process_is_gone(pid: int) -> bool:
    """Return True when no process ``pid`` exists (a permission error means it exists)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OSError):
        return False
    return False


def remove_stale_partials(path: str | os.PathLike) -> list[Path]:
    """Remove what killed writers of ``path`` left behind; return the removed paths.

    The atomic writers stage ``.<name>.partial-<pid>`` (bag folders) and ``.<name>.tmp-<pid>``
    (files) beside the target.  A writer killed with SIGKILL cannot remove its staging copy;
    the next writer of the same target removes those whose process is gone (never one of a
    running process, nor its own).
    """
    target = Path(path)
    pattern = re.compile(rf'^\.{re.escape(target.name)}\.(partial|tmp)-(\d+)$')
    removed: list[Path] = []
    try:
        entries = list(target.parent.iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = pattern.match(entry.name)
        if not match or int(match.group(2)) == os.getpid():
            continue
        if not _process_is_gone(int(match.group(2))):
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            try:
                entry.unlink()
            except OSError:
                continue
        removed.append(entry)
    return removed
