"""
Option builders and helpers shared by the verbs of ``robot-wear-monitor``.

Each option that several verbs take is built here, so it has one spelling and one meaning:

* ``--params FILE``: a friction-model parameter-set YAML (default: the packaged IRB 6620 joint 2
  set);
* ``--config YAML``: a ROS 2 node parameter file (default: the packaged ``wear_monitor.yaml``);
* ``--joint``: the joint to work on (replay and segment also take several, or ``all``);
* ``--gear-ratio R``: motor speed = R x joint speed [-]; when not given, the value of the node
  config (``--config``) for a bag (replay, segment, audit, identify: the same for all four) or
  else the raw-run settings' 1 (raw runs);
* ``--torque-scale S``: normalised torque = effort / S; defaults as ``--gear-ratio``;
* ``--json``: print one JSON object on stdout instead of the text; ``--json-out PATH``: also
  write that object to PATH (atomically).  ``--json PATH`` (replay, audit, identify) is the
  deprecated spelling of ``--json-out PATH``: it still writes the file, with a warning on stderr;
* ``--levels-out PATH`` (audit, identify): the friction levels segmented from a bag or raw runs
  and fitted, as a CSV in ``segment``'s columns; it and the other options of the verbs that
  read levels are in :mod:`robot_wear_monitor.cli.level_options`.

The argparse ``type`` functions (:func:`parse_float_list`, :func:`parse_range`,
:func:`joint_names`) and the JSON output helpers live here too.

**A new option's default** is not written here: a setting is declared once, on its
component's configuration dataclass, with :func:`robot_wear_monitor.setting_fields.setting`
(default, unit, description, check; e.g. :class:`~robot_wear_monitor.experiment.
segmentation_settings.SegmenterConfig`, with the raw-run values in ``RAW_RUN_SETTINGS``).  The
option is then made from it with :func:`add_setting_option` (help with unit and default, type
and range from the check), e.g. ``add_setting_option(parser, '--speed-tolerance',
SegmenterConfig, 'speed_tolerance_rad_s', default_text='raw runs 0.01; bag: the node config')``
with ``default=None`` when the value depends on the input kind; a node parameter of the same
setting is ``ParameterSpec.of(Owner, name)`` (:mod:`robot_wear_monitor.monitoring.node_config`).
"""

from __future__ import annotations

import argparse
from contextlib import contextmanager
import gc
import json
import math
import re
import sys
from typing import Any, Callable, Iterator, Sequence, TYPE_CHECKING

from robot_wear_monitor.atomic_files import write_json_atomic
from robot_wear_monitor.display_time import DisplayTimeConfig, time_zone
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import (NODE_SCALES, RAW_RUN_SETTINGS,
                                                                 SegmenterConfig)
from robot_wear_monitor.history.passwords import location_secrets, redact_location
from robot_wear_monitor.input_files import check_robot_name
from robot_wear_monitor.setting_fields import problem_of, setting_of
from robot_wear_monitor.text import LINE_LIMIT, shorten

if TYPE_CHECKING:  # loads numpy: imported where used, so that the command line starts light
    from robot_wear_monitor.model.params import ParameterSet

PROG = 'robot-wear-monitor'


# --------------------------------------------------------------------------- the collector

@contextmanager
def loading_modules() -> Iterator[None]:
    """
    Load modules with the cyclic collector paused, then keep what they made out of its sight.

    Numpy, scipy, rosbags and the monitor's own modules make some 150,000 objects that live to
    the end of a command and hardly a reference cycle; the collector, run every 700 new
    objects, would scan them again and again (30 ms of a 0.8 s replay).  The block runs with
    the collector paused and ends with :func:`gc.freeze`; :func:`robot_wear_monitor.cli.main`
    unfreezes everything as the command returns, so that what became garbage is collected
    again.  Objects are freed by reference counting as before.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


# --------------------------------------------------------------------------- argparse types

#: The most values a comma list may hold, and the largest magnitude of each.
MAX_LIST_VALUES = 1000
MAX_MAGNITUDE = 1e9


def parse_float_list(text: str) -> list[float]:
    """
    Parse '2.1,8.7,15.3' into floats (argparse type); reject empty items, NaN and inf.

    At most :data:`MAX_LIST_VALUES` values, each at most :data:`MAX_MAGNITUDE` in magnitude.
    """
    items = [item.strip() for item in text.split(',', MAX_LIST_VALUES)]
    if len(items) > MAX_LIST_VALUES:
        raise argparse.ArgumentTypeError(f'more than {MAX_LIST_VALUES} values')
    values = []
    for item in items:
        try:
            value = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f'not a number: {shorten(repr(item))}') from None
        if not math.isfinite(value) or abs(value) > MAX_MAGNITUDE:
            raise argparse.ArgumentTypeError(f'not a finite number of at most '
                                             f'{MAX_MAGNITUDE:g}: {shorten(item)}')
        values.append(value)
    return values


def bounded(low: float, high: float, *, unit: str = '', low_open: bool = False,
            integer: bool = False) -> Callable[[str], float]:
    """
    Return an argparse type: a finite number in [low, high] (``low_open``: (low, high]).

    The error names the range and the unit; argparse adds the option's name and exits 2.
    """
    unit_text = f' {unit}' if unit else ''

    def parse(text: str) -> float:
        try:
            value: float = int(text) if integer else float(text)
        except ValueError:
            kind = 'an integer' if integer else 'a number'
            raise argparse.ArgumentTypeError(f'not {kind}: {shorten(repr(text))}') from None
        ok = math.isfinite(value) and (value > low if low_open else value >= low) \
            and value <= high
        if not ok:
            raise argparse.ArgumentTypeError(
                f'must be {">" if low_open else ">="} {low:g} and <= {high:g}{unit_text}, got '
                f'{shorten(text)}{unit_text}')
        return value
    return parse


def parse_range(text: str) -> list[float]:
    """Parse 'start:stop:step' (inclusive stop) or a comma list into floats (argparse type)."""
    if ':' not in text:
        return parse_float_list(text)
    parts = text.split(':')
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f'expected start:stop:step, got {text!r}')
    start, stop, step = parse_float_list(','.join(parts))
    if step <= 0 or stop < start:
        raise argparse.ArgumentTypeError(f'expected start <= stop and step > 0, got {text!r}')
    count = int(round((stop - start) / step)) + 1
    if count > MAX_LIST_VALUES:
        raise argparse.ArgumentTypeError(f'{count} values, more than {MAX_LIST_VALUES}')
    return [start + i * step for i in range(count)]


def joint_names(text: str) -> list[str]:
    """Parse one ``--joint`` value: a name or comma-separated names (argparse type)."""
    names = [name.strip() for name in text.split(',')]
    if not all(names):
        raise argparse.ArgumentTypeError(f'empty joint name in {text!r}')
    return names


def joint_selection(names: Sequence[str] | None) -> tuple[str | None, list[str] | None]:
    """Return (joint, joints) of ``--joint``: one name keeps the single-joint layout."""
    if not names:
        return None, None
    if len(names) == 1 and names[0] != 'all':
        return names[0], None
    if 'all' in names and len(names) > 1:
        raise InputError('--joint: "all" stands alone')
    return None, list(names)


# --------------------------------------------------------------------------- option builders

def check_option(value: float | None, *, option: str, low: float, high: float, unit: str = '',
                 low_open: bool = False) -> None:
    """
    Raise InputError naming ``option`` unless ``value`` is finite and in [low, high].

    ``low_open``: the low end is excluded (``> low``).  ``unit`` is printed after the numbers
    (e.g. ``'rad/s'``); None passes (the option was not given).
    """
    if value is None:
        return
    unit_text = f' {unit}' if unit else ''
    ok = math.isfinite(value) and (value > low if low_open else value >= low) and value <= high
    if not ok:
        low_text = f'> {low:g}' if low_open else f'>= {low:g}'
        raise InputError(f'{option}: must be {low_text} and <= {high:g}{unit_text}, got '
                         f'{str(value)[:40]}{unit_text}')


def add_params(parser: argparse.ArgumentParser) -> None:
    """Add ``--params FILE``: the friction-model parameter set."""
    parser.add_argument('--params', metavar='FILE',
                        help='parameter-set YAML (default: the packaged IRB 6620 joint 2 set)')


def params_from(args: argparse.Namespace) -> ParameterSet:
    """Return the parameter set of ``--params`` (the packaged one when not given)."""
    # deferred import: start-up time (numpy, yaml: not for --help)
    from robot_wear_monitor.model.params import load_parameter_set
    return load_parameter_set(getattr(args, 'params', None))


def add_config(parser: argparse.ArgumentParser, *, help_text: str) -> None:
    """Add ``--config YAML``: the ROS 2 node parameter file."""
    parser.add_argument('--config', metavar='YAML', help=help_text)


def add_joints(parser: argparse.ArgumentParser, *, help_text: str) -> None:
    """Add ``--joint NAME[,NAME]`` (repeatable, or ``all``): the joints to work on."""
    parser.add_argument('--joint', action='extend', type=joint_names, metavar='NAME[,NAME]',
                        help=help_text)


#: Where ``--gear-ratio`` / ``--torque-scale`` come from when not given, for the verbs that
#: segment a bag or a raw run (segment, audit, identify): the node configuration for a bag.
BAG_SCALE_DEFAULT = (f'bag: from the node config (--config), '
                     f'{NODE_SCALES["gear_ratio"]:g} in the packaged one; raw runs and level '
                     f'tables: {RAW_RUN_SETTINGS["gear_ratio"]:g}')
BAG_TORQUE_SCALE_DEFAULT = (f'bag: from the node config (--config), '
                            f'{NODE_SCALES["torque_scale"]:g} in the packaged one; raw runs: '
                            f'{RAW_RUN_SETTINGS["torque_scale"]:g}')


def setting_type(owner: Any, name: str) -> Callable[[str], Any]:
    """
    Return the argparse type of a declared setting: its kind (number, integer) and its check.

    The range is the one the configuration dataclass and the node parameter check
    (:mod:`robot_wear_monitor.setting_fields`); argparse adds the option's name and exits 2.
    """
    declared = setting_of(owner, name)

    def parse(text: str) -> Any:
        try:
            value: Any = (text if declared.kind == 'str' else
                          int(text) if declared.kind == 'int' else float(text))
        except ValueError:
            kind = 'an integer' if declared.kind == 'int' else 'a number'
            raise argparse.ArgumentTypeError(f'not {kind}: {shorten(repr(text))}') from None
        problem = problem_of(declared, value)
        if problem:
            unit = f' {declared.unit}' if declared.unit not in ('', '-') else ''
            shown = shorten(repr(text), 60) if declared.kind == 'str' else shorten(text)
            raise argparse.ArgumentTypeError(f'{problem}{unit}, got {shown}{unit}')
        return value
    return parse


def add_setting_option(parser: Any, flag: str, owner: Any, name: str, *,
                       default: Any = None, default_text: str | None = None,
                       metavar: str | None = None, help_prefix: str = '',
                       **kwargs: Any) -> None:
    """
    Add an option that sets the declared setting ``name`` of the configuration ``owner``.

    The help is the setting's description and unit, the type its kind and check
    (:func:`setting_type`); ``default`` is the argparse default (None: not given, the verb
    takes the owner's or the node configuration's value), ``default_text`` what the help says
    the default is (default: the owner's default).  ``parser`` may be an argument group.
    """
    declared = setting_of(owner, name)
    shown = default_text if default_text is not None else f'{declared.default!r}'
    parser.add_argument(flag, type=setting_type(owner, name), default=default,
                        metavar=metavar or name.upper(),
                        help=f'{help_prefix}{declared.text} (default: {shown})', **kwargs)


#: argparse types of the options with a physical range (one range per meaning).
GEAR_RATIO = setting_type(SegmenterConfig, 'gear_ratio')
TORQUE_SCALE = setting_type(SegmenterConfig, 'torque_scale')
STANDSTILL_SPEED = bounded(0.0, 1e4, low_open=True)
TEMPERATURE_DEGC = bounded(-50.0, 200.0, unit='degC')
WEAR = bounded(0.0, 1000.0)
SPEED_COUNT = bounded(1, 20, integer=True)
#: any other number: finite and at most 1e9 in magnitude
FINITE = bounded(-MAX_MAGNITUDE, MAX_MAGNITUDE)


def add_gear_ratio_and_torque_scale(parser: argparse.ArgumentParser, *, gear_default: str,
                                    scale_default: str | None = None) -> None:
    """
    Add ``--gear-ratio R`` and ``--torque-scale S`` (None when not given).

    ``gear_default`` and ``scale_default`` (default: the same) say where the value comes from
    when the option is not given.
    """
    parser.add_argument('--gear-ratio', type=GEAR_RATIO, default=None, metavar='R',
                        help=f'motor speed = R x joint speed (default: {gear_default})')
    parser.add_argument('--torque-scale', type=TORQUE_SCALE, default=None, metavar='S',
                        help='normalised torque = effort / S (default: '
                             f'{scale_default or gear_default})')


def add_robot(parser: argparse.ArgumentParser, *, help_text: str) -> None:
    """Add ``--robot NAME``: the robot the joints belong to (its key in a fleet history)."""
    parser.add_argument('--robot', metavar='NAME', type=robot_name, help=help_text)


def robot_name(text: str) -> str:
    """Parse a ``--robot`` value: a non-empty name of at most 128 printable characters."""
    try:
        return check_robot_name(text)
    except InputError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_progress(parser: argparse.ArgumentParser) -> None:
    """Add ``--no-progress`` (the progress bar is drawn only on a terminal)."""
    parser.add_argument('--no-progress', action='store_true',
                        help='no progress bar (there is one only when stderr is a terminal)')


def progress_wanted(args: argparse.Namespace) -> bool:
    """
    Return True when a progress bar should be drawn: stderr is a terminal, no --no-progress.

    A bar in a log file or a pipe is noise (tqdm redraws it), and loading tqdm costs a short
    replay some 10 ms; a script that wants no bar on a terminal passes ``--no-progress``.
    """
    return not args.no_progress and sys.stderr is not None and sys.stderr.isatty()


def add_local(parser: argparse.ArgumentParser) -> None:
    """Add ``--local``: times in the local time zone instead of UTC (ISO 8601 either way)."""
    parser.add_argument('--local', action='store_true',
                        help='times in the local time zone (default UTC)')


def add_display_timezone(parser: argparse.ArgumentParser) -> None:
    """Add ``--display-timezone ZONE``: the times people read in that IANA zone (not --local)."""
    add_setting_option(parser, '--display-timezone', DisplayTimeConfig, 'display_timezone',
                       metavar='ZONE')


def display_zone(args: argparse.Namespace) -> Any:
    """
    Return the zone of ``--display-timezone`` for :func:`~robot_wear_monitor.text.shown_time`.

    None: UTC (ISO 8601, or the machine's zone with ``--local``).  Both options: an error.
    """
    name = getattr(args, 'display_timezone', None)
    if name is None:
        return None
    if getattr(args, 'local', False):
        raise InputError("give --local (the machine's zone) or --display-timezone, not both")
    return time_zone(name, where='--display-timezone')


def add_history(parser: argparse.ArgumentParser, *, help_text: str,
                required: bool = False, writer: bool = False) -> None:
    """
    Add ``--history PATH|URL``: the wear history (an SQLite file or a PostgreSQL URL).

    ``writer``: the verb writes the history, so it also takes ``--init``.
    """
    parser.add_argument('--history', metavar='PATH|URL', required=required,
                        help=help_text + ': an SQLite file, or postgresql://USER@HOST:PORT/DB')
    if writer:
        parser.add_argument('--init', action='store_true',
                            help='make a wear history in an existing empty file, or add one to '
                                 'a PostgreSQL database that holds other tables (a missing '
                                 'file is always created; a file of another program never '
                                 'written)')


def add_json(parser: argparse.ArgumentParser, *, what: str = 'one JSON object',
             legacy_path: bool = False) -> None:
    """
    Add ``--json`` (print JSON on stdout) and ``--json-out PATH`` (write it to a file).

    ``legacy_path``: the verb took ``--json PATH`` before; that spelling still writes the
    file (see :func:`resolve_json`, which warns on stderr).
    """
    text = f'print {what} on stdout instead of the text'
    if legacy_path:
        parser.add_argument('--json', nargs='?', const=True, default=False, metavar='PATH',
                            help=text + ' (--json PATH: deprecated spelling of --json-out '
                                        'PATH)')
    else:
        parser.add_argument('--json', action='store_true', help=text)
    parser.add_argument('--json-out', metavar='PATH',
                        help=f'also write {what} to this file (atomically)')


def resolve_json(args: argparse.Namespace, *, command: str) -> None:
    """
    Turn a deprecated ``--json PATH`` / ``--json -`` into ``--json-out PATH`` / ``--json``.

    Warns on stderr once; leaves ``args.json`` a bool and ``args.json_out`` a path or None.
    """
    value = getattr(args, 'json', False)
    if not isinstance(value, str):
        return
    if value == '-':
        print(f'{PROG} {command}: warning: --json - is deprecated; use --json',
              file=sys.stderr)
        args.json = True
        return
    print(f'{PROG} {command}: warning: --json PATH is deprecated; use --json-out PATH',
          file=sys.stderr)
    if args.json_out is not None and args.json_out != value:
        raise InputError(f'--json {value} and --json-out {args.json_out}: give one file')
    args.json, args.json_out = False, value


def print_json(payload: object) -> None:
    """Print ``payload`` as one indented JSON object on stdout (no NaN or inf)."""
    json.dump(payload, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write('\n')


def write_json_out(path: str | None, payload: Any) -> None:
    """Write ``payload`` to ``--json-out PATH`` atomically (nothing when ``path`` is None)."""
    if path is None:
        return
    try:
        write_json_atomic(path, payload)
    except OSError as error:
        raise InputError(f'{path}: cannot write: {error.strerror}') from None


def emit_json(args: argparse.Namespace, payload: Any) -> bool:
    """Write ``--json-out`` and print ``--json``; return True when JSON went to stdout."""
    write_json_out(getattr(args, 'json_out', None), payload)
    if getattr(args, 'json', False):
        print_json(payload)
        return True
    return False


def warn_deprecated(command: str, old: str, new: str) -> None:
    """Print the one-line deprecation warning of an option spelling on stderr."""
    print(f'{PROG} {command}: warning: {old} is deprecated; use {new}', file=sys.stderr)


def ros_args(args: argparse.Namespace) -> list[str]:
    """Return the ``--ros-args ...`` tail of the command line (live, play)."""
    return list(getattr(args, 'ros_args', None) or [])


def rclpy_missing(error: ImportError) -> InputError:
    """Return the one-line error of a verb that needs rclpy when it is not importable."""
    return InputError(f'needs rclpy, which is not importable ({error}): install the "ros" extra '
                      "(pip install '.[ros]' in the repository) or source a ROS 2 Jazzy setup")


def require_rclpy() -> None:
    """
    Raise :func:`rclpy_missing`'s error when rclpy cannot be imported (live, play, call).

    Asked before any node or client is built, so a plain ``pip install .`` gets one line on
    stderr and exit 2, not the traceback of an import deep inside a node module.
    """
    # deferred import: start-up time (nodes.spinning, numpy: the ROS verbs only)
    from robot_wear_monitor.nodes.spinning import import_rclpy
    try:
        import_rclpy()
    except ImportError as error:
        raise rclpy_missing(error) from None


def shown_location(location: str) -> str:
    """Return a history location as it may be printed: no password, control characters escaped."""
    return shorten(redact_location(location), LINE_LIMIT)


class _RedactingStream:
    """A text stream that writes through another with every secret replaced by ``***``."""

    def __init__(self, stream: Any, secrets: Sequence[str]) -> None:
        self._stream = stream
        self._secrets = tuple(secrets)

    def write(self, text: str) -> int:
        for secret in self._secrets:
            text = text.replace(secret, '***')
        return self._stream.write(text)

    def __getattr__(self, name: str) -> Any:  # flush, fileno, isatty, encoding, ...
        return getattr(self._stream, name)


#: the shortest password the output guard replaces (a shorter one is hidden where printed only)
MIN_GUARDED_SECRET_CHARS = 3


#: a PostgreSQL URL anywhere in a command-line word (``--history=postgresql://...`` too)
_URL_IN_WORD = re.compile(r'postgres(?:ql)?://\S+')


def _secrets_of(args: argparse.Namespace | Sequence[str]) -> set[str]:
    """Return the passwords of the URLs among the parsed options, or in the words of argv."""
    secrets: set[str] = set()
    if isinstance(args, argparse.Namespace):
        for value in vars(args).values():
            for item in value if isinstance(value, (list, tuple)) else (value,):
                secrets.update(location_secrets(item))
    else:
        for word in args:
            for url in _URL_IN_WORD.findall(str(word)):
                secrets.update(location_secrets(url))
    return {s for s in secrets if len(s) >= MIN_GUARDED_SECRET_CHARS}


@contextmanager
def secrets_kept_out(args: argparse.Namespace | Sequence[str]) -> Iterator[None]:
    """
    Keep the passwords of the command's history URLs out of stdout and stderr while it runs.

    ``args``: the parsed options (every option value that is a PostgreSQL URL), or the words of
    the command line before they are parsed (every PostgreSQL URL in a word), so that
    argparse's own messages (an unrecognized argument, a missing or invalid value: they echo
    the words) are covered from the first byte.  Each gives its password (``user:PASS@`` and
    ``?password=``, as given and decoded); whatever the command, a library or a traceback
    prints through ``sys.stdout``/``sys.stderr`` has them replaced by ``***``.  The places that
    print a location also show it redacted (:func:`shown_location`): this guard is the second
    line.
    """
    secrets = _secrets_of(args)
    if not secrets:
        yield
        return
    ordered = sorted(secrets, key=len, reverse=True)
    saved = sys.stdout, sys.stderr
    sys.stdout = _RedactingStream(sys.stdout, ordered)
    sys.stderr = _RedactingStream(sys.stderr, ordered)
    try:
        yield
    except Exception:  # a traceback is printed here, through the guard, not after it
        # deferred import: start-up time (traceback: only when a command fails)
        import traceback
        traceback.print_exc()
        raise SystemExit(1) from None
    finally:
        sys.stdout, sys.stderr = saved
