"""
The README's command chains run as written (with small data): every ```sh block.

Each ``sh`` block runs in one ``bash -e`` in a fresh folder that holds the repository's
``examples/``, blocks in order, so a later block uses what an earlier one made (``wear_bag``,
``levels.csv``), as a reader would.  The commands on the measured data in ``../shared`` (a line
naming ``../shared``) read only those data: they run apart, one test each, in a folder with
``../shared`` beside it, and only they skip when ``../shared`` is absent (the reason names the
block and the command); the chains run either way.  What does not run here, with the reason:

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


def uses_shared(line: str) -> bool:
    """Return whether a command line reads the measured data in ``../shared``."""
    return '../shared' in line


def runnable(block: str) -> str:
    """Return the block's lines that run in the chain (no ``ros2``, no ``../shared`` line)."""
    lines = [line for line in block.splitlines()
             if line.strip() and not line.lstrip().startswith('ros2 ')
             and not uses_shared(line)]
    return '\n'.join(lines) + '\n'


def shared_commands() -> list[tuple[int, str]]:
    """Return (block number, command line) of every README command on ``../shared``."""
    return [(number, line.strip()) for number, block in enumerate(sh_blocks(), start=2)
            for line in block.splitlines()
            if uses_shared(line) and not line.lstrip().startswith('ros2 ')]


def cut(script: str) -> str:
    """Return ``script`` with the sizes of :data:`SMALLER` cut."""
    for before, after in SMALLER:
        script = script.replace(before, after)
    return script


def workspace(tmp_path: Path, *, shared: bool = False) -> tuple[Path, dict[str, str]]:
    """Return a reader's folder (``examples/``; ``../shared`` beside it) and the environment."""
    work = tmp_path / 'main'
    work.mkdir()
    (work / 'examples').symlink_to(ROOT / 'examples')
    if shared:
        (tmp_path / 'shared').symlink_to(SHARED)
    binary = Path(sys.executable).parent
    env = {**os.environ, 'HOME': str(tmp_path), 'MPLBACKEND': 'Agg',
           'PATH': f'{binary}{os.pathsep}{os.environ.get("PATH", "")}'}
    assert shutil.which('robot-wear-monitor', path=env['PATH']), 'pip install . first'
    return work, env


def run_script(script: str, *, work: Path, env: dict[str, str], number: int) -> None:
    """Run ``script`` with ``bash -e`` in ``work``: it must succeed without a traceback."""
    done = subprocess.run(['bash', '-e', '-c', script], cwd=work, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, (f'README sh block {number} failed:\n{script}\n'
                                  f'stdout: {done.stdout[-3000:]}\n'
                                  f'stderr: {done.stderr[-3000:]}')
    assert 'Traceback' not in done.stderr, (number, done.stderr[-3000:])


def test_every_size_cut_matches_the_readme():
    text = ''.join(sh_blocks())
    for before, _ in SMALLER:
        assert before in text, f'the README no longer has {before!r}: update SMALLER'


def test_the_readme_command_chains_run_as_written(tmp_path):
    work, env = workspace(tmp_path)
    for number, block in enumerate(sh_blocks(), start=2):
        script = cut(runnable(block))
        if script.strip():
            run_script(script, work=work, env=env, number=number)


@pytest.mark.parametrize('number, command', shared_commands(),
                         ids=[f'block{n}-{c.split()[1]}' for n, c in shared_commands()])
def test_the_readme_commands_on_the_measured_data_run_as_written(tmp_path, number, command):
    if not SHARED.is_dir():
        pytest.skip(f'{SHARED} is absent: README sh block {number} not run: {command}')
    work, env = workspace(tmp_path, shared=True)
    run_script(cut(command) + '\n', work=work, env=env, number=number)
