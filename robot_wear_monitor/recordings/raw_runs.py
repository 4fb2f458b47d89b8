"""
One reading of measured raw runs for ``segment``, ``identify`` and ``audit``.

A raw run is a CSV (or ``.csv.gz``) with the columns ``t_s, q_rad, dq_rad_s, tau_measured_Nm``
(time [s], position [rad], velocity [rad/s], torque in its own unit, recorded sign), as
:mod:`robot_wear_monitor.recordings.tables` reads it.  This module reads one run or a folder
of runs the one way every verb uses:

* **Files.**  A folder's runs are its ``*.csv`` and ``*.csv.gz`` files with the raw-run
  columns (or those of its ``raw_runs`` subfolder), with any names.  A run's label is its file
  name without ``.csv``/``.csv.gz``.  All runs of a folder are one joint unless a file name
  starts with ``joint<k>_`` (the KUKA runs: joint k), or a run has a ``joint`` column (its
  value, the same on every row); a joint without either is named after the folder.
* **Steadiness.**  A plateau is steady when its speed stays within a band of the run's own
  speed noise and quantisation (:func:`run_settings`: the band is at least
  :data:`~robot_wear_monitor.experiment.segmentation_settings.RAW_RUN_NOISE_BAND` times the
  speed's noise about its running median, and one quantum of a quantised speed signal), or
  within ``--speed-tolerance`` (a fraction of the speed) when given; a gap is a time step
  longer than the configured ``max_gap_s`` or 3 of the run's sample steps.
* **Levels.**  Each run is segmented into eq. (3) levels (pass pairs within the run); runs that
  move one way only are paired across runs of the same joint: each forward pass with the
  backward pass of another run whose speed is the closest (within the tolerance), over their
  common position window, or over the whole passes when they share none (recordings whose
  position is not measured; gravity is then taken to be the same in both, which the output
  says).  A one-way run without a partner uses ``known_torque`` when given.
* **Sign.**  Friction opposes the motion: per joint, from all its levels together, a joint
  whose eq. (3) friction comes out negative (median) in the recorded sign is read with the
  other sign (the KUKA files' convention), and a note says so; ``raw_sign`` keeps the recorded
  sign.
* **Report.**  Every run is counted used or unused, and every unused run named with its reason
  (:func:`unused_reason`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
import math
import os
from pathlib import Path
import re
from typing import Any, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import against_the_motion, FrictionLevel, with_other_sign
from robot_wear_monitor.experiment.segmentation_settings import (RAW_RUN_NOISE_BAND,
                                                                 SegmenterConfig)
from robot_wear_monitor.input_files import (MAX_LEVEL_TABLE_BYTES, MAX_TABLE_LINE_CHARS,
                                            TextLines)
from robot_wear_monitor.recordings.tables import (KUKA_COLUMNS, parse_run_name, RawRun,
                                                  read_raw_csv, RecordingError, slow_run_config)
from robot_wear_monitor.text import shorten


_JOINT_PREFIX = re.compile(r'^joint(\d+)_')
#: Samples of the running median the speed noise is measured about.
_NOISE_WINDOW = 101


def run_label(path: str | os.PathLike) -> str:
    """Return the label of a raw run: its file name without ``.csv`` or ``.csv.gz``."""
    name = Path(path).name
    for suffix in ('.gz', '.csv'):
        name = name[:-len(suffix)] if name.endswith(suffix) else name
    return name


def raw_run_header(path: str | os.PathLike) -> list[str] | None:
    """Return the header cells of a CSV(.gz) file (read bounded), None when unreadable."""
    try:
        with TextLines(path, what='table', limit_bytes=MAX_LEVEL_TABLE_BYTES,
                       line_limit_chars=MAX_TABLE_LINE_CHARS) as lines:
            return [h.strip() for h in next(iter(lines), '').split(',')]
    except InputError:
        return None


def is_raw_run(path: str | os.PathLike) -> bool:
    """Return True when the first line of ``path`` names the raw-run columns."""
    header = raw_run_header(path)
    return header is not None and set(KUKA_COLUMNS) <= set(header)


def folder_runs(folder: str | os.PathLike) -> list[Path]:
    """
    Return the raw runs of a folder (or of its ``raw_runs`` subfolder), sorted by name.

    The runs are the ``*.csv`` and ``*.csv.gz`` files whose header names the raw-run columns
    ``t_s, q_rad, dq_rad_s, tau_measured_Nm``; other files are not runs.
    """
    path = Path(folder)
    if (path / 'raw_runs').is_dir():
        path = path / 'raw_runs'
    files = sorted(p for p in path.iterdir()
                   if p.is_file() and p.name.endswith(('.csv', '.csv.gz')))
    return [p for p in files if is_raw_run(p)]


def joint_of_run(path: str | os.PathLike, header: Sequence[str] | None = None) -> str:
    """
    Return the joint of a raw run, or '' (the folder's one joint).

    ``joint<k>`` of a ``joint<k>_`` file name, else the value of its ``joint`` column.

    :raises RecordingError: the ``joint`` column holds more than one value.

    """
    match = _JOINT_PREFIX.match(Path(path).name)
    if match:
        return f'joint{int(match[1])}'
    header = list(header) if header is not None else (raw_run_header(path) or [])
    if 'joint' not in header:
        return ''
    index = header.index('joint')
    values: set[str] = set()
    with TextLines(path, what='raw run', limit_bytes=MAX_LEVEL_TABLE_BYTES * 64,
                   line_limit_chars=MAX_TABLE_LINE_CHARS, error=RecordingError) as lines:
        for number, line in enumerate(lines):
            cells = line.split(',')
            if number and len(cells) > index and cells[index].strip():
                values.add(cells[index].strip())
    if len(values) > 1:
        raise RecordingError(f'{shorten(Path(path).name, 120)}: the joint column holds '
                             f'{len(values)} joints ({shorten(", ".join(sorted(values)))}); '
                             'a raw run is one joint')
    value = values.pop() if values else ''
    try:
        return f'{float(value):g}'
    except ValueError:
        return value


def folder_joint_name(path: str | os.PathLike) -> str:
    """Return the name of the joint of runs that name none: their folder's name."""
    folder = Path(path).resolve().parent
    if folder.name == 'raw_runs' and folder.parent.name:
        folder = folder.parent
    return folder.name or 'joint'


# --------------------------------------------------------------------------- steadiness

def speed_noise(velocity_rad_s: Any, *, gear_ratio: float,
                standstill_speed_rad_s: float) -> tuple[float, float]:
    """
    Return (noise std, quantum) of a run's moving speed [rad/s, motor side].

    The noise is the scatter of |speed| about its running median (:data:`_NOISE_WINDOW`
    samples) over the samples above standstill: the mean of the 75 % smallest absolute
    deviations / 0.5147 (the std of a normal noise; robust to the ramps, continuous for a
    quantised signal), at most 3 times the std of the sample-to-sample steps / sqrt(2) (a slow
    swing of the speed is no noise).  The quantum is the step of a speed
    signal whose values lie on a grid (each distinct value used 10 times on average and the
    steps multiples of the smallest), else 0.
    """
    # deferred import: start-up time (scipy.ndimage)
    from scipy.ndimage import median_filter
    speed = np.abs(np.asarray(velocity_rad_s, dtype=float)) * gear_ratio
    moving = speed[np.isfinite(speed) & (speed > standstill_speed_rad_s)]
    if moving.size < 10:
        return 0.0, 0.0
    residual = np.abs(moving - median_filter(moving, size=_NOISE_WINDOW, mode='nearest'))
    # the mean of the 75 % smallest |residuals| is 0.5147 std of a normal noise: robust to the
    # ramps (their samples are the largest) and continuous for a quantised signal
    residual = residual[residual <= np.quantile(residual, 0.75)]
    wander = float(residual.mean()) / 0.5147 if residual.size else 0.0
    # noise changes from sample to sample; a slow swing of the speed (an overshoot, a
    # controller's oscillation) is no noise but an unsteady speed: at most 3 x the noise
    # seen in the sample-to-sample steps (their std / sqrt(2), estimated the same way)
    steps = np.abs(np.diff(moving))
    steps = steps[steps <= np.quantile(steps, 0.75)]
    white = float(steps.mean()) / 0.5147 / math.sqrt(2.0) if steps.size else 0.0
    noise = min(wander, 3.0 * white)
    distinct = np.unique(np.round(moving, 9))
    steps = np.diff(distinct)
    steps = steps[steps > 0]
    quantum = 0.0
    if steps.size and distinct.size * 10 <= moving.size:
        smallest = float(steps.min())
        ratio = steps / smallest
        if float(np.median(np.abs(ratio - np.round(ratio)))) < 0.05:
            quantum = smallest
    return noise, quantum


def run_settings(config: SegmenterConfig, time_s: Any, velocity_rad_s: Any, *,
                 speed_tolerance: float | None = None) -> SegmenterConfig:
    """
    Return the settings of one run: its speed band and its gap from its own signal.

    ``speed_tolerance``: a fraction of the speed (``--speed-tolerance``) that replaces the
    noise band (the configured absolute band stays the least).  Without it the absolute band
    is widened to :data:`RAW_RUN_NOISE_BAND` noise std and one quantum
    (:func:`speed_noise`).  ``max_gap_s`` becomes at least 3 of the run's median sample steps
    (a log at 20 Hz is not a gap at every sample).
    """
    t = np.asarray(time_s, dtype=float)
    steps = np.diff(t[np.isfinite(t)])
    steps = steps[steps > 0]
    gap = max(config.max_gap_s, 3.0 * float(np.median(steps))) if steps.size else \
        config.max_gap_s
    if speed_tolerance is not None:
        return replace(config, speed_tolerance_fraction=float(speed_tolerance), max_gap_s=gap)
    noise, quantum = speed_noise(velocity_rad_s, gear_ratio=config.gear_ratio,
                                 standstill_speed_rad_s=config.standstill_speed_rad_s)
    band = max(config.speed_tolerance_rad_s, RAW_RUN_NOISE_BAND * noise, 1.01 * quantum)
    return replace(config, speed_tolerance_rad_s=band, max_gap_s=gap)


def unused_reason(time_s: Any, velocity_rad_s: Any, rejections: Any,
                  config: SegmenterConfig) -> str:
    """
    Return why a raw run gave no friction level, in words with its numbers.

    In order: no moving sample; too slow against the standstill threshold in use (fewer than
    ``min_samples`` samples above it); the longest move shorter than a plateau needs at the
    run's rate; the speed not steady within the tolerance (the longest in-band stretch of the
    longest move is too short); passes each way never paired.
    """
    t = np.asarray(time_s, dtype=float)
    signed = np.asarray(velocity_rad_s, dtype=float) * config.gear_ratio
    speed = np.abs(signed)
    finite = np.isfinite(speed) & np.isfinite(t)
    threshold = config.standstill_speed_rad_s
    if not finite.any():
        return 'no finite velocity sample'
    moving = finite & (speed > threshold)
    if np.count_nonzero(moving) < config.min_samples:
        typical = float(np.median(speed[finite]))
        return (f'too slow to tell from standstill at {typical:.3g} rad/s (the standstill '
                f'threshold in use is {threshold:g} rad/s; {int(np.count_nonzero(moving))} '
                f'samples above it, fastest {float(speed[finite].max()):.3g} rad/s)')
    typical = float(np.median(speed[moving]))
    direction = np.where(moving, np.sign(signed), 0).astype(int)
    # the longest move: a run of samples with one direction above standstill, no gap
    best = (0, 0)
    start = None
    for i in range(direction.size + 1):
        same = (i < direction.size and direction[i] != 0 and start is not None
                and direction[i] == direction[start]
                and t[i] - t[i - 1] <= config.max_gap_s)
        if same:
            continue
        if start is not None and i - start > best[1] - best[0]:
            best = (start, i)
        start = i if i < direction.size and direction[i] != 0 else None
    begin, end = best
    duration = float(t[end - 1] - t[begin]) if end > begin else 0.0
    steps = np.diff(t[finite])
    rate = 1.0 / float(np.median(steps[steps > 0])) if np.any(steps > 0) else math.nan
    needed = config.min_duration_s + 2.0 * config.trim_s
    if duration < needed or end - begin < config.min_samples:
        return (f'plateau shorter than needed at its rate: the longest move lasts '
                f'{duration:.3g} s ({end - begin} samples at {rate:.3g} Hz, {typical:.3g} '
                f'rad/s); a level needs {config.min_duration_s:g} s and '
                f'{config.min_samples} samples per pass')
    move = speed[begin:end]
    level = float(np.median(move))
    band = max(config.speed_tolerance_fraction * level, config.speed_tolerance_rad_s)
    inside = np.abs(move - level) <= band
    padded = np.concatenate(([False], inside, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    longest = int(np.max(edges[1::2] - edges[0::2])) if edges.size else 0
    if rejections.get('pass_too_short', 0) or longest < config.min_samples:
        spread = float(np.std(move))
        return (f'speed not steady within the tolerance: at {level:.3g} rad/s the speed '
                f'scatters by {spread:.3g} rad/s ({100 * spread / level:.0f} %), the band is '
                f'+-{band:.3g} rad/s and its longest stretch inside is {longest} samples '
                f'(give --speed-tolerance FRACTION to widen it)')
    if rejections.get('pass_unpaired', 0) or rejections.get('pass_no_common_window', 0):
        return ('passes each way, but none paired with one the other way at the same speed '
                f'over a common position window (unpaired {rejections.get("pass_unpaired", 0)}'
                f', no common window {rejections.get("pass_no_common_window", 0)})')
    return f'no constant-speed plateau of {config.min_duration_s:g} s or more'


# --------------------------------------------------------------------------- reading

@dataclass
class RunLevel:
    """
    One friction level of raw runs, with where it came from.

    :ivar level: the level, friction in the joint's sign (see :class:`RawRunsReading`).
    :ivar experiment: the run's label, or ``<run>+<run>`` for a pair across runs.
    :ivar joint: the joint's name.
    :ivar run: the (first) run read.
    :ivar cycle: index of the level in its run.
    :ivar duration_s: the run's (the longer run's) duration [s].
    :ivar how: ``within`` (a pass pair of one run), ``window`` (a pair across runs over a
        common position window), ``whole`` (across runs over the whole passes) or ``known``
        (one pass minus a known torque).

    """

    level: FrictionLevel
    experiment: str
    joint: str
    run: RawRun
    cycle: int
    duration_s: float
    how: str = 'within'


@dataclass
class RawRunsReading:
    """
    The levels of a set of raw runs and what became of every run.

    :ivar levels: the levels, in run order.
    :ivar used: labels of the runs that gave a level.
    :ivar unused: label -> the reason a run gave none.
    :ivar notes: what the reading decided (a joint read with the other sign, pairs over whole
        passes), one sentence each.
    :ivar flipped: joints read with the other sign.
    :ivar rejections: the segmentation's rejection counts of all runs, by reason.

    """

    levels: list[RunLevel] = field(default_factory=list)
    used: list[str] = field(default_factory=list)
    unused: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    flipped: list[str] = field(default_factory=list)
    rejections: Counter = field(default_factory=Counter)

    def count_text(self) -> str:
        """Return ``N raw runs: U used, K unused`` and the reasons, one line per unused run."""
        total = len(self.used) + len(self.unused)
        lines = [f'{total} raw run(s): {len(self.used)} used, {len(self.unused)} unused']
        lines += [f'  unused {label}: {reason}' for label, reason in self.unused.items()]
        return '\n'.join(lines)

    def report_lines(self) -> list[str]:
        """Return the notes and the count, for stderr."""
        return list(self.notes) + self.count_text().splitlines()


def read_raw_runs(paths: Sequence[str | os.PathLike], *, config: SegmenterConfig,
                  standstill_set: bool = False, speed_tolerance: float | None = None,
                  raw_sign: bool = False, joint: str | None = None,
                  known_torque: str | None = None) -> RawRunsReading:
    """
    Segment raw runs into eq. (3) levels, the one way of every verb (see the module).

    :param paths: the run files.
    :param config: the raw-run settings (standstill threshold in use included).
    :param standstill_set: the user set the standstill threshold (a slow run keeps it).
    :param speed_tolerance: ``--speed-tolerance``, a fraction of the speed, or None.
    :param raw_sign: keep the recorded sign (``--raw-sign``).
    :param joint: ``--joint``: the name of the joint of runs that name none.
    :param known_torque: a column subtracted from one-way runs without a partner.

    """
    # deferred import: start-up time (segmentation: not every reader of runs needs it)
    from robot_wear_monitor.experiment.position_bins import low_rate_reason
    from robot_wear_monitor.experiment.segmentation import one_way_passes, segment_batch
    reading = RawRunsReading()
    one_way: list[tuple[str, str, RawRun, Any, SegmenterConfig, Path]] = []
    for path in paths:
        file = Path(path)
        label = run_label(file)
        header = raw_run_header(file)
        name = joint_of_run(file, header) or joint or folder_joint_name(file)
        t, q, v, e = read_raw_csv(file)
        test_set, number, nominal = parse_run_name(file)
        run = RawRun(t_s=t, q_rad=q, dq_rad_s=v, tau_measured_Nm=e, joint=number,
                     test_set=test_set, nominal_speed_rad_s=nominal, source=str(file))
        settings = run_settings(config, t, v, speed_tolerance=speed_tolerance)
        result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e,
                               config=settings)
        slow = (slow_run_config(settings, v)
                if not result.levels and not standstill_set else None)
        if slow is not None:  # slower than the standstill threshold: the noise decides
            settings = slow
            result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e,
                                   config=settings)
        reading.rejections.update(result.rejections)
        if result.levels:
            duration = float(t[-1] - t[0])
            reading.levels += [RunLevel(level, label, name, run, i, duration)
                               for i, level in enumerate(result.levels)]
            reading.used.append(label)
            continue
        passes = one_way_passes(time_s=t, position_rad=q, velocity_rad_s=v, effort=e,
                                config=settings)
        if passes and len({p.direction for p in passes}) == 1:
            one_way += [(label, name, run, p, settings, file) for p in passes]
        else:
            slow_log = low_rate_reason(t, v, config)
            reading.unused[label] = (
                f'{slow_log} (segment RUN --position-bins N writes such levels as a table)'
                if slow_log is not None else unused_reason(t, v, result.rejections, settings))
    unpaired = _pair_across_runs(one_way, reading)
    for label in unpaired:
        rows = [row for row in one_way if row[0] == label]
        _, name, run, _, settings, file = rows[0]
        if known_torque is not None:
            levels = known_torque_levels(file, run, known_torque, settings)
            duration = float(run.t_s[-1] - run.t_s[0])
            reading.levels += [RunLevel(level, label, name, run, i, duration, 'known')
                               for i, level in enumerate(levels)]
            reading.used.append(label)
            continue
        way = 'forward' if rows[0][3].direction > 0 else 'backward'
        speed = float(np.median([row[3].level_rad_s for row in rows]))
        reading.unused[label] = (f'the joint moves one way only ({way}, at about {speed:.3g} '
                                 'rad/s) and no run goes the other way at the same speed to '
                                 'pair with: eq. (3) needs a pass each way (or give '
                                 '--known-torque COLUMN)')
    _set_signs(reading, raw_sign=raw_sign)
    return reading


def _pair_across_runs(one_way: list, reading: RawRunsReading) -> list[str]:
    """
    Pair one-way runs of one joint across runs; return the labels of the unpaired.

    A run's speed is the mean |speed| of its passes.  Closest speeds first: every (forward,
    backward) pair of runs of the same joint whose speeds are within twice the larger run's
    tolerance, taken in order of their relative speed difference, each run once.  Runs of one
    pass each over a common position window give eq. (3) there (gravity cancels); otherwise
    eq. (3) over all their plateau samples (:func:`whole_pass_level`).
    """
    # deferred import: start-up time (segmentation: not every reader of runs needs it)
    from robot_wear_monitor.experiment.segmentation import pair_passes, Pass
    runs: dict[str, list] = {}
    for row in one_way:
        runs.setdefault(row[0], []).append(row)
    merged = {}
    for label, rows in runs.items():
        passes = [row[3] for row in rows]
        speed = float(np.mean(np.abs(np.concatenate([p.speed_rad_s for p in passes]))))
        merged[label] = (passes[0] if len(passes) == 1 else Pass(
            direction=passes[0].direction,
            time_s=np.concatenate([p.time_s for p in passes]),
            position_rad=np.concatenate([p.position_rad for p in passes]),
            speed_rad_s=np.concatenate([p.speed_rad_s for p in passes]),
            torque=np.concatenate([p.torque for p in passes]), level_rad_s=speed), speed)
    candidates = []
    for label, rows in runs.items():
        _, name, _, first, settings, _ = rows[0]
        if first.direction < 0:
            continue
        for other, partner_rows in runs.items():
            _, partner, _, opposite, other_settings, _ = partner_rows[0]
            if opposite.direction > 0 or other == label or partner != name:
                continue
            speed, other_speed = merged[label][1], merged[other][1]
            level = max(speed, other_speed)
            tolerance = max(max(s.speed_tolerance_fraction * level, s.speed_tolerance_rad_s)
                            for s in (settings, other_settings))
            difference = abs(speed - other_speed)
            if difference <= 2.0 * tolerance:
                candidates.append((difference / level, label, other))
    paired: set[str] = set()
    whole = 0
    first_pair = len(reading.levels)
    for _, label, other in sorted(candidates):
        if label in paired or other in paired:
            continue
        _, name, run, _, settings, _ = runs[label][0]
        partner_run = runs[other][0][2]
        forward, backward = merged[label][0], merged[other][0]
        paired_level: FrictionLevel | None = None
        how = 'window'
        if len(runs[label]) == 1 and len(runs[other]) == 1:
            paired_level, _ = pair_passes(forward, backward, settings)
        if paired_level is None:
            paired_level, how = whole_pass_level(forward, backward), 'whole'
            whole += 1
        paired.update((label, other))
        duration = float(max(run.t_s[-1] - run.t_s[0],
                             partner_run.t_s[-1] - partner_run.t_s[0]))
        reading.levels.append(RunLevel(paired_level, f'{label}+{other}', name, run, 0, duration,
                                       how))
    reading.levels[first_pair:] = sorted(reading.levels[first_pair:],
                                         key=lambda row: row.level.speed_rad_s)
    reading.used += sorted(paired)
    if whole:
        reading.notes.append(
            f'{whole} pair(s) of one-way runs share no position window: eq. (3) over their '
            'whole plateaus (the load, e.g. gravity, taken to be the same both ways)')
    return sorted(set(runs) - paired)


def whole_pass_level(forward: Any, backward: Any) -> FrictionLevel:
    """Return eq. (3) of two opposite passes over all their samples (no common window)."""
    def spread(torque: FloatArray) -> float:
        return float(np.var(torque, ddof=1)) / torque.size if torque.size > 1 else math.nan

    tau_f, tau_b = float(np.mean(forward.torque)), float(np.mean(backward.torque))
    positions = np.concatenate((forward.position_rad, backward.position_rad))
    return FrictionLevel(
        speed_rad_s=0.5 * (float(np.mean(np.abs(forward.speed_rad_s)))
                           + float(np.mean(np.abs(backward.speed_rad_s)))),
        friction=0.5 * (tau_f - tau_b),
        friction_std_error=0.5 * math.sqrt(spread(forward.torque) + spread(backward.torque)),
        tau_forward=tau_f, tau_backward=tau_b, n_forward=int(forward.torque.size),
        n_backward=int(backward.torque.size), position_min_rad=float(positions.min()),
        position_max_rad=float(positions.max()),
        start_time_s=float(min(forward.time_s[0], backward.time_s[0])),
        end_time_s=float(max(forward.time_s[-1], backward.time_s[-1])))


def known_torque_levels(path: Any, run: RawRun, column: str,
                        settings: SegmenterConfig) -> list[FrictionLevel]:
    """Return one level per pass of a one-way run: direction x (torque - known torque)."""
    # deferred import: start-up time (segmentation: not every reader of runs needs it)
    from robot_wear_monitor.experiment.segmentation import one_way_passes
    (known,) = read_raw_csv(path, columns=(column,))
    passes = one_way_passes(time_s=run.t_s, position_rad=run.q_rad,
                            velocity_rad_s=run.dq_rad_s,
                            effort=run.tau_measured_Nm - known, config=settings)
    levels = []
    for p in passes:
        friction = p.direction * float(np.mean(p.torque))
        spread = float(np.std(p.torque, ddof=1)) / math.sqrt(p.torque.size) \
            if p.torque.size > 1 else math.nan
        inside = (run.t_s >= p.time_s[0]) & (run.t_s <= p.time_s[-1])
        load = float(np.mean(known[inside]))  # the known torque: the load of eq. (3)
        levels.append(FrictionLevel(
            speed_rad_s=float(np.mean(np.abs(p.speed_rad_s))), friction=friction,
            friction_std_error=spread, tau_forward=load + friction,
            tau_backward=load - friction,
            n_forward=int(p.torque.size) if p.direction > 0 else 0,
            n_backward=int(p.torque.size) if p.direction < 0 else 0,
            position_min_rad=float(p.position_rad.min()),
            position_max_rad=float(p.position_rad.max()),
            start_time_s=float(p.time_s[0]), end_time_s=float(p.time_s[-1])))
    return levels


def _set_signs(reading: RawRunsReading, *, raw_sign: bool) -> None:
    """
    Read each joint whose eq. (3) friction is negative (median) with the other sign.

    Friction opposes the motion, so eq. (3)'s (tau+ - tau-)/2 is positive when the torque is
    recorded positive along the motion; a joint whose levels come out negative has its torque
    recorded the other way (the KUKA files): its levels are negated (tau+ and tau- too) and a
    note says so.  ``raw_sign`` keeps the recorded sign (a note says when it is negative).
    """
    joints = dict.fromkeys(row.joint for row in reading.levels)
    for name in joints:
        rows = [row for row in reading.levels if row.joint == name]
        against, median = against_the_motion([row.level.friction for row in rows])
        runs = len({row.experiment for row in rows})
        if not against:
            continue
        if raw_sign:
            reading.notes.append(
                f'{name}: the eq. (3) friction of its {runs} run(s) is negative in the recorded '
                f'sign (median {median:.4g}), kept so by --raw-sign')
            continue
        for row in rows:
            row.level = with_other_sign(row.level)
        reading.flipped.append(name)
        reading.notes.append(
            f'{name}: the eq. (3) friction of its {runs} run(s) comes out negative in the '
            f'recorded sign (median {median:.4g}): the torque is recorded against the motion, '
            'so the runs are read with the other sign (--raw-sign keeps the recorded sign)')


def no_level_error(reading: RawRunsReading, *, n_paths: int) -> InputError:
    """Return the error of raw runs that gave no level: the count and every reason."""
    reasons = '; '.join(f'{label}: {reason}' for label, reason in
                        list(reading.unused.items())[:8])
    more = len(reading.unused) - 8
    one_way = sum('moves one way only' in reason for reason in reading.unused.values())
    summary = (f'; {one_way} run(s) move one way only and have no run the other way at the '
               'same speed (give --known-torque COLUMN to subtract a known torque)'
               if one_way > 1 else '')
    return InputError(f'no friction level found in {n_paths} raw run(s) (0 used, '
                      f'{len(reading.unused)} unused): {reasons}'
                      + (f'; and {more} more' if more > 0 else '') + summary)
