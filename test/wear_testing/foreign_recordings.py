"""
Foreign recordings: multi-joint JointState bags of friction experiments made by another tool.

An independent generator of test recordings.  It shares no trajectory, noise, protocol or bag
code with ``robot_wear_monitor`` (it does not use ``experiment/simulation.py``, the package's
bag writer or ``test/wear_testing/independent_robot.py``); only the friction values come from the
package's model (:func:`robot_wear_monitor.model.friction.friction`).  Bags are written with
rosbags' ``Writer`` and the typestore's ``serialize_cdr``.

Arm and protocol
----------------
A six-axis arm (:data:`JOINT_NAMES`) publishes ``sensor_msgs/msg/JointState`` on
``/joint_states``.  Each experiment tests one joint (``schedule`` names the joint of each
experiment, in order); the other joints hold their posture.  For every speed level of the
tested joint (motor-side speed v [rad/s], joint speed u = v / gear_ratio):

1. a repositioning bump (a cosine velocity profile, no constant-speed part) to the start
   ``a = centre - span/2`` of the level, when the joint is not already there;
2. ``dwell_s`` of standstill;
3. the forward pass: a smoothstep ramp up (``ramp_s``), ``plateau_s`` at constant speed u,
   a smoothstep ramp down, ending at ``b = a + span`` (span = u (plateau_s + ramp_s));
4. ``dwell_s``; 5. the backward pass (the mirror image, b -> a); 6. ``dwell_s``.

Experiments are separated by ``idle_gap_s`` of standstill.  The window centre of an experiment
is ``centre_rad + window_drift_rad x (the joint's experiment number)`` (a drifting window).

Torque of the tested joint, normalised (effort = torque_scale x normalised torque)::

    tau = gravity(q) + inertia x qdd + sign(qd) tau_f(|qd| gear_ratio) + e_level + e_sample

tau_f is the package's model (8) at the experiment's load, temperature and wear (wear
interpolated linearly from ``wear_start`` to ``wear_end`` over the joint's experiments);
``e_level`` is one offset per level (std ``level_error_std``, same in both directions so it
enters the level of eq. (3), reported in the truth), ``e_sample`` white noise per sample.  On
the constant-speed plateau the friction is ``tau_f(v) + e_level``: the truth level.

Recording imperfections (:class:`Imperfections`, each off by default)
--------------------------------------------------------------------
``rate_hz`` (100..1000), ``stamp_jitter_fraction`` (header stamp = true sample time = nominal
+ Gaussian jitter of that fraction of the period, clipped to +-0.3 periods so that stamps keep
increasing), ``drop_fraction`` (messages never recorded), ``shuffle_order`` (a random joint
order per message), ``absent_fraction`` (messages missing one random joint of
``absent_joints``), ``effort_empty_fraction`` (messages with an empty effort array),
``zero_stamp_fraction`` (header stamp 0; 1.0: every message), an interrupted experiment
(``interrupt_experiment``: the joint stops half-way through the forward plateau of level
``interrupt_level`` and the rest of that experiment is skipped), and at writing time
``storage`` (``'mcap'``/``'sqlite3'``) and ``split_files`` (a bag folder of several files).
The direct-drive joint ``wrist_3`` of :func:`default_joints` has gear ratio 1.
The bag receive time of a message is its nominal time + 0.1..0.3 periods (increasing).

Truth (:class:`ForeignRecording`)
---------------------------------
Per message, in bag order: ``receive_ns`` (bag time), ``stamp_ns`` (header stamp, 0 where
zeroed), ``true_time_s`` (when the sample was taken), ``order`` (column permutation: message
column c holds joint ``order[c]``; -1 = joint absent), ``effort_empty`` and the true
``position_rad``/``velocity_rad_s``/``effort`` (n, J) in :data:`JOINT_NAMES` order, exactly the
float64 values written.  :meth:`ForeignRecording.expected_samples` and
:meth:`~ForeignRecording.expected_rejections` give what a reader must return per joint.
``experiments``: one :class:`ExperimentTruth` per experiment (joint, index, the joint's
experiment number, start/end [s], wear, temperature, load, window centre, interrupted, levels).
Each :class:`LevelTruth` holds the motor-side speed [rad/s], the friction level tau_f
(normalised; model + e_level), the model value, the constant-speed position window of the
passes [rad] and the plateau times [s]; ``complete`` is False for the level an interruption
cut (its forward pass is broken, no backward pass).  :meth:`ForeignRecording.truth_dict` is the
whole experiment truth as JSON-ready data (``format: 'foreign_recordings/1'``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
import math
import os
from pathlib import Path
import shutil
from typing import Sequence

import numpy as np
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import load_parameter_set
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

JOINT_NAMES = ('base_yaw', 'shoulder', 'elbow', 'wrist_1', 'wrist_2', 'wrist_3')
TOPIC = '/joint_states'
MSGTYPE = 'sensor_msgs/msg/JointState'
_TYPES = get_typestore(Stores.ROS2_JAZZY)
#: Start of the recording [s since the epoch].
EPOCH_S = 1_750_000_000.0


@dataclass(frozen=True)
class JointSpec:
    """
    One joint of the arm and its friction experiment.

    :ivar name: joint name.
    :ivar gear_ratio: motor speed / joint speed (1: direct drive).
    :ivar torque_scale: effort = torque_scale x normalised torque.
    :ivar speeds_rad_s: motor-side speeds of the experiment's levels, in the order run.
    :ivar load: load torque (normalised) of the model.
    :ivar wear_start: wear at the joint's first experiment.
    :ivar wear_end: wear at its last experiment.
    :ivar posture_rad: position while not tested [rad].
    :ivar centre_rad: window centre of the joint's first experiment [rad].
    :ivar gravity: amplitude of the gravity torque (normalised).
    :ivar inertia: inertia (normalised torque per rad/s^2 of joint acceleration).

    """

    name: str
    gear_ratio: float = 100.0
    torque_scale: float = 1000.0
    speeds_rad_s: tuple[float, ...] = (28.5, 41.7)
    load: float = 0.5
    wear_start: float = 0.0
    wear_end: float = 60.0
    posture_rad: float = 0.0
    centre_rad: float = 0.3
    gravity: float = 0.2
    inertia: float = 0.01


def default_joints() -> dict[str, JointSpec]:
    """Return the default arm: geared joints and the direct-drive ``wrist_3`` (gear ratio 1)."""
    return {
        'base_yaw': JointSpec('base_yaw', 160.0, 3000.0, (20.0, 36.0), 0.4, 0.0, 30.0,
                              0.1, -0.2, 0.0),
        'shoulder': JointSpec('shoulder', 120.0, 2000.0, (35.84, 40.84), 0.6, 0.0, 60.0,
                              -0.4, 0.5, 0.3),
        'elbow': JointSpec('elbow', 100.0, 1500.0, (12.0, 28.5, 41.7), 0.5, 10.0, 70.0,
                           0.8, 0.9, 0.15),
        'wrist_1': JointSpec('wrist_1', 80.0, 400.0, (16.0, 32.0), 0.3, 0.0, 40.0,
                             -0.2, 0.0, 0.05),
        'wrist_2': JointSpec('wrist_2', 80.0, 400.0, (16.0, 32.0), 0.3, 0.0, 40.0,
                             0.3, 0.0, 0.05),
        'wrist_3': JointSpec('wrist_3', 1.0, 20.0, (1.5, 3.0), 0.2, 0.0, 50.0,
                             0.0, 0.0, 0.0, 0.002),
    }


@dataclass(frozen=True)
class Protocol:
    """
    Timing of the experiments [s] and the noise of the measurements.

    :ivar plateau_s: constant-speed time of each pass.
    :ivar ramp_s: duration of each smoothstep ramp.
    :ivar dwell_s: standstill between moves.
    :ivar bump_s: duration of a repositioning bump.
    :ivar idle_gap_s: standstill between experiments.
    :ivar lead_in_s: standstill before the first experiment.
    :ivar torque_noise_std: white noise of the normalised torque per sample.
    :ivar level_error_std: one offset per level of the normalised friction (in the truth).
    :ivar velocity_noise_fraction: velocity noise, relative to the joint speed u of the level.
    :ivar position_noise_rad: position noise [rad].
    :ivar temperature_degc: (min, max) of the joint temperature over the recording [degC].

    """

    plateau_s: float = 1.0
    ramp_s: float = 0.25
    dwell_s: float = 0.4
    bump_s: float = 0.8
    idle_gap_s: float = 4.0
    lead_in_s: float = 1.0
    torque_noise_std: float = 2e-3
    level_error_std: float = 0.0
    velocity_noise_fraction: float = 2e-3
    position_noise_rad: float = 1e-5
    temperature_degc: tuple[float, float] = (35.0, 45.0)


@dataclass(frozen=True)
class Imperfections:
    """What makes a recording real; every item is off by default (see the module docstring)."""

    rate_hz: float = 200.0
    stamp_jitter_fraction: float = 0.0
    drop_fraction: float = 0.0
    shuffle_order: bool = False
    absent_fraction: float = 0.0
    absent_joints: tuple[str, ...] | None = None
    effort_empty_fraction: float = 0.0
    zero_stamp_fraction: float = 0.0
    interrupt_experiment: int | None = None
    interrupt_level: int = 1


@dataclass(frozen=True)
class LevelTruth:
    """One speed level of an experiment (see the module docstring)."""

    speed_rad_s: float
    tau_f: float
    tau_f_model: float
    level_error: float
    window_rad: tuple[float, float]
    forward_s: tuple[float, float]
    backward_s: tuple[float, float] | None
    complete: bool


@dataclass(frozen=True)
class ExperimentTruth:
    """One experiment of one joint (see the module docstring)."""

    joint: str
    index: int
    joint_experiment: int
    start_s: float
    end_s: float
    wear: float
    temperature_degc: float
    load: float
    centre_rad: float
    gear_ratio: float
    torque_scale: float
    interrupted: bool
    levels: tuple[LevelTruth, ...]

    @property
    def complete_levels(self) -> tuple[LevelTruth, ...]:
        """Return the levels with both passes."""
        return tuple(level for level in self.levels if level.complete)


@dataclass
class ForeignRecording:
    """Messages and truth of a generated recording (see the module docstring)."""

    joint_names: tuple[str, ...]
    receive_ns: np.ndarray
    stamp_ns: np.ndarray
    true_time_s: np.ndarray
    order: np.ndarray
    effort_empty: np.ndarray
    position_rad: np.ndarray
    velocity_rad_s: np.ndarray
    effort: np.ndarray
    experiments: list[ExperimentTruth]
    joints: dict[str, JointSpec]
    protocol: Protocol
    imperfections: Imperfections
    dropped: int = 0
    seed: int = 0
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        """Return the number of messages."""
        return int(self.receive_ns.size)

    def present(self, joint: str) -> np.ndarray:
        """Return per message whether it names ``joint``."""
        return np.any(self.order == self.joint_names.index(joint), axis=1)

    def expected_samples(self, joint: str) -> dict[str, np.ndarray]:
        """
        Return what a reader must return for ``joint``: time_s, position_rad, ... (m,).

        time_s is the header stamp, or the bag receive time where the stamp is zero.
        """
        j = self.joint_names.index(joint)
        usable = self.present(joint) & ~self.effort_empty
        stamp = np.where(self.stamp_ns == 0, self.receive_ns, self.stamp_ns)
        sec, nanosec = np.divmod(stamp, 1_000_000_000)
        return {'time_s': (sec + nanosec * 1e-9)[usable],
                'position_rad': self.position_rad[usable, j],
                'velocity_rad_s': self.velocity_rad_s[usable, j],
                'effort': self.effort[usable, j]}

    def expected_rejections(self, joint: str) -> dict[str, int]:
        """Return reason -> messages a reader must reject for ``joint`` (zero counts left out)."""
        present = self.present(joint)
        counts = {'joint_missing': int(np.count_nonzero(~present)),
                  'missing_effort': int(np.count_nonzero(present & self.effort_empty))}
        return {reason: count for reason, count in counts.items() if count}

    def experiments_of(self, joint: str) -> list[ExperimentTruth]:
        """Return the experiments of one joint, in order."""
        return [e for e in self.experiments if e.joint == joint]

    def first_experiment_over(self, joint: str, wear: float) -> ExperimentTruth | None:
        """Return the joint's first experiment whose true wear is >= ``wear`` (None: none)."""
        return next((e for e in self.experiments_of(joint) if e.wear >= wear), None)

    def write_truth(self, path: str | os.PathLike) -> Path:
        """Write :meth:`truth_dict` as JSON to ``path`` (never beside a bag by default)."""
        import json
        target = Path(path)
        target.write_text(json.dumps(self.truth_dict(), indent=1) + '\n', encoding='utf-8')
        return target

    def truth_dict(self) -> dict:
        """Return the experiment truth as JSON-ready data (``format: foreign_recordings/1``)."""
        return {
            'format': 'foreign_recordings/1',
            'topic': TOPIC,
            'joints': {name: asdict(spec) for name, spec in self.joints.items()},
            'protocol': asdict(self.protocol),
            'imperfections': asdict(self.imperfections),
            'messages': len(self), 'dropped': self.dropped, 'seed': self.seed,
            'experiments': [dict(asdict(e), complete_levels=len(e.complete_levels))
                            for e in self.experiments],
        }


# --------------------------------------------------------------------------- trajectory

def _smoothstep_integral(x: np.ndarray) -> np.ndarray:
    """Integral of 3x^2 - 2x^3 from 0 to x."""
    return x ** 3 - 0.5 * x ** 4


class _Path:
    """Piecewise trajectory of one joint: holds, bumps and trapezoid-like passes."""

    def __init__(self, start_s: float, position_rad: float) -> None:
        self.t = start_s
        self.q = position_rad
        self.pieces: list[tuple] = []   # (t0, t1, kind, q0, params)

    def hold(self, duration_s: float) -> None:
        self.pieces.append((self.t, self.t + duration_s, 'hold', self.q, ()))
        self.t += duration_s

    def bump(self, target_rad: float, duration_s: float) -> None:
        """Cosine velocity profile from here to ``target_rad`` (no constant-speed part)."""
        if abs(target_rad - self.q) < 1e-12:
            return
        self.pieces.append((self.t, self.t + duration_s, 'bump', self.q,
                            (target_rad - self.q, duration_s)))
        self.t += duration_s
        self.q = target_rad

    def move(self, speed: float, ramp_s: float, plateau_s: float,
             stop_after_s: float | None = None) -> tuple[float, float]:
        """
        Smoothstep up, plateau at ``speed`` (signed joint speed), smoothstep down.

        With ``stop_after_s`` the plateau ends after that time (an interruption) and the joint
        ramps down.  Returns the (start, end) times of the constant-speed plateau.
        """
        plateau = plateau_s if stop_after_s is None else stop_after_s
        self.pieces.append((self.t, self.t + 2 * ramp_s + plateau, 'move', self.q,
                            (speed, ramp_s, plateau)))
        window = (self.t + ramp_s, self.t + ramp_s + plateau)
        self.t += 2 * ramp_s + plateau
        self.q += speed * (ramp_s + plateau)
        return window

    def evaluate(self, t: np.ndarray, rest_rad: float) -> tuple[np.ndarray, ...]:
        """Return position [rad], velocity [rad/s], acceleration [rad/s^2] at times ``t``."""
        q = np.full(t.shape, rest_rad)
        v = np.zeros(t.shape)
        a = np.zeros(t.shape)
        for t0, t1, kind, q0, params in self.pieces:
            inside = (t >= t0) & (t < t1)
            # after this piece (until the next one) the joint rests where it ended
            q[t >= t1] = self._end(kind, q0, params)
            if not inside.any():
                continue
            s = t[inside] - t0
            if kind == 'hold':
                q[inside] = q0
            elif kind == 'bump':
                dq, duration = params
                phase = 2 * math.pi * s / duration
                q[inside] = q0 + dq * (s / duration - np.sin(phase) / (2 * math.pi))
                v[inside] = dq / duration * (1 - np.cos(phase))
                a[inside] = dq / duration * 2 * math.pi / duration * np.sin(phase)
            else:
                speed, ramp, plateau = params
                total = 2 * ramp + plateau
                up = s < ramp
                down = s > ramp + plateau
                flat = ~up & ~down
                x = s / ramp
                y = (total - s) / ramp
                qs = np.where(up, speed * ramp * _smoothstep_integral(np.clip(x, 0, 1)),
                              speed * (0.5 * ramp + (s - ramp)))
                qs = np.where(down, speed * (ramp + plateau)
                              - speed * ramp * _smoothstep_integral(np.clip(y, 0, 1)), qs)
                vs = np.where(up, speed * (3 * x ** 2 - 2 * x ** 3),
                              np.where(down, speed * (3 * y ** 2 - 2 * y ** 3), speed))
                acc = np.where(up, speed / ramp * (6 * x - 6 * x ** 2),
                               np.where(down, -speed / ramp * (6 * y - 6 * y ** 2), 0.0))
                vs[flat] = speed
                q[inside], v[inside], a[inside] = q0 + qs, vs, acc
        return q, v, a

    @staticmethod
    def _end(kind: str, q0: float, params: tuple) -> float:
        if kind == 'hold':
            return q0
        if kind == 'bump':
            return q0 + params[0]
        speed, ramp, plateau = params
        return q0 + speed * (ramp + plateau)


def _gravity(q: np.ndarray, amplitude: float) -> np.ndarray:
    """Gravity torque of a joint (normalised): a tilted pendulum with a second harmonic."""
    return amplitude * (np.sin(q + 0.4) + 0.15 * np.sin(2.0 * q))


# --------------------------------------------------------------------------- generation

def generate(*, schedule: Sequence[str], joints: dict[str, JointSpec] | None = None,
             protocol: Protocol = Protocol(), imperfections: Imperfections = Imperfections(),
             window_drift_rad: float = 0.0, hold_s: float = 0.0,
             seed: int = 0) -> ForeignRecording:
    """
    Generate a recording: one experiment per entry of ``schedule`` (the tested joint).

    :param schedule: the joint tested by each experiment, in order.
    :param joints: the arm (default :func:`default_joints`); every name is published.
    :param protocol: timing and noise.
    :param imperfections: what makes the recording real (see :class:`Imperfections`).
    :param window_drift_rad: shift of a joint's window centre per experiment of that joint [rad].
    :param hold_s: standstill added at the end [s] (with an empty schedule: a bag in which no
        joint moves).
    :param seed: random seed (noise, drops, orders, absences, stamps).

    """
    arm = dict(default_joints() if joints is None else joints)
    names = tuple(arm)
    for joint in schedule:
        if joint not in arm:
            raise ValueError(f'schedule names {joint!r}, not a joint of {names}')
    rng = np.random.default_rng(seed)
    model = load_parameter_set().model
    paths = {name: _Path(EPOCH_S, arm[name].posture_rad) for name in names}
    clock = EPOCH_S + protocol.lead_in_s
    runs = {name: schedule.count(name) for name in names}
    done = dict.fromkeys(names, 0)
    low, high = protocol.temperature_degc
    experiments: list[ExperimentTruth] = []
    # per-level torque offsets on the plateau, applied by time window: (joint, t0, t1, tau_f)
    frictions: list[tuple[str, float, float, float, float]] = []
    for index, joint in enumerate(schedule):
        spec = arm[joint]
        path = paths[joint]
        path.hold(clock - path.t)
        k = done[joint]
        done[joint] += 1
        wear = spec.wear_start + (spec.wear_end - spec.wear_start) * (
            k / (runs[joint] - 1) if runs[joint] > 1 else 0.0)
        temperature = low + (high - low) * 0.5 * (1 - math.cos(2 * math.pi * index /
                                                               max(len(schedule), 2)))
        centre = spec.centre_rad + window_drift_rad * k
        start = path.t
        levels = []
        interrupted = imperfections.interrupt_experiment == index
        for m, speed in enumerate(spec.speeds_rad_s):
            u = speed / spec.gear_ratio
            span = u * (protocol.plateau_s + protocol.ramp_s)
            a = centre - span / 2
            model_value = float(friction(speed, spec.load, temperature, wear, model))
            error = float(rng.normal(0.0, protocol.level_error_std)) \
                if protocol.level_error_std > 0 else 0.0
            tau_f = model_value + error
            path.bump(a, protocol.bump_s)
            path.hold(protocol.dwell_s)
            cut = interrupted and m == imperfections.interrupt_level
            forward = path.move(u, protocol.ramp_s, protocol.plateau_s,
                                stop_after_s=0.5 * protocol.plateau_s if cut else None)
            frictions.append((joint, path.t - 2 * protocol.ramp_s - (forward[1] - forward[0]),
                              path.t, tau_f, model_value))
            plateau_q = (a + 0.5 * u * protocol.ramp_s,
                         a + 0.5 * u * protocol.ramp_s + u * (forward[1] - forward[0]))
            if cut:
                path.hold(protocol.dwell_s)
                levels.append(LevelTruth(speed, tau_f, model_value, error, plateau_q,
                                         forward, None, False))
                break
            path.hold(protocol.dwell_s)
            backward = path.move(-u, protocol.ramp_s, protocol.plateau_s)
            frictions.append((joint, path.t - 2 * protocol.ramp_s - protocol.plateau_s,
                              path.t, tau_f, model_value))
            path.hold(protocol.dwell_s)
            levels.append(LevelTruth(speed, tau_f, model_value, error, plateau_q, forward,
                                     backward, True))
        experiments.append(ExperimentTruth(
            joint=joint, index=index, joint_experiment=k, start_s=start, end_s=path.t,
            wear=wear, temperature_degc=temperature, load=spec.load, centre_rad=centre,
            gear_ratio=spec.gear_ratio, torque_scale=spec.torque_scale,
            interrupted=interrupted, levels=tuple(levels)))
        clock = path.t + protocol.idle_gap_s
    end = clock + hold_s

    # sampling: nominal grid, drops, jitter of the header stamps, receive times
    period = 1.0 / imperfections.rate_hz
    nominal = EPOCH_S + np.arange(int((end - EPOCH_S) / period)) * period
    keep = rng.random(nominal.size) >= imperfections.drop_fraction
    dropped = int(np.count_nonzero(~keep))
    nominal = nominal[keep]
    n = nominal.size
    jitter = np.clip(rng.normal(0.0, imperfections.stamp_jitter_fraction * period, n),
                     -0.3 * period, 0.3 * period) if imperfections.stamp_jitter_fraction \
        else np.zeros(n)
    true_time = nominal + jitter
    stamp_ns = np.round(true_time * 1e9).astype(np.int64)
    true_time = stamp_ns * 1e-9  # when the sample was taken, as stamped
    receive_ns = np.round((nominal + period * (0.1 + 0.2 * rng.random(n))) * 1e9).astype(
        np.int64)
    rel = (stamp_ns - int(EPOCH_S * 1e9)) * 1e-9   # time since EPOCH_S (precise)

    j_count = len(names)
    position = np.zeros((n, j_count))
    velocity = np.zeros((n, j_count))
    effort = np.zeros((n, j_count))
    for j, name in enumerate(names):
        spec = arm[name]
        path = paths[name]
        t_rel = rel
        pieces = [(t0 - EPOCH_S, t1 - EPOCH_S, kind, q0, params)
                  for t0, t1, kind, q0, params in path.pieces]
        relative = _Path(0.0, spec.posture_rad)
        relative.pieces = pieces
        q, v, acc = relative.evaluate(t_rel, spec.posture_rad)
        motor = np.abs(v) * spec.gear_ratio
        with np.errstate(invalid='ignore'):
            tau_f = np.where(motor > 0, friction(np.maximum(motor, 1e-9), spec.load, 40.0,
                                                 spec.wear_start, model), 0.0)
        # the friction of each pass at its experiment's conditions (and the level error on
        # the plateau): replace the placeholder above inside each pass
        for joint, t0, t1, level_tau, model_value in frictions:
            if joint != name:
                continue
            inside = (t_rel >= t0 - EPOCH_S) & (t_rel < t1 - EPOCH_S)
            if not inside.any():
                continue
            experiment = next(e for e in experiments if e.joint == name
                              and e.start_s <= t0 < e.end_s)
            exact = friction(np.maximum(motor[inside], 1e-9), spec.load,
                             experiment.temperature_degc, experiment.wear, model)
            # level error on the whole pass: at the plateau speed the friction is the level
            tau_f[inside] = exact + (level_tau - model_value)
        torque = (_gravity(q, spec.gravity) + spec.inertia * acc + np.sign(v) * tau_f
                  + rng.normal(0.0, protocol.torque_noise_std, n))
        speeds = np.array([s / spec.gear_ratio for s in spec.speeds_rad_s] or [0.0])
        position[:, j] = q + rng.normal(0.0, protocol.position_noise_rad, n)
        velocity[:, j] = v + rng.normal(0.0, protocol.velocity_noise_fraction
                                        * float(np.max(speeds)), n) * (v != 0)
        effort[:, j] = spec.torque_scale * torque

    # message structure: orders, absent joints, empty efforts, zero stamps
    if imperfections.shuffle_order:
        order = np.argsort(rng.random((n, j_count)), axis=1)
    else:
        order = np.tile(np.arange(j_count), (n, 1))
    absent_pool = [names.index(a) for a in (imperfections.absent_joints or names)]
    absent = rng.random(n) < imperfections.absent_fraction
    for row in np.flatnonzero(absent):
        victim = absent_pool[int(rng.integers(len(absent_pool)))]
        order[row, order[row] == victim] = -1
    effort_empty = rng.random(n) < imperfections.effort_empty_fraction
    zero = rng.random(n) < imperfections.zero_stamp_fraction
    stamp_written = np.where(zero, 0, stamp_ns)
    return ForeignRecording(
        joint_names=names, receive_ns=receive_ns, stamp_ns=stamp_written,
        true_time_s=true_time, order=order, effort_empty=effort_empty, position_rad=position,
        velocity_rad_s=velocity, effort=effort, experiments=experiments, joints=arm,
        protocol=protocol, imperfections=imperfections, dropped=dropped, seed=seed)


# --------------------------------------------------------------------------- writing

def _serialize(recording: ForeignRecording, row: int) -> bytes:
    types = _TYPES.types
    stamp = int(recording.stamp_ns[row])
    columns = [c for c in recording.order[row] if c >= 0]
    names = [recording.joint_names[c] for c in columns]
    effort = np.zeros(0) if recording.effort_empty[row] else recording.effort[row, columns]
    message = types[MSGTYPE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=stamp // 1_000_000_000,
                                                       nanosec=stamp % 1_000_000_000),
            frame_id=''),
        name=names, position=np.ascontiguousarray(recording.position_rad[row, columns]),
        velocity=np.ascontiguousarray(recording.velocity_rad_s[row, columns]),
        effort=np.ascontiguousarray(effort, dtype=np.float64))
    return bytes(_TYPES.serialize_cdr(message, MSGTYPE))


def _write_part(folder: Path, recording: ForeignRecording, rows: range,
                storage: str, topic: str) -> Path:
    plugin = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}[storage]
    writer = Writer(folder, version=9, storage_plugin=plugin)
    writer.open()
    try:
        connection = writer.add_connection(topic, MSGTYPE, typestore=_TYPES)
        for row in rows:
            writer.write(connection, int(recording.receive_ns[row]),
                         _serialize(recording, row))
    finally:
        writer.close()
    return folder


def write_bag(recording: ForeignRecording, path: str | os.PathLike, *,
              storage: str = 'mcap', split_files: int = 1, topic: str = TOPIC) -> Path:
    """
    Write the recording as a bag folder (MCAP or sqlite3), optionally split in files.

    ``topic`` is the JointState topic (another name makes a bag without ``/joint_states``).

    With ``split_files`` > 1 the messages are cut into that many consecutive parts, each
    written by rosbags' Writer, and the files are gathered in one folder under one
    ``metadata.yaml`` listing them all (what ``ros2 bag record --max-bag-size`` leaves).
    """
    from ruamel.yaml import YAML
    target = Path(path)
    if target.exists():
        raise FileExistsError(target)
    n = len(recording)
    if split_files <= 1:
        return _write_part(target, recording, range(n), storage, topic)
    bounds = np.linspace(0, n, split_files + 1).round().astype(int)
    staging = target.with_name(target.name + '.parts')
    staging.mkdir()
    metas = []
    yaml = YAML(typ='safe')
    for k in range(split_files):
        part = _write_part(staging / f'{target.name}_{k}', recording,
                           range(int(bounds[k]), int(bounds[k + 1])), storage, topic)
        metas.append((part, yaml.load((part / 'metadata.yaml').read_text())
                      ['rosbag2_bagfile_information']))
    target.mkdir()
    merged = dict(metas[0][1])
    files, relative = [], []
    for part, meta in metas:
        for name in meta['relative_file_paths']:
            shutil.move(str(part / name), str(target / name))
            relative.append(name)
        files.extend(meta.get('files', []))
    starts = [m['starting_time']['nanoseconds_since_epoch'] for _, m in metas]
    ends = [m['starting_time']['nanoseconds_since_epoch'] + m['duration']['nanoseconds']
            for _, m in metas]
    merged['relative_file_paths'] = relative
    merged['files'] = files
    merged['message_count'] = sum(m['message_count'] for _, m in metas)
    merged['starting_time'] = {'nanoseconds_since_epoch': min(starts)}
    merged['duration'] = {'nanoseconds': max(ends) - min(starts)}
    topics = []
    for entry in metas[0][1]['topics_with_message_count']:
        entry = dict(entry)
        entry['message_count'] = sum(
            e['message_count'] for _, m in metas for e in m['topics_with_message_count']
            if e['topic_metadata']['name'] == entry['topic_metadata']['name'])
        topics.append(entry)
    merged['topics_with_message_count'] = topics
    with open(target / 'metadata.yaml', 'w', encoding='utf-8') as stream:
        YAML(typ='safe', pure=True).dump({'rosbag2_bagfile_information': merged}, stream)
    shutil.rmtree(staging)
    return target
