"""
Replay a recorded ROS 2 bag through the monitoring service, writing the nodes' outputs.

The replay drives the very objects the nodes drive (:mod:`~robot_wear_monitor.monitoring.joints`:
one :class:`FrictionExperimentService` and one :class:`WearEstimatorService` per monitored
joint): every sample of a joint from /joint_states goes to its segmentation, each completed
experiment becomes the same ``friction_levels`` JointState the node publishes, and the joint's
estimator consumes that message and produces ``temperature``, ``wear``, ``wear_alarm``,
``wear_trend`` and ``/diagnostics``.  All topics are written into OUT_BAG (MCAP by default) with
the node types and the node topic names (per-joint namespaces with ``joints``), stamped at the
end of each experiment, so ``ros2 bag play``, Foxglove or PlotJuggler show them.

The bag is read in chunks (:func:`~robot_wear_monitor.recordings.bags.iter_joint_chunks`) and
segmented chunk by chunk (the same levels as sample by sample), so memory does not grow with
the length of the recording.

OUT_BAG is written atomically (``bags.atomic_bag_writer``); a bad input bag raises
:class:`~robot_wear_monitor.recordings.bags.BagError` before anything is written.
"""

from __future__ import annotations

from contextlib import ExitStack, nullcontext
from dataclasses import dataclass, field
import os
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.monitoring.diagnostics import split_rejections
from robot_wear_monitor.monitoring.experiment_service import (explain_no_experiment,
                                                              FrictionExperimentService)
from robot_wear_monitor.monitoring.joints import JointEstimators, JointExperiments
from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
from robot_wear_monitor.monitoring.topics import FRICTION_LEVELS_TOPIC, OUTPUT_TOPICS
from robot_wear_monitor.monitoring.wear_update import WearUpdate
from robot_wear_monitor.recordings.bags import (atomic_bag_writer, iter_joint_chunks,
                                                MONITOR_TYPESTORE)
from robot_wear_monitor.recordings.messages import rosbags_kit, stamp_to_nanoseconds

KIT = rosbags_kit(MONITOR_TYPESTORE)
#: The writer lock a replay holds on its robot in the history (every joint at once).
ROBOT_LOCK = '*'


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
    joints: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: each monitored joint's state in the history after the replay (:func:`joint_state`)
    states: list[dict[str, Any]] = field(default_factory=list)
    #: warnings for the log, not the summary: a joint whose node levels (``wear_threshold``,
    #: ``wear_warning``) are not its parameter set's (the node's win), once per joint
    warnings: list[str] = field(default_factory=list)

    @property
    def invalid(self) -> list[WearUpdate]:
        """Return the updates whose levels failed the plausibility checks (wear not judged)."""
        return [u for u in self.updates if not u.valid]

    @property
    def latched(self) -> list[dict[str, Any]]:
        """Return the joints whose alarm is latched in the history after the replay."""
        return [state for state in self.states if state['alarm']]

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
        bad_data, routine = split_rejections(self.rejections)
        return {
            'format': 'robot_wear_monitor.replay/1',
            'joint': self.joint, 'joint_state_messages': self.message_count,
            'samples': self.sample_count, 'experiments': experiments,
            'first_alarm': None if first is None else {
                'index': first.index, 'stamp_s': first.stamp_s,
                'wear': finite_or_none(first.wear), 'wear_std': finite_or_none(first.wear_std),
                'wear_interval': [finite_or_none(v) for v in first.wear_interval]},
            'forecast': (None if not self.updates or self.updates[-1].trend is None
                         else self.updates[-1].trend.to_json()),
            'rejections': dict(sorted(self.rejections.items())),
            'bad_data_rejections': bad_data,
            'routine_rejections': routine,
            'out_bag': None if self.out_bag is None else str(self.out_bag),
            'recovery': None if self.recovery is None else {
                'files': list(self.recovery.files), 'messages': self.recovery.messages,
                'last_stamp_s': self.recovery.last_stamp_s,
                'complete': self.recovery.complete, 'reason': self.recovery.reason},
            'joints': self.joints,
            'notes': list(self.notes),
            'invalid_estimates': len(self.invalid),
            'state': self.states,
        }


def replay_parameters(*, config_file: str | os.PathLike | None = None,
                      joint: str | None = None, gear_ratio: float | None = None,
                      torque_scale: float | None = None, params_file: str | None = None,
                      joints: Optional[list[str]] = None, robot: str | None = None
                      ) -> tuple[dict[str, Any], dict[str, Any]]:
    """
    Return the validated parameters of both nodes, with the CLI overrides applied.

    The values of :meth:`MonitorConfig.load` (see there), for the callers that build the
    services from the two nodes' values (``segment``); ``replay``, the batch and the demo pass
    the :class:`MonitorConfig` itself to :func:`replay_bag` (``configuration``).
    """
    config = MonitorConfig.load(config_file=config_file, joint=joint, joints=joints,
                                gear_ratio=gear_ratio, torque_scale=torque_scale,
                                params_file=params_file, robot=robot)
    return dict(config.experiment), dict(config.estimator)


def replay_bag(bag: str | os.PathLike, *, out_bag: str | os.PathLike | None,
               configuration: Optional[MonitorConfig] = None,
               experiment_parameters: Optional[Mapping[str, Any]] = None,
               estimator_parameters: Optional[Mapping[str, Any]] = None,
               storage: str = 'mcap',
               history_file: str | os.PathLike | None = None, overwrite: bool = False,
               history_init: Optional[bool] = None,
               progress: bool = False, truth: Optional[list] = None,
               recover: bool = True, chunk_messages: int = 32768,
               batch_experiments: int = 64) -> ReplayResult:
    """
    Replay ``bag`` through the services; write the node outputs to ``out_bag`` if given.

    ``configuration``: both nodes' validated parameters (:meth:`MonitorConfig.load`); or,
    for callers that hold them, ``experiment_parameters`` and ``estimator_parameters``.  The
    monitored joints are those of the parameters (``joint``, or ``joints``, or every joint
    of the recording with ``joints: [all]``).  An unfinished recording (MCAP files without
    ``metadata.yaml``, or an MCAP file given directly) is read up to its last complete message
    (``recover``; the result's ``recovery`` says where it stops); its complete experiments are
    estimated.

    Completed experiments are estimated ``batch_experiments`` at a time (one batched
    refinement, :meth:`JointEstimators.prepare`), then handed to the estimators one by one
    in time order: the trend, alarm, history and outputs are those of one-by-one estimation,
    number for number (1: no batching).

    :raises BagError: the input bag is missing, corrupt, truncated, lacks the topic or has the
        wrong type, or is unfinished and ``recover`` is false (raised before OUT_BAG is
        touched).
    :raises NoExperimentError: no experiment was found in any monitored joint (none already in the
        history either); its message says why, per joint, and no OUT_BAG is written.
    :raises ParameterError: invalid parameters or parameter set.

    """
    if configuration is None:
        if experiment_parameters is None or estimator_parameters is None:
            raise TypeError("replay_bag: give configuration, or both nodes' parameters")
        configuration = MonitorConfig(experiment=experiment_parameters,
                                      estimator=estimator_parameters,
                                      source='replay parameters')
    experiments = JointExperiments(configuration.experiment, source='replay parameters')
    bar: Any = nullcontext()  # tqdm is loaded for a progress bar only
    if progress:
        # deferred import: start-up time (tqdm: a progress bar only)
        from tqdm import tqdm
        bar = tqdm(unit='msg', unit_scale=True, desc=f'read {Path(bag).name}', mininterval=0.5)

    def advance(done: int, total: int) -> None:
        bar.total = max(total, done)
        bar.update(done - bar.n)

    stream = iter_joint_chunks(bag, joints=experiments.selection,
                               progress=advance if progress else None,
                               recover=recover, require_joints=False,
                               chunk_messages=chunk_messages)
    history = WearHistory(history_file if history_file is not None else ':memory:',
                          init=history_init,
                          robot=configuration.robot)
    # one writer of a robot at a time: a second replay of the same robot into the history
    # waits, then restores the first one's rows (its trend is the sequential run's)
    lock = ExitStack()
    try:
        if history_file is not None and str(history_file) != ':memory:':
            lock.enter_context(history.writer_lock(joint=ROBOT_LOCK))
        estimators = JointEstimators(configuration.estimator, history=history,
                                     source='replay parameters')
    except BaseException:
        lock.close()
        history.close()
        raise
    updates: list[WearUpdate] = []
    result = ReplayResult(updates=updates, joint=', '.join(experiments.selection or ('all',)),
                          message_count=0, sample_count=0, truth=truth)

    def run(writer: Any) -> None:
        pending: list = []  # (service, experiment, friction_levels message), in time order
        declared: dict[str, str] = {}  # output topic -> its bag topic, once declared

        def flush() -> None:  # estimate the pending experiments together, then one by one
            if batch_experiments > 1:
                estimators.prepare([msg for _, _, msg in pending])
            for service, experiment, msg in pending:
                publish(service, experiment, msg)
            pending.clear()

        def queue(done: list) -> None:
            pending.extend((service, experiment, service.friction_levels_message(KIT, experiment))
                           for service, experiment in in_time_order(done))
            if len(pending) >= batch_experiments:
                flush()

        def publish(service: FrictionExperimentService, experiment: Any, msg: Any) -> None:
            stamp_ns = stamp_to_nanoseconds(experiment.end_time_s)
            if writer is not None:
                writer.write(bag_topic(FRICTION_LEVELS_TOPIC), msg, stamp_ns)
            estimator, update = estimators.handle_friction_levels(msg)
            if update is None or estimator is None:
                return
            updates.append(update)
            if writer is not None:
                for topic, out in estimators.output_messages(KIT, estimator, update):
                    name = declared.get(topic)
                    if name is None:  # declared when first written, as the nodes publish
                        types = {mapped: OUTPUT_TOPICS[base] for base, mapped
                                 in estimators.topics(estimator.config.joint).items()}
                        name = declared[topic] = bag_topic(topic)
                        writer.add_topic(name, types[topic])
                    writer.write(name, out, stamp_ns)

        def in_time_order(done: list) -> list:  # the joints' experiments of one chunk
            return sorted(done, key=lambda pair: pair[1].end_time_s)

        for chunk in stream:
            done = []
            for joint, samples in chunk.items():
                if not len(samples) and joint in experiments.services:
                    continue
                service = experiments.service(joint)
                done += [(service, experiment) for experiment in service.add_recording(
                    time_s=samples.time_s, position_rad=samples.position_rad,
                    velocity_rad_s=samples.velocity_rad_s, effort=samples.effort)]
            queue(done)
        flush()
        if stream.recovery is not None and not stream.recovery.complete:
            for service in experiments.services.values():
                dropped = service.drop_interrupted()
                if dropped:
                    result.notes.append(
                        f'joint {service.joint!r}: the experiment in progress at the cut '
                        f'({dropped} complete levels) is not estimated')
        queue(experiments.finish())
        flush()

    try:
        with bar:
            if out_bag is None:
                run(None)
                _require_experiments(updates, estimators, experiments, stream)
            else:
                with atomic_bag_writer(out_bag, storage=storage, overwrite=overwrite) as writer:
                    result.removed_partials = list(writer.removed_stale)
                    writer.add_topic(bag_topic(FRICTION_LEVELS_TOPIC),
                                     OUTPUT_TOPICS[FRICTION_LEVELS_TOPIC])
                    run(writer)
                    _require_experiments(updates, estimators, experiments, stream)
                result.out_bag = Path(out_bag)
        result.states = joint_states(history, list(estimators.services))
        result.warnings = [w for w in (s.config.levels_warning()
                                       for s in estimators.services.values()) if w]
    finally:
        lock.close()
        history.close()
    # in time order across joints (an experiment is published when its joint's stream closes
    # it, which can come a chunk after another joint's later one)
    updates.sort(key=lambda update: update.stamp_s)
    result.message_count = stream.message_count
    result.recovery = stream.recovery
    result.notes = list(stream.notes) + result.notes
    result.sample_count = sum(s.messages for s in experiments.services.values())
    result.joints = [joint_summary(service, stream, updates)
                     for service in experiments.services.values()]
    result.rejections = _rejections(experiments, estimators, stream)
    return result


def _rejections(experiments: JointExperiments, estimators: JointEstimators,
                stream: Any) -> dict[str, int]:
    """Return every rejection of the replay by reason, summed over the joints."""
    total: dict[str, int] = {}

    def add(reason: str, count: int) -> None:
        total[reason] = total.get(reason, 0) + int(count)
    for joint in experiments.services:
        for reason, count in stream.rejections.get(joint, {}).items():
            add(reason, count)
    for service in experiments.services.values():
        for reason, count in service.all_rejections().items():
            add(f'segmentation_{reason}', count)
    for estimator in estimators.services.values():
        for reason, count in estimator.rejections.items():
            add(f'friction_levels_{reason}', count)
    for reason, count in estimators.rejections.items():
        add(f'friction_levels_{reason}', count)
    return total


def joint_states(history: WearHistory, joints: Sequence[str]) -> list[dict[str, Any]]:
    """
    Return the joints' state in the history (JSON-ready): what a maintenance team acts on.

    Per joint: ``alarm`` (latched) and ``alarm_since_stamp_s`` (its raise [s]), ``estimates``
    stored, and ``last_estimate``: the stamp [s], w-hat, its 95 % interval and the validity of
    the latest stored estimate (None when there is none); ``threshold`` and ``warning_level``:
    the levels that estimate was judged by [w] (None: none stored).  A re-run that estimates
    nothing new still reports this state.
    """
    rows = {row.joint: row for row in history.fleet(robot=history.robot)}
    states = []
    for joint in joints:
        row = rows.get(joint)
        states.append({
            'robot': history.robot, 'joint': joint, 'alarm': bool(row and row.alarm),
            'alarm_since_stamp_s': finite_or_none(row.alarm_since_stamp_s) if row else None,
            'estimates': row.experiments if row else 0,
            'last_estimate': None if row is None else {
                'stamp_s': row.last_stamp_s, 'wear': finite_or_none(row.wear),
                'wear_interval': [finite_or_none(row.wear_low), finite_or_none(row.wear_high)],
                'valid': not row.invalid_reason,
                'invalid_reason': row.invalid_reason or None},
            'threshold': finite_or_none(row.threshold) if row else None,
            'warning_level': finite_or_none(row.warning_level) if row else None})
    return states


def explain_joint(service: FrictionExperimentService, stream: Any) -> str:
    """Return why a joint of a read bag ``stream`` gave no experiment (one sentence)."""
    joint = service.joint
    return explain_no_experiment(service=service,
                                 reader_rejections=stream.rejections.get(joint, {}),
                                 seen=joint in stream.joints_seen,
                                 joints_seen=stream.joints_seen, topic=stream.topic)


def joint_summary(service: FrictionExperimentService, stream: Any,
                  updates: Sequence[WearUpdate] = ()) -> dict[str, Any]:
    """
    Return what a bag gave for one joint (JSON-ready), replay and segment alike.

    :meth:`FrictionExperimentService.summary` with the reader's rejections (``reader_*``),
    the joint's ``estimates`` and ``first_alarm`` among ``updates``, and ``no_experiment``:
    why no experiment formed (None when one did).
    """
    mine = [u for u in updates if u.joint == service.joint]
    first = next((u for u in mine if u.alarm_raised), None)
    summary = service.summary()
    summary['rejected'] = {**{f'reader_{k}': v for k, v in
                              sorted(stream.rejections.get(service.joint, {}).items())},
                           **summary['rejected']}
    summary['bad_data_rejected'], summary['routine_rejected'] = split_rejections(
        summary['rejected'])
    summary['estimates'] = len(mine)
    summary['first_alarm'] = None if first is None else {
        'index': first.index, 'stamp_s': first.stamp_s, 'wear': finite_or_none(first.wear)}
    summary['no_experiment'] = (None if service.experiments
                                else explain_joint(service, stream))
    return summary


def explain_recording(experiments: JointExperiments, stream: Any) -> str:
    """Return why a read bag gave nothing: one sentence per monitored joint."""
    if not experiments.services:
        return (f'no joint in the JointState messages of {stream.path} '
                f'({stream.message_count} messages)')
    return '; '.join(explain_joint(s, stream) for s in experiments.services.values())


def _require_experiments(updates: list, estimators: JointEstimators,
                         experiments: JointExperiments, stream: Any) -> None:
    """Raise NoExperimentError when the recording gave nothing (and nothing was skipped)."""
    if updates or estimators.rejections or any(s.rejections for s in
                                               estimators.services.values()):
        return
    if any(s.experiments for s in experiments.services.values()):
        return
    raise NoExperimentError(f'no friction experiment: {explain_recording(experiments, stream)}')
