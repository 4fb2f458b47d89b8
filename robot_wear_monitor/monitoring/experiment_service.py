"""
The friction experiment service: joint states of one joint -> friction levels -> experiments.

:class:`FrictionExperimentService` is what the ``friction_experiment_node`` (one per joint) and
the bag replay drive: it segments the joint's samples into friction levels (eq. (3), the
streaming, batch or chunked segmenter of :mod:`robot_wear_monitor.experiment.segmentation`),
assembles the levels into completed experiments (by their speeds and idle gaps, or by the
friction_experiment_runner's start/end events), handles the cut at the end of a recording,
counts rejected inputs by reason and builds the node's diagnostics status and its
``friction_levels`` messages.  :func:`explain_no_experiment` says in one sentence why a
recording gave no experiment.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
import math
from typing import Any, Mapping, Optional, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionExperiment, FrictionLevel
from robot_wear_monitor.experiment.segmentation import (ChunkSegmenter, ExperimentAssembler,
                                                        merge_levels, SegmenterConfig, SpeedTally,
                                                        StreamingSegmenter)
from robot_wear_monitor.monitoring.diagnostics import DiagnosticReport, ROUTINE_REJECTIONS
from robot_wear_monitor.monitoring.monitor_config import FrictionJointConfig
from robot_wear_monitor.monitoring.node_config import IDLE_GAP_S
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.recordings.messages import (DIAGNOSTIC_OK, DIAGNOSTIC_WARN,
                                                    MessageError, MessageKit)
from robot_wear_monitor.text import fmt_number

#: A standstill at least this long [s] is a pause between experiments, not a turn inside one
#: (the planned experiment dwells 0.1-0.2 s at its turns); used at the cut of a recording.
_PAUSE_S = 0.5


@dataclass
class _EventExperiment:
    """An experiment opened by a runner ``start`` event: its window [start_s, end_s] [s]."""

    start: messages.ExperimentEvent
    start_s: float
    end_s: float = math.inf
    levels: list[FrictionLevel] = field(default_factory=list)


@dataclass
class FrictionExperimentService:
    """
    Segment joint states of one joint into friction levels and completed experiments.

    Wraps the streaming segmenter and the experiment assembler of ``segmentation.py``; the
    node feeds it every /joint_states message, the replay every recorded one.

    Experiment boundaries.  Without events an experiment is complete when every configured
    speed has a level, and an idle gap abandons an incomplete one (the assembler).  The
    friction_experiment_runner's events (:meth:`add_experiment_event`, streaming path only)
    say exactly which levels form an experiment: a ``start`` for this joint closes any open
    experiment (emitted if it has levels; the assembler's is flushed) and opens one at the
    event's stamp S; every level completed from then on goes to it, not to the assembler, when
    its passes lie in [S, E] (E = the ``end`` stamp, open until it comes; levels outside are
    counted); an ``end`` with the same experiment id closes it as soon as a sample stamped E or
    later has been added (at once when one already has: the segmentation has then seen every
    sample up to E), and it is emitted with one merged level per planned speed of the event
    (``speeds_rad_s``; the configured speeds when the event has none), in the planned order,
    even if a speed is missing (counted as incomplete); ``aborted`` drops the open experiment's
    levels (rejection ``aborted_experiment``).  Events of other joints, and an ``end`` or
    ``aborted`` of no open experiment, are counted and ignored.  Events and JointStates must be
    stamped by the same clock.
    """

    segmenter_config: SegmenterConfig
    experiment_speeds_rad_s: tuple[float, ...] = ()
    speed_tolerance_rad_s: float = 1.0
    idle_gap_s: float = IDLE_GAP_S
    rejections: Counter = field(default_factory=Counter)
    levels: list[FrictionLevel] = field(default_factory=list)

    def __post_init__(self) -> None:
        """Build the segmenter and the assembler."""
        self.messages = 0
        self.experiments = 0
        self.last_experiment: Optional[FrictionExperiment] = None
        self.last_error = ''
        self._status_total = 0
        # the sample-by-sample segmenter; the chunk segmenter takes its place once a recording
        # is added in chunks (the rejection counts are read from whichever ran)
        self._segmenter: Any = StreamingSegmenter(self.segmenter_config)
        self._chunks: Optional[ChunkSegmenter] = None
        self._last_pause_end_s = -math.inf
        self._speed_tally = SpeedTally(self.speed_tolerance_rad_s)
        self._assembler = ExperimentAssembler(
            speeds_rad_s=list(self.experiment_speeds_rad_s) or None,
            speed_tolerance_rad_s=self.speed_tolerance_rad_s, idle_gap_s=self.idle_gap_s)
        self.event_counts: Counter = Counter()
        self.experiments_from_events = 0
        self.experiments_incomplete = 0
        self.levels_outside_experiment = 0
        self._event_ignored = 0
        self._open: Optional[_EventExperiment] = None
        self._latest_stamp_s = -math.inf

    @classmethod
    def from_node_parameters(cls, values: Mapping[str, Any]) -> 'FrictionExperimentService':
        """Build from validated ``friction_experiment_node`` parameters (see node_config)."""
        return cls.from_joint_config(FrictionJointConfig.from_node_parameters(values))

    @classmethod
    def from_joint_config(cls, config: FrictionJointConfig) -> 'FrictionExperimentService':
        """Build from a joint's typed configuration (:class:`FrictionJointConfig`)."""
        return cls(segmenter_config=config.segmenter,
                   experiment_speeds_rad_s=config.experiment_speeds_rad_s,
                   speed_tolerance_rad_s=config.grouping.experiment_speed_tolerance_rad_s,
                   idle_gap_s=config.grouping.idle_gap_s)

    @property
    def joint(self) -> str:
        """Return the segmented joint."""
        return self.segmenter_config.joint

    def all_rejections(self) -> Counter:
        """Return the rejections of the segmenter and of this service, by reason."""
        total = Counter(self._segmenter.rejections)
        total.update(self.rejections)
        return total

    @property
    def rejected_total(self) -> int:
        """Return the number of rejections so far (cheap: for a per-message check)."""
        return self._segmenter.rejections.total() + self.rejections.total()

    def add_joint_state(self, *, stamp_s: float, name: Sequence[str], position: Sequence[float],
                        velocity: Sequence[float], effort: Sequence[float]
                        ) -> list[FrictionExperiment]:
        """Add one JointState; return the experiments it completes (usually none)."""
        self.messages += 1
        try:
            new_levels = self._segmenter.add_joint_state(stamp_s=stamp_s, name=name,
                                                         position=position, velocity=velocity,
                                                         effort=effort)
        except (InputError, ValueError, TypeError) as error:
            self.rejections['malformed_joint_state'] += 1
            self.last_error = str(error)
            return []
        return self._after_sample(stamp_s, self._assemble(new_levels))

    def add_sample(self, *, time_s: float, position_rad: float, velocity_rad_s: float,
                   effort: float) -> list[FrictionExperiment]:
        """Add one sample of the joint already picked from its JointState (the replay)."""
        return self._after_sample(time_s, self._assemble(self._segmenter.add_sample(
            time_s=time_s, position_rad=position_rad, velocity_rad_s=velocity_rad_s,
            effort=effort)))

    def add_recording(self, *, time_s: Sequence[float] | FloatArray,
                      position_rad: Sequence[float] | FloatArray,
                      velocity_rad_s: Sequence[float] | FloatArray,
                      effort: Sequence[float] | FloatArray) -> list[FrictionExperiment]:
        """
        Segment a chunk of a recording of the joint at once (the replay) and assemble it.

        Chunks are the consecutive parts of one recording (a whole recording is one chunk);
        the chunked batch segmenter gives the same levels and rejection counts as the
        streaming one that ``add_sample`` feeds (tested), at numpy speed, and keeps only the
        move in progress between chunks; the levels then go through the same experiment
        assembler as on the robot.  Use it on a fresh service (not mixed with ``add_sample``
        or ``add_joint_state``), then ``finish()``.  Arrays: shape (n,), time [s], joint
        position [rad], joint speed [rad/s], effort.  The node feeds its drained batches
        here, events between them: an event experiment closes at the first sample stamped at
        or after its ``end`` (the chunk is split there), as sample by sample.
        """
        time_s = np.asarray(time_s, dtype=float)
        end_s = math.inf if self._open is None else self._open.end_s
        with np.errstate(invalid='ignore'):  # NaN stamps never reach the end
            reached = np.flatnonzero(time_s >= end_s) if end_s < math.inf else np.zeros(0, int)
        if not reached.size:
            return self._add_chunk(time_s, position_rad, velocity_rad_s, effort)
        cut = int(reached[0]) + 1
        q, v, e = (np.asarray(a, dtype=float) for a in (position_rad, velocity_rad_s, effort))
        done = self._add_chunk(time_s[:cut], q[:cut], v[:cut], e[:cut])
        done += self._after_sample(float(time_s[cut - 1]), [])
        return done + self.add_recording(time_s=time_s[cut:], position_rad=q[cut:],
                                         velocity_rad_s=v[cut:], effort=e[cut:])

    def _add_chunk(self, time_s: FloatArray, position_rad: Sequence[float] | FloatArray,
                   velocity_rad_s: Sequence[float] | FloatArray,
                   effort: Sequence[float] | FloatArray) -> list[FrictionExperiment]:
        """Segment and assemble one chunk (see :meth:`add_recording`)."""
        if self._chunks is None:
            self._chunks = ChunkSegmenter(self.segmenter_config)
            self._segmenter = self._chunks
        self.messages += len(time_s)
        motion_before = self._chunks.last_motion_s
        experiments = self._assemble(self._chunks.add(
            time_s=time_s, position_rad=position_rad, velocity_rad_s=velocity_rad_s,
            effort=effort))
        # a standstill of idle_gap_s inside the chunk closes the experiment as the live node
        # does sample by sample (the levels before it are in; a level after it would close
        # it anyway)
        ends, lengths = self._rests(time_s, velocity_rad_s, motion_before)
        for rest_end_s in ends[lengths > self.idle_gap_s]:
            if self._open is None:
                experiments += self._completed(self._assembler.idle(now_s=float(rest_end_s)))
        pauses = ends[lengths > _PAUSE_S]
        if pauses.size:
            self._last_pause_end_s = float(pauses[-1])
        if len(time_s):
            experiments += self._idle(float(time_s[-1]))
            finite = time_s[np.isfinite(time_s)]
            if finite.size:  # what an ``end`` event is compared with
                self._latest_stamp_s = max(self._latest_stamp_s, float(finite.max()))
        return experiments

    def add_reader_rejections(self, counts: Mapping[str, int]) -> None:
        """Count messages the CDR reader refused for the joint, by reason (a drained batch)."""
        for reason, count in counts.items():
            if count > 0:
                self.rejections[reason] += int(count)
                self.messages += int(count)

    def _rests(self, time_s: Sequence[float] | FloatArray,
               velocity_rad_s: Sequence[float] | FloatArray,
               motion_before_s: float) -> tuple[np.ndarray, np.ndarray]:
        """
        Return the end times [s] and lengths [s] of the standstills between moving samples.

        A standstill ends at a moving sample; it starts at the moving sample before it (or at
        ``motion_before_s``, the last motion of the previous chunk).
        """
        t = np.asarray(time_s, dtype=float)
        speed = np.abs(np.asarray(velocity_rad_s, dtype=float))  # a new array: scaled in place
        with np.errstate(over='ignore', invalid='ignore'):  # a 1e308 sample: out_of_range later
            np.multiply(speed, self.segmenter_config.gear_ratio, out=speed)
        in_motion = speed > self.segmenter_config.standstill_speed_rad_s
        in_motion &= np.isfinite(t)
        moving = t[in_motion]
        if moving.size == 0:
            return moving, moving
        starts = np.concatenate(([motion_before_s], moving[:-1]))
        return moving, moving - starts

    def drop_interrupted(self) -> int:
        """
        At the cut of a recording: drop the experiment the cut interrupts; return its levels.

        The move in progress at the cut is dropped (a cut pass).  The experiment in progress is
        kept when it is complete: the joint paused (0.5 s or more, longer than the turns of one
        experiment) after its last level and was moving again at the cut (the next experiment
        had begun), or it has the speeds of this joint's previous experiment, or the joint
        stood still for ``idle_gap_s`` before the cut (the rule that would have closed it);
        otherwise it is dropped (counted as ``experiment_cut``), since the levels
        that followed are lost.  Chunked path (``add_recording``) only.
        """
        if self._chunks is None or self._open is not None:
            return 0
        self._chunks.discard_move()
        speeds = self._assembler.current_speeds()
        if not speeds:
            return 0
        moving_at_cut = self._chunks.last_time_s - self._chunks.last_motion_s <= _PAUSE_S
        if moving_at_cut and self._last_pause_end_s > self._assembler.last_level_end_s:
            return 0  # the joint paused after these levels, then started the next experiment
        previous = self.last_experiment
        if previous is not None and len(previous.speeds_rad_s) == len(speeds) and all(
                abs(a - b) <= self.speed_tolerance_rad_s
                for a, b in zip(sorted(previous.speeds_rad_s), sorted(speeds))):
            return 0
        if self._chunks.last_time_s - self._chunks.last_motion_s > self.idle_gap_s:
            return 0
        dropped = self._assembler.discard()
        self.rejections['experiment_cut'] += 1
        return dropped

    def close_idle(self) -> list[FrictionExperiment]:
        """
        Close the assembler's experiment because the stream has stopped (no samples).

        The live node calls it when no JointState has come for ``idle_gap_s`` (wall time): a
        recording or a robot that stops publishing after an experiment must not hold that
        experiment back until the next one.  The segmentation is not flushed (a move in
        progress goes on if the stream comes back).
        """
        if self._open is not None:
            return []
        return self._completed(self._assembler.flush() or [])

    def _idle(self, now_s: float) -> list[FrictionExperiment]:
        """
        Close the assembler's experiment once the joint has stood still for idle_gap_s.

        Standing still, not merely no new level: a level at a slow speed takes its time.
        """
        if now_s - self._segmenter.last_motion_s <= self.idle_gap_s:
            return []
        return self._completed(self._assembler.idle(now_s=now_s))

    @property
    def fastest_speed_rad_s(self) -> float:
        """Return the fastest motor-side speed of the accepted samples so far [rad/s]."""
        return self._segmenter.fastest_speed_rad_s

    @property
    def passes(self) -> int:
        """Return the constant-speed passes found so far (paired or not)."""
        return self._segmenter.passes

    def levels_per_speed(self) -> dict[float, int]:
        """Return the friction levels found per speed (motor side, the speed's mean to 0.1)."""
        return self._speed_tally.counts()

    @property
    def levels_at_other_speeds(self) -> dict[float, int]:
        """Return the levels at no configured speed, per speed (0.1 rad/s): reported, unused."""
        return self._assembler.ignored_speeds.counts()

    def summary(self) -> dict[str, Any]:
        """
        Return what the segmentation found, for a report (JSON-ready).

        Keys: ``joint``, ``samples`` (read), ``rejected`` (reason -> count),
        ``passes``, ``levels``, ``levels_per_speed_rad_s`` (speed -> count),
        ``levels_at_other_speeds_rad_s`` (speed -> count), ``experiments``,
        ``experiments_abandoned``, ``speeds_configured_rad_s`` (empty: discovered).
        """
        return {'joint': self.joint, 'samples': self.messages,
                'rejected': dict(sorted(self.all_rejections().items())),
                'passes': self.passes, 'levels': len(self.levels),
                'levels_per_speed_rad_s': {f'{k:g}': v
                                           for k, v in self.levels_per_speed().items()},
                'levels_at_other_speeds_rad_s': {
                    f'{k:g}': v for k, v in self.levels_at_other_speeds.items()},
                'experiments': self.experiments,
                'experiments_abandoned': self._assembler.abandoned,
                'speeds_configured_rad_s': list(self.experiment_speeds_rad_s)}

    def _assemble(self, new_levels: Sequence[FrictionLevel]) -> list[FrictionExperiment]:
        experiments: list[FrictionExperiment] = []
        for level in new_levels:
            self.levels.append(level)
            self._speed_tally.add(level.speed_rad_s)
            if self._open is None:
                experiments.extend(self._assembler.add(level))
            elif self._open.start_s <= level.start_time_s and \
                    level.end_time_s <= self._open.end_s:
                self._open.levels.append(level)
            else:
                self.levels_outside_experiment += 1
        return self._completed(experiments)

    def _completed(self, experiments: list[FrictionExperiment]) -> list[FrictionExperiment]:
        """Count completed experiments and keep the last one; return them."""
        if experiments:
            self.experiments += len(experiments)
            self.last_experiment = experiments[-1]
        return experiments

    def _after_sample(self, stamp_s: float, experiments: list[FrictionExperiment]
                      ) -> list[FrictionExperiment]:
        """
        Close the event experiment whose ``end`` stamp the samples have reached.

        Also closes the assembler's experiment when the joint has idled for ``idle_gap_s``
        since its last level (with discovered speeds nothing else would close it until the
        next experiment starts).
        """
        stamp_s = float(stamp_s)
        if math.isfinite(stamp_s) and stamp_s > self._latest_stamp_s:
            self._latest_stamp_s = stamp_s
            if self._open is None:
                experiments = experiments + self._idle(stamp_s)
        if self._open is not None and self._latest_stamp_s >= self._open.end_s:
            experiments = experiments + self._completed(self._close_event_experiment())
        return experiments

    # ----------------------------------------------------------------- experiment events

    def handle_experiment_event_msg(self, msg: Any) -> list[FrictionExperiment]:
        """
        Read one ``friction_experiment/events`` message and apply it (see the class doc).

        A malformed message is counted (rejection ``experiment_event_<reason>``) and ignored.
        """
        try:
            event = messages.experiment_event_from_msg(msg)
        except MessageError as error:
            self.rejections[f'experiment_event_{error.reason}'] += 1
            self.last_error = f'experiment event: {error}'
            return []
        return self.add_experiment_event(event)

    def add_experiment_event(self, event: messages.ExperimentEvent
                             ) -> list[FrictionExperiment]:
        """Apply one runner event; return the experiments it completes (see the class doc)."""
        if event.joint != self.joint:
            self.event_counts['other_joint'] += 1
            return []
        self.event_counts[event.event] += 1
        if event.event == 'start':
            done = self._close_event_experiment()
            done += self._assembler.flush() or []
            self._open = _EventExperiment(start=event, start_s=float(event.stamp_s))
            return self._completed(done)
        if self._open is None or self._open.start.experiment_id != event.experiment_id:
            self.event_counts['unmatched'] += 1
            return []
        if event.event == 'aborted':
            self.rejections['aborted_experiment'] += 1
            self._open = None
            return []
        self._open.end_s = float(event.stamp_s)
        if self._latest_stamp_s >= self._open.end_s:
            return self._completed(self._close_event_experiment())
        return []

    @property
    def open_experiment_id(self) -> Optional[int]:
        """Return the runner's id of the experiment in progress (opened by ``start``), if any."""
        return None if self._open is None else int(self._open.start.experiment_id)

    def _close_event_experiment(self) -> list[FrictionExperiment]:
        """Close the open event experiment; return it when it has levels (not counted yet)."""
        current, self._open = self._open, None
        if current is None:
            return []
        levels = [lv for lv in current.levels if lv.end_time_s <= current.end_s]
        self.levels_outside_experiment += len(current.levels) - len(levels)
        speeds = list(current.start.speeds_rad_s or self.experiment_speeds_rad_s)
        groups: list[list[FrictionLevel]] = [[] for _ in speeds]
        for level in levels:
            if speeds:
                distance = [abs(v - level.speed_rad_s) for v in speeds]
                slot = int(np.argmin(distance))
                if distance[slot] > self.speed_tolerance_rad_s:
                    self._event_ignored += 1
                    continue
            else:
                slot = next((i for i, group in enumerate(groups) if abs(
                    group[0].speed_rad_s - level.speed_rad_s) <= self.speed_tolerance_rad_s),
                    len(groups))
                if slot == len(groups):
                    groups.append([])
            groups[slot].append(level)
        found = [merge_levels(group) for group in groups if group]
        if not found:
            return []
        if len(found) < len(groups):
            self.experiments_incomplete += 1
        self.experiments_from_events += 1
        return [FrictionExperiment(levels=tuple(found))]

    def diagnostic_name(self) -> str:
        """Return the DiagnosticStatus name: ``friction_experiment: <joint>``."""
        return f'friction_experiment: {self.joint}'

    def current_status(self) -> DiagnosticReport:
        """
        Return the segmentation status: counts, last experiment, rejections by reason.

        WARN while malformed inputs (reasons outside :data:`ROUTINE_REJECTIONS`) were rejected
        since the previous call (the node calls it once per diagnostics period), OK otherwise;
        the counts are totals since start.
        """
        rejections = self.all_rejections()
        total = sum(rejections.values())
        defects = sum(n for r, n in rejections.items() if r not in ROUTINE_REJECTIONS)
        new = defects - self._status_total
        self._status_total = defects
        summary = (f'{self.messages} joint_states, {len(self.levels)} friction levels, '
                   f'{self.experiments} experiments')
        values = [('joint', self.joint), ('joint_states', str(self.messages)),
                  ('passes', str(self.passes)),
                  ('friction_levels', str(len(self.levels))),
                  ('levels_per_speed_rad_s', ','.join(
                      f'{k:g}:{v}' for k, v in self.levels_per_speed().items())),
                  ('experiments', str(self.experiments)),
                  ('speeds_rad_s', ','.join(f'{v:g}' for v in self.experiment_speeds_rad_s)
                   or 'found in the data'),
                  ('levels_at_other_speeds', str(self._assembler.ignored + self._event_ignored)),
                  ('levels_at_other_speeds_rad_s', ','.join(
                      f'{k:g}:{v}' for k, v in self.levels_at_other_speeds.items())),
                  ('experiments_abandoned', str(self._assembler.abandoned))]
        if not self.experiments and self.messages:
            rejected = self.all_rejections()
            values.append(('no_experiment_yet', explain_no_experiment(
                service=self, reader_rejections={},
                seen=rejected.get('joint_missing', 0) < self.messages)))
        if self.event_counts:
            open_id = self.open_experiment_id
            values += [('experiment_events', str(sum(self.event_counts[k] for k in (
                           'start', 'end', 'aborted')))),
                       ('experiment_events_other_joints', str(self.event_counts['other_joint'])),
                       ('experiment_events_unmatched', str(self.event_counts['unmatched'])),
                       ('experiments_from_events', str(self.experiments_from_events)),
                       ('experiments_incomplete', str(self.experiments_incomplete)),
                       ('levels_outside_experiment', str(self.levels_outside_experiment)),
                       ('experiment_open', 'none' if open_id is None else str(open_id))]
        if self.last_experiment is not None:
            values += [('last_experiment_end_s', fmt_number(self.last_experiment.end_time_s, 15)),
                       ('last_speeds_rad_s', ','.join(
                           fmt_number(v, 6) for v in self.last_experiment.speeds_rad_s)),
                       ('last_frictions', ','.join(
                           fmt_number(f, 6) for f in self.last_experiment.frictions))]
        values.append(('rejected_total', str(total)))
        values += [(f'rejected_{reason}', str(count))
                   for reason, count in sorted(rejections.items())]
        if self.last_error:
            values.append(('last_rejection', self.last_error))
        if new > 0:
            reasons = ', '.join(sorted(set(rejections) - ROUTINE_REJECTIONS))
            return DiagnosticReport(DIAGNOSTIC_WARN, f'{summary}; {new} malformed inputs '
                                    f'rejected in the last period ({reasons})', tuple(values))
        return DiagnosticReport(DIAGNOSTIC_OK, summary, tuple(values))

    def diagnostics_message(self, kit: MessageKit, *, stamp_s: float) -> Any:
        """Return the DiagnosticArray of :meth:`current_status`."""
        status = self.current_status()
        return messages.diagnostics_to_msg(
            kit, stamp_s=stamp_s, name=self.diagnostic_name(), hardware_id=self.joint,
            level=status.level, message=status.message, values=status.values)

    def finish(self) -> list[FrictionExperiment]:
        """
        Flush the segmenter and the assembler at the end of a stream (bag end, shutdown).

        An experiment opened by a ``start`` event and not ended is closed (emitted if it has
        levels).
        """
        experiments = self._assemble(self._segmenter.finish() or [])
        experiments.extend(self._completed(self._close_event_experiment()))
        experiments.extend(self._completed(self._assembler.flush() or []))
        return experiments

    def friction_levels_message(self, kit: MessageKit, experiment: FrictionExperiment) -> Any:
        """Return the ``friction_levels`` JointState of a completed experiment."""
        return messages.friction_levels_to_msg(
            kit, stamp_s=experiment.end_time_s, joint=self.joint,
            speeds_rad_s=experiment.speeds_rad_s, frictions=experiment.frictions)


def explain_no_experiment(*, service: FrictionExperimentService,
                          reader_rejections: Mapping[str, int], seen: bool = True,
                          joints_seen: Optional[list[str]] = None,
                          topic: str = '/joint_states') -> str:
    """
    Return one sentence on why a recording of the joint gave no friction experiment.

    Checked in order: a joint name that is in no message (the names seen are listed), no
    usable sample of the joint, no motion (motor speed never above the standstill speed), no
    constant-speed plateau (every pass too short), passes found but never paired
    forward/backward over a common window, and levels whose speeds match none of the
    configured experiment speeds (the recorded speeds are listed).
    """
    config = service.segmenter_config
    joint = service.joint
    if not seen and joints_seen is None:
        return f'joint {joint!r} is in no message on {topic}'
    if not seen:
        names = list(joints_seen or ())
        shown = ', '.join(names[:12]) + (', ...' if len(names) > 12 else '')
        return f'joint {joint!r} is in no message on {topic} (joints seen: {shown or "none"})'
    if service.messages == 0:
        reasons = ', '.join(f'{k} {v}' for k, v in sorted(reader_rejections.items()))
        return f'no usable sample of joint {joint!r} ({reasons or "none"})'
    fastest = service.fastest_speed_rad_s
    if not fastest > config.standstill_speed_rad_s:
        return (f'joint {joint!r} never moves: its motor speed stays at or below '
                f'{fastest:.3g} rad/s (standstill {config.standstill_speed_rad_s:g} rad/s at '
                f'gear ratio {config.gear_ratio:g}); check the joint name and the gear ratio')
    rejections = service.all_rejections()
    if not service.levels:
        if rejections.get('pass_unpaired', 0) or rejections.get('pass_no_common_window', 0):
            return (f'joint {joint!r} has {service.passes} constant-speed passes, but none '
                    f'was paired with a pass the other way over a common position window '
                    f'(unpaired {rejections.get("pass_unpaired", 0)}, no common window '
                    f'{rejections.get("pass_no_common_window", 0)}): eq. (3) needs back-and-'
                    f'forth moves at one speed')
        return (f'joint {joint!r} moves (up to {fastest:.3g} rad/s motor side) but has no '
                f'constant-speed plateau of {config.min_duration_s:g} s or more '
                f'({rejections.get("pass_too_short", 0)} passes too short)')
    found = sorted(service.levels_per_speed())
    shown = ', '.join(f'{v:g}' for v in found[:12]) + (', ...' if len(found) > 12 else '')
    if not service.experiment_speeds_rad_s:
        return (f'{len(service.levels)} friction levels of joint {joint!r} at {shown} rad/s '
                f'formed no experiment')
    configured = ', '.join(f'{v:g}' for v in service.experiment_speeds_rad_s)
    return (f'{len(service.levels)} friction levels of joint {joint!r} at {shown} rad/s, but '
            f'none formed an experiment of the configured speeds [{configured}] rad/s '
            f'(tolerance {service.speed_tolerance_rad_s:g} rad/s): set '
            f'experiment_speeds_rad_s in --config to the recorded speeds, or leave it unset '
            f'to take the speeds found in the recording')
