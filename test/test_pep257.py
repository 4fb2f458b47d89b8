"""Docstrings of the public API, as ament_pep257 checks them."""

import importlib.util
import subprocess
import sys

import pytest

from conftest import REPO_ROOT


@pytest.mark.linter
def test_pep257():
    try:  # on a ROS 2 host, the ament linter itself
        from ament_pep257.main import main
    except ImportError:
        main = None
    if main is not None:  # pragma: no cover - ROS hosts only
        assert main(argv=[str(REPO_ROOT / 'robot_wear_monitor'), str(REPO_ROOT / 'test')]) == 0
        return
    if importlib.util.find_spec('pydocstyle') is None:
        pytest.skip('pydocstyle is not installed (pip install ".[test]")')
    result = subprocess.run(
        [sys.executable, '-m', 'pydocstyle', '--convention=pep257', 'robot_wear_monitor'],
        cwd=REPO_ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, 'pydocstyle found problems:\n' + result.stdout + result.stderr
