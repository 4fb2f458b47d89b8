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
import math
from types import MappingProxyType
from typing import Any, Mapping

from robot_wear_monitor.errors import InputError

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

    The defaults are :data:`STREAM_SETTINGS` (gear ratio and torque scale 1); measured raw
    runs take :func:`raw_run_segmenter_config`.

    :ivar joint: name of the joint in the ``JointState`` messages.
    :ivar gear_ratio: motor speed = gear_ratio x joint speed (1 for link-side sensors).
    :ivar torque_scale: normalised torque = effort / torque_scale (same unit as effort).
    :ivar standstill_speed_rad_s: motor-side speed at or below which the joint counts as
        standing still [rad/s].
    :ivar speed_tolerance_fraction: a sample is at constant speed if its speed is within this
        fraction of the pass's speed level [-].
    :ivar speed_tolerance_rad_s: lower bound of that tolerance band, motor side [rad/s].
    :ivar min_duration_s: shortest constant-speed plateau kept as a pass [s].
    :ivar trim_s: time dropped at each end of each plateau (ends of the ramps) [s].
    :ivar min_samples: fewest samples per pass inside the common position window.
    :ivar min_window_rad: narrowest common position window of a pair, joint side [rad].
    :ivar window_center_rad: phi_bar, the centre of a fixed position window, joint side [rad];
        None uses the whole common window of each pair.
    :ivar window_half_width_rad: half width of that fixed window [rad] (set with the centre).
    :ivar max_gap_s: a time step longer than this splits the stream [s].

    """

    joint: str
    gear_ratio: float = 1.0
    torque_scale: float = 1.0
    standstill_speed_rad_s: float = STREAM_SETTINGS['standstill_speed_rad_s']
    speed_tolerance_fraction: float = STREAM_SETTINGS['speed_tolerance_fraction']
    speed_tolerance_rad_s: float = STREAM_SETTINGS['speed_tolerance_rad_s']
    min_duration_s: float = STREAM_SETTINGS['min_duration_s']
    trim_s: float = STREAM_SETTINGS['trim_s']
    min_samples: int = STREAM_SETTINGS['min_samples']
    min_window_rad: float = STREAM_SETTINGS['min_window_rad']
    window_center_rad: float | None = None
    window_half_width_rad: float | None = None
    max_gap_s: float = STREAM_SETTINGS['max_gap_s']

    def __post_init__(self) -> None:
        """Validate every field; raise InputError naming the first bad one."""
        if not isinstance(self.joint, str) or not self.joint:
            raise InputError(f'SegmenterConfig.joint: expected a non-empty string, '
                             f'got {self.joint!r}')
        positive = ('gear_ratio', 'torque_scale', 'max_gap_s')
        non_negative = ('standstill_speed_rad_s', 'speed_tolerance_fraction',
                        'speed_tolerance_rad_s', 'min_duration_s', 'trim_s', 'min_window_rad')
        for name in positive + non_negative:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise InputError(f'SegmenterConfig.{name}: expected a finite number, '
                                 f'got {value!r}')
            if name in positive and value <= 0:
                raise InputError(f'SegmenterConfig.{name}: must be > 0, got {value}')
            if value < 0:
                raise InputError(f'SegmenterConfig.{name}: must be >= 0, got {value}')
        if self.speed_tolerance_fraction >= 1:
            raise InputError('SegmenterConfig.speed_tolerance_fraction: must be < 1, '
                             f'got {self.speed_tolerance_fraction}')
        if isinstance(self.min_samples, bool) or not isinstance(self.min_samples, int) \
                or self.min_samples < 3:
            raise InputError(f'SegmenterConfig.min_samples: expected an integer >= 3, '
                             f'got {self.min_samples!r}')
        center, half = self.window_center_rad, self.window_half_width_rad
        if (center is None) != (half is None):
            raise InputError('SegmenterConfig.window_half_width_rad: window_center_rad and '
                             'window_half_width_rad must be given together')
        if center is not None:
            for name, value in (('window_center_rad', center), ('window_half_width_rad', half)):
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not math.isfinite(value):
                    raise InputError(f'SegmenterConfig.{name}: expected a finite number, '
                                     f'got {value!r}')
            assert half is not None  # given together with the centre (checked above)
            if half <= 0:
                raise InputError(f'SegmenterConfig.window_half_width_rad: must be > 0, '
                                 f'got {half}')


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
