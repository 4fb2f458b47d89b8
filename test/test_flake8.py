"""Code style as ament_flake8 checks it (99 columns), over the package, tests and benchmarks."""

import shutil
import subprocess
import sys

import pytest

from conftest import REPO_ROOT

TARGETS = ['robot_wear_monitor', 'test', 'bench', 'launch', 'setup.py']


@pytest.mark.linter
def test_flake8():
    try:  # on a ROS 2 host, the ament linter itself
        from ament_flake8.main import main_with_errors
    except ImportError:
        main_with_errors = None
    if main_with_errors is not None:  # pragma: no cover - ROS hosts only
        rc, errors = main_with_errors(argv=[str(REPO_ROOT / t) for t in TARGETS])
        assert rc == 0, f'Found {len(errors)} code style errors / warnings:\n' + '\n'.join(errors)
        return
    if shutil.which('flake8') is None and not _module_available('flake8'):
        pytest.skip('flake8 is not installed (pip install ".[test]")')
    targets = [t for t in TARGETS if (REPO_ROOT / t).exists()]
    result = subprocess.run([sys.executable, '-m', 'flake8', *targets], cwd=REPO_ROOT,
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, 'flake8 found problems:\n' + result.stdout + result.stderr


def _module_available(name: str) -> bool:
    import importlib.util
    return importlib.util.find_spec(name) is not None
