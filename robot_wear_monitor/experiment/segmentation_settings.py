"""
The one owner of the segmentation settings: :class:`SegmenterConfig` and its two default sets.

* :data:`STREAM_SETTINGS`, for bags and streams: the ``friction_experiment_node``'s parameter
  defaults (:mod:`robot_wear_monitor.monitoring.node_config` declares them from here, and
  ``config/wear_monitor.yaml`` holds the same values, tested).  ``segment`` and ``replay`` of a
  bag, ``audit`` and ``identify`` of a bag, the nodes, the simulation's
  :func:`~robot_wear_monitor.experiment.simulation.segmenter_config_for` and the
  ``friction_experiment_runner``'s plan use them.
* :data:`RAW_RUN_SETTINGS`, for measured raw runs (the KUKA iiwa CSV runs: link-side sensors
  at 200 Hz, a speed estimate that ripples by a few percent, torque in N m): gear ratio and
  torque scale 1, a 5 % constant-speed band of at least 0.01 rad/s, standstill below 0.03
  rad/s, plateaus of 0.3 s or more, a 0.05 s gap splits the run.  ``segment``, ``audit`` and
  ``identify`` of a raw run use them (a slow run's threshold may follow its speed noise, see
  :func:`robot_wear_monitor.recordings.tables.slow_run_config`), and each run's speed band
  and gap follow its own signal (:data:`RAW_RUN_READING`,
  :func:`robot_wear_monitor.recordings.raw_runs.run_settings`).

Speeds are motor side [rad/s] (link side where the gear ratio is 1), times [s], positions [rad].
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.setting_fields import (at_least, check_settings, fraction, in_range,
                                               non_empty, non_negative, positive, setting)

#: Segmentation settings of bags and streams: the friction_experiment_node's parameter defaults.
STREAM_SETTINGS: Mapping[str, Any] = MappingProxyType({
    'standstill_speed_rad_s': 0.1, 'speed_tolerance_fraction': 0.05,
    'speed_tolerance_rad_s': 0.05, 'min_duration_s': 0.2, 'trim_s': 0.02, 'min_samples': 20,
    'min_window_rad': 0.0, 'max_gap_s': 0.1})

#: Segmentation settings of measured raw runs (KUKA iiwa CSV runs, link side, N m).
RAW_RUN_SETTINGS: Mapping[str, Any] = MappingProxyType({
    'joint': 'kuka_joint', 'gear_ratio': 1.0, 'torque_scale': 1.0,
    'standstill_speed_rad_s': 0.03, 'speed_tolerance_fraction': 0.05,
    'speed_tolerance_rad_s': 0.01, 'min_duration_s': 0.3, 'trim_s': 0.02, 'min_samples': 20,
    'min_window_rad': 0.0, 'max_gap_s': 0.05})

#: The friction_experiment_node's gear ratio and torque scale: the packaged robot's (ABB IRB
#: 6620 joint 2, motor side, effort in units of 10 N m).  Every verb that segments a bag
#: (``segment``, ``replay``, ``audit``, ``identify``) takes them from the node configuration
#: (``--config``), whose packaged file holds these values.
NODE_SCALES: Mapping[str, float] = MappingProxyType({'gear_ratio': 150.0, 'torque_scale': 10.0})
#: How raw runs are read (:mod:`robot_wear_monitor.recordings.raw_runs`), the defaults of the
#: verbs' options: ``raw_sign`` (``--raw-sign``: keep the recorded torque sign; default the
#: data decide, per joint), ``speed_tolerance`` (``--speed-tolerance``: a fraction of the
#: speed; default None, the band follows the run's speed noise) and ``noise_band`` (that band
#: in noise std of the speed about its running median).
RAW_RUN_READING: Mapping[str, Any] = MappingProxyType({
    'raw_sign': False, 'speed_tolerance': None, 'noise_band': 4.0})
#: The steadiness band of a raw run in std of its speed noise (``RAW_RUN_READING``).
RAW_RUN_NOISE_BAND: float = RAW_RUN_READING['noise_band']


@dataclass(frozen=True)
class SegmenterConfig:
    """
    Settings of the segmentation of one joint; units are in the field names.

    The defaults are :data:`STREAM_SETTINGS` (gear ratio and torque scale 1; the node's are
    :data:`NODE_SCALES`); measured raw runs take :func:`raw_run_segmenter_config`.  Each field
    is declared once with its unit, description and check
    (:func:`robot_wear_monitor.setting_fields.setting`): the friction_experiment_node declares
    its parameters from them, and the command-line options take their help and range from them.
    """

    joint: str = setting(description='name of the joint in the JointState messages',
                         check=non_empty)
    gear_ratio: float = setting(1.0, description='motor-side speed = joint-side velocity * '
                                'gear_ratio (1 for link-side sensors)', unit='-',
                                check=in_range(0.0, 1e4, low_open=True))
    torque_scale: float = setting(1.0, description='normalised torque = effort / torque_scale',
                                  unit='effort unit', check=in_range(0.0, 1e9, low_open=True))
    standstill_speed_rad_s: float = setting(
        STREAM_SETTINGS['standstill_speed_rad_s'], unit='rad/s', check=non_negative,
        description='motor-side speed at or below which the joint stands still')
    speed_tolerance_fraction: float = setting(
        STREAM_SETTINGS['speed_tolerance_fraction'], unit='-', check=fraction,
        description='a sample is at constant speed within this fraction of the level')
    speed_tolerance_rad_s: float = setting(
        STREAM_SETTINGS['speed_tolerance_rad_s'], unit='rad/s', check=non_negative,
        description='lower bound of the constant-speed band, motor side')
    min_duration_s: float = setting(
        STREAM_SETTINGS['min_duration_s'], unit='s', check=non_negative,
        description='shortest constant-speed plateau kept as a pass (after trimming)')
    trim_s: float = setting(
        STREAM_SETTINGS['trim_s'], unit='s', check=non_negative,
        description='time dropped at each end of each constant-speed plateau')
    min_samples: int = setting(
        STREAM_SETTINGS['min_samples'], check=at_least(3),
        description='fewest samples per pass inside the common position window')
    min_window_rad: float = setting(
        STREAM_SETTINGS['min_window_rad'], unit='rad', check=non_negative,
        description='narrowest common position window of a forward/backward pair, joint side')
    window_center_rad: float | None = setting(
        None, unit='rad', description='phi_bar, the centre of a fixed position window, joint '
        'side; None uses the whole common window of each pair')
    window_half_width_rad: float | None = setting(
        None, unit='rad', check=positive,
        description='half width of the fixed position window (set with the centre)')
    max_gap_s: float = setting(
        STREAM_SETTINGS['max_gap_s'], unit='s', check=positive,
        description='a time step longer than this splits the joint-state stream')

    def __post_init__(self) -> None:
        """Validate every field; raise InputError naming the first bad one."""
        check_settings(self)
        if (self.window_center_rad is None) != (self.window_half_width_rad is None):
            raise InputError('SegmenterConfig.window_half_width_rad: window_center_rad and '
                             'window_half_width_rad must be given together')


@dataclass(frozen=True)
class ExperimentGrouping:
    """
    How friction levels are grouped into experiments (the assembler and the services).

    ``idle_gap_s`` has one default per context, all here (:data:`EXPERIMENT_GAPS_S`): a stream
    or bag (the node, ``replay``, ``segment``, ``audit`` and ``identify`` of a bag) ends an
    experiment after 3 s without a level; see that table for the other contexts and why they
    differ.
    """

    experiment_speed_tolerance_rad_s: float = setting(
        1.0, unit='rad/s', check=positive,
        description='a level belongs to an experiment speed within this tolerance, motor side')
    idle_gap_s: float = setting(
        3.0, unit='s', check=positive,
        description='a pause longer than this between two friction levels ends an experiment '
                    '(levels of one experiment come about 1 s apart)')

    def __post_init__(self) -> None:
        """Validate every field; raise InputError naming the first bad one."""
        check_settings(self)


#: The pause [s] between two friction levels that ends an experiment, per context:
#:
#: * ``stream``: the friction_experiment_node's ``idle_gap_s`` default, and so of ``replay``,
#:   ``segment``, ``audit`` and ``identify`` of a bag (they read the node configuration): the
#:   runner's levels come about 1 s apart, an experiment has ended after 3 s of standstill.
#: * ``raw_run``: ``segment RUN.csv --speeds``, grouping the levels of one measured raw run
#:   into experiments at those speeds.  A raw run is one recorded test programme of one
#:   joint; its pauses between speeds are the programme's, not a runner's, and have been up to
#:   tens of seconds in the KUKA runs, so the grouping waits 30 s (the value it always used).
#: * ``identify_bag``: ``identify``'s numbering of the levels it segmented from a bag into
#:   experiments (:func:`robot_wear_monitor.audit.identify_inputs.number_experiments`,
#:   ``--experiment-gap``): by time alone, levels more than 10 s apart start a new experiment
#:   (the value it always used).  This numbering does not look at the speed set repeating, as
#:   the stream grouping does, so it waits longer than the stream's 3 s to split.
EXPERIMENT_GAPS_S: Mapping[str, float] = MappingProxyType({
    'stream': ExperimentGrouping().idle_gap_s, 'raw_run': 30.0, 'identify_bag': 10.0})


def stream_segmenter_config(joint: str, **overrides: Any) -> SegmenterConfig:
    """
    Return the settings of a bag or stream of ``joint``: :data:`STREAM_SETTINGS`.

    Keyword arguments override any field (e.g. ``gear_ratio``, ``torque_scale``).
    """
    return SegmenterConfig(**{'joint': joint, **STREAM_SETTINGS, **overrides})


def raw_run_segmenter_config(**overrides: Any) -> SegmenterConfig:
    """
    Return the settings of a measured raw run: :data:`RAW_RUN_SETTINGS`.

    Keyword arguments override any field.
    """
    return SegmenterConfig(**{**RAW_RUN_SETTINGS, **overrides})
