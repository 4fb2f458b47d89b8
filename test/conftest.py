"""Shared fixtures: the measured data in ../shared (skipped with a reason when absent)."""

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = REPO_ROOT.parent / 'shared'
EXTERNAL_DIR = SHARED_DIR / 'data' / 'external'
SEED_DIR = SHARED_DIR / 'seed'


def _require(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f'measured data not available: {path} is absent '
                    '(clone the repository with ../shared beside it)')
    return path


@pytest.fixture(scope='session')
def external_data_dir() -> Path:
    """Return ../shared/data/external, or skip when ../shared is absent."""
    return _require(EXTERNAL_DIR)


@pytest.fixture(scope='session')
def kuka_dir(external_data_dir: Path) -> Path:
    """Return the KUKA iiwa data folder, or skip when it is absent."""
    return _require(external_data_dir / 'kuka_iiwa_yezhao_drake')


@pytest.fixture(scope='session')
def repo_root() -> Path:
    """Return the repository root."""
    return REPO_ROOT
