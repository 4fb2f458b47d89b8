"""Static types: mypy over the package with the configuration of setup.cfg, at 0 errors."""

import subprocess
import sys

import pytest
from wear_testing.paths import REPO_ROOT


@pytest.mark.linter
def test_mypy():
    pytest.importorskip('mypy', reason='mypy is not installed (pip install ".[test]")')
    result = subprocess.run([sys.executable, '-m', 'mypy', '--config-file', 'setup.cfg'],
                            cwd=REPO_ROOT, capture_output=True, text=True, timeout=900,
                            check=False)
    assert result.returncode == 0, 'mypy found problems:\n' + result.stdout + result.stderr
