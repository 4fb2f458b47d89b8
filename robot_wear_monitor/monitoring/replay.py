"""Replay a recorded ROS 2 bag through the monitoring service, writing the nodes' outputs.

The replay drives the very objects the nodes drive: :class:`FrictionExperimentService` gets
every sample of the joint from /joint_states, each completed experiment becomes the same
``friction_levels`` JointState the node publishes, and :class:`WearEstimatorService` consumes
that message and produces ``temperature``, ``wear``, ``wear_alarm`` and ``/diagnostics``.  All
five topics are written into OUT_BAG (MCAP by default) with the node types, stamped at the end
of each experiment, so ``ros2 bag play``, Foxglove or PlotJuggler show them.

OUT_BAG is written atomically (``bags.atomic_bag_writer``); a bad input bag raises
:class:`~robot_wear_monitor.recordings.bags.BagError` before anything is written.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import os
from pathlib import Path
from typing import Any, Mapping, Optional

import numpy as np

from robot_wear_monitor.recordings.bags import atomic_bag_writer, read_joint_samples, TYPESTORE
from robot_wear_monitor.monitoring.history import WearHistory
from robot_wear_monitor.recordings.messages import rosbags_kit, stamp_to_nanoseconds
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                       load_node_parameters, WEAR_ESTIMATOR_NODE)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.service import (EstimatorConfig, FRICTION_LEVELS_TOPIC,
                                                   FrictionExperimentService, json_number,
                                                   OUTPUT_TOPICS, WearEstimatorService, WearUpdate)

KIT = rosbags_kit(TYPESTORE)


class NoExperimentError(InputError):
    """A recording in which no friction experiment was found; the message says why."""


def bag_topic(topic: str) -> str:
    """Return the absolute bag topic of a node topic (the root namespace)."""
    return topic if topic.startswith('/') else '/' + topic


@dataclass
class ReplayResult:
    """What a replay found: one update per experiment plus counters."""

    updates: list[WearUpdate]
    joint: str
    message_count: int
    sample_count: int
    rejections: dict[str, int] = field(default_factory=dict)
    out_bag: Optional[Path] = None
    truth: Optional[list] = None
    removed_partials: list[Path] = field(default_factory=list)
    recovery: Optional[Any] = None

    @property
    def first_alarm(self) -> Optional[WearUpdate]:
        """Return the update that raised the alarm first, or None."""
        return next((u for u in self.updates if u.alarm_raised), None)

    def truth_for(self, update: WearUpdate) -> Optional[Any]:
        """Return the simulated truth of the experiment of ``update`` (by time), if known."""
        for entry in self.truth or ():
            if entry.start_time_s - 1e-6 <= update.stamp_s <= entry.end_time_s + 1e-6:
                return entry
        return None

    def summary(self) -> dict[str, Any]:
        """Return the JSON summary: every experiment and the first that raised the alarm."""
        experiments = []
        for update in self.updates:
            entry = update.to_json()
            truth = self.truth_for(update)
            if truth is not None:
                entry['truth'] = {'k': truth.k, 'wear': truth.wear,
                                  'temperature_degc': truth.temperature_degc,
                                  'load': truth.load}
            experiments.append(entry)
        first = self.first_alarm
        return {
            'format': 'robot_wear_monitor.replay/1',
            'joint': self.joint, 'joint_state_messages': self.message_count,
            'samples': self.sample_count, 'experiments': experiments,
            'first_alarm': None if first is None else {
                'index': first.index, 'stamp_s': first.stamp_s,
                'wear': json_number(first.wear), 'wear_std': json_number(first.wear_std),
                'wear_interval': [json_number(v) for v in first.wear_interval]},
            'forecast': (None if not self.updates or self.updates[-1].trend is None
                         else self.updates[-1].trend.to_json()),
            'rejections': dict(sorted(self.rejections.items())),
            'out_bag': None if self.out_bag is None else str(self.out_bag),
            'recovery': None if self.recovery is None else {
                'files': list(self.recovery.files), 'messages': self.recovery.messages,
                'last_stamp_s': self.recovery.last_stamp_s,
                'complete': self.recovery.complete, 'reason': self.recovery.reason},
        }


def replay_parameters(*, config_file: str | os.PathLike | None = None,
                      joint: str | None = None, gear_ratio: float | None = None,
                      torque_scale: float | None = None, params_file: str | None = None
                      ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Return the validated parameters of both nodes, with the CLI overrides applied."""
    experiment: dict[str, Any] = {}
    estimator: dict[str, Any] = {'history_file': ':memory:'}
    if joint is not None:
        experiment['joint'] = estimator['joint'] = joint
    if gear_ratio is not None:
        experiment['gear_ratio'] = float(gear_ratio)
    if torque_scale is not None:
        experiment['torque_scale'] = float(torque_scale)
    if params_file is not None:
        estimator['parameter_set_file'] = str(params_file)
    return (load_node_parameters(FRICTION_EXPERIMENT_NODE, config_file, overrides=experiment),
            load_node_parameters(WEAR_ESTIMATOR_NODE, config_file, overrides=estimator))


def replay_bag(bag: str | os.PathLike, *, out_bag: str | os.PathLike | None,
               experiment_parameters: Mapping[str, Any],
               estimator_parameters: Mapping[str, Any], storage: str = 'mcap',
               history_file: str | os.PathLike | None = None, overwrite: bool = False,
               progress: bool = False, truth: Optional[list] = None,
               recover: bool = True) -> ReplayResult:
    """Replay ``bag`` through the service; write the node outputs to ``out_bag`` if given.

    An unfinished recording (MCAP files without ``metadata.yaml``, or an MCAP file given
    directly) is read up to its last complete message (``recover``; the result's ``recovery``
    says where it stops); its complete experiments are estimated.

    Raises:
        BagError: the input bag is missing, corrupt, truncated, lacks the topic or the joint,
            or has the wrong type, or is unfinished and ``recover`` is false (raised before
            OUT_BAG is touched).
        NoExperimentError: no experiment was found (none already in the history either);
            its message says why, and no OUT_BAG is written.
        ParameterError: invalid parameters or parameter set.

    """
    experiments_service = FrictionExperimentService.from_node_parameters(experiment_parameters)
    params = load_parameter_set(estimator_parameters.get('parameter_set_file') or None)
    config = EstimatorConfig.from_node_parameters(estimator_parameters, params=params)
    from tqdm import tqdm
    with tqdm(unit='msg', unit_scale=True, desc=f'read {Path(bag).name}',
              disable=not progress, mininterval=0.5) as bar:
        def advance(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        samples = read_joint_samples(bag, joint=experiments_service.joint, progress=advance,
                                     recover=recover)
    history = WearHistory(history_file if history_file is not None else ':memory:')
    estimator = WearEstimatorService(config, history=history)
    updates: list[WearUpdate] = []
    result = ReplayResult(updates=updates, joint=config.joint,
                          message_count=samples.message_count, sample_count=samples.time_s.size,
                          truth=truth, recovery=samples.recovery)

    def run(writer: Any) -> None:
        def publish(experiment: Any) -> None:
            msg = experiments_service.friction_levels_message(KIT, experiment)
            stamp_ns = stamp_to_nanoseconds(experiment.end_time_s)
            if writer is not None:
                writer.write(bag_topic(FRICTION_LEVELS_TOPIC), msg, stamp_ns)
            update = estimator.handle_friction_levels(msg)
            if update is None:
                return
            updates.append(update)
            if writer is not None:
                for topic, out in estimator.output_messages(KIT, update):
                    writer.write(bag_topic(topic), out, stamp_ns)

        experiments = experiments_service.add_recording(
            time_s=samples.time_s, position_rad=samples.position_rad,
            velocity_rad_s=samples.velocity_rad_s, effort=samples.effort)
        for experiment in tqdm(experiments, unit='experiment', desc='estimate',
                               disable=not progress, mininterval=0.5):
            publish(experiment)
        for experiment in experiments_service.finish():
            publish(experiment)

    try:
        if out_bag is None:
            run(None)
            _require_experiments(updates, estimator, experiments_service, samples)
        else:
            with atomic_bag_writer(out_bag, storage=storage, overwrite=overwrite) as writer:
                result.removed_partials = list(writer.removed_stale)
                for topic, msgtype in OUTPUT_TOPICS.items():
                    writer.add_topic(bag_topic(topic), msgtype)
                run(writer)
                _require_experiments(updates, estimator, experiments_service, samples)
            result.out_bag = Path(out_bag)
    finally:
        history.close()
    rejections = dict(samples.rejections)
    for reason, count in experiments_service.all_rejections().items():
        rejections[f'segmentation_{reason}'] = count
    for reason, count in estimator.rejections.items():
        rejections[f'friction_levels_{reason}'] = count
    result.rejections = rejections
    return result


def explain_no_experiment(*, samples: Any, service: FrictionExperimentService) -> str:
    """Return one sentence on why a recording of the joint gave no friction experiment.

    Checked in order: no usable sample of the joint, no motion (motor speed never above the
    standstill speed), no constant-speed plateau (every pass too short), passes found but
    never paired forward/backward over a common window, and levels whose speeds match none of
    the configured experiment speeds (the recorded speeds are listed).
    """
    config = service.segmenter_config
    joint = service.joint
    if samples.time_s.size == 0:
        reasons = ', '.join(f'{k} {v}' for k, v in sorted(samples.rejections.items()))
        return f'no usable sample of joint {joint!r} ({reasons or "none"})'
    speed = np.abs(np.asarray(samples.velocity_rad_s)) * config.gear_ratio
    fastest = float(np.nanmax(speed)) if speed.size else 0.0
    if not fastest > config.standstill_speed_rad_s:
        return (f'joint {joint!r} never moves: its motor speed stays at or below '
                f'{fastest:.3g} rad/s (standstill {config.standstill_speed_rad_s:g} rad/s at '
                f'gear ratio {config.gear_ratio:g}); check the joint name and the gear ratio')
    rejections = service.all_rejections()
    if not service.levels:
        if rejections.get('pass_unpaired', 0) or rejections.get('pass_no_common_window', 0):
            return (f'joint {joint!r} has constant-speed passes, but none was paired with a '
                    f'pass the other way over a common position window (unpaired '
                    f'{rejections.get("pass_unpaired", 0)}, no common window '
                    f'{rejections.get("pass_no_common_window", 0)}): eq. (3) needs back-and-'
                    f'forth moves at one speed')
        return (f'joint {joint!r} moves (up to {fastest:.3g} rad/s motor side) but has no '
                f'constant-speed plateau of {config.min_duration_s:g} s or more '
                f'({rejections.get("pass_too_short", 0)} passes too short)')
    found = sorted({round(float(level.speed_rad_s), 1) for level in service.levels})
    shown = ', '.join(f'{v:g}' for v in found[:12]) + (', ...' if len(found) > 12 else '')
    configured = ', '.join(f'{v:g}' for v in service.experiment_speeds_rad_s)
    return (f'{len(service.levels)} friction levels of joint {joint!r} at {shown} rad/s, but '
            f'none formed an experiment of the configured speeds [{configured}] rad/s '
            f'(tolerance {service.speed_tolerance_rad_s:g} rad/s): set '
            f'experiment_speeds_rad_s in --config to the recorded speeds')


def _require_experiments(updates: list, estimator: WearEstimatorService,
                         service: FrictionExperimentService, samples: Any) -> None:
    """Raise NoExperimentError when the recording gave nothing (and nothing was skipped)."""
    if updates or estimator.rejections:
        return
    if service.experiments:
        return
    raise NoExperimentError(f'no friction experiment: '
                            f'{explain_no_experiment(samples=samples, service=service)}')
