"""
Can this estimate be trusted?  Plausibility checks of one experiment's levels and estimate.

An estimate of (T, w) is only as good as the assumption that the friction levels are the
joint's friction as the parameter set describes it.  A wrong gear ratio (the speeds scaled by
one factor), a wrong torque scale (the frictions scaled by one factor), another joint's data or
a saturated torque give levels the model cannot speak about; the estimator still returns a
number, and a monitor that reported it would say "no alarm" without knowing.  Before an
estimate is used, :func:`check_levels` asks:

* ``speed_range``: are the speeds inside the range the parameter set describes
  (``design.speed_min_rad_s`` .. ``design.speed_max_rad_s``, motor rad/s)?
* ``speeds_configured``: are they the configured experiment's speeds (when configured)?
* ``friction_range``: is each level inside what the model gives at that speed for any
  temperature in the set's bounds, any wear in 0 .. ``estimation.wear_max`` and a load within
  4 standard deviations, widened by 4 noise standard deviations (normalised torque)?
* ``model_check``: does the model fit (the chi2 test of eq. (16), p-value at least
  ``invalid_p_value``)?
* ``wear_range``: is w-hat inside the wear range of the set (below ``estimation.wear_max``)?

Any failed check makes the estimate *invalid*: it is reported with the reasons, stored, and
never used as evidence for or against an alarm.  When the failures fit a configuration mistake,
the likely cause is named (:func:`likely_cause`): all speeds scaled by one factor (gear ratio),
the levels fitting the model once multiplied by one factor (torque scale), levels that vary with
speed but are many times smaller or larger than the set's friction (another unit, e.g. N.m
against a normalised set), equal levels at every speed where the model expects a spread
(saturated torque), otherwise another joint or robot.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Iterable, Optional, Sequence, TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import ParameterSet

if TYPE_CHECKING:
    from robot_wear_monitor.estimation.wear_estimates import WearEstimate

#: Default p-value of the model check below which an estimate is invalid (the diagnostics warn
#: already below ``min_fit_p_value``, 0.01: one healthy experiment in 100 does that by chance).
INVALID_P_VALUE = 1e-4
#: Margins of the friction range: load within this many standard deviations of its mean, the
#: level within this many noise standard deviations of the model's range.
LOAD_SIGMAS = 4.0
NOISE_SIGMAS = 4.0
#: Relative tolerance of the speed range and of "all speeds scaled by one factor".
SPEED_TOLERANCE = 0.05
#: Scale factors tried for the torque-scale diagnosis (1/50 .. 50).
_SCALES = np.geomspace(0.02, 50.0, 161)

CHECK_NAMES = ('speed_range', 'speeds_configured', 'friction_range', 'model_check',
               'wear_range')


@dataclass(frozen=True)
class Plausibility:
    """
    The verdict on one experiment: valid, or the failed checks in words and the likely cause.

    :ivar failed: the names of the failed checks (see :data:`CHECK_NAMES`), empty when valid.
    :ivar reasons: one sentence per failed check, with the numbers and their units.
    :ivar likely_cause: the configuration mistake the failures point to ('' when none fits).

    """

    failed: tuple[str, ...] = ()
    reasons: tuple[str, ...] = ()
    likely_cause: str = ''

    @property
    def valid(self) -> bool:
        """Return True when every check passed."""
        return not self.failed

    def text(self) -> str:
        """Return the verdict in words: 'cannot judge the wear: <reasons>; likely cause: ...'."""
        return 'plausible' if self.valid else f'cannot judge the wear: {self.detail()}'

    def detail(self) -> str:
        """Return the failed checks' reasons and the likely cause ('' when valid)."""
        text = '; '.join(self.reasons)
        if self.likely_cause:
            text += f'; likely cause: {self.likely_cause}'
        return text

    def to_json(self) -> dict[str, Any]:
        """Return the keys ``valid``, ``invalid_checks``, ``invalid_reasons``, ``likely_cause``."""
        return {'valid': self.valid, 'invalid_checks': list(self.failed),
                'invalid_reasons': list(self.reasons),
                'likely_cause': self.likely_cause or None}


VALID = Plausibility()


def _fmt(values: Iterable[float]) -> str:
    return ', '.join(f'{v:.3g}' for v in values)


def friction_range(speeds_rad_s: ArrayLike, *, params: ParameterSet
                   ) -> tuple[np.ndarray, np.ndarray]:
    """
    Return the lowest and highest friction level the set allows at each speed, (N,) each.

    The model (8) over T in the set's bounds, w in 0 .. ``wear_max`` and the load within
    :data:`LOAD_SIGMAS` standard deviations of its mean, widened by :data:`NOISE_SIGMAS` noise
    standard deviations.  Normalised torque; speeds motor side [rad/s].
    """
    v = np.asarray(speeds_rad_s, dtype=float)
    temperatures = np.linspace(params.temperature_min_degc, params.temperature_max_degc, 9)
    wears = np.linspace(0.0, params.wear_max, 31)
    loads = params.load_mean + params.load_std * np.linspace(-LOAD_SIGMAS, LOAD_SIGMAS, 5)
    grid = friction(v[:, None, None, None], loads[None, :, None, None],
                    temperatures[None, None, :, None], wears[None, None, None, :], params.model)
    grid = np.asarray(grid, dtype=float).reshape(v.size, -1)
    margin = NOISE_SIGMAS * params.sigma
    return grid.min(axis=1) - margin, grid.max(axis=1) + margin


def _speed_factor(speeds: np.ndarray, expected: np.ndarray) -> Optional[float]:
    """Return f when each speed is f times a configured one (f far from 1), else None."""
    if speeds.size == 0 or speeds.size != expected.size:
        return None
    ratios = np.sort(speeds) / np.sort(expected)
    factor = float(np.median(ratios))
    if np.all(np.abs(ratios / factor - 1.0) <= SPEED_TOLERANCE) and \
            abs(math.log(factor)) > math.log(1.0 + 2 * SPEED_TOLERANCE):
        return factor
    return None


def _best_scale(speeds: np.ndarray, frictions: np.ndarray, params: ParameterSet
                ) -> tuple[float, float]:
    """
    Return (c, p): the factor c whose c * frictions fit the model best, and that fit's p-value.

    Only for N >= 3 (with N <= 2 the two parameters (T, w) fit any scaled levels).
    """
    # deferred import: start-up time (the estimator: not every importer needs it)
    from robot_wear_monitor.estimation.estimator import estimate_wear
    lo, hi = friction_range(speeds, params=params)
    scaled = _SCALES[:, None] * frictions[None, :]
    inside = np.all((scaled >= lo) & (scaled <= hi), axis=1)
    if not np.any(inside):
        return math.nan, math.nan
    scales = _SCALES[inside]
    batch = estimate_wear(speeds, scaled[inside], params=params)
    chi2 = np.asarray(batch.chi2, dtype=float)
    best = int(np.argmin(chi2))
    return float(scales[best]), float(batch.p_value[best])


#: Levels whose spread is within this fraction of their size are "equal" (saturated, stuck).
EQUAL_LEVELS = 0.05
#: Levels that vary with speed and are this many times smaller or larger than the set's
#: friction are in another unit (a torque scale is not that far off).
UNIT_FACTOR = 20.0
#: The start of the likely cause that names a unit mistake.
UNIT_CAUSE = 'the unit of the levels'


def unit_mistake(ratio: float, friction_unit: str) -> str:
    """Return the likely cause of levels ``ratio`` times the set's friction: another unit."""
    size = (f'{1 / ratio:.3g} times smaller' if ratio < 1 else f'{ratio:.3g} times larger')
    return (f'{UNIT_CAUSE}: they are about {size} than the friction of the parameter set '
            f'(unit: {friction_unit}) at these speeds, and they vary with speed: levels in '
            f"another unit (N.m, A) than the set's; give the levels in {friction_unit} (raw "
            'torques: --torque-scale), or identify a set in their unit (identify '
            '--friction-unit)')


def likely_cause(*, speeds_rad_s: ArrayLike, frictions: ArrayLike, params: ParameterSet,
                 failed: Sequence[str], expected_speeds_rad_s: Sequence[float] = ()) -> str:
    """
    Return the configuration mistake the failed checks point to, in words ('' if none fits).

    :param speeds_rad_s: the levels' speeds, motor side [rad/s], shape (N,).
    :param frictions: the levels (normalised torque), shape (N,).
    :param params: the parameter set the estimate used.
    :param failed: the names of the failed checks.
    :param expected_speeds_rad_s: the configured experiment's speeds [rad/s] (may be empty).

    """
    speeds = np.asarray(speeds_rad_s, dtype=float)
    values = np.asarray(frictions, dtype=float)
    if {'speed_range', 'speeds_configured'} & set(failed):
        factor = _speed_factor(speeds, np.asarray(expected_speeds_rad_s, dtype=float))
        ratio = (f' (the speeds are {factor:.3g} times the configured ones: the gear ratio '
                 f'looks {factor:.3g} times too {"large" if factor > 1 else "small"})'
                 if factor is not None else '')
        return ('the gear ratio (--gear-ratio, node parameter gear_ratio): motor speed = joint '
                f'velocity x gear ratio{ratio}')
    model = np.asarray(friction(speeds, params.load_mean, params.design_temperature_degc,
                                0.0, params.model), dtype=float)
    level, expected = float(np.median(np.abs(values))), float(np.median(np.abs(model)))
    equal = np.ptp(values) <= EQUAL_LEVELS * max(level, 1e-300)
    if speeds.size >= 1 and not equal and level > 0 and expected > 0 and \
            abs(math.log(level / expected)) > math.log(UNIT_FACTOR):
        return unit_mistake(level / expected, params.friction_unit)
    if speeds.size >= 3:
        scale, p_value = _best_scale(speeds, values, params)
        if math.isfinite(scale) and p_value >= 0.01 and abs(math.log(scale)) > math.log(1.25):
            direction = 'large' if scale > 1 else 'small'
            return (f'the torque scale (--torque-scale, node parameter torque_scale): the levels '
                    f'x {scale:.3g} fit the model (p = {p_value:.2g}); the torque scale looks '
                    f'about {max(scale, 1 / scale):.2g} times too {direction}')
    if speeds.size >= 3 and np.ptp(values) <= 2.0 * params.sigma and equal:
        if np.ptp(model) > 6.0 * params.sigma:
            return ('a saturated torque or a stuck torque signal: the levels are equal '
                    f'({_fmt(values)}) at every speed, where the model expects them to differ')
    if {'friction_range', 'model_check'} & set(failed):
        return ('levels of another joint or robot than the parameter set describes (check '
                '--joint and --params), or a torque scale that is off')
    return ''


def check_levels(*, speeds_rad_s: ArrayLike, frictions: ArrayLike, params: ParameterSet,
                 estimate: Optional[WearEstimate] = None,
                 expected_speeds_rad_s: Sequence[float] = (),
                 speed_tolerance_rad_s: float = 1.0,
                 invalid_p_value: float = INVALID_P_VALUE) -> Plausibility:
    """
    Check one experiment's levels (and its estimate) against what the parameter set knows.

    :param speeds_rad_s: motor-side speeds [rad/s], shape (N,), finite and > 0.
    :param frictions: friction levels (normalised torque), shape (N,), finite.
    :param params: the parameter set of the estimate.
    :param estimate: the estimate of these levels (its p-value and w-hat are checked), or None.
    :param expected_speeds_rad_s: the configured experiment's speeds [rad/s]; empty: not checked.
    :param speed_tolerance_rad_s: how far a speed may be from a configured one [rad/s].
    :param invalid_p_value: the model check fails below this p-value.

    :return: The :class:`Plausibility` verdict (:data:`VALID` when every check passes).

    """
    speeds = np.asarray(speeds_rad_s, dtype=float)
    values = np.asarray(frictions, dtype=float)
    failed: list[str] = []
    reasons: list[str] = []
    low_speed = params.speed_min_rad_s * (1.0 - SPEED_TOLERANCE)
    high_speed = params.speed_max_rad_s * (1.0 + SPEED_TOLERANCE)
    outside = speeds[(speeds < low_speed) | (speeds > high_speed)]
    if outside.size:
        failed.append('speed_range')
        reasons.append(f'speed(s) {_fmt(outside)} rad/s (motor side) outside the range '
                       f'{params.speed_min_rad_s:g}-{params.speed_max_rad_s:g} rad/s of the '
                       f'parameter set {params.name}')
    expected = np.asarray(expected_speeds_rad_s, dtype=float)
    if expected.size and (speeds.size != expected.size or np.any(
            np.abs(np.sort(speeds) - np.sort(expected)) > speed_tolerance_rad_s)):
        failed.append('speeds_configured')
        reasons.append(f'{speeds.size} level(s) at {_fmt(speeds)} rad/s where the configured '
                       f'experiment has {expected.size} at {_fmt(expected)} rad/s')
    if not outside.size:
        lo, hi = friction_range(speeds, params=params)
        bad = (values < lo) | (values > hi)
        if np.any(bad):
            failed.append('friction_range')
            reasons.append('friction level(s) ' + ', '.join(
                f'{f:.3g} at {v:.3g} rad/s (model range {a:.3g} to {b:.3g})'
                for f, v, a, b in zip(values[bad], speeds[bad], lo[bad], hi[bad]))
                + ' (normalised torque) outside what the model gives for any temperature, '
                'wear and load')
    if estimate is not None:
        p_value = float(estimate.p_value)
        if math.isfinite(p_value) and p_value < invalid_p_value:
            failed.append('model_check')
            reasons.append(f'the levels do not fit the model (chi2 {float(estimate.chi2):.3g} on '
                           f'{int(estimate.dof)} dof, p = {p_value:.2g} < {invalid_p_value:g})')
        wear = float(estimate.wear)
        if params.estimates_wear and (not math.isfinite(wear) or wear >= params.wear_max):
            failed.append('wear_range')
            reasons.append(f'w-hat {wear:.4g} is beyond the wear range 0-{params.wear_max:g} the '
                           'parameter set describes')
    if not failed:
        return VALID
    return Plausibility(failed=tuple(failed), reasons=tuple(reasons),
                        likely_cause=likely_cause(speeds_rad_s=speeds, frictions=values,
                                                  params=params, failed=failed,
                                                  expected_speeds_rad_s=expected_speeds_rad_s))
