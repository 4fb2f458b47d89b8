"""
Friction levels of eq. (3) over position bins, for logs too slow for time windows (2 Hz).

The time-window segmentation (:mod:`.segmentation`) needs ``min_samples`` samples per pass in a
common window: a lab logger at 2 Hz gives a pass 2-6 samples.  Labs form levels from such logs
by eq. (3) over position bins instead: at one speed set-point, the forward and the backward
samples that fall in the same position bin see the same gravity, so

    tau_f = mean over bins of (tau+_bin - tau-_bin) / 2                         (3)

**Samples.**  Finite samples with a motor speed (``gear_ratio`` x velocity) above
``standstill_speed_rad_s``; moves are runs of them in one direction.  **Set-points.**  Given
(``speeds_rad_s``), or found: each move's median speed, clustered (medians less than the speed
tolerance of ``config`` apart are one set-point); a move belongs to the set-point nearest its
median, and its samples within the tolerance of that set-point are used (ramp samples are
dropped).  **Bins.**  Per set-point, the position range
both directions cover is cut into ``n_bins`` equal bins; a bin counts when it holds at least
:data:`MIN_PER_BIN` samples each way.  A common slope of torque in position (gravity),
estimated within the bins, moves every bin's mean to the bin centre, so a gravity slope cancels
even when the samples of the two directions fall at other places in a bin.

**Decision: one level per set-point and log**, pooled over its bins with equal weights and over
all passes at that set-point (a 2 Hz pass pair fills no bin twice each way).  Its standard error
comes from the within-bin scatter: ``sqrt(sum_b 0.25 (s+^2/n+_b + s-^2/n-_b)) / bins``.
"""

from __future__ import annotations

from collections import Counter
import math
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionLevel
from robot_wear_monitor.experiment.segmentation import SegmenterConfig


#: Fewest samples per direction in a bin for the bin to count.
MIN_PER_BIN = 2


def _tolerance(level: FloatArray | float, config: SegmenterConfig) -> FloatArray:
    return np.maximum(config.speed_tolerance_fraction * np.asarray(level, dtype=float),
                      config.speed_tolerance_rad_s)


def moves(speed: FloatArray, threshold: float) -> NDArray[np.int_]:
    """Return the move index of every sample (-1 at standstill): runs of one direction."""
    sign = np.where(speed > threshold, 1, np.where(speed < -threshold, -1, 0))
    starts = (sign != 0) & np.concatenate(([True], sign[1:] != sign[:-1]))
    index = np.cumsum(starts) - 1
    return np.where(sign != 0, index, -1)


def pass_sample_counts(velocity_rad_s: ArrayLike, config: SegmenterConfig) -> NDArray[np.int_]:
    """Return the number of samples of every move (one direction above standstill)."""
    speed = np.asarray(velocity_rad_s, dtype=float) * config.gear_ratio
    speed = np.where(np.isfinite(speed), speed, 0.0)
    index = moves(speed, config.standstill_speed_rad_s)
    return np.bincount(index[index >= 0]) if np.any(index >= 0) else np.zeros(0, dtype=int)


def low_rate_reason(time_s: ArrayLike, velocity_rad_s: ArrayLike,
                    config: SegmenterConfig) -> str | None:
    """
    Return why a log is too slow for time-window levels, with its numbers, or None.

    Too slow: the joint moves both ways, and its passes hold fewer than ``min_samples``
    samples (median) or its sample step is longer than ``max_gap_s``.
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(velocity_rad_s, dtype=float)
    steps = np.diff(t[np.isfinite(t)])
    steps = steps[steps > 0]
    counts = pass_sample_counts(v, config)
    speed = v[np.isfinite(v)] * config.gear_ratio
    both = (np.any(speed > config.standstill_speed_rad_s)
            and np.any(speed < -config.standstill_speed_rad_s))
    if not steps.size or not counts.size or not both:
        return None
    step = float(np.median(steps))
    typical = int(np.median(counts))
    if typical >= config.min_samples and step <= config.max_gap_s:
        return None
    rate = 1.0 / step
    needed = max(rate * config.min_samples / max(typical, 1), 1.0 / config.max_gap_s)
    return (f'the log is too slow for time-window levels: {rate:.3g} Hz (a sample every '
            f'{step:.3g} s), a pass holds {int(counts.min())}-{int(counts.max())} samples '
            f'(median {typical}), but a level needs min_samples = {config.min_samples} per '
            f'pass in a common window and samples at most max_gap_s = {config.max_gap_s:g} s '
            f'apart: give --position-bins N (eq. (3) over N position bins, forward and '
            f'backward samples in one bin, at least {MIN_PER_BIN} each way) or log at '
            f'{needed:.3g} Hz or more')


def _set_points(speed: FloatArray, index: NDArray[np.int_], config: SegmenterConfig,
                speeds_rad_s: Sequence[float] | None) -> FloatArray:
    """Return the set-point speeds [rad/s, motor side]: given, or clustered move medians."""
    if speeds_rad_s:
        return np.sort(np.abs(np.asarray(speeds_rad_s, dtype=float)))
    medians = np.sort([float(np.median(np.abs(speed[index == k])))
                       for k in np.unique(index[index >= 0])])
    if not medians.size:
        return medians
    breaks = np.diff(medians) > _tolerance(medians[1:], config)
    cluster = np.concatenate(([0], np.cumsum(breaks)))
    return np.array([float(np.median(medians[cluster == c])) for c in np.unique(cluster)])


def position_binned_levels(*, time_s: ArrayLike, position_rad: ArrayLike,
                           velocity_rad_s: ArrayLike, effort: ArrayLike,
                           config: SegmenterConfig, n_bins: int,
                           speeds_rad_s: Sequence[float] | None = None
                           ) -> tuple[list[FrictionLevel], Counter]:
    """
    Return one level of eq. (3) over ``n_bins`` position bins per speed set-point.

    Units as the segmenter's: motor speed [rad/s] = ``gear_ratio`` x velocity, normalised
    torque = effort / ``torque_scale``, joint position [rad].  Returns the levels (in order of
    speed) and the set-points without a level (``pass_no_common_window``: no bin with
    :data:`MIN_PER_BIN` samples each way).

    :raises InputError: ``n_bins`` is not an integer >= 1.

    """
    if isinstance(n_bins, bool) or not isinstance(n_bins, int) or n_bins < 1:
        raise InputError(f'position bins: expected an integer >= 1, got {n_bins!r}')
    arrays = (time_s, position_rad, velocity_rad_s, effort)
    t, q, v, e = (np.asarray(x, dtype=float) for x in arrays)
    if not t.shape == q.shape == v.shape == e.shape or t.ndim != 1:
        raise InputError('position bins: time, position, velocity and effort differ in shape')
    finite = np.isfinite(t) & np.isfinite(q) & np.isfinite(v) & np.isfinite(e)
    t, q, e = t[finite], q[finite], e[finite] / config.torque_scale
    speed = v[finite] * config.gear_ratio
    index = moves(speed, config.standstill_speed_rad_s)
    rejections: Counter = Counter()
    levels: list[FrictionLevel] = []
    points = _set_points(speed, index, config, speeds_rad_s)
    if not points.size:
        return levels, rejections
    # each move belongs to the set-point nearest its median speed (a ramp through another
    # set-point's speed is no sample of it)
    medians = np.array([float(np.median(np.abs(speed[index == k])))
                        for k in range(int(index.max()) + 1)]) if np.any(index >= 0) \
        else np.zeros(0)
    nearest = np.abs(medians[:, None] - points[None, :]).argmin(axis=1) if medians.size \
        else np.zeros(0, dtype=int)
    owner = np.where(index >= 0, nearest[np.maximum(index, 0)] if nearest.size else -1, -1)
    for k, point in enumerate(points):
        at = (owner == k) & (np.abs(np.abs(speed) - point) <= _tolerance(point, config))
        level = _binned_level(t[at], q[at], speed[at], e[at], n_bins)
        if level is None:
            rejections['pass_no_common_window'] += 1
        else:
            levels.append(level)
    return levels, rejections


def _binned_level(t: FloatArray, q: FloatArray, speed: FloatArray, torque: FloatArray,
                  n_bins: int) -> FrictionLevel | None:
    """Return the level of one set-point's samples over position bins, or None."""
    forward, backward = speed > 0, speed < 0
    if not forward.any() or not backward.any():
        return None
    low = max(float(q[forward].min()), float(q[backward].min()))
    high = min(float(q[forward].max()), float(q[backward].max()))
    if not high > low:
        return None
    edges = np.linspace(low, high, n_bins + 1)
    inside = (q >= low) & (q <= high)
    bins = np.clip(np.searchsorted(edges, q, side='right') - 1, 0, n_bins - 1)
    cell = np.where(inside, bins * 2 + forward.astype(int), -1)
    counts = np.bincount(cell[cell >= 0], minlength=2 * n_bins).reshape(n_bins, 2)
    valid = np.flatnonzero((counts >= MIN_PER_BIN).all(axis=1))
    if not valid.size:
        return None
    used = inside & np.isin(bins, valid)
    keys, c = cell[used], counts.ravel()
    qu, tu = q[used], torque[used]
    mean_q = np.bincount(keys, weights=qu, minlength=2 * n_bins) / np.maximum(c, 1)
    mean_t = np.bincount(keys, weights=tu, minlength=2 * n_bins) / np.maximum(c, 1)
    dq, dt = qu - mean_q[keys], tu - mean_t[keys]
    sxx = float(np.dot(dq, dq))
    slope = float(np.dot(dq, dt)) / sxx if sxx > 0 else 0.0  # gravity, within the bins
    centre = 0.5 * (edges[:-1] + edges[1:])
    at_centre = (mean_t + slope * (np.repeat(centre, 2) - mean_q)).reshape(n_bins, 2)
    residual = dt - slope * dq
    variance = []
    for way in (1, 0):  # forward, backward: the within-bin scatter
        own = keys % 2 == way
        dof = int(own.sum()) - valid.size - (1 if sxx > 0 else 0)
        variance.append(float(np.dot(residual[own], residual[own])) / max(dof, 1))
    n_f, n_b = counts[valid, 1], counts[valid, 0]
    tau_f = float(np.mean(at_centre[valid, 1]))
    tau_b = float(np.mean(at_centre[valid, 0]))
    error = 0.5 * math.sqrt(float(np.sum(variance[0] / n_f + variance[1] / n_b))) / valid.size
    used_forward = used & forward
    used_backward = used & backward
    return FrictionLevel(
        speed_rad_s=0.5 * (float(np.mean(speed[used_forward]))
                           - float(np.mean(speed[used_backward]))),
        friction=0.5 * (tau_f - tau_b), friction_std_error=error, tau_forward=tau_f,
        tau_backward=tau_b, n_forward=int(n_f.sum()), n_backward=int(n_b.sum()),
        position_min_rad=float(edges[valid[0]]), position_max_rad=float(edges[valid[-1] + 1]),
        start_time_s=float(t[used].min()), end_time_s=float(t[used].max()))
