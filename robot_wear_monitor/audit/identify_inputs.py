"""
The tables ``identify`` fits: loaded, checked and prepared.

:func:`load_identify_levels` reads a level table, raw runs or a bag (with optional temperature
and load topics); :func:`check_baseline` and :func:`check_wear_test` say what a baseline or a
wear-test table lacks (columns, distinct speeds, temperatures, loads, the critical experiment);
:func:`attach_series`, :func:`number_experiments` and :func:`prepare_levels` add measured
temperature or load series and experiment numbers to levels read from a bag.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
import re
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.data import is_bag, load_audit_data
from robot_wear_monitor.audit.fitting import as_text, AuditTable
from robot_wear_monitor.audit.identification_result import (GOOD_SPEEDS, MIN_SPEEDS,
                                                            MIN_WEAR_SPEEDS, NOMINAL_PARAMETERS)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import EXPERIMENT_GAPS_S


def load_identify_levels(path: str | os.PathLike, *, role: str, joint: str | None = None,
                         topic: str = '/joint_states', flip_sign: bool = True,
                         gear_ratio: float | None = None, torque_scale: float | None = None,
                         temperature_topic: str | None = None, load_topic: str | None = None,
                         experiment_gap_s: float = EXPERIMENT_GAPS_S['identify_bag'],
                         temperature_column: str | None = None,
                         load_column: str | None = None,
                         known_torque: str | None = None,
                         standstill_speed_rad_s: float | None = None,
                         config_file: str | os.PathLike | None = None,
                         speed_tolerance: float | None = None,
                         notes: list[str] | None = None) -> AuditTable:
    """
    Return the levels of one ``identify`` input with ``temperature`` and ``load`` columns.

    :param path: a level CSV, a raw run, a folder of raw runs or a bag.
    :param role: 'BASELINE' or 'WEAR' (for messages).
    :param joint, topic, flip_sign, gear_ratio, torque_scale, known_torque, standstill_speed_rad_s,
        speed_tolerance, notes:
        as for :func:`~robot_wear_monitor.audit.data.load_audit_data` (bag: motor speed =
        gear_ratio x joint speed, normalised torque = effort / torque_scale; None: the node
        configuration ``config_file``'s, as ``segment``); a level table or
        raw runs (joint speeds) have their speeds multiplied by ``gear_ratio`` too (motor side,
        as the nodes see them).
    :param temperature_topic: bag input: the joint temperature [degC] on this topic
        (sensor_msgs/Temperature or std_msgs/Float64), taken at each level's time.
    :param load_topic: bag input: the load torque (normalised) on this topic (std_msgs/Float64).
    :param experiment_gap_s: bag input: levels more than this many seconds apart start a new
        experiment [s] (default: the ``identify_bag`` context of
        :data:`~robot_wear_monitor.experiment.segmentation_settings.EXPERIMENT_GAPS_S`).
    :param config_file: bag input: the node parameter file (None: the packaged one).
    :param temperature_column, load_column: the table's columns holding temperature and load
        (default ``temperature`` and ``load``).

    """
    table = load_audit_data(path, model='speed', joint=joint, topic=topic, flip_sign=flip_sign,
                            gear_ratio=gear_ratio, torque_scale=torque_scale,
                            known_torque=known_torque,
                            standstill_speed_rad_s=standstill_speed_rad_s,
                            config_file=config_file,
                            speed_tolerance=speed_tolerance, notes=notes)
    topics = {'temperature': temperature_topic, 'load': load_topic}
    if any(topics.values()):
        if not is_bag(path):
            raise InputError(f'{role} {path}: --temperature-topic and --load-topic are '
                             f'for bag input')
        # deferred import: start-up time (rosbags: bag input only)
        from robot_wear_monitor.recordings.bags import read_scalar_topic
        for column, name in topics.items():
            if name:
                time_s, values, _ = read_scalar_topic(path, topic=name)
                table = attach_series(table, column=column, time_s=time_s, values=values,
                                      source=f'topic {name}')
    if is_bag(path):
        table = number_experiments(table, gap_s=experiment_gap_s)
    elif gear_ratio is not None and gear_ratio != 1.0:  # the bag reader applies it; levels
        # and raw runs are joint side
        numeric = dict(table.numeric)
        numeric['speed'] = numeric['speed'] * float(gear_ratio)
        table = AuditTable(numeric, dict(table.text), table.source)
    return prepare_levels(table, role=role, temperature_column=temperature_column,
                          load_column=load_column)


def default_set_name(baseline: str | os.PathLike) -> str:
    """Return ``identified_<stem of the baseline>`` (non-identifier characters as '_')."""
    stem = Path(str(baseline).rstrip('/')).name.split('.')[0]
    return 'identified_' + (re.sub(r'[^A-Za-z0-9_]+', '_', stem) or 'set')


# --------------------------------------------------------------------------- data checks

def distinct_count(values: FloatArray, resolution: float, *, log: bool = False) -> int:
    """Return how many distinct values there are at ``resolution`` (of the log with ``log``)."""
    x = np.log(values) if log else values
    return len(np.unique(np.round(x / resolution)))


def _require_columns(table: AuditTable, columns: Sequence[str], what: str) -> None:
    for name in columns:
        if name not in table.numeric:
            kind = 'non-numeric' if name in table.text else 'missing'
            raise InputError(f'{table.source}: column {name!r} is {kind} ({what} needs '
                             f'{", ".join(columns)})')


def check_baseline(table: AuditTable) -> list[str]:
    """
    Check that baseline levels can determine model (5); return the warnings.

    :raises InputError: a missing column, fewer than :data:`MIN_SPEEDS` distinct speeds, a single
        temperature or a single load, or fewer levels than twice the parameters.

    """
    _require_columns(table, ('speed', 'friction', 'temperature', 'load'), 'model (5)')
    n_speeds = distinct_count(table.numeric['speed'], 0.02, log=True)
    temperature = table.numeric['temperature']
    load = table.numeric['load']
    n_temperatures = distinct_count(temperature, 0.1)
    n_loads = distinct_count(load, 0.005)
    if n_speeds < MIN_SPEEDS:
        raise InputError(f'{table.source}: {n_speeds} distinct speed(s); model (5) needs at '
                         f'least {MIN_SPEEDS} (measure more speeds, low ones below the Stribeck '
                         f'speed and high ones for the viscous slope)')
    if n_temperatures < 2:
        raise InputError(f'{table.source}: a single temperature ({temperature[0]:g} degC); the '
                         'temperature terms of (5) need friction levels at several temperatures '
                         '(measure cold and warm, e.g. after start-up and after warm-up)')
    if n_loads < 2:
        raise InputError(f'{table.source}: a single load ({load[0]:g}); the load terms of (5) '
                         'need friction levels at several loads (measure with other payloads '
                         'or poses)')
    if table.n_rows < 2 * len(NOMINAL_PARAMETERS):
        raise InputError(f'{table.source}: {table.n_rows} friction levels are too few for the '
                         f'{len(NOMINAL_PARAMETERS)} parameters of (5) (need at least '
                         f'{2 * len(NOMINAL_PARAMETERS)})')
    warnings = []
    if n_speeds < GOOD_SPEEDS:
        warnings.append(f'only {n_speeds} distinct speeds: measure more speeds (at least '
                        f'{GOOD_SPEEDS}, spread from the lowest to the highest)')
    if n_temperatures < 3:
        warnings.append(f'only {n_temperatures} distinct temperatures: T_V0 needs three or '
                        'more; measure at more temperatures')
    if n_loads < 3:
        warnings.append(f'only {n_loads} distinct loads: measure at more loads')
    if 'experiment' not in table.columns:
        warnings.append('no experiment column: the held-out error is cross-validated by level, '
                        'not by experiment, and may be optimistic')
    return warnings


def _experiment_key(text: str) -> str:
    """Normalise an experiment label the way :func:`as_text` writes numbers."""
    try:
        return f'{float(text):g}'
    except ValueError:
        return str(text).strip()


def experiment_order(labels: Sequence[str]) -> list[str]:
    """Return the distinct experiment labels in their time order (numeric labels by number)."""
    unique = list(dict.fromkeys(labels))
    try:
        return sorted(unique, key=float)
    except ValueError:
        return sorted(unique)


def check_wear_test(table: AuditTable, critical_experiment: str) -> str:
    """
    Check the wear-test levels; return the critical experiment's label as in the table.

    :raises InputError: a missing column, an unknown critical experiment, or too few distinct
        speeds in it for the three parameters of (7).

    """
    _require_columns(table, ('speed', 'friction', 'temperature', 'load'),
                     'the wear profile (6)')
    if 'experiment' not in table.columns:
        raise InputError(f"{table.source}: column 'experiment' is missing (the wear test "
                         'needs its time index k)')
    labels = as_text(table, 'experiment')
    key = _experiment_key(critical_experiment)
    if key not in set(labels.tolist()):
        order = experiment_order(labels.tolist())
        raise InputError(f'{table.source}: --critical-experiment {critical_experiment}: no such '
                         f'experiment (the test has {len(order)}: {order[0]} ... {order[-1]})')
    n_speeds = distinct_count(table.numeric['speed'][labels == key], 0.02, log=True)
    if n_speeds < MIN_WEAR_SPEEDS:
        raise InputError(f'{table.source}: critical experiment {key} has {n_speeds} distinct '
                         f'speed(s); the wear model (7) needs at least {MIN_WEAR_SPEEDS}')
    return key


# --------------------------------------------------------------------------- inputs and figures

def attach_series(table: AuditTable, *, column: str, time_s: ArrayLike, values: ArrayLike,
                  source: str) -> AuditTable:
    """
    Return ``table`` with ``column`` = the series interpolated at each level's time.

    For levels segmented from a bag (column ``time``, the level's centre time [s]) whose
    temperature or load was recorded on a topic: linear interpolation in time, the end values
    held outside the series.  Raises InputError when the table has no ``time`` column or the
    levels lie more than 60 s outside the series (a topic from another recording).
    """
    if 'time' not in table.numeric:
        raise InputError(f'{table.source}: {source}: the levels have no time to match it to')
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float)
    level_t = table.numeric['time']
    if level_t.min() < t[0] - 60.0 or level_t.max() > t[-1] + 60.0:
        raise InputError(f'{table.source}: {source} covers {t[0]:.1f}..{t[-1]:.1f} s, the '
                         f'levels {level_t.min():.1f}..{level_t.max():.1f} s')
    numeric = dict(table.numeric)
    numeric[column] = np.interp(level_t, t, v)
    return AuditTable(numeric, dict(table.text), table.source, table.levels)


def number_experiments(table: AuditTable, *, gap_s: float) -> AuditTable:
    """
    Return ``table`` with ``experiment`` = 0, 1, ... split where levels are > gap_s apart.

    For levels segmented from a recording without an experiment column: consecutive levels
    (in time) less than ``gap_s`` [s] apart belong to one experiment.
    """
    if 'time' not in table.numeric or 'experiment' in table.columns:
        return table
    if not (math.isfinite(gap_s) and gap_s > 0):
        raise InputError(f'experiment gap must be > 0 s, got {gap_s}')
    t = table.numeric['time']
    order = np.argsort(t, kind='stable')
    index = np.empty(t.size)
    index[order] = np.concatenate([[0], np.cumsum(np.diff(t[order]) > gap_s)])
    numeric = dict(table.numeric)
    numeric['experiment'] = index
    return AuditTable(numeric, dict(table.text), table.source, table.levels)


def prepare_levels(table: AuditTable, *, role: str, temperature_column: str | None = None,
                   load_column: str | None = None) -> AuditTable:
    """
    Return the levels with ``temperature`` and ``load`` columns, named or checked.

    :param table: levels read by :func:`~robot_wear_monitor.audit.data.load_audit_data`.
    :param role: 'BASELINE' or 'WEAR' (for messages).
    :param temperature_column: column holding the joint temperature [degC] (default
        ``temperature``).
    :param load_column: column holding the load torque tau_l (default ``load``).

    :raises InputError: a named column is missing, or the table has no temperature or load; the
        message says where they can come from.

    """
    numeric = dict(table.numeric)
    for target, name, option in (('temperature', temperature_column, '--temperature-column'),
                                 ('load', load_column, '--load-column')):
        if name is not None and name != target:
            if name not in numeric:
                raise InputError(f'{role} {table.source}: {option} {name!r}: no such numeric '
                                 f'column (columns: {", ".join(table.columns)})')
            numeric[target] = numeric[name]
        if target not in numeric:
            hint = (" (the raw runs' gravity load is in column load_torque: "
                    '--load-column load_torque)' if 'load_torque' in numeric and
                    target == 'load' else '')
            raise InputError(
                f'{role} {table.source}: no {target!r} column: model (5) needs the {target} of '
                f'every friction level; segmented raw runs and bags carry none: add it as a '
                f'column of a level CSV, name the column with {option}, or for a bag name '
                f'its topic with --{target}-topic{hint}')
    return AuditTable(numeric, dict(table.text), table.source, table.levels)
