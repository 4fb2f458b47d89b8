"""
ROS 2 isolation of a test session: its own domain ids, localhost discovery, rclpy or a skip.

Importing this module (conftest does, first) sets ``ROS_DOMAIN_ID`` from the process id and
localhost-only discovery before any rclpy context starts; process-level tests take further
domain ids of their own from :func:`next_ros_domain_id`.
"""

import itertools
import os

import pytest

_DOMAIN_BASE = 1 + (os.getpid() % 20) * 5
os.environ['ROS_DOMAIN_ID'] = str(_DOMAIN_BASE)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)
_NEXT_DOMAIN = itertools.count(_DOMAIN_BASE + 1)


def require_rclpy():
    """Return the rclpy module; skip without it, but fail under CI (node tests never skip)."""
    try:
        import rclpy
    except ImportError as error:
        if os.environ.get('CI'):
            pytest.fail(f'rclpy is required in CI (pip install ".[ros]"): {error}')
        pytest.skip(f'rclpy is not installed ({error}); pip install ".[ros]"')
    return rclpy


def next_ros_domain_id() -> int:
    """Return a ROS_DOMAIN_ID no other test of this session uses (for process-level tests)."""
    return next(_NEXT_DOMAIN)
