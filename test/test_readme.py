"""The README's command chains run as written (with small data): every ```sh block.

Each ``sh`` block runs in one ``bash -e`` in a fresh folder that holds the repository's
``examples/`` (and ``../shared`` beside it when it exists), blocks in order, so a later block
uses what an earlier one made (``wear_bag``, ``levels.csv``), as a reader would.  What does not
run here, with the reason:

* the first block (``pip install ... && demo``, ``pytest``): it is the CI itself, and the demo
  has its own tests;
* lines starting with ``ros2``: ros2cli is not on PyPI (the nodes run as processes in
  ``test/nodes``);
* ``text`` blocks: synopses with ``[--option]`` and sample output, not commands.

Sizes are cut where a block would take minutes (:data:`SMALLER`); each cut must match, so the
README cannot drift away from what is tested.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import shutil
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / 'shared'
#: (README text, what runs instead): the same command on less data.
SMALLER = (
    ('robot-wear-monitor simulate --out wear_bag ',
     'robot-wear-monitor simulate --out wear_bag --experiments 8 '),
    ('--experiments 30 ', '--experiments 6 '),
    ('--runs 1000 ', '--runs 200 '),
)


def sh_blocks() -> list[str]:
    """Return the README's ``sh`` blocks after the first, continuation lines joined."""
    text = (ROOT / 'README.md').read_text(encoding='utf-8')
    blocks = re.findall(r'```sh\n(.*?)```', text, re.S)
    return [block.replace('\\\n', ' ') for block in blocks[1:]]


def runnable(block: str) -> str:
    """Return the block's lines that run here (no ``ros2`` line), sizes cut."""
    lines = [line for line in block.splitlines()
             if line.strip() and not line.lstrip().startswith('ros2 ')]
    return '\n'.join(lines) + '\n'


def test_every_size_cut_matches_the_readme():
    text = ''.join(sh_blocks())
    for before, _ in SMALLER:
        assert before in text, f'the README no longer has {before!r}: update SMALLER'


def test_the_readme_command_chains_run_as_written(tmp_path):
    if not SHARED.is_dir():
        pytest.skip(f'{SHARED} is absent: the README audits the measured data there')
    work = tmp_path / 'main'
    work.mkdir()
    (work / 'examples').symlink_to(ROOT / 'examples')
    (tmp_path / 'shared').symlink_to(SHARED)
    binary = Path(sys.executable).parent
    env = {**os.environ, 'HOME': str(tmp_path), 'MPLBACKEND': 'Agg',
           'PATH': f'{binary}{os.pathsep}{os.environ.get("PATH", "")}'}
    assert shutil.which('robot-wear-monitor', path=env['PATH']), 'pip install . first'
    for number, block in enumerate(sh_blocks(), start=2):
        script = runnable(block)
        for before, after in SMALLER:
            script = script.replace(before, after)
        if not script.strip():
            continue
        done = subprocess.run(['bash', '-e', '-c', script], cwd=work, env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, (f'README sh block {number} failed:\n{script}\n'
                                      f'stdout: {done.stdout[-3000:]}\n'
                                      f'stderr: {done.stderr[-3000:]}')
        assert 'Traceback' not in done.stderr, (number, done.stderr[-3000:])
