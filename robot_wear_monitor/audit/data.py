"""
Reading the data of an audit: level tables (CSV), raw runs, bags, into an AuditTable.

Units: speeds motor side [rad/s] (link side for the KUKA raw runs), friction in the table's own
unit (normalised for the packaged model; N.m for the KUKA data), temperature [degC].
"""

from __future__ import annotations

from dataclasses import replace
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.errors import InputError, no_such_path_text
from robot_wear_monitor.experiment.segmentation_settings import raw_run_segmenter_config
from robot_wear_monitor.input_files import (csv_file_rows, MAX_LEVEL_TABLE_BYTES,
                                            MAX_TABLE_LINE_CHARS)
from robot_wear_monitor.recordings.raw_runs import (folder_runs, is_raw_run, no_level_error,
                                                    read_raw_runs)
from robot_wear_monitor.recordings.tables import with_standstill_speed
from robot_wear_monitor.text import escaped, shorten


#: The models an audit identifies: (4) per group, (5), (8).
MODELS = ('speed', 'nominal', 'complete')
REQUIRED_COLUMNS = {'speed': ('speed', 'friction'),
                    'nominal': ('speed', 'friction', 'temperature', 'load'),
                    'complete': ('speed', 'friction', 'temperature', 'load', 'wear')}


def table_from_columns(columns: Mapping[str, Sequence], *, source: str = '<table>',
                       model: str = 'speed') -> AuditTable:
    """
    Validate a mapping of columns into an :class:`AuditTable`.

    Numeric columns become float arrays; a column whose values are not all numbers is a text
    (categorical) column.  Column names and text values have their control characters escaped
    here, where they enter (:func:`~robot_wear_monitor.text.escaped`): they are printed in
    the audit's report.  Raises :class:`InputError` for an empty table, unequal lengths,
    missing required columns, NaN/inf or non-positive speeds.
    """
    if model not in MODELS:
        raise InputError(f'unknown model {model!r} (expected one of {", ".join(MODELS)})')
    if not columns:
        raise InputError(f'{source}: the table has no columns')
    lengths = {len(v) for v in columns.values()}
    if len(lengths) != 1:
        raise InputError(f'{source}: columns have different lengths {sorted(lengths)}')
    if lengths.pop() == 0:
        raise InputError(f'{source}: the table has no rows')
    numeric: dict[str, FloatArray] = {}
    text: dict[str, NDArray[np.str_]] = {}
    for name, values in columns.items():
        name = escaped(str(name).strip())
        array = np.asarray(values)
        if name.lower() in CATEGORICAL_COLUMNS:  # groups, never numbers (joint 2 != 2 x joint 1)
            text[name] = np.array([_category(v) for v in array])
            continue
        if array.dtype.kind in 'fiub':
            numeric[name] = array.astype(float)
            continue
        try:
            numeric[name] = np.array([float(v) for v in array], dtype=float)
        except (TypeError, ValueError):
            text[name] = np.array([escaped(str(v).strip()) for v in array])
    missing = [c for c in REQUIRED_COLUMNS[model] if c not in numeric]
    if missing:
        what = 'non-numeric' if missing[0] in text else 'missing'
        raise InputError(f'{source}: column {missing[0]!r} is {what} (the {model} model needs '
                         f'{", ".join(REQUIRED_COLUMNS[model])})')
    for name, array in numeric.items():
        bad = ~np.isfinite(array)
        if bad.any():
            raise InputError(f'{source}: column {name!r} has NaN or inf values '
                             f'(first at row {int(np.argmax(bad)) + 1})')
    speed = numeric['speed']
    if np.any(speed == 0):
        raise InputError(f"{source}: column 'speed' is 0 at row {int(np.argmax(speed == 0)) + 2} "
                         '(a standstill row is no friction level)')
    if np.any(speed < 0):
        numeric, text = _fold_direction(numeric, text, source)
    return AuditTable(numeric, text, source)


#: Columns that name groups (a joint, a run, a direction, a robot, a pose): text, never numbers.
CATEGORICAL_COLUMNS = ('joint', 'run', 'direction', 'robot', 'pose', 'test_set', 'axis')


def _category(value: object) -> str:
    """Return a group label: numbers written alike (2, 2.0 and ' 2' are one group)."""
    text = escaped(str(value).strip())
    try:
        number = float(text)
    except ValueError:
        return text
    return f'{number:g}' if number == number else text


def _fold_direction(numeric: dict[str, FloatArray], text: dict[str, NDArray[np.str_]],
                    source: str) -> tuple[dict[str, FloatArray], dict[str, NDArray[np.str_]]]:
    """
    Turn signed speeds (one row per direction) into |speed| and a ``direction`` group.

    The friction of a negative-speed row is its magnitude: a table whose frictions at negative
    speeds are negative (the signed torque) has them negated; eq. (3)'s level is the symmetric
    special case (the audit tests whether the direction matters).
    """
    if 'direction' in text or 'direction' in numeric:
        raise InputError(f"{source}: signed speeds and a 'direction' column: give one of them")
    speed = numeric['speed']
    negative = speed < 0
    friction = numeric['friction'].copy()
    if np.median(friction[negative]) < 0:  # signed torques: the friction opposes the motion
        friction[negative] = -friction[negative]
    numeric = {**numeric, 'speed': np.abs(speed), 'friction': friction}
    text = {**text, 'direction': np.where(negative, 'negative', 'positive')}
    return numeric, text


def read_level_table(path: str | Path, *, model: str = 'speed') -> AuditTable:
    """
    Read a CSV (optionally .gz) table of friction levels with a header row.

    Read with bounds as it is read (:func:`~robot_wear_monitor.input_files.csv_file_rows`: a
    regular file, at most :data:`~robot_wear_monitor.input_files.MAX_LEVEL_TABLE_BYTES` of
    text, decompressed ones for ``.gz``, lines of at most ``MAX_TABLE_LINE_CHARS``); an error
    names the file and the line.
    """
    file = Path(path)
    name = shorten(file, 200)
    rows = [(number, row) for number, row in csv_file_rows(
        file, what='level table', limit_bytes=MAX_LEVEL_TABLE_BYTES,
        line_limit_chars=MAX_TABLE_LINE_CHARS) if row and any(cell.strip() for cell in row)]
    if not rows:
        raise InputError(f'{name}: empty table')
    header = [h.strip() for h in rows[0][1]]
    numbered = rows[1:]
    if not numbered:
        raise InputError(f'{name}: the table has no rows')
    if len(set(header)) != len(header):
        raise InputError(f'{name}: duplicate column names in the header')
    for number, row in numbered:
        if len(row) != len(header):
            raise InputError(f'{name}: line {number} has {len(row)} fields, the header '
                             f'{len(header)}')
    body = [row for _, row in numbered]
    columns = {column: [row[i].strip() for row in body] for i, column in enumerate(header)}
    for column in REQUIRED_COLUMNS.get(model, ()):
        values = columns.get(column)
        if values is not None and any(v == '' or v.lower() == 'nan' for v in values):
            raise InputError(f'{name}: column {column!r} has empty or NaN values')
    return table_from_columns(columns, source=name, model=model)


def table_from_levels(levels: Sequence, *, extra: Mapping[str, Sequence] | None = None,
                      source: str = '<levels>', model: str = 'speed') -> AuditTable:
    """
    Build a table from :class:`~robot_wear_monitor.experiment.levels.FrictionLevel` objects.

    Columns: ``speed``, ``friction``, ``friction_std_error`` and the candidates
    ``position_centre`` [rad], ``position_span`` [rad], ``time`` (level centre time) [s];
    ``extra`` adds per-level columns (e.g. ``experiment``, ``joint``).
    """
    if not levels:
        raise InputError(f'{source}: no friction levels')
    columns: dict[str, Sequence] = {
        'speed': [lv.speed_rad_s for lv in levels],
        'friction': [lv.friction for lv in levels],
        'friction_std_error': [lv.friction_std_error for lv in levels],
        'position_centre': [0.5 * (lv.position_min_rad + lv.position_max_rad) for lv in levels],
        'position_span': [lv.position_max_rad - lv.position_min_rad for lv in levels],
        'time': [0.5 * (lv.start_time_s + lv.end_time_s) for lv in levels],
    }
    columns.update(extra or {})
    return table_from_columns(columns, source=source, model=model)


def table_from_raw_runs(paths: Sequence[str | Path], *, flip_sign: bool = True,
                        config=None, model: str = 'speed',
                        known_torque: str | None = None,
                        standstill_speed_rad_s: float | None = None,
                        speed_tolerance: float | None = None, joint: str | None = None,
                        notes: list[str] | None = None) -> AuditTable:
    """
    Segment raw runs (``t_s, q_rad, dq_rad_s, tau_measured_Nm``) into levels.

    The one reading of raw runs of every verb,
    :func:`robot_wear_monitor.recordings.raw_runs.read_raw_runs` (settings of
    :func:`robot_wear_monitor.experiment.segmentation_settings.raw_run_segmenter_config`, each
    run's speed band from its own noise or ``speed_tolerance``, a fraction of the speed;
    one-way runs paired across runs at the closest speed); link-side rad/s and the torque's
    unit.

    Columns: ``speed``, ``friction`` (``flip_sign``: a joint whose eq. (3) friction is negative
    in the recorded sign is read with the other sign, friction opposing the motion; False
    keeps the recorded sign, ``--raw-sign``), ``friction_std_error``, ``experiment`` (the
    run's file name), ``joint`` (``joint<k>`` of a ``joint<k>_`` file name, a ``joint``
    column, ``joint`` (--joint), else the folder's name; only with several joints) and
    ``pose`` (KUKA names) and the candidates ``position_centre`` and ``position_span`` of the
    common window [rad], ``time`` (level centre time in the run) [s], ``cycle`` (index of the
    level in its run), ``load_torque`` = |tau+ + tau-|/2 (the gravity load the level was
    measured under, the tau_l of eq. (5)) and ``run_duration`` [s], and ``direction``
    (``positive``/``negative`` for the levels of one pass with a known torque, ``both`` for
    eq. (3) levels; only when a one-way level is there).

    A one-way run without a partner gives its friction as the pass's torque minus
    ``known_torque``, a column of the run with a torque the user knows (gravity, a model
    torque; the torque's unit); without one it is reported.  ``standstill_speed_rad_s`` sets
    the standstill threshold (default: the settings', or 5 times the speed noise of a run
    slower than it).  ``notes``: a list that receives the reading's notes (a joint read with
    the other sign) and the count of runs used and unused with every unused run's reason.
    The table's ``levels`` are the segmented levels of its rows (friction with the table's
    sign), labelled by run and joint.
    """
    settings = config if config is not None else raw_run_segmenter_config()
    if standstill_speed_rad_s is not None:  # the user's threshold, also for slow runs
        settings = with_standstill_speed(settings, standstill_speed_rad_s)
    reading = read_raw_runs(paths, config=settings,
                            standstill_set=standstill_speed_rad_s is not None,
                            speed_tolerance=speed_tolerance, raw_sign=not flip_sign,
                            joint=joint, known_torque=known_torque)
    if notes is not None:
        notes.extend(reading.report_lines())
    if not reading.levels:
        raise no_level_error(reading, n_paths=len(paths))
    columns: dict[str, list] = {k: [] for k in (
        'speed', 'friction', 'friction_std_error', 'experiment', 'joint', 'pose',
        'position_centre', 'position_span', 'time', 'cycle', 'load_torque', 'run_duration',
        'direction')}
    levels: list[tuple[Any, str, str]] = []  # (level, experiment, joint) of each row
    for row in reading.levels:
        level = row.level
        levels.append((level, row.experiment, row.joint))
        columns['speed'].append(level.speed_rad_s)
        columns['friction'].append(level.friction)
        columns['friction_std_error'].append(level.friction_std_error)
        columns['experiment'].append(row.experiment)
        columns['joint'].append(row.joint)
        columns['pose'].append('new_pose' if 'new_pose' in row.run.test_set else 'standard')
        columns['position_centre'].append(0.5 * (level.position_min_rad
                                                 + level.position_max_rad))
        columns['position_span'].append(level.position_max_rad - level.position_min_rad)
        columns['time'].append(0.5 * (level.start_time_s + level.end_time_s))
        columns['cycle'].append(float(row.cycle))
        columns['load_torque'].append(0.5 * abs(level.tau_forward + level.tau_backward))
        columns['run_duration'].append(row.duration_s)
        # a one-way pass keeps its direction; eq. (3) levels hold both
        columns['direction'].append('both' if level.n_forward and level.n_backward else
                                    'positive' if level.n_forward else 'negative')
    if len(set(columns['pose'])) == 1:
        del columns['pose']
    if set(columns['direction']) == {'both'}:
        del columns['direction']
    if len(set(columns['joint'])) == 1:
        del columns['joint']
    table = table_from_columns(columns, source=f'{len(paths)} raw runs', model=model)
    return replace(table, levels=tuple(levels))


def table_from_bag(path: str | Path, *, joint: str, topic: str = '/joint_states',
                   config=None, model: str = 'speed',
                   experiment_parameters: Mapping[str, Any] | None = None) -> AuditTable:
    """
    Segment the joint states of a recorded bag into friction levels (one per pass pair).

    The bag is segmented as ``segment`` and the replay do
    (:func:`robot_wear_monitor.monitoring.segment.segment_bag`), with
    ``experiment_parameters``, the validated ``friction_experiment_node`` parameters of the
    joint (as :func:`bag_segmentation_parameters` returns them), or else with ``config``, a
    :class:`~robot_wear_monitor.experiment.segmentation.SegmenterConfig` (default: the node's
    defaults, the packaged robot's gear ratio and torque scale); the table's ``levels`` are
    ``segment``'s rows.
    """
    # deferred import: start-up time (node configuration, bag segmentation: bags only)
    from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                           SEGMENTER_FIELDS, validate_parameters)
    from robot_wear_monitor.monitoring.segment import segment_bag

    if experiment_parameters is not None:
        parameters = dict(experiment_parameters)
    elif config is None:
        parameters = bag_segmentation_parameters(joint=joint)
    else:
        if config.window_center_rad is not None:
            raise InputError('table_from_bag: a fixed position window is not a setting of the '
                             'bag segmentation')
        parameters = validate_parameters(
            FRICTION_EXPERIMENT_NODE,
            {name: getattr(config, name) for name in SEGMENTER_FIELDS},
            source='segmentation settings')
    result = segment_bag(path, experiment_parameters=parameters, topic=topic)
    table = table_from_levels([level for level, _, _ in result.rows], source=str(path),
                              model=model)
    return replace(table, levels=tuple(result.rows))


def bag_segmentation_parameters(*, joint: str, config_file: str | os.PathLike | None = None,
                                gear_ratio: float | None = None,
                                torque_scale: float | None = None) -> dict[str, Any]:
    """
    Return the ``friction_experiment_node`` parameters a bag of ``joint`` is segmented with.

    Those of the node configuration ``config_file`` (default: the packaged
    ``wear_monitor.yaml``, gear ratio 150 and torque scale 10), the joint's own
    ``<joint>.<name>`` values included, with ``gear_ratio`` / ``torque_scale`` overriding when
    given: the very parameters ``segment --joint JOINT`` and ``replay`` take, so that
    ``audit`` and ``identify`` of a bag find the same levels.
    """
    # deferred import: start-up time (the node configuration: bags only)
    from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                           load_node_parameters)
    overrides: dict[str, Any] = {'joint': joint}
    if gear_ratio is not None:
        overrides['gear_ratio'] = float(gear_ratio)
    if torque_scale is not None:
        overrides['torque_scale'] = float(torque_scale)
    return load_node_parameters(FRICTION_EXPERIMENT_NODE, config_file, overrides=overrides)


def is_bag(path: str | os.PathLike) -> bool:
    """Return True for a bag: a folder with ``metadata.yaml``, or a ``.mcap`` / ``.db3`` file."""
    file = Path(path)
    return (file.is_dir() and (file / 'metadata.yaml').exists()) or \
        file.suffix in ('.mcap', '.db3')


def load_audit_data(path: str | os.PathLike, *, model: str = 'speed', joint: str | None = None,
                    topic: str = '/joint_states', flip_sign: bool = True,
                    gear_ratio: float | None = None, torque_scale: float | None = None,
                    known_torque: str | None = None,
                    standstill_speed_rad_s: float | None = None,
                    config_file: str | os.PathLike | None = None,
                    speed_tolerance: float | None = None,
                    notes: list[str] | None = None) -> AuditTable:
    """
    Read DATA of ``audit``: a level CSV, a raw run, a folder of raw runs, or a bag.

    ``known_torque``: the column of raw runs subtracted from one-way runs without a partner
    (see :func:`table_from_raw_runs`); ``standstill_speed_rad_s``: the standstill threshold
    of raw runs (None: the raw-run set's 0.03 rad/s, or from a slow run's speed noise).  A
    bag is segmented with the node configuration ``config_file``
    (:func:`bag_segmentation_parameters`: the packaged one by default, gear ratio 150 and
    torque scale 10, as ``segment`` and ``replay``; ``gear_ratio`` and ``torque_scale``
    override it when not None), a raw run with the raw-run settings
    (:mod:`robot_wear_monitor.experiment.segmentation_settings`; link side, N m).

    * a CSV (or .csv.gz) with ``speed`` and ``friction`` columns: a table of levels;
    * a CSV with ``t_s, q_rad, dq_rad_s, tau_measured_Nm``: one raw run, segmented;
    * a folder holding ``*.csv`` or ``*.csv.gz`` raw runs with any names (or a ``raw_runs``
      subfolder): all runs, one joint unless named ``joint<k>_...`` or with a ``joint``
      column (``joint`` names the joint of runs that name none; ``speed_tolerance``,
      ``notes``: see :func:`table_from_raw_runs`);
    * a bag (folder with ``metadata.yaml``, or a ``.mcap`` / ``.db3`` file): ``joint`` needed.
    """
    file = Path(path)
    if not file.exists():
        raise InputError(no_such_path_text(file, what='file or folder'))
    if is_bag(file):
        if not joint:
            raise InputError(f'{file}: a bag needs --joint NAME (the joint to segment)')
        parameters = bag_segmentation_parameters(joint=joint, config_file=config_file,
                                                 gear_ratio=gear_ratio,
                                                 torque_scale=torque_scale)
        return table_from_bag(file, joint=joint, topic=topic, model=model,
                              experiment_parameters=parameters)
    raw: dict[str, Any] = {'flip_sign': flip_sign, 'model': model,
                           'known_torque': known_torque,
                           'standstill_speed_rad_s': standstill_speed_rad_s,
                           'speed_tolerance': speed_tolerance, 'joint': joint, 'notes': notes}
    if file.is_dir():
        runs = folder_runs(file)
        if not runs:
            raise InputError(f'{file}: no raw runs here and no bag metadata.yaml: a folder of '
                             'raw runs holds *.csv or *.csv.gz files with the columns t_s, '
                             'q_rad, dq_rad_s, tau_measured_Nm (any names; one joint unless '
                             'named joint<k>_... or with a joint column)')
        return table_from_raw_runs(runs, **raw)
    if _is_raw_run(file):
        return table_from_raw_runs([file], **raw)
    return read_level_table(file, model=model)


def levels_out_text(tables: Sequence[AuditTable], *,
                    roles: Sequence[str] | None = None) -> str:
    """
    Return the segmented levels behind the rows of ``tables`` as ``segment``'s level CSV.

    The columns are ``segment``'s (:data:`robot_wear_monitor.monitoring.segment.LEVEL_COLUMNS`,
    the same numbers for the same input and settings), then ``temperature`` [degC] and ``load``
    where every table has them, then ``role`` (one of ``roles`` per table) when given.  A bag's
    ``experiment`` and ``joint`` are ``segment``'s; a raw run's are the run's name and the joint
    of its file name, and its friction has the table's sign (from the data unless --raw-sign).

    :raises InputError: a table was read as levels (a CSV): there are no segmented levels.

    """
    # deferred import: start-up time (monitoring.segment: --levels-out only)
    from robot_wear_monitor.monitoring.segment import levels_csv_text
    rows: list = []
    extra: dict[str, list] = {}
    shared = [name for name in ('temperature', 'load')
              if all(name in table.numeric for table in tables)]
    for i, table in enumerate(tables):
        if len(table.levels) != table.n_rows:
            raise InputError(f'--levels-out: {table.source} is a table of levels already; '
                             '--levels-out writes the levels segmented from a bag or raw runs')
        rows += table.levels
        for name in shared:
            extra.setdefault(name, []).extend(float(v) for v in table.numeric[name])
        if roles is not None:
            extra.setdefault('role', []).extend([roles[i]] * table.n_rows)
    return levels_csv_text(rows, extra=extra)


def _is_raw_run(file: Path) -> bool:
    """Return True when the first line of ``file`` names a raw run's columns (read bounded)."""
    return is_raw_run(file)  # False when unreadable: read_level_table says what is wrong
