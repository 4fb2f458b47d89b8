"""
The ``robot-wear-monitor`` command line: the only place that parses argv.

One module per verb, in ros2cli's habit: each has ``HELP``, ``add_arguments(parser)`` and
``main(args) -> int``; the options several verbs share are built in
:mod:`robot_wear_monitor.cli.options`, so each has one meaning.  The work itself is done by
keyword-only functions of the core modules.  A user mistake raises
:class:`~robot_wear_monitor.errors.InputError`, which :func:`main` prints as one line on stderr
with exit code 2 (never a traceback).
"""

from __future__ import annotations

import argparse
import atexit
import gc
import importlib
import os
import sys
from types import ModuleType
from typing import NoReturn, Sequence

from robot_wear_monitor import __version__
from robot_wear_monitor.cli.options import (loading_modules, parse_float_list, parse_range,
                                            PROG, resolve_json, secrets_kept_out)
from robot_wear_monitor.cli.outputs import check_outputs
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.text import escaped, shorten

__all__ = ['build_parser', 'main', 'parse_float_list', 'parse_range', 'PROG', 'verb_module',
           'VERBS']

#: The verbs in the order of ``--help``; each is the module ``robot_wear_monitor.cli.<verb>``
#: (a hyphen in the verb an underscore in the module: ``new-life``, ``new_life``).
VERBS = ('design', 'plan', 'estimate', 'study', 'simulate', 'segment', 'replay', 'demo',
         'examples', 'audit', 'history', 'fleet', 'acknowledge', 'new-life', 'live', 'play',
         'call', 'identify', 'notify', 'dashboard')

#: Verbs that pass a ``--ros-args ...`` tail to rclpy.
_ROS_VERBS = ('live', 'play', 'call')


class OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose syntax errors are one line on stderr (exit 2), like the rest."""

    def error(self, message: str) -> NoReturn:  # noqa: D102 - argparse's hook
        self.exit(2, f'{self.prog}: error: {message} (see {self.prog} --help)\n')


def verb_module(name: str) -> ModuleType:
    """Return the module of the verb ``name`` (one of :data:`VERBS`), loaded when first asked."""
    return importlib.import_module(f'{__name__}.{name.replace("-", "_")}')


def build_parser(verbs: Sequence[str] = VERBS) -> argparse.ArgumentParser:
    """
    Return the argparse parser of ``robot-wear-monitor`` with the subcommands ``verbs``.

    All of them by default; :func:`main` builds the parser of the one verb a command names
    (its parsing, messages and ``--help`` are those of the whole parser) and loads no other
    verb's module.
    """
    parser = OneLineParser(
        prog=PROG, description='Wear monitoring of a robot joint from constant-speed friction '
                               'data (Bittencourt & Axelsson).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name in verbs:
        verb = verb_module(name)
        sub = subparsers.add_parser(name, help=verb.HELP, description=verb.HELP)
        verb.add_arguments(sub)
        sub.set_defaults(handler=verb.main)
    return parser


def freeze_objects_at_exit() -> None:
    """
    Let the interpreter's exit skip its last collection of the objects alive (idempotent).

    As it exits, Python runs the cyclic collector over every object once more before it
    frees the modules; a replay leaves some 60,000 (numpy, rosbags, its own), which
    took 40 ms of a 0.8 s run.  :func:`gc.freeze` at exit (an :mod:`atexit` hook) moves them
    out of the collector's sight: the modules still free what they hold (what sits in a
    reference cycle is left to the operating system, like any object alive at exit); the
    outputs are written and closed before.
    """
    atexit.unregister(gc.freeze)  # once, however many commands a process runs
    atexit.register(gc.freeze)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 2 bad input, 130 Ctrl-C)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # from the first byte: argparse's messages echo the words, a password among them too
    with secrets_kept_out(argv):
        return _parse_and_run(argv)


def _parse_and_run(argv: list[str]) -> int:
    """Parse ``argv`` and run its command (:func:`main` within the output guard of argv)."""
    # a command names its verb first; anything else (--help, --version, a mistake) gets all
    parser = build_parser(argv[:1] if argv[:1] and argv[0] in VERBS else VERBS)
    ros_args: list[str] = []
    if '--ros-args' in argv:  # ROS arguments go to rclpy untouched (live, play, call)
        cut = argv.index('--ros-args')
        argv, ros_args = argv[:cut], argv[cut:]
    try:
        args = parser.parse_args(argv)  # a syntax error: one line on stderr, exit 2
    except SystemExit as done:  # also --help and --version (exit 0)
        return done.code if isinstance(done.code, int) else 2
    if ros_args and args.command not in _ROS_VERBS:
        parser.error(f'--ros-args is only for {", ".join(_ROS_VERBS[:-1])} and '
                     f'{_ROS_VERBS[-1]}, not {args.command}')
    args.ros_args = ros_args
    # deferred import: start-up time (blas_threads: --help and the parse load none of it)
    from robot_wear_monitor.blas_threads import use_single_blas_thread
    freeze_objects_at_exit()
    try:
        with loading_modules():  # numpy (and scipy when OPENBLAS_NUM_THREADS is set to > 1)
            use_single_blas_thread()
        with secrets_kept_out(args):  # no history password reaches the terminal
            return _run_command(args)
    except KeyboardInterrupt:
        print(f'{PROG} {args.command}: interrupted', file=sys.stderr)
        return 130
    finally:
        gc.unfreeze()  # what loading_modules kept out of sight (the exit freezes all again)


def _run_command(args: argparse.Namespace) -> int:
    """Run a parsed command; return the exit code (errors as one line on stderr)."""
    try:
        resolve_json(args, command=args.command)
        check_outputs(args)
        return int(args.handler(args) or 0)
    except InputError as error:
        # one line whatever a name in it holds: control characters escaped, newlines included
        message = escaped(str(error).strip()) or type(error).__name__
        print(f'{PROG} {args.command}: error: {message}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'{PROG} {args.command}: interrupted', file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`): no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as error:  # a write that failed after the checks (disk full, ...)
        where = f'{shorten(error.filename, 200)}: ' if error.filename else ''
        print(f'{PROG} {args.command}: error: {where}{error.strerror or error}',
              file=sys.stderr)
        return 2
