"""
The node tests need rclpy: without it they are not collected, except under CI (``CI`` set).

Under CI a missing rclpy is a collection error, so a node test never skips there; elsewhere
the folder is left out and the session header says why.
"""

import importlib.util
import os

RCLPY_MISSING = importlib.util.find_spec('rclpy') is None
if RCLPY_MISSING and os.environ.get('CI'):
    raise ImportError('rclpy is required in CI (pip install ".[ros]"): the node tests never skip')
#: test files left out without rclpy (none when it is installed)
collect_ignore_glob = ['test_*.py'] if RCLPY_MISSING else []


def pytest_report_header(config):
    """Say that the node tests are left out, and why, when rclpy is missing."""
    if RCLPY_MISSING:
        return 'test/nodes: skipped, rclpy is not installed (pip install ".[ros]")'
    return None
