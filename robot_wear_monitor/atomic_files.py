"""Atomic file output: write to a temporary sibling, then rename, so nothing is half-written."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` via a temporary sibling file and ``os.replace``."""
    target = Path(path)
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
