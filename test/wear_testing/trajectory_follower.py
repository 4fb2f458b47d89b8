"""
A simulated arm that follows JointTrajectory points, for the runner's tests (no ROS).

Written for the tests, independent of ``robot_wear_monitor.experiment.simulation``: the arm
follows the last trajectory it received like a trajectory controller does, by a cubic Hermite
spline through the points' positions and velocities, starting from its own state when the
trajectory arrives (the points' ``time_from_start`` count from then); after the last point it
holds.  The torque of a tested joint is (normalised; effort = torque_scale x it)::

    tau = g cos(q) + J qdd + sign(qd) tau_f(|qd| gear_ratio, load, T, w) + e

with tau_f the complete friction model (8) of ``independent_robot`` at the joint's true load,
temperature and wear, and ``e`` white noise.  The other joints hold with a constant torque.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from wear_testing import independent_robot as robot


@dataclass(frozen=True)
class JointTruth:
    """The true state of a tested joint: what its friction levels must give."""

    gear_ratio: float = 150.0
    torque_scale: float = 10.0
    load: float = 0.5
    temperature_degc: float = 40.0
    wear: float = 40.0
    gravity: float = 0.8
    inertia: float = 0.01

    def friction(self, speeds_rad_s: Sequence[float]) -> np.ndarray:
        """Return the true friction levels at motor-side speeds [normalised]."""
        return np.asarray(robot.friction_model(np.asarray(speeds_rad_s, dtype=float),
                                               self.load, self.temperature_degc, self.wear))


class HermiteFollower:
    """One received trajectory: knots at 0 (the state at receipt) and at every point."""

    def __init__(self, *, time_from_start_s, positions, velocities, start_position,
                 start_velocity) -> None:
        """Keep the knots (times [s], positions [rad] and velocities [rad/s], (P + 1, J))."""
        self.t = np.concatenate(([0.0], np.asarray(time_from_start_s, dtype=float)))
        self.q = np.vstack([start_position, np.asarray(positions, dtype=float)])
        velocities = np.asarray(velocities, dtype=float)
        if velocities.size == 0:
            velocities = np.zeros_like(self.q[1:])
        self.v = np.vstack([start_velocity, velocities])

    def state(self, elapsed_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return position, velocity, acceleration of every joint ``elapsed_s`` after receipt."""
        if elapsed_s >= self.t[-1]:
            zero = np.zeros_like(self.q[-1])
            return self.q[-1].copy(), zero, zero.copy()
        i = int(np.searchsorted(self.t, max(elapsed_s, 0.0), side='right')) - 1
        h = self.t[i + 1] - self.t[i]
        s = (max(elapsed_s, 0.0) - self.t[i]) / h
        p0, p1, v0, v1 = self.q[i], self.q[i + 1], self.v[i] * h, self.v[i + 1] * h
        q = ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * v0
             + (-2 * s**3 + 3 * s**2) * p1 + (s**3 - s**2) * v1)
        qd = ((6 * s**2 - 6 * s) * p0 + (3 * s**2 - 4 * s + 1) * v0
              + (-6 * s**2 + 6 * s) * p1 + (3 * s**2 - 2 * s) * v1) / h
        qdd = ((12 * s - 6) * p0 + (6 * s - 4) * v0 + (-12 * s + 6) * p1
               + (6 * s - 2) * v1) / h**2
        return q, qd, qdd


class SimulatedArm:
    """An arm of named joints at a posture; tested joints have friction (see the module doc)."""

    def __init__(self, joint_names: Sequence[str], posture_rad: Sequence[float], *,
                 tested: dict[str, JointTruth], torque_noise_std: float = 5e-3,
                 velocity_noise_std: float = 2e-5, seed: int = 0) -> None:
        """Stand still at ``posture_rad``; ``tested`` gives the friction of some joints."""
        self.names = list(joint_names)
        self.posture = np.asarray(posture_rad, dtype=float)
        self.tested = dict(tested)
        self.torque_noise_std = float(torque_noise_std)
        self.velocity_noise_std = float(velocity_noise_std)
        self.rng = np.random.default_rng(seed)
        self._follower: Optional[HermiteFollower] = None
        self._received_s = 0.0
        self.trajectories = 0

    def command(self, time_s: float, *, joint_names: Sequence[str], time_from_start_s,
                positions, velocities) -> None:
        """Receive a trajectory at ``time_s``: follow it from the current state."""
        q, qd, _ = self.state(time_s)
        order = [self.names.index(name) for name in joint_names]
        positions = np.asarray(positions, dtype=float)
        velocities = np.asarray(velocities, dtype=float)
        full_q = np.tile(q, (positions.shape[0], 1))
        full_v = np.zeros_like(full_q)
        full_q[:, order] = positions
        if velocities.size:
            full_v[:, order] = velocities
        self._follower = HermiteFollower(time_from_start_s=time_from_start_s, positions=full_q,
                                         velocities=full_v, start_position=q,
                                         start_velocity=qd)
        self._received_s = float(time_s)
        self.trajectories += 1

    def command_points(self, time_s: float, points) -> None:
        """Receive ``planning.TrajectoryPoints`` at ``time_s``."""
        self.command(time_s, joint_names=points.joint_names,
                     time_from_start_s=points.time_from_start_s,
                     positions=points.positions_rad, velocities=points.velocities_rad_s)

    def state(self, time_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the exact position, velocity and acceleration of every joint."""
        if self._follower is None:
            zero = np.zeros_like(self.posture)
            return self.posture.copy(), zero, zero.copy()
        return self._follower.state(time_s - self._received_s)

    def sample(self, time_s: float) -> tuple[list[float], list[float], list[float]]:
        """Return a measured JointState (position, velocity, effort), noise included."""
        q, qd, qdd = self.state(time_s)
        effort = np.zeros_like(q)
        for name, truth in self.tested.items():
            j = self.names.index(name)
            speed = abs(qd[j]) * truth.gear_ratio
            friction = float(truth.friction([speed])[0]) if speed > 1e-9 else 0.0
            tau = (truth.gravity * np.cos(q[j]) + truth.inertia * qdd[j]
                   + np.sign(qd[j]) * friction
                   + self.rng.normal(0.0, self.torque_noise_std))
            effort[j] = truth.torque_scale * tau
        velocity = qd + self.rng.normal(0.0, self.velocity_noise_std, qd.size)
        return q.tolist(), velocity.tolist(), effort.tolist()
