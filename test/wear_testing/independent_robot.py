"""
Independent test data: a 6-axis arm running the friction experiment while its joint wears.

This generator shares no code with ``robot_wear_monitor`` (it does not import or copy
``experiment/simulation.py`` or ``model/friction.py``): the friction model, the trajectories, the
noise and the protocol are written here from the paper (Bittencourt and Axelsson, eqs. (3), (5),
(7), (8), (9)) and ``../shared/seed/PARAMETERS.md``, so that the package's segmentation,
estimation, replay and bag reading can be checked against a truth they did not produce.

Protocol of one experiment, for every motor-side speed v in the given order (joint speed =
v / gear_ratio):

1. a quick repositioning bump (a one-period cosine velocity profile, no constant-speed part)
   from where the joint stands to ``centre - d(v)/2``;
2. standstill;
3. forward pass: raised-cosine ramp up, constant speed for ``plateau_s``, raised-cosine ramp
   down, ending at ``centre + d(v)/2``;
4. standstill;
5. backward pass over the same positions (mirror image of the forward pass);
6. standstill.

Experiments are separated by ``gap_s`` of standstill, and after the last one the joint returns
to the centre.  The constant-speed positions of both passes of every speed are symmetric about
``centre_rad``.

Torque of the monitored joint (normalised; effort = torque_scale x normalised torque)::

    tau = g cos(q) + J qdd + sign(qd) [tau_f(|qd| gear_ratio, load, T, w) + e_level] + e_sample

with tau_f the complete model (8) = (5) + (7) of PARAMETERS.md, ``e_level`` one model error per
experiment and speed (std ``level_noise_std``, sigma of (9b) by default, the same in both
directions so that it enters the friction level of eq. (3)), ``e_sample`` white noise per sample
and the effort rounded to ``effort_resolution``.  The other joints hold a fixed posture.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

#: Joint names of the simulated arm.
JOINT_NAMES = tuple(f'joint_{i}' for i in range(1, 7))
#: Topic of the recorded joint states.
JOINT_STATES_TOPIC = '/joint_states'
#: Message type of the recorded joint states.
JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'
#: The paper's N = 4 experiment speeds of Table V [rad/s, motor side].
TABLE_V_SPEEDS_RAD_S = (2.1, 28.5, 35.1, 41.7)

#: Table I (nominal model (5)) and Table II (wear profile (7)), as read in PARAMETERS.md.
PAPER_PARAMETERS = {
    'F_c0': 3.11e-2, 'F_ctl': 2.34e-2, 'F_s0': -2.50e-2, 'F_stl': 1.26e-1, 'F_sT': 1.60e-3,
    'F_v0': 1.30e-4, 'F_vT': 1.32e-3, 'phi_s0': -24.81, 'phi_stl': 9.22, 'phi_sT': 0.98,
    'T_V0': 20.71, 'alpha': 1.36,
    'F_sw': 9.02e-4, 'F_vw': -5.15e-7, 'phi_sw': 2.19,
}
#: sigma of (9b): sqrt(4.23e-3^2 + 3.82e-3^2).
SIGMA_9B = math.hypot(4.23e-3, 3.82e-3)

#: Fixed posture of the arm [rad] (the monitored joint's entry is replaced by its trajectory).
_POSTURE_RAD = np.array([0.1, 0.6, -0.4, 0.05, 0.5, -0.2])
#: Holding torques of the other joints [normalised].
_HOLDING_TORQUE = np.array([0.0, 0.0, 0.35, 0.01, 0.06, 0.0])


# --------------------------------------------------------------------------- friction model

def nominal_friction(speed_rad_s, load, temperature_degc, p=PAPER_PARAMETERS):
    """Return the nominal friction tau_f^0 of eq. (5) at motor-side speed(s) [normalised]."""
    v = np.abs(np.asarray(speed_rad_s, dtype=float))
    a = p['alpha']
    temp = float(temperature_degc)
    tl = float(load)
    phi_s = p['phi_s0'] + p['phi_sT'] * temp
    return (p['F_c0'] + p['F_ctl'] * tl
            + p['F_stl'] * tl * np.exp(-(v / p['phi_stl']) ** a)
            + (p['F_s0'] + p['F_sT'] * temp) * np.exp(-(v / phi_s) ** a)
            + (p['F_v0'] + p['F_vT'] * math.exp(-temp / p['T_V0'])) * v)


def wear_friction(speed_rad_s, wear, p=PAPER_PARAMETERS):
    """Return the wear profile tau~_f of eq. (7) at motor-side speed(s) [normalised]."""
    v = np.abs(np.asarray(speed_rad_s, dtype=float))
    w = float(wear)
    if w <= 0.0:
        return np.zeros_like(v)
    return (p['F_sw'] * w * np.exp(-(v / (p['phi_sw'] * w)) ** p['alpha'])
            + p['F_vw'] * w * v)


def friction_model(speed_rad_s, load, temperature_degc, wear, p=PAPER_PARAMETERS):
    """Return the complete model (8) = (5) + (7) at motor-side speed(s) [normalised]."""
    return (nominal_friction(speed_rad_s, load, temperature_degc, p)
            + wear_friction(speed_rad_s, wear, p))


# --------------------------------------------------------------------------- data types

@dataclass(frozen=True)
class ExperimentTruth:
    """
    What really happened in one experiment.

    :ivar index: 0-based experiment number.
    :ivar wear: true wear w.
    :ivar temperature_degc: true joint temperature [degC].
    :ivar load: true load torque tau_l [normalised].
    :ivar start_s: time of the first sample of the experiment (its first repositioning) [s].
    :ivar end_s: time of the last sample of its final standstill [s].
    :ivar speeds_rad_s: commanded motor-side speeds, in the order they were run.
    :ivar friction_model: tau_f of model (8) at each speed (no model error) [normalised].
    :ivar friction_true: friction actually applied at each constant speed (model + level error).

    """

    index: int
    wear: float
    temperature_degc: float
    load: float
    start_s: float
    end_s: float
    speeds_rad_s: tuple[float, ...]
    friction_model: tuple[float, ...]
    friction_true: tuple[float, ...]

    def to_dict(self) -> dict:
        """Return the truth as a plain dict (JSON-safe)."""
        return asdict(self)


@dataclass
class Recording:
    """
    A recorded joint-state stream of the whole arm and its truth.

    :ivar stamps_s: sample times [s], shape (n,), a realistic ROS epoch.
    :ivar stamps_ns: the same times in integer nanoseconds, shape (n,).
    :ivar names: joint names (joint_1 .. joint_6).
    :ivar position: joint positions [rad], shape (n, 6).
    :ivar velocity: joint velocities [rad/s, joint side], shape (n, 6).
    :ivar effort: efforts (torque_scale x normalised torque), shape (n, 6).
    :ivar truth: one :class:`ExperimentTruth` per experiment.
    :ivar joint: the monitored joint.
    :ivar gear_ratio: motor speed / joint speed of the monitored joint.
    :ivar torque_scale: effort per normalised torque.
    :ivar centre_rad: position the passes are centred on [rad].
    :ivar repositionings: number of repositioning bumps (moves without a constant-speed part).

    """

    stamps_s: np.ndarray
    stamps_ns: np.ndarray
    names: tuple[str, ...]
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    truth: list[ExperimentTruth]
    joint: str
    gear_ratio: float
    torque_scale: float
    centre_rad: float
    repositionings: int

    @property
    def joint_index(self) -> int:
        """Column of the monitored joint."""
        return self.names.index(self.joint)

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.stamps_s[-1] - self.stamps_s[0])

    def __len__(self) -> int:
        """Return the number of samples (= JointState messages)."""
        return int(self.stamps_s.size)


# --------------------------------------------------------------------------- trajectory pieces

def _hold(n: int, dt: float):
    """Standstill: zero displacement, velocity and acceleration over n samples."""
    z = np.zeros(n)
    return z, z, z


def _pass_profile(speed: float, n_ramp: int, n_plateau: int, dt: float):
    """
    Raised-cosine ramp up, constant ``speed``, raised-cosine ramp down (signed speed).

    Returns displacement from the start, velocity and acceleration, each over
    ``2 n_ramp + n_plateau`` samples; the displacement at the end (one sample later) is
    ``speed (T_ramp + T_plateau)``.
    """
    t_r = n_ramp * dt
    t_p = n_plateau * dt
    t = np.arange(2 * n_ramp + n_plateau) * dt
    q = np.empty_like(t)
    v = np.empty_like(t)
    a = np.empty_like(t)
    up = t < t_r
    flat = (t >= t_r) & (t < t_r + t_p)
    down = t >= t_r + t_p
    w = math.pi / t_r
    tu = t[up]
    v[up] = 0.5 * speed * (1.0 - np.cos(w * tu))
    a[up] = 0.5 * speed * w * np.sin(w * tu)
    q[up] = 0.5 * speed * (tu - np.sin(w * tu) / w)
    tf = t[flat] - t_r
    v[flat] = speed
    a[flat] = 0.0
    q[flat] = 0.5 * speed * t_r + speed * tf
    td = t[down] - t_r - t_p
    v[down] = 0.5 * speed * (1.0 + np.cos(w * td))
    a[down] = -0.5 * speed * w * np.sin(w * td)
    q[down] = 0.5 * speed * t_r + speed * t_p + 0.5 * speed * (td + np.sin(w * td) / w)
    return q, v, a


def _bump_profile(distance: float, n: int, dt: float):
    """Move ``distance`` in n samples with velocity (d/T)(1 - cos(2 pi t / T)); no plateau."""
    t_b = n * dt
    t = np.arange(n) * dt
    w = 2.0 * math.pi / t_b
    v = distance / t_b * (1.0 - np.cos(w * t))
    a = distance / t_b * w * np.sin(w * t)
    q = distance / t_b * (t - np.sin(w * t) / w)
    return q, v, a


def _samples(duration_s: float, rate_hz: float) -> int:
    return max(int(round(duration_s * rate_hz)), 1)


# --------------------------------------------------------------------------- the generator

def generate_wear_test(*, n_experiments: int = 8, wear_start: float = 0.0,
                       wear_end: float = 60.0, seed: int = 0, rate_hz: float = 1000.0,
                       joint: str = 'joint_2',
                       speeds_rad_s: Sequence[float] = TABLE_V_SPEEDS_RAD_S,
                       gear_ratio: float = 150.0, torque_scale: float = 10.0,
                       temperatures_degc: Sequence[float] | None = None,
                       loads: Sequence[float] | None = None,
                       wears: Sequence[float] | None = None,
                       plateau_s: float = 0.3, ramp_s: float = 0.05,
                       standstill_s: float = 0.05, reposition_s: float = 0.15,
                       gap_s: float = 1.0, centre_rad: float = 0.6,
                       gravity: float = 0.8, inertia: float = 0.01,
                       level_noise_std: float = SIGMA_9B, torque_noise_std: float = 5.0e-3,
                       effort_resolution: float = 1.0e-3,
                       velocity_noise_std: float = 2.0e-5, position_noise_std: float = 1.0e-6,
                       start_time_s: float = 1_700_000_000.0,
                       friction_parameters: dict | None = None,
                       effort_limit: float | None = None) -> Recording:
    """
    Simulate an accelerated wear test: ``n_experiments`` friction experiments of one joint.

    :param n_experiments: number of experiments.
    :param wear_start: true wear of the first experiment.
    :param wear_end: true wear of the last one (linear in between).
    :param seed: random seed (temperatures, loads, noise).
    :param rate_hz: sample rate of the joint states [Hz].
    :param joint: the monitored joint (one of joint_1 .. joint_6).
    :param speeds_rad_s: motor-side constant speeds of each experiment, run in this order.
    :param gear_ratio: motor speed / joint speed.
    :param torque_scale: effort per normalised torque.
    :param temperatures_degc: per-experiment temperature; default uniform in [30, 50] degC.
    :param loads: per-experiment load tau_l; default N(0.5, 0.1) clipped to [0.2, 0.8].
    :param wears: per-experiment wear, overriding ``wear_start``/``wear_end``.
    :param plateau_s: duration of each constant-speed part [s].
    :param ramp_s: duration of each raised-cosine ramp [s].
    :param standstill_s: standstill after a repositioning and after each pass [s].
    :param reposition_s: duration of a repositioning bump [s].
    :param gap_s: standstill between experiments [s].
    :param centre_rad: joint position the passes are centred on [rad].
    :param gravity: amplitude g of the gravity torque g cos(q) [normalised].
    :param inertia: J of the inertial torque J qdd (qdd joint side) [normalised s^2/rad].
    :param level_noise_std: std of the model error per experiment and speed [normalised].
    :param torque_noise_std: std of the white torque noise per sample [normalised].
    :param effort_resolution: quantisation step of the recorded effort (effort units); 0 = none.
    :param velocity_noise_std: std of the white velocity noise [rad/s, joint side].
    :param position_noise_std: std of the white position noise [rad].
    :param start_time_s: time of the first sample [s].
    :param friction_parameters: the joint's friction coefficients (default
        :data:`PAPER_PARAMETERS`: the joint the packaged parameter set describes; another
        dict: another joint).
    :param effort_limit: the drive's torque limit (effort units): the recorded effort of the
        monitored joint saturates at +- this value (None: no limit).

    :return: The :class:`Recording` with its truth.

    :raises ValueError: a bad argument.

    """
    if joint not in JOINT_NAMES:
        raise ValueError(f'joint must be one of {JOINT_NAMES}, got {joint!r}')
    if int(n_experiments) < 1:
        raise ValueError(f'n_experiments must be >= 1, got {n_experiments}')
    n_exp = int(n_experiments)
    speeds = [float(s) for s in speeds_rad_s]
    if not speeds or min(speeds) <= 0:
        raise ValueError(f'speeds_rad_s must be positive, got {speeds_rad_s!r}')
    if rate_hz <= 0 or gear_ratio <= 0 or torque_scale <= 0:
        raise ValueError('rate_hz, gear_ratio and torque_scale must be > 0')
    rng = np.random.default_rng(seed)
    if temperatures_degc is None:
        temperatures = rng.uniform(30.0, 50.0, n_exp)
    else:
        temperatures = np.asarray(temperatures_degc, dtype=float)
    if loads is None:
        load_values = np.clip(rng.normal(0.5, 0.1, n_exp), 0.2, 0.8)
    else:
        load_values = np.asarray(loads, dtype=float)
    if wears is None:
        wear_values = (np.full(n_exp, float(wear_start)) if n_exp == 1 else
                       np.linspace(float(wear_start), float(wear_end), n_exp))
    else:
        wear_values = np.asarray(wears, dtype=float)
    for label, values in (('temperatures_degc', temperatures), ('loads', load_values),
                          ('wears', wear_values)):
        if values.shape != (n_exp,):
            raise ValueError(f'{label}: expected {n_exp} values, got shape {values.shape}')
    level_errors = rng.normal(0.0, level_noise_std, (n_exp, len(speeds)))
    coefficients = PAPER_PARAMETERS if friction_parameters is None else {
        **PAPER_PARAMETERS, **friction_parameters}

    dt = 1.0 / rate_hz
    n_ramp = _samples(ramp_s, rate_hz)
    n_plateau = _samples(plateau_s, rate_hz)
    n_still = _samples(standstill_s, rate_hz)
    n_bump = _samples(reposition_s, rate_hz)
    n_gap = _samples(gap_s, rate_hz)

    # Pieces of the monitored joint's trajectory: position, velocity, acceleration, the model
    # error applied while moving and the experiment each sample belongs to.
    q_parts: list[np.ndarray] = []
    v_parts: list[np.ndarray] = []
    a_parts: list[np.ndarray] = []
    level_parts: list[np.ndarray] = []   # model error applied while moving (0 elsewhere)
    exp_parts: list[np.ndarray] = []     # experiment index of each sample (-1 in gaps)
    here = [float(centre_rad)]
    repositionings = [0]

    def append(piece, level_error: float, experiment: int) -> None:
        dq, v, a = piece
        q_parts.append(here[0] + dq)
        v_parts.append(v)
        a_parts.append(a)
        level_parts.append(np.full(v.size, level_error))
        exp_parts.append(np.full(v.size, experiment))

    def move_to(target: float, experiment: int) -> None:
        distance = target - here[0]
        if abs(distance) > 1e-12:
            append(_bump_profile(distance, n_bump, dt), 0.0, experiment)
            repositionings[0] += 1
            here[0] = target

    append(_hold(n_still, dt), 0.0, -1)
    for k in range(n_exp):
        for i, speed in enumerate(speeds):
            joint_speed = speed / gear_ratio
            travel = joint_speed * (n_ramp + n_plateau) * dt
            move_to(centre_rad - 0.5 * travel, k)
            append(_hold(n_still, dt), 0.0, k)
            for direction in (1.0, -1.0):
                append(_pass_profile(direction * joint_speed, n_ramp, n_plateau, dt),
                       level_errors[k, i], k)
                here[0] += direction * travel
                append(_hold(n_still, dt), 0.0, k)
        append(_hold(n_gap, dt), 0.0, -1)
    move_to(centre_rad, -1)
    append(_hold(n_still, dt), 0.0, -1)

    q = np.concatenate(q_parts)
    qd = np.concatenate(v_parts)
    qdd = np.concatenate(a_parts)
    level_error = np.concatenate(level_parts)
    experiment = np.concatenate(exp_parts)
    n = q.size
    stamps_ns = (int(round(start_time_s * 1e9))
                 + np.round(np.arange(n) * (1e9 / rate_hz)).astype(np.int64))
    stamps_s = stamps_ns / 1e9

    # Friction of the monitored joint: model (8) at each sample's speed and its experiment's
    # conditions (the conditions of the next experiment during a gap do not matter: the joint
    # stands still there, except for the repositioning, which belongs to its experiment).
    motor_speed = np.abs(qd) * gear_ratio
    friction = np.zeros(n)
    for k in range(n_exp):
        mine = (experiment == k) & (qd != 0.0)
        friction[mine] = friction_model(motor_speed[mine], load_values[k], temperatures[k],
                                        wear_values[k], coefficients)
    final = (experiment == -1) & (qd != 0.0)
    friction[final] = friction_model(motor_speed[final], load_values[-1], temperatures[-1],
                                     wear_values[-1], coefficients)
    torque = (gravity * np.cos(q) + inertia * qdd + np.sign(qd) * (friction + level_error)
              + rng.normal(0.0, torque_noise_std, n))

    col = JOINT_NAMES.index(joint)
    position = np.tile(_POSTURE_RAD, (n, 1)) + rng.normal(0.0, 1e-5, (n, 6))
    velocity = rng.normal(0.0, 1e-4, (n, 6))
    effort = torque_scale * (np.tile(_HOLDING_TORQUE, (n, 1))
                             + rng.normal(0.0, 1e-3, (n, 6)))
    position[:, col] = q + rng.normal(0.0, position_noise_std, n)
    velocity[:, col] = qd + rng.normal(0.0, velocity_noise_std, n)
    effort[:, col] = torque_scale * torque
    if effort_limit is not None:
        effort[:, col] = np.clip(effort[:, col], -effort_limit, effort_limit)
    if effort_resolution > 0:
        effort = np.round(effort / effort_resolution) * effort_resolution

    truth = []
    for k in range(n_exp):
        rows = np.flatnonzero(experiment == k)
        model = friction_model(np.array(speeds), load_values[k], temperatures[k],
                               wear_values[k], coefficients)
        truth.append(ExperimentTruth(
            index=k, wear=float(wear_values[k]), temperature_degc=float(temperatures[k]),
            load=float(load_values[k]), start_s=float(stamps_s[rows[0]]),
            end_s=float(stamps_s[rows[-1]]),
            speeds_rad_s=tuple(speeds), friction_model=tuple(float(f) for f in model),
            friction_true=tuple(float(f) for f in model + level_errors[k])))
    return Recording(stamps_s=stamps_s, stamps_ns=stamps_ns, names=JOINT_NAMES,
                     position=position, velocity=velocity, effort=effort, truth=truth,
                     joint=joint, gear_ratio=float(gear_ratio),
                     torque_scale=float(torque_scale), centre_rad=float(centre_rad),
                     repositionings=repositionings[0])


# --------------------------------------------------------------------------- output

def messages(recording: Recording) -> Iterator[tuple[float, list[str], list[float],
                                                     list[float], list[float]]]:
    """Yield (stamp [s], names, position, velocity, effort) per sample, for live publishing."""
    names = list(recording.names)
    for stamp, pos, vel, eff in zip(recording.stamps_s.tolist(), recording.position.tolist(),
                                    recording.velocity.tolist(), recording.effort.tolist()):
        yield stamp, list(names), pos, vel, eff


def write_bag(path, recording: Recording, *, storage: str = 'mcap') -> Path:
    """
    Write ``recording`` as /joint_states (sensor_msgs/msg/JointState) into a new bag.

    One message per sample; header.stamp and the bag (log) time are the sample's time.  Uses
    rosbags directly with the ROS 2 Jazzy typestore.  ``storage`` is 'mcap' or 'sqlite3'.
    Returns the bag directory.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores

    plugins = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
    if storage not in plugins:
        raise ValueError(f"storage must be 'mcap' or 'sqlite3', got {storage!r}")
    typestore = get_typestore(Stores.ROS2_JAZZY)
    joint_state = typestore.types[JOINT_STATE_TYPE]
    header = typestore.types['std_msgs/msg/Header']
    time = typestore.types['builtin_interfaces/msg/Time']
    names = list(recording.names)
    path = Path(path)
    sec = recording.stamps_ns // 1_000_000_000
    nanosec = recording.stamps_ns % 1_000_000_000
    with Writer(path, version=Writer.VERSION_LATEST, storage_plugin=plugins[storage]) as writer:
        connection = writer.add_connection(JOINT_STATES_TOPIC, JOINT_STATE_TYPE,
                                           typestore=typestore)
        for i in range(len(recording)):
            msg = joint_state(
                header=header(stamp=time(sec=int(sec[i]), nanosec=int(nanosec[i])),
                              frame_id=''),
                name=names, position=recording.position[i], velocity=recording.velocity[i],
                effort=recording.effort[i])
            writer.write(connection, int(recording.stamps_ns[i]),
                         typestore.serialize_cdr(msg, JOINT_STATE_TYPE))
    return path
