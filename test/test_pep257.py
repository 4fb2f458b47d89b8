"""
Docstrings as ROS 2 checks them: ament_pep257 itself, from the package root.

As the ament_python template's ``test/test_pep257.py``: ``main(argv=['.', 'test'])`` with
ament's own conventions (D213 second-line summaries; reST field lists, not Google sections).
The ``test`` extra installs ament_pep257; without it this test fails (no fallback).
"""

from ament_pep257.main import main
import pytest
from wear_testing.paths import REPO_ROOT


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257(monkeypatch):
    monkeypatch.chdir(REPO_ROOT)
    rc = main(argv=['.', 'test'])
    assert rc == 0, 'Found code style errors / warnings'
