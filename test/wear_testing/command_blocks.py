"""
The command blocks of a markdown page (README.md, docs/*.md), and running them as a reader would.

A command block is a fenced block of ``sh`` (or ``bash``, ``shell``, ``console``).  A block that
cannot run in a test (a live ROS 2 graph that never ends, a server, an install) is marked on the
line right before its fence with an HTML comment, invisible on GitHub::

    <!-- not run: the reason -->

``text`` blocks are synopses (``[--option]``) and sample output, not commands.  A command line
naming ``../shared`` reads the measured data kept beside the repository: it runs apart, in a
folder with ``../shared`` beside it, and only it skips when that folder is absent.
"""

from __future__ import annotations

from dataclasses import dataclass
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
from typing import Optional, Sequence

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / 'shared'
SHELLS = ('sh', 'bash', 'shell', 'console')
_BLOCK = re.compile(r'(?:^<!--\s*not run:\s*(?P<reason>.*?)\s*-->\n)?^```(?P<lang>[\w-]*)[^\n]*\n'
                    r'(?P<body>.*?)^```', re.S | re.M)


@dataclass(frozen=True)
class CommandBlock:
    """
    One command block of a page.

    :ivar page: the page, relative to the repository.
    :ivar number: the block's number among the page's command blocks (1 = first).
    :ivar text: the commands, continuation lines joined.
    :ivar not_run: the reason of its ``not run`` mark (None: the block runs).
    """

    page: str
    number: int
    text: str
    not_run: Optional[str]

    @property
    def name(self) -> str:
        """Return ``page block N``."""
        return f'{self.page} block {self.number}'


def command_blocks(page: Path) -> list[CommandBlock]:
    """Return the command blocks of ``page`` in order."""
    text = page.read_text(encoding='utf-8')
    blocks = []
    for match in _BLOCK.finditer(text):
        if match['lang'] not in SHELLS:
            continue
        blocks.append(CommandBlock(page=str(page.relative_to(ROOT)), number=len(blocks) + 1,
                                   text=match['body'].replace('\\\n', ' '),
                                   not_run=match['reason']))
    return blocks


def uses_shared(line: str) -> bool:
    """Return whether a command line reads the measured data in ``../shared``."""
    return '../shared' in line


def command_lines(block: CommandBlock) -> list[str]:
    """Return the block's command lines (no blank lines, no comment lines)."""
    return [line for line in block.text.splitlines()
            if line.strip() and not line.lstrip().startswith('#')]


def chain_script(block: CommandBlock) -> str:
    """Return the lines of a runnable block that run in the page's chain (no ``../shared``)."""
    return '\n'.join(line for line in command_lines(block) if not uses_shared(line)) + '\n'


def shared_commands(blocks: Sequence[CommandBlock]) -> list[tuple[CommandBlock, str]]:
    """Return (block, line) of every runnable command on ``../shared``."""
    return [(block, line.strip()) for block in blocks if block.not_run is None
            for line in command_lines(block) if uses_shared(line)]


def unmarked_ros2_lines(blocks: Sequence[CommandBlock]) -> list[str]:
    """Return the ``ros2`` lines of blocks not marked ``not run`` (ros2cli is not on PyPI)."""
    return [f'{block.name}: {line.strip()}' for block in blocks if block.not_run is None
            for line in command_lines(block) if line.lstrip().startswith('ros2 ')]


def cut(script: str, smaller: Sequence[tuple[str, str]]) -> str:
    """Return ``script`` with each (text, what runs instead) of ``smaller`` replaced."""
    for before, after in smaller:
        script = script.replace(before, after)
    return script


def workspace(folder: Path, *, shared: bool = False,
              examples: bool = True) -> tuple[Path, dict[str, str]]:
    """
    Return a reader's folder and the environment.

    The folder holds the repository's ``examples/`` (``examples=False``: nothing, a new user's
    empty folder), with ``../shared`` beside it when ``shared``.
    """
    work = folder / 'main'
    work.mkdir()
    if examples:
        (work / 'examples').symlink_to(ROOT / 'examples')
    if shared:
        (folder / 'shared').symlink_to(SHARED)
    binary = Path(sys.executable).parent
    env = {**os.environ, 'HOME': str(folder), 'MPLBACKEND': 'Agg',
           'PATH': f'{binary}{os.pathsep}{os.environ.get("PATH", "")}'}
    assert shutil.which('robot-wear-monitor', path=env['PATH']), 'pip install . first'
    return work, env


def run_script(script: str, *, work: Path, env: dict[str, str], name: str) -> None:
    """Run ``script`` with ``bash -e`` in ``work``: it must succeed without a traceback."""
    done = subprocess.run(['bash', '-e', '-c', script], cwd=work, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, (f'{name} failed:\n{script}\n'
                                  f'stdout: {done.stdout[-3000:]}\n'
                                  f'stderr: {done.stderr[-3000:]}')
    assert 'Traceback' not in done.stderr, (name, done.stderr[-3000:])
