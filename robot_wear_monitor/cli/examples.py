"""
``robot-wear-monitor examples``: copy the packaged example files into a folder of one's own.

The README's tour runs ``audit`` and ``identify`` on ``examples/``; a pip-installed package
keeps them under ``<prefix>/share/robot_wear_monitor/examples`` (:mod:`robot_wear_monitor.
share_files`), so a new user's empty folder gets them with one command.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import shutil

from robot_wear_monitor.atomic_files import check_writable, OutputError, staging_folder
from robot_wear_monitor.cli.options import PROG
from robot_wear_monitor.share_files import packaged_file
from robot_wear_monitor.text import escaped

HELP = ('copy the example level tables and raw runs (audit, identify: docs/identify.md) into '
        'a folder')
#: The folder made when none is named.
DEFAULT_DEST = 'examples'
#: A file every copy of the examples holds (how the packaged folder is recognised).
MARKER = 'baseline.csv'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``examples``."""
    parser.add_argument('dest', nargs='?', default=DEFAULT_DEST, metavar='DEST',
                        help=f'the folder to make (default ./{DEFAULT_DEST}); it must not exist '
                             'or be empty')


def packaged_examples() -> Path:
    """Return the installed ``examples/`` folder (where :func:`packaged_file` finds it)."""
    return packaged_file('examples', MARKER).parent


def copy_examples(*, dest: str | os.PathLike) -> list[Path]:
    """
    Copy the packaged examples to the new folder ``dest``; return the files copied (sorted).

    Staged beside ``dest`` and renamed into place, so an interrupted copy leaves nothing.

    :raises OutputError: ``dest`` exists and is not an empty folder, or cannot be written.
    """
    source = packaged_examples()
    target = check_writable(dest, what='DEST', folder=True)
    if target.is_dir() and any(target.iterdir()):
        raise OutputError(f'{target}: the folder exists and is not empty (name a new one)')
    with staging_folder(target) as staging:
        copy = staging / 'examples'
        shutil.copytree(source, copy, ignore=shutil.ignore_patterns('__pycache__', '.*'))
        os.replace(copy, target)
    return sorted(path for path in target.rglob('*') if path.is_file())


def main(args: argparse.Namespace) -> int:
    """Run ``examples``: copy the files, say how many and where."""
    files = copy_examples(dest=args.dest)
    top = sorted(p.name for p in Path(args.dest).iterdir())
    print(escaped(f'{PROG} examples: {len(files)} files into {args.dest}/ ({", ".join(top)}) '
                  f'from {packaged_examples()}'))
    return 0
