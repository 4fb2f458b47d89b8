"""Code style as ament_flake8 checks it (99 columns), over the package, tests and benchmarks."""

import shutil
import subprocess
import sys

import pytest

from conftest import REPO_ROOT

TARGETS = ['robot_wear_monitor', 'test', 'bench', 'launch', 'setup.py']


#: ament_flake8's plugins (flake8 --version names them as below); the `test` extra installs them.
AMENT_PLUGINS = ('flake8-blind-except', 'flake8-builtins', 'flake8-class-newline',
                 'flake8-comprehensions', 'flake8-deprecated', 'flake8-docstrings',
                 'import-order', 'flake8-quotes')


@pytest.mark.flake8
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
    version = subprocess.run([sys.executable, '-m', 'flake8', '--version'], cwd=REPO_ROOT,
                             capture_output=True, text=True, check=False).stdout
    listed = ''.join(version.split()).replace('_', '-')  # --version wraps its lines
    missing = [plugin for plugin in AMENT_PLUGINS if plugin not in listed]
    assert not missing, f'flake8 runs without ament_flake8 plugins {missing}: ' \
                        'pip install ".[test]"'
    targets = [t for t in TARGETS if (REPO_ROOT / t).exists()]
    result = subprocess.run([sys.executable, '-m', 'flake8', *targets], cwd=REPO_ROOT,
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, 'flake8 found problems:\n' + result.stdout + result.stderr


def _module_available(name: str) -> bool:
    import importlib.util
    return importlib.util.find_spec(name) is not None
