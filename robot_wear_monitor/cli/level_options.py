"""
The options of the verbs that read friction levels from raw runs, a bag or a level table.

``audit``, ``identify`` and ``segment``: where the levels come from (``--joint``, ``--topic``,
``--config``, ``--gear-ratio``, ``--torque-scale``, ``--standstill-speed``, ``--known-torque``),
how raw runs are read (``--raw-sign``, ``--speed-tolerance``), the levels' unit
(``--friction-unit``), ``--configuration-column`` and ``--levels-out``.  Their defaults are the
raw-run reading's and the node configuration's (:mod:`robot_wear_monitor.experiment.
segmentation_settings`); the options every verb shares are in :mod:`robot_wear_monitor.cli.
options`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
from typing import Any, Sequence

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.cli.options import (add_config, add_gear_ratio_and_torque_scale,
                                            BAG_SCALE_DEFAULT, BAG_TORQUE_SCALE_DEFAULT,
                                            bounded, PROG, STANDSTILL_SPEED)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import RAW_RUN_READING, RAW_RUN_SETTINGS
from robot_wear_monitor.text import escaped


def add_level_source(parser: argparse.ArgumentParser, *,
                     gear_default: str = BAG_SCALE_DEFAULT) -> None:
    """
    Add the options of raw-run and bag inputs that are segmented into levels (audit, identify).

    ``--gear-ratio`` and ``--torque-scale`` are None when not given: a bag then takes them
    from the node configuration ``--config`` (as ``segment`` and ``replay``), a raw run from
    the raw-run settings (1); see :func:`level_source_scales`.
    """
    parser.add_argument('--joint', help='joint name to segment (bag input), or to select from a '
                        "level table's joint column (identify --speed-only)")
    parser.add_argument('--topic', default='/joint_states', help='joint-state topic (bag input)')
    add_raw_reading(parser)
    parser.add_argument('--known-torque', metavar='COLUMN',
                        help='raw runs that move one way only and have no run the other way: '
                             'a column of a known torque (gravity, a model torque; the '
                             "torque's unit) subtracted to give the friction")
    parser.add_argument('--standstill-speed', type=STANDSTILL_SPEED, metavar='RAD_S',
                        help='raw runs: the speed below which a sample is standstill [rad/s] '
                             + RAW_STANDSTILL_DEFAULT)
    add_gear_ratio_and_torque_scale(parser, gear_default=gear_default,
                                    scale_default=BAG_TORQUE_SCALE_DEFAULT)
    add_config(parser, help_text='bag input: the node parameter file whose '
                                 'friction_experiment_node parameters segment the bag, as '
                                 'segment and replay do (default: the packaged '
                                 'wear_monitor.yaml; per-joint values as <joint>: {...})')
    parser.add_argument('--levels-out', metavar='PATH',
                        help="write the friction levels fitted as a CSV in segment's columns "
                             '(plus temperature and load where the levels have them); bag or '
                             'raw-run input (atomically)')


def add_friction_unit(parser: argparse.ArgumentParser) -> None:
    """Add ``--friction-unit`` (identify, audit): the unit of the levels, said in the output."""
    parser.add_argument('--friction-unit', metavar='UNIT',
                        help='the unit of the levels (and of their load), stated in the set and '
                             'the report (default: N.m for raw runs read with torque scale 1, '
                             'else normalised)')


def friction_unit(args: argparse.Namespace, source: str, torque_scale: float | None, *,
                  command: str, note: bool = True, holder: str = 'the set') -> str:
    """
    Return the friction unit of the levels read from ``source``: ``--friction-unit``, else.

    N.m for raw runs (a folder, a raw ``.csv``/``.csv.gz``) with torque scale 1 or none, else
    'normalised'; ``note`` prints on stderr that a level table's unit was not stated (and
    what ``holder`` says).
    """
    # deferred import: start-up time (numpy, scipy, yaml: not for --help)
    from robot_wear_monitor.audit.data import is_bag
    from robot_wear_monitor.recordings.raw_runs import is_raw_run
    from robot_wear_monitor.yaml_files import shorten
    if getattr(args, 'friction_unit', None):
        unit = args.friction_unit.strip()
        if not unit or len(unit) > 40 or not unit.isprintable():
            raise InputError(f'--friction-unit: a short unit such as A or N.m, got '
                             f'{shorten(repr(args.friction_unit))}')
        return unit
    path = Path(source)
    raw = not is_bag(path) and (path.is_dir() or is_raw_run(path))
    unit = 'N.m' if raw and torque_scale in (None, 1.0) else 'normalised'
    if not raw and note:  # a level table does not say its unit
        print(f'{PROG} {command}: note: the friction unit of {shorten(str(source))} is not '
              f'stated; {holder} says {unit!r} (give --friction-unit UNIT, e.g. N.m)',
              file=sys.stderr)
    return unit


def add_configuration_column(parser: argparse.ArgumentParser) -> None:
    """Add ``--configuration-column`` (identify): one set per configuration of the levels."""
    parser.add_argument('--configuration-column', metavar='COLUMN',
                        help='a column of the levels that names their configuration (e.g. '
                             'payload): write one set per value beside --out '
                             "(<out stem>_<value>.yaml, with that configuration's load "
                             'estimate and operating range) besides the pooled --out '
                             '(default: configurations split by a gap in the load column)')


#: ``--speed-tolerance``: a fraction of the speed, in (0, 1).
SPEED_TOLERANCE = bounded(0.0, 1.0, low_open=True)


def add_raw_reading(parser: argparse.ArgumentParser) -> None:
    """
    Add ``--raw-sign`` and ``--speed-tolerance``: how raw runs are read (segment, audit, identify).

    Their defaults are the raw-run reading's
    (:data:`~robot_wear_monitor.experiment.segmentation_settings.RAW_RUN_READING`).
    """
    parser.add_argument('--raw-sign', action='store_true',
                        default=RAW_RUN_READING['raw_sign'],
                        help='raw runs: keep the recorded torque sign (default: the data '
                             'decide, per joint: a joint whose eq. (3) friction comes out '
                             'negative is read with the other sign, and the output says so)')
    parser.add_argument('--speed-tolerance', type=SPEED_TOLERANCE, metavar='FRACTION',
                        default=RAW_RUN_READING['speed_tolerance'],
                        help='raw runs: a plateau is steady when its speed stays within this '
                             'fraction of it (like the node parameter speed_tolerance_fraction; '
                             f'default: within {RAW_RUN_READING["noise_band"]:g} std of the '
                             "run's own speed noise and one step of a quantised speed, at "
                             f'least {RAW_RUN_SETTINGS["speed_tolerance_fraction"]:g} of the '
                             'speed)')


def print_notes(notes: Sequence[str]) -> None:
    """Print how raw runs were read (notes, runs used and unused) on stderr, escaped."""
    for line in notes:
        print(escaped(line), file=sys.stderr)


#: The help's default of ``--standstill-speed`` (the raw-run settings' threshold).
RAW_STANDSTILL_DEFAULT = (f'(default {RAW_RUN_SETTINGS["standstill_speed_rad_s"]:g}, or 5 x the '
                          'speed noise of a run slower than that)')


def write_levels_out(args: argparse.Namespace, tables: Sequence[Any],
                     roles: Sequence[str] | None = None) -> str | None:
    """
    Write ``--levels-out``: the tables' segmented levels as ``segment``'s CSV; return its path.

    Called as soon as the levels are read, before the fit (so they are there to look at when
    the fit refuses them); atomically, the path checked before any work
    (:func:`robot_wear_monitor.cli.outputs.check_outputs`).  None without the option; a
    level-table input (no segmented levels) is an InputError.
    """
    if not getattr(args, 'levels_out', None):
        return None
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.data import levels_out_text
    write_text_atomic(args.levels_out, levels_out_text(tables, roles=roles))
    return str(args.levels_out)


def level_source_scales(args: argparse.Namespace) -> tuple[float | None, float | None]:
    """
    Return (gear ratio, torque scale) of a level source: the options, None when not given.

    None: a bag takes the node configuration's value (``--config``), a raw run or a level
    table 1 (:func:`robot_wear_monitor.audit.data.load_audit_data`).
    """
    return args.gear_ratio, args.torque_scale
