"""
Plan the friction experiment: the motion that gives the designed speeds' friction levels.

For each designed speed v_i (motor side, rad/s) the tested joint runs a forward and a backward
pass at the constant joint speed v_i / gear_ratio through a position window around ``center_rad``
(joint side); the speed changes (trapezoidal, or jerk-limited S-curves) happen outside the
window, and the joint stands still for ``dwell_s`` at every turn.  Each plateau is as short as
the segmentation and the wanted accuracy allow, so the experiment is as short as the constraints
allow:

* the segmentation keeps a plateau of at least ``min_duration_s`` after trimming ``trim_s`` at
  each end, with at least ``min_samples`` samples (the friction-experiment node's
  ``min_duration_s``, ``trim_s`` and ``min_samples``);
* the friction level tau_f = (tau+ - tau-)/2 of eq. (3) averages M samples per pass, so its
  standard error is ``noise_std`` / sqrt(2 M); M >= noise_std^2 / (2 target_std_error^2).

The plateau is then (ceil(M) + 4) / rate_hz + 2 trim_s: the segmentation measures a plateau
from its first to its last kept sample and trims at sample resolution, so up to three samples
are lost at the ends (stamp jitter included), and one more is margin.

The motion is a sequence of phases of constant jerk (for trapezoids: constant acceleration), so
position, velocity and acceleration are exact at any time (:meth:`ExperimentPlan.sample`); the
same plan drives the simulator (``simulation.simulate_experiment``), the trajectory files of
``robot-wear-monitor plan`` and the ``friction_experiment_runner`` node.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.plan_config import PlanConfig, PlanError  # noqa: F401

#: Phase kinds of :attr:`ExperimentPlan.kind`.
REPOSITION, DWELL, RAMP, PLATEAU = 0, 1, 2, 3


@dataclass(frozen=True)
class PlannedSpeed:
    """The part of the plan for one designed speed (times from the plan's start)."""

    speed_rad_s: float
    joint_speed_rad_s: float
    plateau_s: float
    window_rad: tuple[float, float]
    ramp_rad: float
    start_s: float
    end_s: float

    @property
    def duration_s(self) -> float:
        """Time spent on this speed, repositioning included [s]."""
        return self.end_s - self.start_s


@dataclass(frozen=True)
class ExperimentPlan:
    """
    A planned friction experiment: phases of constant jerk of the tested joint.

    Arrays of shape (P,) per phase: ``start_s``, ``duration_s``, the state at the phase start
    ``position_rad``, ``velocity_rad_s``, ``acceleration_rad_s2``, its ``jerk_rad_s3``, the
    ``speed_index`` (which designed speed it serves) and its ``kind`` (REPOSITION, DWELL, RAMP,
    PLATEAU).
    """

    config: PlanConfig
    speeds: tuple[PlannedSpeed, ...]
    start_s: FloatArray
    duration_s: FloatArray
    position_rad: FloatArray
    velocity_rad_s: FloatArray
    acceleration_rad_s2: FloatArray
    jerk_rad_s3: FloatArray
    speed_index: NDArray[np.int64]
    kind: NDArray[np.int64]

    @property
    def total_s(self) -> float:
        """Duration of the whole experiment [s]."""
        return float(self.start_s[-1] + self.duration_s[-1])

    def sample(self, time_s: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray,
                                                 NDArray[np.int64]]:
        """
        Return the exact (position, velocity, acceleration, speed index) at ``time_s``.

        :param time_s: times from the plan's start [s], any shape; clipped to [0, total_s].

        :return: Joint-side position [rad], velocity [rad/s], acceleration [rad/s^2] and the index
            of the designed speed each time belongs to, all of the shape of ``time_s``.

        """
        t = np.clip(np.asarray(time_s, dtype=float), 0.0, self.total_s)
        i = np.clip(np.searchsorted(self.start_s, t, side='right') - 1, 0,
                    self.start_s.size - 1)
        tau = np.minimum(t - self.start_s[i], self.duration_s[i])
        p0, v0 = self.position_rad[i], self.velocity_rad_s[i]
        a0, j = self.acceleration_rad_s2[i], self.jerk_rad_s3[i]
        position = p0 + v0 * tau + a0 * tau ** 2 / 2.0 + j * tau ** 3 / 6.0
        velocity = v0 + a0 * tau + j * tau ** 2 / 2.0
        acceleration = a0 + j * tau
        return position, velocity, acceleration, self.speed_index[i]

    def sampled(self, rate_hz: Optional[float] = None) -> tuple[FloatArray, FloatArray,
                                                                FloatArray, FloatArray,
                                                                NDArray[np.int64]]:
        """
        Return (time_s, position, velocity, acceleration, speed index) at ``rate_hz``.

        The samples are k / rate_hz for k = 0 .. floor(total_s rate_hz), plus the end point.
        Default rate: the configured JointState rate.
        """
        rate = float(rate_hz or self.config.rate_hz)
        if not (math.isfinite(rate) and rate > 0):
            raise InputError(f'plan: sample rate must be > 0, got {rate_hz}')
        t = np.arange(int(math.floor(self.total_s * rate + 1e-9)) + 1) / rate
        if self.total_s - t[-1] > 1e-9:
            t = np.append(t, self.total_s)
        return (t, *self.sample(t))

    def joint_positions(self, position_rad: FloatArray) -> FloatArray:
        """Return positions of every joint of ``joint_names`` (others held), shape (n, J)."""
        cfg = self.config
        names = cfg.joint_names or (cfg.joint,)
        out = np.empty((np.size(position_rad), len(names)))
        others = [k for k, name in enumerate(names) if name != cfg.joint]
        out[:, others] = np.asarray(cfg.hold_positions_rad, dtype=float)
        out[:, names.index(cfg.joint)] = position_rad
        return out

    def limits_used(self) -> dict[str, float]:
        """Return the largest |velocity| [rad/s], |acceleration| and |jerk| of the plan."""
        end_v = (self.velocity_rad_s + self.acceleration_rad_s2 * self.duration_s
                 + self.jerk_rad_s3 * self.duration_s ** 2 / 2.0)
        end_a = self.acceleration_rad_s2 + self.jerk_rad_s3 * self.duration_s
        return {'speed_rad_s': float(max(np.abs(self.velocity_rad_s).max(),
                                         np.abs(end_v).max())),
                'acceleration_rad_s2': float(max(np.abs(self.acceleration_rad_s2).max(),
                                                 np.abs(end_a).max())),
                'jerk_rad_s3': float(np.abs(self.jerk_rad_s3).max())}


# --------------------------------------------------------------------------- building blocks

def _speed_change(delta: float, acceleration: float, jerk: Optional[float]
                  ) -> list[tuple[float, float, float]]:
    """Return phases (duration, a0, jerk) changing the speed by ``delta`` from rest of a."""
    size = abs(delta)
    if size == 0.0:
        return []
    sign = 1.0 if delta > 0 else -1.0
    if jerk is None:
        return [(size / acceleration, sign * acceleration, 0.0)]
    if size >= acceleration ** 2 / jerk:
        tj = acceleration / jerk
        ta = size / acceleration - tj
        phases = [(tj, 0.0, sign * jerk)]
        if ta > 0:
            phases.append((ta, sign * acceleration, 0.0))
        phases.append((tj, sign * acceleration, -sign * jerk))
        return phases
    peak = math.sqrt(size * jerk)
    tj = peak / jerk
    return [(tj, 0.0, sign * jerk), (tj, sign * peak, -sign * jerk)]


def _ramp_time(speed: float, acceleration: float, jerk: Optional[float]) -> float:
    return sum(d for d, _, _ in _speed_change(speed, acceleration, jerk))


def _ramp_distance(speed: float, acceleration: float, jerk: Optional[float]) -> float:
    """Distance to reach ``speed`` from rest (the profiles are symmetric: mean speed v/2)."""
    return 0.5 * speed * _ramp_time(speed, acceleration, jerk)


class _Builder:
    """Append phases of constant jerk, tracking the exact state."""

    def __init__(self, position: float) -> None:
        self.rows: list[tuple] = []
        self.t = 0.0
        self.p, self.v, self.a = position, 0.0, 0.0

    def add(self, duration: float, a0: float, jerk: float, index: int, kind: int) -> None:
        if duration <= 0:
            return
        self.rows.append((self.t, duration, self.p, self.v, a0, jerk, index, kind))
        self.p += self.v * duration + a0 * duration ** 2 / 2.0 + jerk * duration ** 3 / 6.0
        self.v += a0 * duration + jerk * duration ** 2 / 2.0
        self.a = a0 + jerk * duration
        self.t += duration

    def dwell(self, duration: float, index: int) -> None:
        self.v = 0.0
        self.add(duration, 0.0, 0.0, index, DWELL)

    def move(self, target: float, speed: float, cfg: PlanConfig, index: int, kind: int,
             cruise_kind: int) -> None:
        """Rest-to-rest move to ``target`` at cruise ``speed`` at most (lower if too short)."""
        distance = abs(target - self.p)
        if distance <= 1e-12:
            self.p = target
            return
        sign = 1.0 if target > self.p else -1.0
        acc, jerk = cfg.max_acceleration_rad_s2, cfg.max_jerk_rad_s3
        if 2.0 * _ramp_distance(speed, acc, jerk) > distance:
            low, high = 0.0, speed
            for _ in range(80):
                mid = 0.5 * (low + high)
                if 2.0 * _ramp_distance(mid, acc, jerk) > distance:
                    high = mid
                else:
                    low = mid
            speed = low
        cruise = (distance - 2.0 * _ramp_distance(speed, acc, jerk)) / speed
        for d, a0, j in _speed_change(sign * speed, acc, jerk):
            self.add(d, a0, j, index, kind)
        self.v = sign * speed
        self.add(cruise, 0.0, 0.0, index, cruise_kind)
        for d, a0, j in _speed_change(-sign * speed, acc, jerk):
            self.add(d, a0, j, index, kind)
        self.v, self.a, self.p = 0.0, 0.0, target


# --------------------------------------------------------------------------- the plan

def plan_experiment(*, config: PlanConfig) -> ExperimentPlan:
    """
    Plan the friction experiment of one joint (see the module docstring).

    Per designed speed, in the given order: a repositioning move to the start of its forward
    pass, the forward pass, a dwell, the backward pass, a dwell; at the end, back to the centre.
    Each pass ramps up outside the window, runs the plateau (``config.plateau_s``) centred on
    ``center_rad``, and ramps down outside it.

    :param config: the constraints.

    :return: The :class:`ExperimentPlan`.

    :raises PlanError: a plateau that does not fit the window, or a motion beyond the joint
        limits; the message names the speed and the numbers, ``field`` the constraint.

    """
    cfg = config
    acc, jerk = cfg.max_acceleration_rad_s2, cfg.max_jerk_rad_s3
    plateau = cfg.plateau_s
    joint_speeds = [v / cfg.gear_ratio for v in cfg.speeds_rad_s]
    reposition = cfg.max_speed_rad_s if cfg.max_speed_rad_s is not None else max(joint_speeds)
    builder = _Builder(cfg.center_rad)
    builder.dwell(cfg.dwell_s, 0)
    planned = []
    for index, (motor, speed) in enumerate(zip(cfg.speeds_rad_s, joint_speeds)):
        half = 0.5 * speed * plateau
        if half > cfg.half_range_rad and cfg.shorten_to_window:
            if speed * cfg.shortest_plateau_s <= 2.0 * cfg.half_range_rad:
                half = cfg.half_range_rad
        if half > cfg.half_range_rad:
            raise PlanError(
                f'speed {motor:g} rad/s needs a plateau of {plateau:.3g} s = {2 * half:.4g} rad '
                f'at the joint, wider than the window {2 * cfg.half_range_rad:.4g} rad',
                field='half_range_rad', hint='widen the window or lower the accuracy target')
        ramp = _ramp_distance(speed, acc, jerk)
        left, right = cfg.center_rad - half - ramp, cfg.center_rad + half + ramp
        if cfg.position_limits_rad is not None:
            low, high = cfg.position_limits_rad
            if left < low or right > high:
                raise PlanError(
                    f'speed {motor:g} rad/s moves the joint over [{left:.4g}, {right:.4g}] rad '
                    f'(window and ramps of {ramp:.3g} rad), beyond its limits [{low:g}, '
                    f'{high:g}] rad', field='position_limits_rad',
                    hint='raise --max-acceleration or move --center')
        start = builder.t
        builder.move(left, reposition, cfg, index, REPOSITION, REPOSITION)
        if start != builder.t:
            builder.dwell(cfg.dwell_s, index)
        builder.move(right, speed, cfg, index, RAMP, PLATEAU)
        builder.dwell(cfg.dwell_s, index)
        builder.move(left, speed, cfg, index, RAMP, PLATEAU)
        builder.dwell(cfg.dwell_s, index)
        planned.append(PlannedSpeed(speed_rad_s=motor, joint_speed_rad_s=speed,
                                    plateau_s=2.0 * half / speed,
                                    window_rad=(cfg.center_rad - half, cfg.center_rad + half),
                                    ramp_rad=ramp, start_s=start, end_s=builder.t))
    last = len(joint_speeds) - 1
    builder.move(cfg.center_rad, reposition, cfg, last, REPOSITION, REPOSITION)
    builder.dwell(cfg.dwell_s, last)
    rows = np.array([r[:6] for r in builder.rows], dtype=float)
    tags = np.array([r[6:] for r in builder.rows], dtype=np.int64)
    return ExperimentPlan(config=cfg, speeds=tuple(planned), start_s=rows[:, 0],
                          duration_s=rows[:, 1], position_rad=rows[:, 2],
                          velocity_rad_s=rows[:, 3], acceleration_rad_s2=rows[:, 4],
                          jerk_rad_s3=rows[:, 5], speed_index=tags[:, 0], kind=tags[:, 1])


def plan_summary(plan: ExperimentPlan) -> dict:
    """Return the plan's figures as JSON-ready data (durations per speed and in total)."""
    cfg = plan.config
    error = (cfg.noise_std / math.sqrt(2.0 * cfg.samples_per_pass)
             if cfg.noise_std > 0 else 0.0)
    return {
        'joint': cfg.joint,
        'speeds_rad_s': list(cfg.speeds_rad_s),
        'plateau_s': cfg.plateau_s,
        'samples_per_pass': cfg.samples_per_pass,
        'std_error': error,
        'per_speed': [{'speed_rad_s': s.speed_rad_s, 'joint_speed_rad_s': s.joint_speed_rad_s,
                       'duration_s': s.duration_s, 'window_rad': list(s.window_rad),
                       'ramp_rad': s.ramp_rad} for s in plan.speeds],
        'total_s': plan.total_s,
        'limits_used': plan.limits_used(),
        'position_range_rad': _position_range(plan),
    }


def _position_range(plan: ExperimentPlan) -> list[float]:
    """Return [min, max] of the position [rad]: every phase is monotone, so at phase ends."""
    ends = np.append(plan.position_rad, plan.sample(plan.total_s)[0])
    return [float(ends.min()), float(ends.max())]


@dataclass(frozen=True)
class TrajectoryPoints:
    """
    Waypoints of a planned experiment for a trajectory controller.

    :ivar joint_names: the joints, shape (J,) (the tested joint and the held ones).
    :ivar time_from_start_s: point times [s], shape (P,), increasing, all > 0.
    :ivar positions_rad: shape (P, J); velocities_rad_s: shape (P, J);
    :ivar accelerations_rad_s2: shape (P, J) (zero for the held joints).

    """

    joint_names: tuple[str, ...]
    time_from_start_s: FloatArray
    positions_rad: FloatArray
    velocities_rad_s: FloatArray
    accelerations_rad_s2: FloatArray


def trajectory_points(plan: ExperimentPlan, *, point_rate_hz: float = 50.0
                      ) -> TrajectoryPoints:
    """
    Return waypoints of ``plan``: a uniform grid at ``point_rate_hz`` plus every phase end.

    Position, velocity and acceleration are exact at every point (the plan is piecewise cubic);
    the phase ends are included so that a controller's spline through the points has the
    plan's corners.  The point at t = 0 is left out (a trajectory controller starts from the
    current state; the plan starts at rest at ``center_rad``, where the joint must be).
    """
    rate = float(point_rate_hz)
    if not (math.isfinite(rate) and rate > 0):
        raise InputError(f'plan: point rate must be > 0, got {point_rate_hz}')
    total = plan.total_s
    grid = np.arange(1, int(math.floor(total * rate + 1e-9)) + 1) / rate
    ends = np.append(plan.start_s[1:], total)
    times = np.unique(np.round(np.concatenate([grid, ends]), 9))
    times = times[(times > 0) & (times <= total + 1e-9)]
    q, v, a, _ = plan.sample(times)
    cfg = plan.config
    names = cfg.joint_names or (cfg.joint,)
    j = names.index(cfg.joint)
    velocities = np.zeros((times.size, len(names)))
    accelerations = np.zeros((times.size, len(names)))
    velocities[:, j], accelerations[:, j] = v, a
    return TrajectoryPoints(joint_names=tuple(names), time_from_start_s=times,
                            positions_rad=plan.joint_positions(q), velocities_rad_s=velocities,
                            accelerations_rad_s2=accelerations)
