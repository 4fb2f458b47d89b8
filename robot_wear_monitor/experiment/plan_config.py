"""
What a friction experiment plan must respect: :class:`PlanConfig`, its settings declared once.

Split from :mod:`robot_wear_monitor.experiment.planning` (which re-exports it) so that the
command line, the node parameter table and the docs read the plan's defaults, units and
checks without loading numpy.  Speeds motor side [rad/s] unless named joint side, positions
[rad], times [s].
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import SegmenterConfig
from robot_wear_monitor.setting_fields import (check_settings, non_empty, non_negative,
                                               positive, setting, shared_setting)


class PlanError(InputError):
    """
    A motion the constraints do not allow.

    :ivar field: the :class:`PlanConfig` field to change (``half_range_rad``,
        ``position_limits_rad``, ``max_speed_rad_s``).
    :ivar detail: the problem with its numbers, without the hint of what to change.

    """

    def __init__(self, detail: str, *, field: str, hint: str) -> None:
        """Keep ``detail`` and ``field``; the message is ``plan: <detail> (<hint>)``."""
        super().__init__(f'plan: {detail}' + (f' ({hint})' if hint else ''))
        self.detail = detail
        self.field = field


#: Samples of margin per plateau for the segmentation's sample-resolution ends: it measures a
#: plateau from its first to its last kept sample and trims at sample resolution, so up to
#: three samples are lost at the ends (stamp jitter included), and one more is margin.
_MARGIN_SAMPLES = 4.0


@dataclass(frozen=True)
class PlanConfig:
    """
    What the friction experiment of one joint must respect; units are in the field names.

    Each setting is declared once with its unit, description and check
    (:func:`robot_wear_monitor.setting_fields.setting`; ``gear_ratio``, ``min_duration_s``,
    ``trim_s`` and ``min_samples`` are the segmentation's own, :class:`SegmenterConfig`): the
    ``friction_experiment_runner``'s parameters and ``plan``'s options are made from them.

    :ivar position_limits_rad: (lower, upper) joint limits [rad]; None: not checked.
    :ivar joint_names: all joints of the trajectory (the tested one included); empty: only it.
    :ivar hold_positions_rad: positions of the other joints, in ``joint_names`` order without the
        tested joint [rad] (held during the experiment).
    :ivar desired_plateau_s: a longer plateau wanted for every speed [s] (None: as short as
        the segmentation and the accuracy target allow).
    :ivar shorten_to_window: a plateau that does not fit the window is shortened to fit it
        (down to the segmentation's minimum, ``min_duration_s`` and ``min_samples``) instead
        of refused; the accuracy target then does not hold for that speed.

    """

    joint: str = setting(description='name of the tested joint', check=non_empty)
    speeds_rad_s: tuple[float, ...] = setting(
        unit='rad/s', description='speeds of the friction experiment, motor side')
    center_rad: float = setting(unit='rad', description='centre of the position window, joint '
                                'side')
    half_range_rad: float = setting(
        unit='rad', check=positive, description='half width of the position window the '
        'constant-speed passes stay in, joint side')
    max_acceleration_rad_s2: float = setting(
        unit='rad/s^2', check=positive,
        description='joint acceleration limit of the planned motion, joint side')
    gear_ratio: float = shared_setting(SegmenterConfig, 'gear_ratio')
    max_jerk_rad_s3: Optional[float] = setting(
        None, unit='rad/s^3', check=positive,
        description='joint jerk limit, joint side; unset: trapezoidal speed changes')
    max_speed_rad_s: Optional[float] = setting(
        None, unit='rad/s', check=positive,
        description='joint speed limit, joint side; unset: the fastest designed speed (also '
                    'the speed of the repositioning moves)')
    position_limits_rad: Optional[tuple[float, float]] = None
    rate_hz: float = setting(250.0, unit='Hz', check=positive,
                             description='JointState rate the segmentation sees (sample counts)')
    noise_std: float = setting(
        0.01, unit='-', check=non_negative,
        description='torque noise of one sample, normalised (effort / torque_scale)')
    target_std_error: Optional[float] = setting(
        1.0e-3, unit='-', check=positive,
        description=('wanted standard error of each friction level, normalised; unset: only '
                     "the segmentation's shortest plateau"))
    min_duration_s: float = shared_setting(
        SegmenterConfig, 'min_duration_s',
        description=('shortest plateau the segmentation keeps after trimming (the '
                     "segmentation's min_duration_s)"))
    trim_s: float = shared_setting(
        SegmenterConfig, 'trim_s',
        description='time the segmentation trims at each plateau end (its trim_s)')
    min_samples: int = shared_setting(
        SegmenterConfig, 'min_samples',
        description='fewest samples per pass the segmentation keeps (its min_samples)')
    dwell_s: float = setting(0.1, unit='s', check=non_negative,
                             description='standstill at every turn of the motion')
    joint_names: tuple[str, ...] = ()
    hold_positions_rad: tuple[float, ...] = ()
    desired_plateau_s: Optional[float] = setting(
        None, unit='s', check=positive,
        description='a longer plateau wanted for every speed; unset: as short as the '
                    'segmentation and the accuracy target allow')
    shorten_to_window: bool = False

    def __post_init__(self) -> None:
        """Validate; raise InputError naming the first bad field."""
        if not isinstance(self.joint, str) or not self.joint:
            raise InputError('plan: joint must be a non-empty name')
        speeds = tuple(float(v) for v in self.speeds_rad_s)
        object.__setattr__(self, 'speeds_rad_s', speeds)
        if not speeds or not all(math.isfinite(v) and v > 0 for v in speeds):
            raise InputError(f'plan: speeds must be positive motor-side rad/s, got {speeds}')
        check_settings(self, prefix='plan: ')
        if self.position_limits_rad is not None:
            low, high = (float(x) for x in self.position_limits_rad)
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise InputError(f'plan: position limits must be finite with lower < upper, '
                                 f'got {self.position_limits_rad}')
            if not low <= self.center_rad - self.half_range_rad or \
                    not self.center_rad + self.half_range_rad <= high:
                raise InputError(
                    f'plan: the window {self.center_rad:g} +- {self.half_range_rad:g} rad is '
                    f'outside the joint range [{low:g}, {high:g}] rad')
        names = tuple(self.joint_names)
        if names:
            if self.joint not in names or len(set(names)) != len(names):
                raise InputError(f'plan: joint_names must be unique and contain '
                                 f'{self.joint!r}, got {list(names)}')
            if len(self.hold_positions_rad) != len(names) - 1:
                raise InputError(f'plan: hold_positions_rad needs {len(names) - 1} values (one '
                                 f'per other joint), got {len(self.hold_positions_rad)}')
        elif self.hold_positions_rad:
            raise InputError('plan: hold_positions_rad given without joint_names')
        fastest = max(speeds) / self.gear_ratio
        if self.max_speed_rad_s is not None and fastest > self.max_speed_rad_s * (1 + 1e-12):
            raise PlanError(f'speed {max(speeds):g} rad/s (motor) is {fastest:.4g} rad/s at the '
                            f'joint, above its limit {self.max_speed_rad_s:g} rad/s',
                            field='max_speed_rad_s', hint='')

    @property
    def samples_per_pass(self) -> int:
        """Return the samples M each pass needs inside its plateau (segmentation and accuracy)."""
        needed = float(self.min_samples)
        if self.target_std_error is not None and self.noise_std > 0:
            needed = max(needed, self.noise_std ** 2 / (2.0 * self.target_std_error ** 2))
        needed = max(needed, self.min_duration_s * self.rate_hz)
        return int(math.ceil(needed - 1e-9))

    @property
    def plateau_s(self) -> float:
        """Constant-speed time of each pass [s] (the same for every speed unless shortened)."""
        needed = (self.samples_per_pass + _MARGIN_SAMPLES) / self.rate_hz + 2.0 * self.trim_s
        return max(needed, float(self.desired_plateau_s or 0.0))

    @property
    def shortest_plateau_s(self) -> float:
        """Shortest plateau the segmentation keeps [s] (``shorten_to_window`` stops there)."""
        samples = max(self.min_samples, math.ceil(self.min_duration_s * self.rate_hz - 1e-9))
        return (samples + _MARGIN_SAMPLES) / self.rate_hz + 2.0 * self.trim_s
