"""
Friction levels of a recording, as ``robot-wear-monitor segment`` writes them (CSV).

:func:`segment_bag` segments the joints of a ROS 2 bag as the replay does (joint discovery,
chunked reading, the per-joint services of :mod:`~robot_wear_monitor.monitoring.joints`) and
numbers each level by the experiment it belongs to; :func:`segment_raw_csv` segments a raw
run or a folder of them with the raw-run settings (the one reading of
:mod:`~robot_wear_monitor.recordings.raw_runs`).  :func:`levels_csv_text` formats the levels as
the CSV table ``audit`` and ``identify`` read.  Speeds are motor-side [rad/s], frictions
normalised torque (effort / torque_scale), times [s].
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
import io
import os
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import against_the_motion, FrictionLevel, with_other_sign
from robot_wear_monitor.experiment.segmentation import ExperimentAssembler
from robot_wear_monitor.experiment.segmentation_settings import raw_run_segmenter_config
from robot_wear_monitor.recordings.raw_runs import (folder_joint_name, folder_runs, no_level_error,
                                                    read_raw_runs, run_label)
from robot_wear_monitor.recordings.tables import read_raw_csv, with_standstill_speed
from robot_wear_monitor.text import escaped

#: Columns of the level CSV, in order.
LEVEL_COLUMNS = ('speed', 'friction', 'friction_std_error', 'tau_forward', 'tau_backward',
                 'n_forward', 'n_backward', 'position_min_rad', 'position_max_rad',
                 'start_time_s', 'end_time_s', 'experiment', 'joint')


@dataclass
class SegmentedLevels:
    """
    The friction levels of a recording and what was found per joint.

    :ivar rows: (level, experiment index or '' when the level is in no experiment, joint name).
    :ivar notes: the reader's notes on the recording (bag input).
    :ivar joints: one :func:`~robot_wear_monitor.monitoring.replay.joint_summary` per monitored
        joint (bag input).
    :ivar rejections: raw-run input: the segmentation's rejection counts by reason.
    :ivar n_levels: raw-run input: the levels segmented (also those in no experiment at
        ``speeds_rad_s``).

    """

    rows: list[tuple[FrictionLevel, Any, str]]
    notes: list[str] = field(default_factory=list)
    joints: list[dict[str, Any]] = field(default_factory=list)
    rejections: dict[str, int] = field(default_factory=dict)
    n_levels: int = 0


def segment_raw_csv(path: str | os.PathLike, *, gear_ratio: Optional[float] = None,
                    torque_scale: Optional[float] = None,
                    speeds_rad_s: Optional[Sequence[float]] = None,
                    standstill_speed_rad_s: Optional[float] = None,
                    position_bins: Optional[int] = None,
                    speed_tolerance: Optional[float] = None, raw_sign: bool = False,
                    joint: Optional[str] = None) -> SegmentedLevels:
    """
    Segment one raw run, or a folder of raw runs, with the raw-run settings (ratio, scale 1).

    The one reading of raw runs of every verb
    (:func:`~robot_wear_monitor.recordings.raw_runs.read_raw_runs`: each run's speed band from
    its own noise or ``speed_tolerance``, a fraction of the speed; one-way runs of a folder
    paired across runs; the friction's sign from the data per joint unless ``raw_sign``).
    ``path``: a raw run or a folder of them (``*.csv``, ``*.csv.gz``, any names).
    ``gear_ratio`` / ``torque_scale`` / ``standstill_speed_rad_s``: override the raw-run
    settings when not None (a set standstill threshold is used also for a slow run);
    ``speeds_rad_s``: assemble the levels into experiments at these speeds (otherwise a level's
    experiment is its run's file name); ``position_bins``: one level per speed set-point by
    eq. (3) over this many position bins (:mod:`~robot_wear_monitor.experiment.position_bins`,
    for low-rate logs; one run) instead of one per pass pair.  ``joint``: the joint name of
    runs that name none (default their folder's name).  The notes say what the reading decided
    and how many runs were used and unused, each unused one with its reason.

    :raises InputError: no run gave a level (every run's reason said).

    """
    overrides = {k: val for k, val in (('gear_ratio', gear_ratio),
                                       ('torque_scale', torque_scale)) if val is not None}
    config = raw_run_segmenter_config(**overrides)
    if standstill_speed_rad_s is not None:  # the user's threshold, also for a slow run
        config = with_standstill_speed(config, standstill_speed_rad_s)
    folder = Path(path).is_dir()
    if position_bins is not None:
        if folder:
            raise InputError('--position-bins is for one raw run, not a folder')
        return _position_binned(path, config=config, n_bins=position_bins,
                                speeds_rad_s=speeds_rad_s, raw_sign=raw_sign)
    paths = folder_runs(path) if folder else [Path(path)]
    if not paths:
        raise InputError(f'{path}: no raw runs here: a folder of raw runs holds *.csv or '
                         '*.csv.gz files with the columns t_s, q_rad, dq_rad_s, '
                         'tau_measured_Nm (any names)')
    reading = read_raw_runs(paths, config=config,
                            standstill_set=standstill_speed_rad_s is not None,
                            speed_tolerance=speed_tolerance, raw_sign=raw_sign, joint=joint)
    if not reading.levels:
        if not folder:  # one run: its reason is the error
            raise InputError(f'{path}: no friction level: '
                             f'{next(iter(reading.unused.values()), "no level")}')
        raise no_level_error(reading, n_paths=len(paths))
    rows: list[tuple[FrictionLevel, Any, str]] = [(row.level, row.experiment, row.joint)
                                                  for row in reading.levels]
    if speeds_rad_s:
        rows = []
        for name in dict.fromkeys(row.joint for row in reading.levels):
            assembler = ExperimentAssembler(speeds_rad_s=speeds_rad_s)
            done = [x for row in reading.levels if row.joint == name
                    for x in assembler.add(row.level)] + assembler.flush()
            rows += [(level, k, name) for k, x in enumerate(done) for level in x.levels]
    return SegmentedLevels(rows=rows, rejections=dict(reading.rejections),
                           n_levels=len(reading.levels),
                           notes=reading.report_lines() if folder else list(reading.notes))


def _position_binned(path: Any, *, config: Any, n_bins: int,
                     speeds_rad_s: Optional[Sequence[float]], raw_sign: bool) -> SegmentedLevels:
    """Return the levels of one low-rate run over position bins, signed from the data."""
    # deferred import: start-up time (position bins: low-rate raw runs only)
    from robot_wear_monitor.experiment.position_bins import position_binned_levels
    t, q, v, e = read_raw_csv(path)
    levels, rejections = position_binned_levels(
        time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config,
        n_bins=n_bins, speeds_rad_s=speeds_rad_s)
    if not levels:
        raise InputError(f'{path}: no friction level over {n_bins} position bins: '
                         f'no speed set-point has a bin with 2 samples each way '
                         f'({sum(rejections.values())} set-points without one)')
    notes = []
    against, median = against_the_motion([level.friction for level in levels])
    if against and not raw_sign:  # friction opposes the motion: the data decide
        levels = [with_other_sign(level) for level in levels]
        notes.append(f'{run_label(path)}: the eq. (3) friction comes out negative in the '
                     f'recorded sign (median {median:.4g}): read with the other sign '
                     '(--raw-sign keeps the recorded sign)')
    name = folder_joint_name(path)
    return SegmentedLevels(rows=[(level, run_label(path), name) for level in levels],
                           rejections=dict(rejections), n_levels=len(levels), notes=notes)


def segment_bag(path: str | os.PathLike, *, experiment_parameters: Mapping[str, Any],
                topic: str = '/joint_states',
                speeds_rad_s: Optional[Sequence[float]] = None) -> SegmentedLevels:
    """
    Segment the joints of a bag as the replay does; raise NoExperimentError on no level.

    ``experiment_parameters``: the validated friction experiment node parameters (e.g. of
    :func:`~robot_wear_monitor.monitoring.replay.replay_parameters`); ``speeds_rad_s``: keep
    only experiments at these motor speeds [rad/s] (``experiment_speeds_rad_s``).
    """
    # deferred import: start-up time (the replay, rosbags: bags only)
    from robot_wear_monitor.monitoring.joints import JointExperiments
    from robot_wear_monitor.monitoring.replay import (explain_recording, joint_summary,
                                                      NoExperimentError)
    from robot_wear_monitor.recordings.bags import iter_joint_chunks
    experiment = dict(experiment_parameters)
    if speeds_rad_s:
        # deferred import: start-up time (the node configuration: bags only)
        from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                               validate_parameters)
        experiment = validate_parameters(
            FRICTION_EXPERIMENT_NODE, {**experiment, 'experiment_speeds_rad_s': speeds_rad_s},
            source='--speeds')
    by_joint = JointExperiments(experiment, source='segment parameters')
    stream = iter_joint_chunks(path, joints=by_joint.selection, topic=topic,
                               require_joints=False)
    found: dict[str, list] = {}
    for chunk in stream:
        for name, samples in chunk.items():
            service = by_joint.service(name)
            found.setdefault(name, []).extend(service.add_recording(
                time_s=samples.time_s, position_rad=samples.position_rad,
                velocity_rad_s=samples.velocity_rad_s, effort=samples.effort))
    for service, done in by_joint.finish():
        found.setdefault(service.joint, []).append(done)
    result = SegmentedLevels(rows=[], notes=list(stream.notes))
    for name, service in by_joint.services.items():
        experiments = found.get(name, [])
        for level in service.levels:
            k = next((i for i, x in enumerate(experiments)
                      if x.start_time_s <= level.start_time_s
                      and level.end_time_s <= x.end_time_s), '')
            result.rows.append((level, k, name))
        result.joints.append(joint_summary(service, stream))
    if not result.rows:
        raise NoExperimentError(f'no friction level: {explain_recording(by_joint, stream)}')
    return result


def levels_csv_text(rows: Sequence[tuple[FrictionLevel, Any, str]], *,
                    robot: str | None = None,
                    extra: Mapping[str, Sequence[Any]] | None = None,
                    terminal: bool = False) -> str:
    """
    Return the level CSV (header :data:`LEVEL_COLUMNS`) of ``rows`` as text.

    ``robot``: a last column ``robot`` with this name (none when None); ``extra``: more
    columns after it, name -> one value per row (a float written with 6 significant digits).
    ``terminal``: the text goes to a terminal; the text cells (experiment, joint, robot, extra
    text) have their control characters escaped (:func:`~robot_wear_monitor.text.escaped`),
    so that a joint's name from a recording reaches no terminal raw (a file keeps the text).
    """
    text = io.StringIO()
    writer = csv.writer(text)
    extra = dict(extra or {})
    writer.writerow(list(LEVEL_COLUMNS) + (['robot'] if robot is not None else [])
                    + list(extra))

    def cell(value: Any) -> Any:
        return escaped(value) if terminal and isinstance(value, str) else value

    robot_cell = [cell(robot)] if robot is not None else []
    for i, (level, k, joint) in enumerate(rows):
        more = [f'{v[i]:.6g}' if isinstance(v[i], float) else cell(v[i])
                for v in extra.values()]
        writer.writerow([f'{level.speed_rad_s:.6g}', f'{level.friction:.6g}',
                         f'{level.friction_std_error:.3g}', f'{level.tau_forward:.6g}',
                         f'{level.tau_backward:.6g}', level.n_forward, level.n_backward,
                         f'{level.position_min_rad:.6g}', f'{level.position_max_rad:.6g}',
                         f'{level.start_time_s:.6f}', f'{level.end_time_s:.6f}',
                         cell(k), cell(joint),
                         *robot_cell, *more])
    return text.getvalue()
