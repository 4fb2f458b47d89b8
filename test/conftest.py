"""
Shared fixtures: measured data in ../shared (skipped when absent) and the ROS 2 graph.

ROS 2 isolation: this test session uses its own ``ROS_DOMAIN_ID`` (from the process id) and
localhost-only discovery, set before any rclpy context starts (:mod:`wear_testing.ros_graph`);
process-level tests get further domain ids of their own.  Node tests need rclpy: they skip
where it is missing, except under CI (``CI`` set), where a missing rclpy fails them: a node
test never skips in CI.  The helpers live in the package ``wear_testing`` (``test/`` is on
pytest's ``pythonpath``).
"""

import os
from pathlib import Path
import tempfile

import pytest
from wear_testing.paths import EXTERNAL_DIR, REPO_ROOT, require_path
from wear_testing.ros_graph import require_rclpy

# the interval calibrations of this session (and its subprocesses) are stored apart from the
# user's cache, so a test never reads a calibration that an older version stored
os.environ['ROBOT_WEAR_MONITOR_CACHE'] = tempfile.mkdtemp(prefix='rwm_calibrations_')

# the throw-away PostgreSQL server of the history tests (postgresql_server, postgresql_url,
# history_location)
pytest_plugins = ('wear_testing.postgres_server',)


@pytest.fixture(scope='session')
def external_data_dir() -> Path:
    """Return ../shared/data/external, or skip when ../shared is absent."""
    return require_path(EXTERNAL_DIR)


@pytest.fixture(scope='session')
def kuka_dir(external_data_dir: Path) -> Path:
    """Return the KUKA iiwa data folder, or skip when it is absent."""
    return require_path(external_data_dir / 'kuka_iiwa_yezhao_drake')


@pytest.fixture(scope='session')
def repo_root() -> Path:
    """Return the repository root."""
    return REPO_ROOT


@pytest.fixture
def ros_context():
    """Initialise rclpy for one test and shut it down after (skips without rclpy, not in CI)."""
    rclpy = require_rclpy()
    rclpy.init()
    yield rclpy
    rclpy.try_shutdown()
