"""Where the repository and the measured data kept beside it (``../shared``) are."""

from pathlib import Path
import sys

import pytest

#: The repository root (the folder holding ``setup.py``).
REPO_ROOT = Path(__file__).resolve().parents[2]
#: ``../shared``: the paper, its parameters and measured data, kept beside the repository.
SHARED_DIR = REPO_ROOT.parent / 'shared'
#: Measured friction data of public robots, each folder with its PROVENANCE.md.
EXTERNAL_DIR = SHARED_DIR / 'data' / 'external'
#: The paper and PARAMETERS.md.
SEED_DIR = SHARED_DIR / 'seed'
#: Where the interpreter's console scripts are installed.
BIN = Path(sys.executable).parent


def require_path(path: Path) -> Path:
    """Return ``path``, or skip the test saying that the measured data are absent."""
    if not path.exists():
        pytest.skip(f'measured data not available: {path} is absent '
                    '(clone the repository with ../shared beside it)')
    return path


def console_script(name: str) -> str:
    """Return the path of an installed console script (or the name, found on PATH)."""
    path = BIN / name
    return str(path) if path.exists() else name
