"""
The pass finder and pairer: one joint's stream into friction levels of eq. (3) of the paper.

The friction experiment moves one joint back and forth around a position phi_bar at a constant
speed.  For every forward/backward pair of constant-speed passes at the same speed level, over the
same position window, gravity is the same in both directions and cancels in

    tau_f = (tau+ - tau-) / 2                                                   (3)

where tau+ and tau- are the mean torques of the forward (positive velocity) and the backward pass.

Pipeline, shared by the streaming and the batch path so that both give identical levels:

1. **Samples.**  A sample is (time [s], joint position [rad], joint velocity [rad/s], effort).  A
   sample with a NaN/inf field is rejected (``non_finite``), one with a value no robot gives
   (:data:`SAMPLE_LIMITS`: |position| > 1e6 rad, |velocity| > 1e6 rad/s, |effort| > 1e12) as
   ``out_of_range``; one whose time does not increase past the last accepted sample (backwards
   or a duplicate stamp) is rejected (``time_not_increasing``).  Each is rejected alone: the
   samples around it stay one stream.  A time step between accepted samples longer than
   ``max_gap_s`` is counted (``time_gap``) and splits the stream.  From ``JointState`` messages,
   a message without the joint (``joint_missing``), with an empty effort/position/velocity array
   (``missing_effort``/``missing_position``/``missing_velocity``) or with an array whose length
   differs from ``name`` (``length_mismatch``) is rejected as a whole.
2. **Moves.**  Motor speed = ``gear_ratio`` x joint velocity; normalised torque = effort /
   ``torque_scale``.  A move is a maximal run of accepted samples with the same direction and
   motor speed above ``standstill_speed_rad_s``; a gap cuts it (a rejected sample alone does
   not: its neighbours are at most ``max_gap_s`` apart, or the gap cuts).
3. **Passes.**  In each move the constant-speed plateau is found: the speed level is the
   densest speed of the move (the speed with the most samples within the tolerance band of it,
   refined by a median), the plateau is the longest run of samples within
   ``speed_tolerance_fraction`` x level (at least ``speed_tolerance_rad_s``) of it, so the
   acceleration and deceleration phases are dropped; ``trim_s`` more is dropped at each end
   (the last and first samples of the ramps that fall inside the band).  A plateau shorter
   than ``min_duration_s`` is dropped (``pass_too_short``).
   If ``window_center_rad`` and ``window_half_width_rad`` are set, only the samples in that
   position window are kept.
4. **Pairs.**  A pass is paired with the next pass if that goes the other way at the same speed
   level; both are cut to the position window they have in common, which must be at least
   ``min_window_rad`` wide and hold at least ``min_samples`` samples per pass.  Otherwise the
   older pass is counted as ``pass_unpaired`` (or ``pass_no_common_window``).  Each pair gives
   one :class:`~robot_wear_monitor.experiment.levels.FrictionLevel`.  tau+ and tau- are the
   mean torques of the passes in the window, each corrected to the window centre along a
   straight line
   fitted in position (so a gravity slope cancels exactly even when the samples of the two
   passes do not fall at the same positions); the standard error comes from the scatter about
   those lines: ``0.5 sqrt(s+^2/n+ + s-^2/n-)``.

Rejection counters count samples or messages for the sample reasons and passes for the
``pass_*`` reasons; ``time_gap`` counts gaps.  A pair whose one pass sits at its extreme torque
in at least half of the window while the other does not is a drive at its torque limit (a
clipped signal): both passes are rejected as ``pass_torque_saturated``.

The streaming path buffers only the samples of the current move (constant work per message; the
move is analysed with numpy when it ends, so each sample is touched a bounded number of times)
and holds at most one unpaired pass.  The batch path finds the moves of a whole recording with
numpy, analyses the moves that end in a chunk at once (the same operations on the same values
as the per-move analysis, so the same levels bit for bit) and runs the same pairing.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
import math
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionLevel
from robot_wear_monitor.experiment.segmentation_settings import SegmenterConfig


#: Sample and message rejection reasons, in the order they are checked.
SAMPLE_REASONS = ('joint_missing', 'missing_position', 'missing_velocity', 'missing_effort',
                  'length_mismatch', 'non_finite', 'out_of_range', 'time_not_increasing',
                  'time_gap')
#: Largest magnitudes of a sample's position [rad], velocity [rad/s] and effort (its unit)
#: that a robot can report; beyond, the sample is ``out_of_range`` (and no sum overflows).
SAMPLE_LIMITS = (1e6, 1e6, 1e12)
#: Pass rejection reasons.
PASS_REASONS = ('pass_too_short', 'pass_unpaired', 'pass_no_common_window',
                'pass_torque_saturated')
#: A pass whose torque sits at its extreme value in at least this fraction of the window, while
#: its partner's does not, hit the drive's torque limit (a clipped signal, not friction).
SATURATED_FRACTION = 0.5
_PARTNER_FRACTION = 0.2


@dataclass
class SegmentationResult:
    """Friction levels of a recording and the rejection counters (reason -> count)."""

    levels: list[FrictionLevel]
    rejections: Counter = field(default_factory=Counter)


# --------------------------------------------------------------------------- message handling

def pick_joint(*, name: Sequence[str], position: Sequence[float], velocity: Sequence[float],
               effort: Sequence[float], joint: str) -> tuple[float, float, float] | str:
    """
    Return (position, velocity, effort) of ``joint`` from one JointState, or a reason.

    The reason (a key of :data:`SAMPLE_REASONS`) says why the message cannot be used: the joint
    is absent, an array is empty, or an array's length differs from ``name``.  Values are not
    checked for finiteness here (the segmenter does that).
    """
    names = list(name)
    try:
        index = names.index(joint)
    except ValueError:
        return 'joint_missing'
    n = len(names)
    for reason, values in (('missing_position', position), ('missing_velocity', velocity),
                           ('missing_effort', effort)):
        if len(values) == 0:
            return reason
    if len(position) != n or len(velocity) != n or len(effort) != n:
        return 'length_mismatch'
    return float(position[index]), float(velocity[index]), float(effort[index])


# --------------------------------------------------------------------------- passes and pairs

@dataclass(frozen=True)
class Pass:
    """
    Constant-speed samples of one move: time [s], position [rad], motor speed, torque.

    ``direction`` is +1 or -1; ``level_rad_s`` the speed level [rad/s, motor side]; the arrays
    (shape (n,)) are the plateau's samples, torque normalised (effort / ``torque_scale``).
    """

    direction: int
    time_s: FloatArray
    position_rad: FloatArray
    speed_rad_s: FloatArray
    torque: FloatArray
    level_rad_s: float


def _tolerance(level: float, config: SegmenterConfig) -> float:
    return max(config.speed_tolerance_fraction * level, config.speed_tolerance_rad_s)


def _longest_run(mask: NDArray[np.bool_]) -> tuple[int, int]:
    """Return [start, stop) of the longest run of True in ``mask`` (0, 0 if none)."""
    if not mask.any():
        return 0, 0
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, stops = edges[0::2], edges[1::2]
    best = int(np.argmax(stops - starts))
    return int(starts[best]), int(stops[best])


#: Time comparisons (trims, durations) allow this much [s]: stamps far from zero (a ROS epoch)
#: are rounded to ~0.2 us, and a sample exactly at a threshold must fall on the same side
#: whatever the time origin (a bag of a run gives the levels of the run itself).
_TIME_EPS_S = 1e-6


def _analyse_move(time_s: FloatArray, position_rad: FloatArray, speed_rad_s: FloatArray,
                  torque: FloatArray, direction: int, config: SegmenterConfig,
                  rejections: Counter) -> Pass | None:
    """
    Find the constant-speed plateau of one move; None (counted) when it is unusable.

    ``speed_rad_s`` is the signed motor speed; moves shorter than ``min_duration_s`` in total
    are standstill jitter and are ignored without being counted.
    """
    if time_s.size < 3 or time_s[-1] - time_s[0] < config.min_duration_s - _TIME_EPS_S:
        return None
    speed = np.abs(speed_rad_s)
    # The speed level is where the speeds are densest: the value with the most samples within
    # its tolerance band (the plateau of a trapezoid, not an overshoot or a ramp).
    ordered = np.sort(speed)
    band = np.maximum(config.speed_tolerance_fraction * ordered, config.speed_tolerance_rad_s)
    counts = (np.searchsorted(ordered, ordered + band, side='right')
              - np.searchsorted(ordered, ordered - band, side='left'))
    level = float(ordered[int(np.argmax(counts))])
    for _ in range(2):
        # the median of the speeds within the band: those of ``ordered``, already sorted
        near = ordered[np.abs(ordered - level) <= _tolerance(level, config)]
        if not near.size:
            rejections['pass_too_short'] += 1
            return None
        half = near.size // 2
        level = float(near[half] if near.size % 2 else (near[half - 1] + near[half]) / 2.0)
    start, stop = _longest_run(np.abs(speed - level) <= _tolerance(level, config))
    if config.trim_s > 0 and stop > start:
        run = time_s[start:stop]
        stop = start + int(np.searchsorted(run, run[-1] - config.trim_s + _TIME_EPS_S,
                                           side='right'))
        start += int(np.searchsorted(run, run[0] + config.trim_s - _TIME_EPS_S, side='left'))
    keep = slice(start, stop)
    if stop - start < 3 or \
            time_s[stop - 1] - time_s[start] < config.min_duration_s - _TIME_EPS_S:
        rejections['pass_too_short'] += 1
        return None
    t, q, v, e = time_s[keep], position_rad[keep], speed_rad_s[keep], torque[keep]
    if config.window_center_rad is not None:
        in_window = np.abs(q - config.window_center_rad) <= config.window_half_width_rad
        if np.count_nonzero(in_window) < config.min_samples:
            rejections['pass_no_common_window'] += 1
            return None
        t, q, v, e = t[in_window], q[in_window], v[in_window], e[in_window]
    return Pass(direction=direction, time_s=t, position_rad=q, speed_rad_s=v, torque=e,
                level_rad_s=level)


def _analyse_moves(t: FloatArray, q: FloatArray, speed: FloatArray, torque: FloatArray,
                   sign: NDArray[np.int8], starts: NDArray[np.intp], stops: NDArray[np.intp],
                   config: SegmenterConfig) -> list[Pass | str]:
    """
    Analyse the moves [starts[k], stops[k]) of one chunk at once, each as :func:`_analyse_move`.

    ``t`` (accepted sample times [s], strictly increasing), ``q`` [rad], ``speed`` (signed
    motor speed [rad/s]) and ``torque``: shape (n,); ``sign``: the move direction of each
    sample; the segments (moves and standstills) follow each other.  The same operations on
    the same values as the per-move analysis (so the same levels bit for bit), with numpy over
    all moves where an operation is elementwise and per move only for the sort and the
    densest-speed search.

    :return: per move that is not standstill jitter, in time order, its :class:`Pass` or the
        reason it is unusable (``pass_too_short``, ``pass_no_common_window``).

    """
    if not starts.size:
        return []
    length = stops - starts
    keep = (sign[starts] != 0) & (length >= 3)
    keep[keep] = ~(t[stops[keep] - 1] - t[starts[keep]] < config.min_duration_s - _TIME_EPS_S)
    moves = np.flatnonzero(keep)
    if not moves.size:
        return []
    # The work is on the span of the segments, in buffers reused (no large temporaries): the
    # samples of the other segments (standstill, jitter) are masked out by the tolerance -inf.
    origin = int(starts[0])
    first_s, end_s = starts[moves] - origin, stops[moves] - origin  # in the span
    speeds = np.abs(speed[origin:int(stops[-1])])
    ordered = speeds.copy()
    bounds = list(zip(first_s.tolist(), end_s.tolist()))
    for a, b in bounds:
        ordered[a:b].sort()
    fraction, least = config.speed_tolerance_fraction, config.speed_tolerance_rad_s
    work = np.multiply(ordered, fraction)
    np.maximum(work, least, out=work)  # the band of each speed
    high, low = ordered + work, ordered - work
    densest = []
    for a, b in bounds:
        within_band = ordered[a:b].searchsorted(high[a:b], side='right')
        within_band -= ordered[a:b].searchsorted(low[a:b], side='left')
        densest.append(a + int(within_band.argmax()))
    level = ordered[densest]
    per_segment, tolerance = np.zeros(starts.size), np.full(starts.size, -np.inf)
    mask = np.empty(speeds.size, dtype=bool)

    def near(values: FloatArray, level: FloatArray) -> NDArray[np.bool_]:
        """Return |values - level| <= tolerance(level), per sample of the span, in ``mask``."""
        per_segment[moves] = level
        tolerance[moves] = np.maximum(fraction * level, least)
        np.abs(np.subtract(values, np.repeat(per_segment, length), out=work), out=work)
        return np.less_equal(work, np.repeat(tolerance, length), out=mask)

    alive = np.ones(moves.size, dtype=bool)
    for _ in range(2):
        # the median of the speeds within the band of the level, move by move
        index = np.flatnonzero(near(ordered, level))
        first = index.searchsorted(first_s)
        count = index.searchsorted(end_s) - first
        alive &= count > 0
        if not index.size:
            break
        half = np.where(alive, first + count // 2, 0)
        upper = ordered[index[half]]
        lower = ordered[index[np.where(alive & (count % 2 == 0), half - 1, half)]]
        level = np.where(count % 2 == 1, upper, (lower + upper) / 2.0)
    # the longest run of samples in the band, in time order (runs do not cross moves)
    inside = near(speeds, level)
    head, tail = np.empty_like(inside), np.empty_like(inside)
    head[0], tail[-1] = inside[0], inside[-1]
    np.greater(inside[1:], inside[:-1], out=head[1:])
    np.greater(inside[:-1], inside[1:], out=tail[:-1])
    head[first_s], tail[end_s - 1] = inside[first_s], inside[end_s - 1]
    run_start, run_stop = np.flatnonzero(head), np.flatnonzero(tail) + 1
    run_move = first_s.searchsorted(run_start, side='right') - 1
    order = np.lexsort((run_start, run_start - run_stop, run_move))  # longest first
    best = order[np.flatnonzero(np.diff(run_move[order], prepend=-1))]
    has_run = np.zeros(moves.size, dtype=bool)
    has_run[run_move[best]] = True
    start, stop = starts[moves], starts[moves]  # in the chunk; no run: empty
    start[run_move[best]] = run_start[best] + origin
    stop[run_move[best]] = run_stop[best] + origin
    if config.trim_s > 0:
        last = np.where(has_run, stop - 1, start)
        trimmed_stop = t.searchsorted(t[last] - config.trim_s + _TIME_EPS_S, side='right')
        trimmed_start = t.searchsorted(t[start] + config.trim_s - _TIME_EPS_S, side='left')
        start, stop = (np.where(has_run, np.clip(trimmed_start, start, stop), start),
                       np.where(has_run, np.clip(trimmed_stop, start, stop), stop))
    enough = stop - start >= 3
    enough[enough] = ~(t[stop[enough] - 1] - t[start[enough]]
                       < config.min_duration_s - _TIME_EPS_S)
    found: list[Pass | str] = []
    for k, (a, b) in enumerate(zip(start.tolist(), stop.tolist())):
        if not (alive[k] and enough[k]):
            found.append('pass_too_short')
            continue
        tk, qk, vk, ek = t[a:b], q[a:b], speed[a:b], torque[a:b]
        if config.window_center_rad is not None:
            in_window = np.abs(qk - config.window_center_rad) <= config.window_half_width_rad
            if np.count_nonzero(in_window) < config.min_samples:
                found.append('pass_no_common_window')
                continue
            tk, qk, vk, ek = tk[in_window], qk[in_window], vk[in_window], ek[in_window]
        found.append(Pass(direction=int(sign[a]), time_s=tk, position_rad=qk, speed_rad_s=vk,
                          torque=ek, level_rad_s=float(level[k])))
    return found


def _mean(values: FloatArray) -> float:
    """Return the mean of ``values`` (shape (n,), n >= 1): numpy's sum and division, at once."""
    return float(np.add.reduce(values)) / values.size


def _torque_at(position: FloatArray, torque: FloatArray, centre: float, mean_q: float,
               mean: float) -> tuple[float, float]:
    """
    Return the torque of a pass at ``centre`` and the residual variance, by a line fit.

    The line tau = a + b (q - mean q) is fitted in position; its value at the window centre is
    the mean torque corrected for the pass's samples not being centred in the window (so a
    gravity slope cancels exactly between the two directions).  ``mean_q`` and ``mean``: the
    means of ``position`` [rad] and ``torque``.
    """
    x = position - mean_q
    y = torque - mean
    sxx = float(np.dot(x, x))
    slope = float(np.dot(x, y)) / sxx if sxx > 0 else 0.0
    residual = y - slope * x
    dof = max(torque.size - 2, 1)
    return mean + slope * (centre - mean_q), float(np.dot(residual, residual)) / dof


class _Pairer:
    """Pair consecutive opposite passes at the same speed level into friction levels."""

    def __init__(self, config: SegmenterConfig, rejections: Counter) -> None:
        self._config = config
        self._rejections = rejections
        self._pending: Pass | None = None
        self.passes = 0  # constant-speed passes found (paired or not)
        self.found: list[Pass] | None = None  # every pass, when a caller keeps them

    def add(self, new: Pass) -> list[FrictionLevel]:
        self.passes += 1
        if self.found is not None:
            self.found.append(new)
        old, self._pending = self._pending, new
        if old is None:
            return []
        if old.direction == new.direction or abs(old.level_rad_s - new.level_rad_s) > \
                2.0 * _tolerance(max(old.level_rad_s, new.level_rad_s), self._config):
            self._rejections['pass_unpaired'] += 1
            return []
        level, reason = self._pair(old, new)
        if reason == 'pass_torque_saturated':  # both passes are spent
            self._pending = None
            self._rejections[reason] += 2
            return []
        if level is None:
            self._rejections['pass_no_common_window'] += 1
            return []
        self._pending = None
        return [level]

    def finish(self) -> None:
        if self._pending is not None:
            self._rejections['pass_unpaired'] += 1
            self._pending = None

    def _pair(self, first: Pass, second: Pass) -> tuple[FrictionLevel | None, str]:
        return pair_passes(first, second, self._config)


def one_way_passes(*, time_s: ArrayLike, position_rad: ArrayLike, velocity_rad_s: ArrayLike,
                   effort: ArrayLike, config: SegmenterConfig) -> list[Pass]:
    """
    Return every constant-speed pass of a recording (paired or not), in time order.

    For runs that move one way only (one file per speed and direction): their passes are
    paired across files with :func:`pair_passes`.
    """
    segmenter = ChunkSegmenter(config)
    segmenter._pairer.found = []
    segmenter.add(time_s=time_s, position_rad=position_rad, velocity_rad_s=velocity_rad_s,
                  effort=effort)
    segmenter.finish()
    return list(segmenter._pairer.found)


def same_speed(first: Pass, second: Pass, config: SegmenterConfig) -> bool:
    """Return True when two passes are at one speed level (within twice the tolerance)."""
    return abs(first.level_rad_s - second.level_rad_s) <= 2.0 * _tolerance(
        max(first.level_rad_s, second.level_rad_s), config)


def pair_passes(first: Pass, second: Pass, config: SegmenterConfig
                ) -> tuple[FrictionLevel | None, str]:
    """
    Return the level of eq. (3) of two opposite passes, or None and the reason.

    Both passes are cut to their common position window (at least ``min_window_rad`` wide,
    ``min_samples`` samples each); tau+ and tau- are their torques at the window centre (a
    line fitted in position, so a gravity slope cancels).  Reasons: ``pass_no_common_window``,
    ``pass_torque_saturated``.
    """
    forward, backward = (first, second) if first.direction > 0 else (second, first)
    ranges = [(p.position_rad.min(), p.position_rad.max()) for p in (forward, backward)]
    low = max(ranges[0][0], ranges[1][0])
    high = min(ranges[0][1], ranges[1][1])
    if high <= low or high - low < config.min_window_rad:
        return None, 'pass_no_common_window'
    parts = []
    for p, (least, most) in zip((forward, backward), ranges):
        keep: slice | NDArray[np.intp] = slice(None)  # the pass within the window: all of it
        begin, end, n = 0, -1, p.position_rad.size
        if least < low or most > high:
            inside = np.flatnonzero((p.position_rad >= low) & (p.position_rad <= high))
            n = inside.size
            if n < config.min_samples:
                return None, 'pass_no_common_window'
            begin, end = int(inside[0]), int(inside[-1])
            # the same samples as a boolean mask takes; a view when they are consecutive
            keep = slice(begin, end + 1) if end - begin + 1 == n else inside
        elif n < config.min_samples:
            return None, 'pass_no_common_window'
        q, e = p.position_rad[keep], p.torque[keep]
        mean = _mean(e)
        parts.append((p.time_s[begin], p.time_s[end], q, e, _mean(q), mean,
                      _at_extreme(e, mean), _mean(np.abs(p.speed_rad_s[keep]))))
    (tf0, tf1, qf, ef, qf_mean, ef_mean, clip_f, vf_mean), \
        (tb0, tb1, qb, eb, qb_mean, eb_mean, clip_b, vb_mean) = parts
    clipped = sorted((clip_f, clip_b))
    if clipped[1] >= SATURATED_FRACTION and clipped[0] < _PARTNER_FRACTION:
        return None, 'pass_torque_saturated'
    centre = 0.5 * (low + high)
    mean_f, var_f = _torque_at(qf, ef, centre, qf_mean, ef_mean)
    mean_b, var_b = _torque_at(qb, eb, centre, qb_mean, eb_mean)
    speed = 0.5 * (vf_mean + vb_mean)
    return FrictionLevel(
        speed_rad_s=speed, friction=0.5 * (mean_f - mean_b),
        friction_std_error=0.5 * math.sqrt(var_f / ef.size + var_b / eb.size),
        tau_forward=mean_f, tau_backward=mean_b, n_forward=int(ef.size),
        n_backward=int(eb.size), position_min_rad=float(low), position_max_rad=float(high),
        start_time_s=float(min(tf0, tb0)), end_time_s=float(max(tf1, tb1))), ''


def _at_extreme(torque: FloatArray, mean: float) -> float:
    """
    Return the fraction of a pass's torque samples at its extreme value away from zero.

    A drive at its torque limit records the limit itself, sample after sample: a measured
    torque with noise repeats its largest magnitude only by chance.  ``mean``: the mean of
    ``torque`` (which side is away from zero).
    """
    extreme = float(torque.max() if mean >= 0 else torque.min())
    return float(np.count_nonzero(torque == extreme)) / max(torque.size, 1)


# --------------------------------------------------------------------------- streaming

class StreamingSegmenter:
    """
    Segment one joint's samples as they arrive (the live node); see the module docstring.

    :ivar config: the settings.
    :ivar rejections: counter reason -> count of rejected messages, samples and passes.

    """

    def __init__(self, config: SegmenterConfig) -> None:
        """Start with no samples; ``config`` selects the joint and the conversions."""
        if not isinstance(config, SegmenterConfig):
            raise InputError(f'StreamingSegmenter: expected a SegmenterConfig, '
                             f'got {type(config).__name__}')
        self.config = config
        self.rejections: Counter = Counter()
        self._pairer = _Pairer(config, self.rejections)
        self._last_time = -math.inf
        self._sign = 0
        self._buffer: tuple[list, list, list, list] = ([], [], [], [])
        self.fastest_speed_rad_s = 0.0  # of the accepted samples, motor side
        self.last_motion_s = -math.inf  # time of the last accepted sample in motion

    @property
    def passes(self) -> int:
        """Return the number of constant-speed passes found so far (paired or not)."""
        return self._pairer.passes

    def add_joint_state(self, *, stamp_s: float, name: Sequence[str], position: Any,
                        velocity: Any, effort: Any) -> list[FrictionLevel]:
        """
        Add one ``sensor_msgs/JointState`` message; return the levels it completes.

        :param stamp_s: header stamp [s].
        :param name: joint names of the message (any order, any number of joints).
        :param position: joint positions [rad], same length as ``name``.
        :param velocity: joint velocities [rad/s], same length as ``name``.
        :param effort: efforts (unit of ``torque_scale``), same length as ``name``.

        """
        picked = pick_joint(name=name, position=position, velocity=velocity, effort=effort,
                            joint=self.config.joint)
        if isinstance(picked, str):
            self.rejections[picked] += 1
            return []
        return self.add_sample(time_s=stamp_s, position_rad=picked[0],
                               velocity_rad_s=picked[1], effort=picked[2])

    def add_sample(self, *, time_s: float, position_rad: float, velocity_rad_s: float,
                   effort: float) -> list[FrictionLevel]:
        """Add one sample of the joint (joint-side units); return the levels it completes."""
        t, q, v, e = float(time_s), float(position_rad), float(velocity_rad_s), float(effort)
        config = self.config
        if not (math.isfinite(t) and math.isfinite(q) and math.isfinite(v)
                and math.isfinite(e)):
            self.rejections['non_finite'] += 1
            return []
        if abs(q) > SAMPLE_LIMITS[0] or abs(v) > SAMPLE_LIMITS[1] or abs(e) > SAMPLE_LIMITS[2]:
            self.rejections['out_of_range'] += 1
            return []
        if t <= self._last_time:
            self.rejections['time_not_increasing'] += 1
            return []
        levels: list[FrictionLevel] = []
        if t - self._last_time > config.max_gap_s and self._last_time > -math.inf:
            self.rejections['time_gap'] += 1
            levels = self._close_move()
        self._last_time = t
        speed = config.gear_ratio * v
        if abs(speed) > self.fastest_speed_rad_s:
            self.fastest_speed_rad_s = abs(speed)
        sign = 1 if speed > config.standstill_speed_rad_s else (
            -1 if speed < -config.standstill_speed_rad_s else 0)
        if sign != 0:
            self.last_motion_s = t
        if sign != self._sign:
            levels += self._close_move()
            self._sign = sign
        if sign != 0:
            times, positions, speeds, torques = self._buffer
            times.append(t)
            positions.append(q)
            speeds.append(speed)
            torques.append(e / config.torque_scale)
        return levels

    def finish(self) -> list[FrictionLevel]:
        """End of the stream: analyse the move in progress; return the levels it completes."""
        levels = self._close_move()
        self._pairer.finish()
        return levels

    def _close_move(self) -> list[FrictionLevel]:
        times, positions, speeds, torques = self._buffer
        sign, self._sign = self._sign, 0
        if not times:
            return []
        arrays = [np.array(values, dtype=np.float64) for values in self._buffer]
        self._buffer = ([], [], [], [])
        found = _analyse_move(arrays[0], arrays[1], arrays[2], arrays[3], sign, self.config,
                              self.rejections)
        return self._pairer.add(found) if found is not None else []


# --------------------------------------------------------------------------- batch

def _as_1d(values: ArrayLike, label: str) -> FloatArray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise InputError(f'segment_batch: {label} must be one-dimensional, '
                         f'got shape {array.shape}')
    return array


def segment_batch(*, time_s: ArrayLike, position_rad: ArrayLike, velocity_rad_s: ArrayLike,
                  effort: ArrayLike, config: SegmenterConfig) -> SegmentationResult:
    """
    Segment a whole recording of one joint at once (the replay path).

    :param time_s: sample times [s], shape (n,).
    :param position_rad: joint positions [rad], shape (n,).
    :param velocity_rad_s: joint velocities [rad/s], shape (n,).
    :param effort: efforts (unit of ``config.torque_scale``), shape (n,).
    :param config: the settings.

    :return: The same levels and sample/pass rejection counts as feeding the samples one by one to
        a :class:`StreamingSegmenter` and calling ``finish``.

    :raises InputError: the arrays are not one-dimensional or differ in length.

    """
    if not isinstance(config, SegmenterConfig):
        raise InputError(f'segment_batch: expected a SegmenterConfig, '
                         f'got {type(config).__name__}')
    segmenter = ChunkSegmenter(config)
    levels = segmenter.add(time_s=time_s, position_rad=position_rad,
                           velocity_rad_s=velocity_rad_s, effort=effort)
    levels += segmenter.finish()
    return SegmentationResult(levels=levels, rejections=segmenter.rejections)


class ChunkSegmenter:
    """
    Segment one joint's recording chunk by chunk with numpy (the replay of a long bag).

    Feeding a recording in chunks of any sizes, then calling :meth:`finish`, gives the same
    levels and rejection counts as :func:`segment_batch` on the whole recording, and as the
    :class:`StreamingSegmenter` fed sample by sample (tested).  Between chunks only the move in
    progress (its samples since the last sign change) and a few scalars are kept, so memory
    does not grow with the recording.

    :ivar config: the settings.
    :ivar rejections: counter reason -> count of rejected samples and passes.

    """

    def __init__(self, config: SegmenterConfig) -> None:
        """Start with no samples."""
        if not isinstance(config, SegmenterConfig):
            raise InputError(f'ChunkSegmenter: expected a SegmenterConfig, '
                             f'got {type(config).__name__}')
        self.config = config
        self.rejections: Counter = Counter()
        self._pairer = _Pairer(config, self.rejections)
        self._time_max = -math.inf           # largest finite time seen (accepted or not)
        self._last_time = -math.inf          # time of the last accepted sample
        self._sign = 0                       # sign of the move in progress
        self.fastest_speed_rad_s = 0.0       # of the accepted samples, motor side
        self.last_motion_s = -math.inf       # time of the last accepted sample in motion
        self._move: tuple[FloatArray, ...] = ()  # (t, q, motor speed, torque) of that move

    @property
    def passes(self) -> int:
        """Return the number of constant-speed passes found so far (paired or not)."""
        return self._pairer.passes

    def add(self, *, time_s: ArrayLike, position_rad: ArrayLike, velocity_rad_s: ArrayLike,
            effort: ArrayLike) -> list[FrictionLevel]:
        """
        Add the next chunk of samples; return the levels it completes.

        Arrays: shape (n,), time [s], joint position [rad], joint speed [rad/s], effort (unit
        of ``config.torque_scale``).

        :raises InputError: the arrays are not one-dimensional or differ in length.

        """
        config = self.config
        t = _as_1d(time_s, 'time_s')
        q = _as_1d(position_rad, 'position_rad')
        v = _as_1d(velocity_rad_s, 'velocity_rad_s')
        e = _as_1d(effort, 'effort')
        if not t.size == q.size == v.size == e.size:
            raise InputError(f'segment_batch: arrays differ in length: time_s {t.size}, '
                             f'position_rad {q.size}, velocity_rad_s {v.size}, '
                             f'effort {e.size}')
        if t.size == 0:
            return []
        rejections = self.rejections
        accepted = self._accepted(t, q, v, e)
        if accepted is not None:  # some samples are rejected
            if accepted.size == 0:
                return []
            t, q, v, e = t[accepted], q[accepted], v[accepted], e[accepted]
        else:  # all are accepted: copies all the same (the passes keep views of them)
            t, q = t.copy(), q.copy()
        ta, n = t, t.size
        gap = np.empty(n, dtype=bool)
        gap[0] = ta[0] - self._last_time > config.max_gap_s and self._last_time > -math.inf
        np.greater(np.diff(ta), config.max_gap_s, out=gap[1:])
        _count(rejections, 'time_gap', np.count_nonzero(gap))
        speed = config.gear_ratio * v
        self.fastest_speed_rad_s = max(self.fastest_speed_rad_s, float(speed.max()),
                                       -float(speed.min()))
        sign = ((speed > config.standstill_speed_rad_s).view(np.int8)
                - (speed < -config.standstill_speed_rad_s).view(np.int8))
        moving = np.flatnonzero(sign)
        if moving.size:
            self.last_motion_s = float(ta[moving[-1]])
        # A new move starts where the sign changes or after a gap (a rejected sample alone
        # does not cut it: the time between its neighbours decides).
        gap[0] |= sign[0] != self._sign
        gap[1:] |= sign[1:] != sign[:-1]
        starts = np.flatnonzero(gap)
        levels: list[FrictionLevel] = []
        qa, ea = q, e / config.torque_scale
        if starts.size and starts[0] == 0:
            levels += self._close_move()  # the move in progress ends before this chunk
        elif starts.size:  # the move in progress ends in this chunk
            self._extend(ta, qa, speed, ea, int(sign[0]), 0, int(starts[0]))
            levels += self._close_move()
        else:
            starts = np.zeros(1, dtype=np.intp)  # it goes on past this chunk
        # the moves that start and end in this chunk, at once
        for found in _analyse_moves(ta, qa, speed, ea, sign, starts[:-1], starts[1:], config):
            if isinstance(found, str):
                rejections[found] += 1
            else:
                levels += self._pairer.add(found)
        last = int(starts[-1])
        self._extend(ta, qa, speed, ea, int(sign[last]), last, n)
        self._last_time = float(ta[-1])
        return levels

    def _accepted(self, t: FloatArray, q: FloatArray, v: FloatArray, e: FloatArray
                  ) -> NDArray[np.intp] | None:
        """
        Count the rejected samples of a chunk; return the indices of the others (None: all).

        A sample is accepted when its fields are finite and within :data:`SAMPLE_LIMITS` and
        its time is past that of every such sample before it (of this or an earlier chunk).
        """
        with np.errstate(invalid='ignore'):  # a comparison with NaN is False: not in range
            usable = ((np.abs(q) <= SAMPLE_LIMITS[0]) & (np.abs(v) <= SAMPLE_LIMITS[1])
                      & (np.abs(e) <= SAMPLE_LIMITS[2]) & np.isfinite(t))
        if t[0] > self._time_max and usable.all() and (t[1:] > t[:-1]).all():
            self._time_max = float(t[-1])
            return None
        finite = np.isfinite(t) & np.isfinite(q) & np.isfinite(v) & np.isfinite(e)
        _count(self.rejections, 'out_of_range', np.count_nonzero(finite & ~usable))
        running = np.maximum.accumulate(np.where(usable, t, -np.inf))
        before = np.maximum(running[:-1], self._time_max)
        previous_max = np.concatenate(([self._time_max], before))
        self._time_max = max(self._time_max, float(running[-1]))
        accepted = usable & (t > previous_max)
        _count(self.rejections, 'non_finite', np.count_nonzero(~finite))
        _count(self.rejections, 'time_not_increasing', np.count_nonzero(usable & ~accepted))
        return np.flatnonzero(accepted)

    def finish(self) -> list[FrictionLevel]:
        """End of the recording: analyse the move in progress; return the levels it completes."""
        levels = self._close_move()
        self._pairer.finish()
        return levels

    def _extend(self, t: FloatArray, q: FloatArray, speed: FloatArray, torque: FloatArray,
                sign: int, start: int, stop: int) -> None:
        """Append samples start:stop to the move in progress (which has this sign)."""
        self._sign = sign
        if sign == 0:
            self._move = ()
            return
        part = (t[start:stop], q[start:stop], speed[start:stop], torque[start:stop])
        self._move = part if not self._move else tuple(
            np.concatenate((old, new)) for old, new in zip(self._move, part))

    @property
    def last_time_s(self) -> float:
        """Return the time of the last accepted sample [s] (-inf before the first)."""
        return self._last_time

    def discard_move(self) -> None:
        """Drop the move in progress without analysing it (a recording cut in it)."""
        self._move, self._sign = (), 0

    def _close_move(self) -> list[FrictionLevel]:
        move, sign = self._move, self._sign
        self._move, self._sign = (), 0
        if sign == 0 or not move:
            return []
        time_s, position_rad, speed_rad_s, torque = move
        found = _analyse_move(time_s, position_rad, speed_rad_s, torque, sign, self.config,
                              self.rejections)
        return self._pairer.add(found) if found is not None else []


def _count(counter: Counter, reason: str, count: int | np.integer) -> None:
    if count:
        counter[reason] += int(count)
