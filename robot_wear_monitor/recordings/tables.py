"""
Readers of raw measured runs (not bags) into sample arrays for the segmenter.

The KUKA LBR iiwa 14 friction runs of ``../shared/data/external/kuka_iiwa_yezhao_drake`` are one
gzip CSV per run (``raw_runs/<set>_<vel_label>.csv.gz``) with the columns ``t_s, q_rad, dq_rad_s,
tau_measured_Nm`` of the tested joint (link side: position [rad], velocity [rad/s], joint torque
sensor [N m], raw sign).  The author's processed tables (``processed_original/*.dat``) hold one
row per speed: mean joint velocity [rad/s] and mean torque [N m].

For the segmenter, the iiwa's sensors are on the link side, so ``gear_ratio`` is 1 and
``torque_scale`` is 1 (levels in N m and link-side rad/s): see
:func:`~robot_wear_monitor.experiment.segmentation_settings.raw_run_segmenter_config`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import io
import math
import os
from pathlib import Path
import re
from typing import Any
import warnings

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import (raw_run_segmenter_config,
                                                                 SegmenterConfig)
from robot_wear_monitor.input_files import (MAX_LEVEL_TABLE_BYTES, MAX_RAW_RUN_BYTES,
                                            MAX_RAW_RUN_SAMPLES, MAX_TABLE_LINE_CHARS,
                                            read_text_file, TextLines)
from robot_wear_monitor.text import shorten


KUKA_COLUMNS = ('t_s', 'q_rad', 'dq_rad_s', 'tau_measured_Nm')
_RUN_NAME = re.compile(r'^(?P<set>joint(?P<joint>\d)(?:_[a-z_]+?)?)_vel_(?P<label>[0-9p]+)$')


class RecordingError(InputError):
    """A raw recording cannot be read; the message names the file and the problem."""


@dataclass(frozen=True)
class RawRun:
    """
    One raw run of one joint, as sample arrays of shape (n,).

    :ivar t_s: time [s].
    :ivar q_rad: joint position [rad].
    :ivar dq_rad_s: joint velocity [rad/s].
    :ivar tau_measured_Nm: measured joint torque [N m] (raw sign).
    :ivar joint: tested joint number (1..7), 0 when unknown.
    :ivar test_set: name of the test set, e.g. ``joint5_new_pose_friction_test``.
    :ivar nominal_speed_rad_s: commanded speed from the file name [rad/s], NaN when unknown.
    :ivar source: the file read.

    """

    t_s: FloatArray
    q_rad: FloatArray
    dq_rad_s: FloatArray
    tau_measured_Nm: FloatArray  # noqa: N815 - the CSV column name, with its unit
    joint: int
    test_set: str
    nominal_speed_rad_s: float
    source: str

    def __iter__(self):
        """Unpack as (t_s, q_rad, dq_rad_s, tau_measured_Nm)."""
        return iter((self.t_s, self.q_rad, self.dq_rad_s, self.tau_measured_Nm))

    def __len__(self) -> int:
        """Return the number of samples."""
        return int(self.t_s.size)


def speed_from_label(label: str) -> float:
    """Return the speed of a folder label: ``p8`` -> 0.8, ``p15`` -> 0.15, ``1p1`` -> 1.1."""
    if not re.fullmatch(r'\d*p?\d*', label) or not label.strip('p'):
        raise RecordingError(f'not a speed label: {label!r}')
    return float(label.replace('p', '.') if not label.startswith('p')
                 else '0.' + label[1:])


def parse_run_name(path: str | os.PathLike) -> tuple[str, int, float]:
    """Return (test set, joint number, nominal speed [rad/s]) of a KUKA run file name."""
    stem = Path(path).name
    for suffix in ('.gz', '.csv'):
        stem = stem[:-len(suffix)] if stem.endswith(suffix) else stem
    match = _RUN_NAME.match(stem)
    if match is None:
        return stem, 0, float('nan')
    return match['set'], int(match['joint']), speed_from_label(match['label'])


def read_raw_csv(path: str | os.PathLike, *,
                 columns: tuple[str, ...] = KUKA_COLUMNS) -> tuple[FloatArray, ...]:
    """
    Read a (gzip) CSV with a header row; return the named columns as float arrays (n,).

    Read with bounds as it is read (:class:`~robot_wear_monitor.input_files.TextLines`: a
    regular file, at most :data:`~robot_wear_monitor.input_files.MAX_RAW_RUN_BYTES` of text,
    decompressed ones for ``.gz``, lines of at most ``MAX_TABLE_LINE_CHARS``, at most
    ``MAX_RAW_RUN_SAMPLES`` rows); the rows are parsed a block of lines at a time, and an error
    names the file and the line.

    :raises RecordingError: the file is missing, not a regular file, past a limit, not UTF-8,
        not CSV, lacks a column or has no rows.

    """
    reader = TextLines(path, what='raw run', limit_bytes=MAX_RAW_RUN_BYTES,
                       line_limit_chars=MAX_TABLE_LINE_CHARS, error=RecordingError)
    name = reader.name
    parts: list[FloatArray] = []
    samples = 0
    with reader:
        header: list[str] | None = None
        for first, block in reader.blocks():
            if header is None:
                head, _, block = block.partition('\n')
                header = [h.strip() for h in head.split(',')]
                missing = [c for c in columns if c not in header]
                if missing:
                    raise RecordingError(f'{name}: missing column {shorten(missing[0])!r} '
                                         f'(header: {shorten(",".join(header))})')
                usecols = [header.index(c) for c in columns]
                first += 1
            if block.isspace() or not block:
                continue  # blank lines (the parser is slow on them)
            parts.append(_parsed_rows(block, first, usecols, name))
            samples += parts[-1].shape[0]
            if samples > MAX_RAW_RUN_SAMPLES:
                last = first + block.count('\n') - 1
                raise RecordingError(f'{name}: line {last}: more than the limit of '
                                     f'{MAX_RAW_RUN_SAMPLES} samples (rows) of a raw run')
    data = np.concatenate(parts) if parts else np.empty((0, len(columns)))
    if data.shape[0] == 0:
        raise RecordingError(f'{name}: no data rows')
    return tuple(np.ascontiguousarray(data[:, i]) for i in range(len(columns)))


def _parsed_rows(block: str, first_line: int, usecols: list[int], name: str) -> FloatArray:
    """Return the rows of ``block`` (lines from ``first_line``) as an (n, columns) array."""
    def parse(text: str) -> FloatArray:
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')  # "input contained no data": an empty block
            return np.loadtxt(io.StringIO(text), delimiter=',', dtype=np.float64, ndmin=2,
                              usecols=usecols)

    try:
        return parse(block)
    except ValueError:
        pass
    for offset, line in enumerate(block.split('\n')):  # find the line and say why
        try:
            parse(line)
        except ValueError as error:
            reason = str(error).splitlines()[0] if str(error) else 'not numbers'
            reason = re.sub(r' at row \d+, column (\d+)\.?$', r' (column \1)', reason)
            reason = re.sub(r' at row \d+', '', reason)
            raise RecordingError(f'{name}: line {first_line + offset}: not a numeric CSV row: '
                                 f'{shorten(reason, 160)}') from None
    raise RecordingError(f'{name}: line {first_line}: not a numeric CSV block')


def read_kuka_run(path: str | os.PathLike) -> RawRun:
    """
    Read one KUKA iiwa run ``raw_runs/<set>_<vel_label>.csv.gz`` into a :class:`RawRun`.

    The arrays are unpackable: ``t_s, q_rad, dq_rad_s, tau_measured_Nm = read_kuka_run(p)``.
    """
    t, q, dq, tau = read_raw_csv(path)
    test_set, joint, speed = parse_run_name(path)
    return RawRun(t_s=t, q_rad=q, dq_rad_s=dq, tau_measured_Nm=tau, joint=joint,
                  test_set=test_set, nominal_speed_rad_s=speed, source=str(path))


def list_kuka_runs(directory: str | os.PathLike, *, test_set: str | None = None) -> list[Path]:
    """
    Return the run files of a KUKA data folder (or its ``raw_runs``), sorted by speed.

    :param directory: the ``kuka_iiwa_yezhao_drake`` folder or its ``raw_runs`` subfolder.
    :param test_set: keep only this set, e.g. ``joint3`` or ``joint5_new_pose_friction_test``.

    """
    folder = Path(directory)
    if (folder / 'raw_runs').is_dir():
        folder = folder / 'raw_runs'
    if not folder.is_dir():
        raise RecordingError(f'{folder}: not a folder')
    files = sorted(folder.glob('*.csv.gz'))
    if test_set is not None:
        files = [f for f in files if parse_run_name(f)[0] == test_set]
    return sorted(files, key=lambda f: (parse_run_name(f)[0], parse_run_name(f)[2]))


def read_author_table(path: str | os.PathLike) -> tuple[FloatArray, FloatArray]:
    """
    Read a processed table ``FRICTION_*_SET_JOINT*.dat``: (velocity [rad/s], torque [N m]).

    Rows are returned sorted by |velocity|.  Read with a bound (a regular file, at most
    :data:`~robot_wear_monitor.input_files.MAX_LEVEL_TABLE_BYTES`).
    """
    text = read_text_file(path, what='processed table', limit_bytes=MAX_LEVEL_TABLE_BYTES,
                          error=RecordingError)
    try:
        data = np.loadtxt(io.StringIO(text), dtype=np.float64, ndmin=2)
    except ValueError as error:
        raise RecordingError(f'{shorten(path, 200)}: cannot read table: '
                             f'{shorten(str(error).splitlines()[0], 160)}') from None
    if data.shape[1] != 2 or data.shape[0] == 0:
        raise RecordingError(f'{path}: expected two columns, got shape {data.shape}')
    order = np.argsort(np.abs(data[:, 0]))
    return data[order, 0].copy(), data[order, 1].copy()


def kuka_segmenter_config(**overrides: Any) -> SegmenterConfig:
    """
    Return :func:`~robot_wear_monitor.experiment.segmentation_settings.raw_run_segmenter_config`.

    Deprecated (a :class:`DeprecationWarning`; removed in the release after next): the same
    settings under their one name, ``raw_run_segmenter_config``.
    """
    warnings.warn('robot_wear_monitor.recordings.tables.kuka_segmenter_config is deprecated and '
                  'will be removed: use robot_wear_monitor.experiment.segmentation_settings.'
                  'raw_run_segmenter_config', DeprecationWarning, stacklevel=2)
    return raw_run_segmenter_config(**overrides)


def with_standstill_speed(config: SegmenterConfig,
                          standstill_speed_rad_s: float) -> SegmenterConfig:
    """
    Return ``config`` with the user's standstill threshold [rad/s, motor side].

    The absolute constant-speed band is kept within half the threshold, so that a run just
    above it is not taken for one at another speed.
    """
    threshold = float(standstill_speed_rad_s)
    return replace(config, standstill_speed_rad_s=threshold,
                   speed_tolerance_rad_s=min(config.speed_tolerance_rad_s, 0.5 * threshold))


def slow_run_config(config: SegmenterConfig, velocity_rad_s: Any) -> SegmenterConfig | None:
    """
    Return settings whose standstill threshold follows the run's speed noise, or None.

    For a run slower than the configured standstill threshold (motor side): the velocity's
    noise std is estimated from its sample-to-sample differences (median absolute deviation),
    and the threshold becomes 5 noise std, the absolute speed band 3 noise std (at most the
    configured ones).  None when the noise is as large as the run's speed (then the run is too
    slow to tell from standstill) or the run is not slower than the threshold.
    """
    v = np.asarray(velocity_rad_s, dtype=float) * config.gear_ratio
    v = v[np.isfinite(v)]
    if v.size < 10:
        return None
    typical = float(np.median(np.abs(v)))
    if typical > config.standstill_speed_rad_s:
        return None
    noise = 1.4826 * float(np.median(np.abs(np.diff(v)))) / math.sqrt(2.0)
    standstill = 5.0 * noise
    if not 0.0 < standstill < 0.5 * typical:
        return None
    return replace(config, standstill_speed_rad_s=standstill,
                   speed_tolerance_rad_s=min(config.speed_tolerance_rad_s,
                                             max(3.0 * noise, 0.05 * typical)))
