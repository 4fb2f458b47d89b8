"""
Code style as ROS 2 checks it: ament_flake8 itself, from the package root.

As the ament_python template's ``test/test_flake8.py``: ``main_with_errors(argv=[])`` checks the
current folder (the package, ``test/``, ``bench/``, ``launch/``, ``setup.py``) with ament's own
configuration.  The ``test`` extra installs ament_flake8 and the plugins it loads; without them
this test fails (no fallback).
"""

from ament_flake8.main import main_with_errors
import pytest
from wear_testing.paths import REPO_ROOT


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8(monkeypatch):
    monkeypatch.chdir(REPO_ROOT)
    rc, errors = main_with_errors(argv=[])
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + \
        '\n'.join(errors)
