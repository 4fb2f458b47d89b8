"""
Simulated friction experiments of one joint of a 6-axis arm, and accelerated wear scenarios.

One experiment (Sec. II-A of the paper) moves the tested joint back and forth around phi_bar at
each speed of a list, along the planned motion of ``experiment.planning`` (the same plan that
``robot-wear-monitor plan`` writes and the runner node sends): for every speed a forward and a
backward pass at constant speed for about ``cruise_s`` inside a window of ``max_stroke_rad``,
trapezoidal (or jerk-limited) speed changes outside it, and a short standstill at each turn.
The normalised motor torque of the tested joint is

    tau = sign(v) tau_f(|v_m|, load, T, w) + g(q) + J a_m + e,                             (*)

with tau_f the complete friction model (8) plus a per-level model error ``level_error_std``
(the epsilon of eq. (9b)), g(q) = ``gravity_amplitude`` sin(q + ``gravity_phase_rad``), J the
``inertia`` times the motor acceleration a_m, and e white sensor noise; v_m = ``gear_ratio`` x
joint speed.  Effort = tau x ``torque_scale`` is quantised to ``effort_resolution``, the joint
position to ``position_resolution_rad``, and the joint velocity carries noise.  The other joints
of the arm stand still (with sensor noise) in the same ``JointState`` samples.

A scenario repeats the experiment for k = 0..K-1, ``experiment_interval_s`` apart, with wear,
temperature and load changing from one experiment to the next (Sec. V); the truth of each
experiment is kept in :class:`ExperimentTruth` and written as JSON by :func:`write_truth_json`
(``<bag>.truth.json`` beside a bag, see :func:`truth_path_for`).

Units: motor-side speeds [rad/s]; joint-side positions [rad] and velocities [rad/s]; torques
normalised (effort / torque_scale); temperatures [degC].
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
import json
import math
import os
from pathlib import Path
from typing import Any, Iterator, Optional, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.atomic_files import write_json_atomic
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.planning import plan_experiment, PlanConfig
from robot_wear_monitor.experiment.segmentation_settings import (SegmenterConfig,
                                                                 stream_segmenter_config,
                                                                 STREAM_SETTINGS)
from robot_wear_monitor.input_files import MAX_JSON_BYTES, read_text_file
from robot_wear_monitor.model.friction import friction as friction_model
from robot_wear_monitor.model.params import FrictionModel, load_parameter_set, ParameterSet
from robot_wear_monitor.text import shorten


#: Speed grid of the real data, eq. (27) of the paper [rad/s, motor side].
PAPER_SPEEDS_RAD_S = (2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1)
#: Optimal N = 4 design of Table V [rad/s, motor side].
TABLE_V_SPEEDS_RAD_S = (2.1, 28.5, 35.1, 41.7)
DEFAULT_JOINT_NAMES = ('joint_1', 'joint_2', 'joint_3', 'joint_4', 'joint_5', 'joint_6')
TRUTH_SUFFIX = '.truth.json'


@dataclass(frozen=True)
class JointSimConfig:
    """
    The simulated arm, joint, trajectory and sensors; units are in the field names.

    :ivar joint: name of the tested joint (one of ``joint_names``).
    :ivar joint_names: names of all joints in the JointState samples.
    :ivar gear_ratio: motor speed / joint speed.
    :ivar torque_scale: effort per unit of normalised torque (e.g. N m at the motor).
    :ivar sample_rate_hz: JointState rate [Hz].
    :ivar phi_bar_rad: centre of the back-and-forth moves, joint side [rad].
    :ivar cruise_s: wanted constant-speed time per pass [s].
    :ivar max_stroke_rad: longest travel per pass, joint side [rad].
    :ivar acceleration_rad_s2: joint acceleration limit of the speed changes [rad/s^2].
    :ivar jerk_rad_s3: joint jerk limit [rad/s^3]; None: trapezoidal speed changes.
    :ivar dwell_s: standstill at every turn [s].
    :ivar gravity_amplitude: amplitude of g(q), normalised.
    :ivar gravity_phase_rad: phase of g(q) = amplitude sin(q + phase) [rad].
    :ivar inertia: normalised torque per motor acceleration [1/(rad/s^2)].
    :ivar effort_noise_std: white noise on the tested joint's torque, normalised.
    :ivar velocity_noise_std_rad_s: white noise on the measured speed, motor side [rad/s].
    :ivar effort_resolution: quantisation step of effort (effort units).
    :ivar position_resolution_rad: quantisation step of joint positions [rad].
    :ivar other_positions_rad: positions of the other joints, in ``joint_names`` order without
        the tested joint [rad].
    :ivar other_efforts: efforts of the other joints (effort units).
    :ivar shuffle_joint_order: give every sample a random order of the joint names.

    """

    joint: str = 'joint_2'
    joint_names: tuple[str, ...] = DEFAULT_JOINT_NAMES
    gear_ratio: float = 150.0
    torque_scale: float = 10.0
    sample_rate_hz: float = 250.0
    phi_bar_rad: float = 0.2
    cruise_s: float = 1.2
    max_stroke_rad: float = 1.2
    acceleration_rad_s2: float = 10.0
    jerk_rad_s3: Optional[float] = None
    dwell_s: float = 0.2
    gravity_amplitude: float = 0.3
    gravity_phase_rad: float = 0.4
    inertia: float = 1.0e-4
    effort_noise_std: float = 0.01
    velocity_noise_std_rad_s: float = 0.01
    effort_resolution: float = 1.0e-3
    position_resolution_rad: float = 1.0e-6
    other_positions_rad: tuple[float, ...] = (0.1, -0.5, 0.3, 0.0, 0.7)
    other_efforts: tuple[float, ...] = (0.5, 4.0, 0.8, 0.2, 0.05)
    shuffle_joint_order: bool = False

    def __post_init__(self) -> None:
        """Validate; raise InputError naming the field."""
        if self.joint not in self.joint_names:
            raise InputError(f'JointSimConfig.joint: {self.joint!r} is not in joint_names')
        if len(set(self.joint_names)) != len(self.joint_names):
            raise InputError('JointSimConfig.joint_names: names must be unique')
        for name in ('gear_ratio', 'torque_scale', 'sample_rate_hz', 'cruise_s',
                     'max_stroke_rad', 'acceleration_rad_s2', 'effort_resolution',
                     'position_resolution_rad'):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0:
                raise InputError(f'JointSimConfig.{name}: must be > 0, got {value}')
        for name in ('dwell_s', 'gravity_amplitude', 'inertia', 'effort_noise_std',
                     'velocity_noise_std_rad_s'):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise InputError(f'JointSimConfig.{name}: must be >= 0, got {value}')
        others = len(self.joint_names) - 1
        for name in ('other_positions_rad', 'other_efforts'):
            if len(getattr(self, name)) != others:
                raise InputError(f'JointSimConfig.{name}: expected {others} values '
                                 f'(one per other joint), got {len(getattr(self, name))}')

    @property
    def joint_index(self) -> int:
        """Index of the tested joint in ``joint_names``."""
        return self.joint_names.index(self.joint)


def segmenter_config_for(config: JointSimConfig, **overrides) -> SegmenterConfig:
    """
    Return segmenter settings matching a simulated joint (conversions and tolerances).

    The bag-and-stream set (:data:`~robot_wear_monitor.experiment.segmentation_settings.
    STREAM_SETTINGS`) with the joint's gear ratio and torque scale; a gap of 5 samples at the
    simulated rate splits the stream.  Keyword arguments override any field.
    """
    settings: dict[str, Any] = {'gear_ratio': config.gear_ratio,
                                'torque_scale': config.torque_scale,
                                'max_gap_s': 5.0 / config.sample_rate_hz}
    settings.update(overrides)
    return stream_segmenter_config(config.joint, **settings)


@dataclass(frozen=True)
class ExperimentTruth:
    """
    What the simulator used for experiment k (the answer the monitor should find).

    :ivar k: experiment index.
    :ivar wear: wear level w.
    :ivar temperature_degc: joint temperature T [degC].
    :ivar load: load torque tau_l, normalised.
    :ivar speeds_rad_s: motor-side speed levels, in the order run.
    :ivar friction_model: tau_f of the complete model (8) at each speed, normalised.
    :ivar friction_true: friction the joint actually had (model + level error), normalised.
    :ivar start_time_s: time of the first sample of the experiment [s].
    :ivar end_time_s: time of the last sample [s].

    """

    k: int
    wear: float
    temperature_degc: float
    load: float
    speeds_rad_s: tuple[float, ...]
    friction_model: tuple[float, ...]
    friction_true: tuple[float, ...]
    start_time_s: float
    end_time_s: float


@dataclass
class Scenario:
    """
    JointState samples of all joints plus the truth of every experiment.

    :ivar joint_names: joint names, column order of the arrays.
    :ivar joint: the tested joint.
    :ivar time_s: sample stamps [s], shape (n,).
    :ivar position_rad: joint positions [rad], shape (n, J).
    :ivar velocity_rad_s: joint velocities [rad/s], shape (n, J).
    :ivar effort: efforts (effort units), shape (n, J).
    :ivar truth: one :class:`ExperimentTruth` per experiment.
    :ivar config: the simulated joint.
    :ivar name_order: per-sample permutation of the columns, shape (n, J), or None (column order).

    """

    joint_names: tuple[str, ...]
    joint: str
    time_s: FloatArray
    position_rad: FloatArray
    velocity_rad_s: FloatArray
    effort: FloatArray
    truth: list[ExperimentTruth]
    config: JointSimConfig
    name_order: NDArray[np.int64] | None = None
    metadata: dict = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        """Return the number of JointState samples."""
        return int(self.time_s.size)

    def joint_samples(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Return (time_s, position_rad, velocity_rad_s, effort) of the tested joint, (n,)."""
        j = self.config.joint_index
        return self.time_s, self.position_rad[:, j], self.velocity_rad_s[:, j], self.effort[:, j]

    def messages(self) -> Iterator[tuple[float, list[str], FloatArray, FloatArray, FloatArray]]:
        """Yield (stamp_s, name, position, velocity, effort) per JointState message."""
        names = np.array(self.joint_names, dtype=object)
        for i in range(self.time_s.size):
            order = self.name_order[i] if self.name_order is not None else slice(None)
            yield (float(self.time_s[i]), list(names[order]), self.position_rad[i, order],
                   self.velocity_rad_s[i, order], self.effort[i, order])


# --------------------------------------------------------------------------- trajectories

def plan_config_for(config: JointSimConfig, speeds_rad_s: Sequence[float] | FloatArray
                    ) -> PlanConfig:
    """
    Return the plan the simulated joint executes (``experiment.planning``).

    The window is centred on ``phi_bar_rad`` with half width ``max_stroke_rad`` / 2, each
    plateau lasts ``cruise_s`` (``desired_plateau_s``; no accuracy target; shorter where the
    window is too narrow for it at a fast speed, down to what :func:`segmenter_config_for`
    keeps), the
    speed changes use ``acceleration_rad_s2`` (and ``jerk_rad_s3`` when set), and the joint
    stands still ``dwell_s`` at every turn.
    """
    return PlanConfig(joint=config.joint, speeds_rad_s=tuple(float(v) for v in speeds_rad_s),
                      center_rad=config.phi_bar_rad, half_range_rad=0.5 * config.max_stroke_rad,
                      gear_ratio=config.gear_ratio,
                      max_acceleration_rad_s2=config.acceleration_rad_s2,
                      max_jerk_rad_s3=config.jerk_rad_s3, rate_hz=config.sample_rate_hz,
                      noise_std=config.effort_noise_std, target_std_error=None,
                      min_duration_s=STREAM_SETTINGS['min_duration_s'],
                      trim_s=STREAM_SETTINGS['trim_s'], min_samples=STREAM_SETTINGS['min_samples'],
                      desired_plateau_s=config.cruise_s, dwell_s=config.dwell_s,
                      shorten_to_window=True)


def experiment_trajectory(*, speeds_rad_s: Sequence[float] | FloatArray, config: JointSimConfig
                          ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.int64]]:
    """
    Return the tested joint's planned trajectory, sampled at the sample rate.

    The motion is the one ``robot-wear-monitor plan`` and the ``friction_experiment_runner``
    node send to the robot (:func:`plan_config_for`, ``planning.plan_experiment``): there is
    no second trajectory generator.

    :return: (position [rad], velocity [rad/s], acceleration [rad/s^2], speed index) of shape (n,),
        joint side, at t = k / sample_rate_hz; the speed index says which speed of
        ``speeds_rad_s`` a sample belongs to.

    """
    plan = plan_experiment(config=plan_config_for(config, speeds_rad_s))
    t = np.arange(int(math.floor(plan.total_s * config.sample_rate_hz)) + 1) \
        / config.sample_rate_hz
    return plan.sample(t)


def _quantise(values: FloatArray, step: float) -> FloatArray:
    return np.round(values / step) * step


def simulate_experiment(*, speeds_rad_s: Sequence[float], temperature_degc: float, load: float,
                        wear: float, model: FrictionModel, config: JointSimConfig,
                        rng: np.random.Generator, start_time_s: float = 0.0,
                        level_error_std: float = 0.0, k: int = 0
                        ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                                   ExperimentTruth]:
    """
    Simulate one friction experiment of the tested joint, eq. (*) of the module docstring.

    :return: (time_s (n,), position_rad (n, J), velocity_rad_s (n, J), effort (n, J), truth).

    """
    speeds = np.asarray(list(speeds_rad_s), dtype=float)
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or \
            np.any(speeds <= 0):
        raise InputError(f'simulate_experiment: speeds_rad_s must be positive, got '
                         f'{list(speeds_rad_s)!r}')
    true_model = friction_model(speeds, load, temperature_degc, wear, model)
    true_level = true_model + (rng.normal(0.0, level_error_std, speeds.size)
                               if level_error_std > 0 else 0.0)
    q, v, a, index = experiment_trajectory(speeds_rad_s=speeds, config=config)
    n = q.size
    time_s = start_time_s + np.arange(n) / config.sample_rate_hz
    motor_speed = config.gear_ratio * v
    moving = np.abs(motor_speed) > 0
    # Friction at the speed actually run (the model of the level's speed on the cruise; the
    # model at the instantaneous speed on the ramps), plus the level's model error.
    friction_now = friction_model(np.maximum(np.abs(motor_speed), 1e-9), load,
                                  temperature_degc, wear, model)
    friction_now = friction_now + (true_level - true_model)[index]
    tau = (np.sign(motor_speed) * friction_now * moving
           + config.gravity_amplitude * np.sin(q + config.gravity_phase_rad)
           + config.inertia * config.gear_ratio * a
           + rng.normal(0.0, config.effort_noise_std, n))
    names = config.joint_names
    j = config.joint_index
    position = np.empty((n, len(names)))
    velocity = np.empty((n, len(names)))
    effort = np.empty((n, len(names)))
    others = [i for i in range(len(names)) if i != j]
    position[:, others] = np.asarray(config.other_positions_rad)
    effort[:, others] = np.asarray(config.other_efforts) + rng.normal(
        0.0, config.effort_noise_std * config.torque_scale, (n, len(others)))
    velocity[:, others] = rng.normal(0.0, config.velocity_noise_std_rad_s / config.gear_ratio,
                                     (n, len(others)))
    position[:, j] = q
    velocity[:, j] = v + rng.normal(0.0, config.velocity_noise_std_rad_s / config.gear_ratio, n)
    effort[:, j] = tau * config.torque_scale
    position = _quantise(position, config.position_resolution_rad)
    effort = _quantise(effort, config.effort_resolution)
    truth = ExperimentTruth(k=int(k), wear=float(wear), temperature_degc=float(temperature_degc),
                            load=float(load), speeds_rad_s=tuple(float(s) for s in speeds),
                            friction_model=tuple(float(f) for f in true_model),
                            friction_true=tuple(float(f) for f in np.atleast_1d(true_level)),
                            start_time_s=float(time_s[0]), end_time_s=float(time_s[-1]))
    return time_s, position, velocity, effort, truth


# --------------------------------------------------------------------------- scenarios

@dataclass(frozen=True)
class ScenarioConfig:
    """
    A sequence of experiments k = 0..K-1 with wear, temperature and load per experiment.

    :ivar speeds_rad_s: motor-side speeds of every experiment [rad/s].
    :ivar wear: w(k), one per experiment.
    :ivar temperature_degc: T(k) [degC], one per experiment.
    :ivar load: tau_l(k), normalised, one per experiment.
    :ivar experiment_interval_s: time from one experiment's start to the next [s].
    :ivar start_time_s: stamp of the first sample [s] (default 2024-01-01T00:00:00Z).
    :ivar level_error_std: std of the per-level model error epsilon of eq. (9b), normalised.
    :ivar joint: the simulated arm and sensors.

    """

    speeds_rad_s: tuple[float, ...]
    wear: tuple[float, ...]
    temperature_degc: tuple[float, ...]
    load: tuple[float, ...]
    experiment_interval_s: float = 3600.0
    start_time_s: float = 1704067200.0
    level_error_std: float = 0.0
    joint: JointSimConfig = field(default_factory=JointSimConfig)

    def __post_init__(self) -> None:
        """Validate the lengths and ranges; raise InputError naming the field."""
        count = len(self.wear)
        if count == 0:
            raise InputError('ScenarioConfig.wear: at least one experiment is needed')
        for name in ('temperature_degc', 'load'):
            if len(getattr(self, name)) != count:
                raise InputError(f'ScenarioConfig.{name}: expected {count} values (one per '
                                 f'experiment), got {len(getattr(self, name))}')
        if not self.speeds_rad_s or any(not (s > 0 and math.isfinite(s))
                                        for s in self.speeds_rad_s):
            raise InputError(f'ScenarioConfig.speeds_rad_s: expected positive speeds, got '
                             f'{self.speeds_rad_s!r}')
        if any(w < 0 or not math.isfinite(w) for w in self.wear):
            raise InputError('ScenarioConfig.wear: values must be finite and >= 0')
        if not self.level_error_std >= 0:
            raise InputError(f'ScenarioConfig.level_error_std: must be >= 0, '
                             f'got {self.level_error_std}')
        if not self.experiment_interval_s > 0:
            raise InputError(f'ScenarioConfig.experiment_interval_s: must be > 0, '
                             f'got {self.experiment_interval_s}')

    @property
    def n_experiments(self) -> int:
        """Return the number of experiments K."""
        return len(self.wear)


def simulate_scenario(*, config: ScenarioConfig, model: FrictionModel | None = None,
                      seed: int = 0) -> Scenario:
    """
    Simulate every experiment of a scenario; reproducible for a given seed.

    :param config: the scenario.
    :param model: friction model coefficients (default: the packaged parameter set's).
    :param seed: random seed.

    :raises InputError: an experiment would last longer than ``experiment_interval_s``.

    """
    if model is None:
        model = load_parameter_set().model
    rng = np.random.default_rng(seed)
    chunks = []
    truth = []
    for k in range(config.n_experiments):
        start = config.start_time_s + k * config.experiment_interval_s
        t, q, v, e, tr = simulate_experiment(
            speeds_rad_s=config.speeds_rad_s, temperature_degc=config.temperature_degc[k],
            load=config.load[k], wear=config.wear[k], model=model, config=config.joint, rng=rng,
            start_time_s=start, level_error_std=config.level_error_std, k=k)
        if k + 1 < config.n_experiments and t[-1] >= start + config.experiment_interval_s:
            raise InputError(f'ScenarioConfig.experiment_interval_s: an experiment lasts '
                             f'{t[-1] - t[0]:.1f} s, longer than the interval')
        chunks.append((t, q, v, e))
        truth.append(tr)
    time_s, position, velocity, effort = (np.concatenate(c) for c in zip(*chunks))
    order = None
    if config.joint.shuffle_joint_order:
        order = np.argsort(rng.random((time_s.size, len(config.joint.joint_names))), axis=1)
    return Scenario(joint_names=config.joint.joint_names, joint=config.joint.joint,
                    time_s=time_s, position_rad=position, velocity_rad_s=velocity,
                    effort=effort, truth=truth, config=config.joint, name_order=order,
                    metadata={'seed': int(seed), 'scenario': asdict(config)})


def accelerated_wear_profile(*, n_experiments: int = 100, wear_final: float = 60.0,
                             rise_experiments: float = 6.0, baseline: float = 1.0,
                             jitter: float = 0.5, rng: np.random.Generator) -> FloatArray:
    """
    Return w(k): about ``baseline`` with small random variations, then an exponential rise.

    w(k) = baseline + (wear_final - baseline) exp((k - K + 1) / rise_experiments) + jitter, at
    least 0: it stays low for most of the test and crosses 35 in the last few experiments, like
    the accelerated wear tests of the paper (Figs. 3 and 9).
    """
    k = np.arange(n_experiments, dtype=float)
    rise = (wear_final - baseline) * np.exp((k - (n_experiments - 1)) / rise_experiments)
    return np.maximum(baseline + rise + rng.normal(0.0, jitter, n_experiments), 0.0)


def accelerated_wear_scenario(*, n_experiments: int = 100,
                              speeds_rad_s: Sequence[float] = TABLE_V_SPEEDS_RAD_S,
                              params: ParameterSet | None = None, seed: int = 0,
                              wear_final: float = 60.0, level_error_std: float | None = None,
                              joint: JointSimConfig | None = None,
                              experiment_interval_s: float = 3600.0) -> ScenarioConfig:
    """
    Return an accelerated wear test like Sec. V: wear rising at the end, T and load varying.

    Wear: :func:`accelerated_wear_profile` (low, then past 35 in the last experiments).
    Temperature: a slow drift and a faster swing within 30-50 degC plus 1 degC noise.
    Load: 0.5 +- 0.1 (slow swing plus noise, clipped to 0.3-0.7).  ``level_error_std``
    defaults to the parameter set's sigma of eq. (9b).
    """
    if n_experiments < 1:
        raise InputError(f'accelerated_wear_scenario: n_experiments must be >= 1, '
                         f'got {n_experiments}')
    params = params if params is not None else load_parameter_set()
    rng = np.random.default_rng(seed)
    k = np.arange(n_experiments, dtype=float)
    wear = accelerated_wear_profile(n_experiments=n_experiments, wear_final=wear_final, rng=rng)
    temperature = np.clip(40.0 + 6.0 * np.sin(2 * np.pi * k / 41.0 + 0.5)
                          + 3.0 * np.sin(2 * np.pi * k / 9.0) + rng.normal(0.0, 1.0, k.size),
                          30.0, 50.0)
    load = np.clip(params.load_mean + 0.7 * params.load_std * np.sin(2 * np.pi * k / 23.0 + 1.0)
                   + 0.5 * params.load_std * rng.normal(0.0, 1.0, k.size),
                   params.load_mean - 2 * params.load_std, params.load_mean + 2 * params.load_std)
    return ScenarioConfig(
        speeds_rad_s=tuple(float(s) for s in speeds_rad_s), wear=tuple(wear.tolist()),
        temperature_degc=tuple(temperature.tolist()), load=tuple(load.tolist()),
        experiment_interval_s=experiment_interval_s,
        level_error_std=params.sigma if level_error_std is None else level_error_std,
        joint=joint if joint is not None else JointSimConfig())


# --------------------------------------------------------------------------- truth JSON

def truth_path_for(bag_path: str | os.PathLike) -> Path:
    """Return where the truth of a simulated bag goes: ``<bag>.truth.json`` beside it."""
    path = Path(bag_path)
    return path.with_name(path.name.rstrip('/') + TRUTH_SUFFIX)


def truth_to_dict(scenario: Scenario) -> dict:
    """Return the JSON-ready truth of a scenario: settings and one entry per experiment."""
    config = replace(scenario.config)
    return {
        'format': 'robot_wear_monitor.simulation.truth/1',
        'joint': scenario.joint, 'joint_names': list(scenario.joint_names),
        'gear_ratio': config.gear_ratio, 'torque_scale': config.torque_scale,
        'sample_rate_hz': config.sample_rate_hz, 'n_samples': scenario.n_samples,
        'units': {'speeds_rad_s': 'motor side rad/s', 'friction': 'normalised torque',
                  'temperature_degc': 'degC', 'time_s': 's (header stamps)'},
        'joint_config': asdict(config),
        'metadata': scenario.metadata,
        'experiments': [asdict(t) for t in scenario.truth],
        # what ``simulate --continue-from`` reads: the last true wear and the last sample [s]
        'final_wear': {scenario.joint: scenario.truth[-1].wear},
        'end_time_s': float(scenario.time_s[-1]),
    }


def write_truth_json(path: str | os.PathLike, scenario: Scenario) -> Path:
    """Write the truth of a scenario to ``path`` atomically (temporary file + rename)."""
    return write_json_atomic(path, truth_to_dict(scenario))


def read_truth_json(path: str | os.PathLike) -> list[ExperimentTruth]:
    """Read the experiments of a truth file written by :func:`write_truth_json`."""
    try:
        document = json.loads(read_text_file(path, what='truth file',
                                             limit_bytes=MAX_JSON_BYTES))
        return [ExperimentTruth(**{**e, 'speeds_rad_s': tuple(e['speeds_rad_s']),
                                   'friction_model': tuple(e['friction_model']),
                                   'friction_true': tuple(e['friction_true'])})
                for e in document['experiments']]
    except InputError:
        raise
    except (ValueError, KeyError, TypeError) as error:
        raise InputError(f'{shorten(path, 200)}: not a truth file: {shorten(error)}') from None
