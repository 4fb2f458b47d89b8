"""
Check every output a command names before it does any work (``main`` calls it first).

A full disk or a read-only folder must not cost an hour of replay and then a traceback: the
files (``--json-out``, ``--plot``, ``--csv``, ``--out-params``, ``--levels-out``, a file
``--out``), the folders
(``--plots``, a folder ``--out``) and an SQLite ``--history`` are checked here with
:func:`robot_wear_monitor.atomic_files.check_writable`; what still fails later is an
:class:`~robot_wear_monitor.atomic_files.OutputError` (exit 2, the path and the reason), and
the safe writer leaves no partial file.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import sys

from robot_wear_monitor.atomic_files import (check_writable, check_writable_file, OutputError,
                                             write_text_atomic)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history.backends import is_postgresql_url

#: Verbs whose ``--out`` is a folder (a bag, a report folder); elsewhere it is a file.
FOLDER_OUT = ('simulate', 'replay', 'demo')
#: Verbs that write the ``--history`` they are given (``fleet`` only reads it).
HISTORY_WRITERS = ('replay', 'live')


def _check_folder(path: str, option: str) -> None:
    target = check_writable(path, what=option, folder=True)
    if target.is_dir() and not os.access(target, os.W_OK | os.X_OK):
        raise OutputError(f'{option} {target}: the folder is not writable')


def check_outputs(args: argparse.Namespace) -> None:
    """Raise :class:`OutputError` for the first named output that cannot be written."""
    command = getattr(args, 'command', '')
    for attribute, option in (('json_out', '--json-out'), ('plot', '--plot'),
                              ('out_params', '--out-params'), ('levels_out', '--levels-out')):
        value = getattr(args, attribute, None)
        if value:
            check_writable(value, what=option)
    csv = getattr(args, 'csv', None)
    if csv and csv != '-':
        check_writable(csv, what='--csv')
    plots = getattr(args, 'plots', None)
    if plots:
        if Path(plots).exists():
            _check_folder(plots, '--plots')
        else:  # made by the verb, with its parents
            parent = next((p for p in Path(plots).absolute().parents if p.exists()), None)
            if parent is None or not parent.is_dir() or not os.access(parent,
                                                                      os.W_OK | os.X_OK):
                raise OutputError(f'--plots {plots}: cannot create it under {parent}')
    out = getattr(args, 'out', None)
    if out and out != '-':
        if command in FOLDER_OUT:
            if command != 'replay' or not Path(out).exists():
                _check_folder(out, '--out')
        else:
            check_writable(out, what='--out')
    history = getattr(args, 'history', None)
    if history and command in HISTORY_WRITERS and str(history) != ':memory:':
        if not is_postgresql_url(history):
            check_writable_file(history, what='--history')


def to_terminal(target: str | None) -> bool:
    """Return True when an output ``target`` ('-' or None: stdout) is a terminal."""
    if target not in (None, '-'):
        return False
    try:
        return bool(sys.stdout.isatty())
    except (AttributeError, ValueError):  # a replaced or closed stdout
        return False


def write_text_output(target: str, text: str) -> bool:
    """
    Write ``text`` to the file ``target`` atomically, or to stdout when ``target`` is '-'.

    Return True when a file was written; an OS failure is an :class:`InputError` naming the path.
    """
    if target == '-':
        sys.stdout.write(text)
        return False
    try:
        write_text_atomic(target, text)
    except OSError as error:
        raise InputError(f'{target}: cannot write: {error.strerror}') from None
    return True
