"""Shared fixtures: measured data in ../shared (skipped when absent) and the ROS 2 graph.

ROS 2 isolation: this test session uses its own ``ROS_DOMAIN_ID`` (from the process id) and
localhost-only discovery, set before any rclpy context starts; process-level tests get further
domain ids of their own from :func:`ros_domain_ids`.  Node tests need rclpy: they skip where it
is missing, except under CI (``CI`` set), where a missing rclpy fails them: a node test never
skips in CI.
"""

import itertools
import os
from pathlib import Path
import tempfile

import pytest

_DOMAIN_BASE = 1 + (os.getpid() % 20) * 5
os.environ['ROS_DOMAIN_ID'] = str(_DOMAIN_BASE)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)
_NEXT_DOMAIN = itertools.count(_DOMAIN_BASE + 1)
# the interval calibrations of this session (and its subprocesses) are stored apart from the
# user's cache, so a test never reads a calibration that an older version stored
os.environ['ROBOT_WEAR_MONITOR_CACHE'] = tempfile.mkdtemp(prefix='rwm_calibrations_')

# the throw-away PostgreSQL server of the history tests (postgresql_server, postgresql_url,
# history_location)
pytest_plugins = ('postgres_server',)

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


def require_rclpy():
    """Return the rclpy module; skip without it, but fail under CI (node tests never skip)."""
    try:
        import rclpy
    except ImportError as error:
        if os.environ.get('CI'):
            pytest.fail(f'rclpy is required in CI (pip install ".[ros]"): {error}')
        pytest.skip(f'rclpy is not installed ({error}); pip install ".[ros]"')
    return rclpy


@pytest.fixture
def ros_context():
    """Initialise rclpy for one test and shut it down after (skips without rclpy, not in CI)."""
    rclpy = require_rclpy()
    rclpy.init()
    yield rclpy
    rclpy.try_shutdown()


def next_ros_domain_id() -> int:
    """Return a ROS_DOMAIN_ID no other test of this session uses (for process-level tests)."""
    return next(_NEXT_DOMAIN)
