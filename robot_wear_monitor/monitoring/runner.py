"""
The friction experiment runner without ROS: plans, schedule, events, abort and status.

The ``friction_experiment_runner`` node is a thin shell over :class:`ExperimentRunner`.  From
the node's parameters (``node_config.FRICTION_EXPERIMENT_RUNNER_PARAMETERS``) it builds one
:class:`~robot_wear_monitor.experiment.planning.PlanConfig` per tested joint and plans every
motion once, at start-up, so that a parameter the motion cannot respect refuses the node with
one line naming the parameter (exit code 2), not a start request hours later.

A start request runs the tested joints one after the other.  Per joint, at its planned offset
from the request: the ``start`` event, then its JointTrajectory (header stamp 0: "start on
receipt" for ros2_control's joint_trajectory_controller); ``end_margin_s`` after the planned end
of the motion, the ``end`` event; ``pause_between_joints_s`` later, the next joint.  The events
(``recordings.messages.ExperimentEvent``) tell the friction_experiment_node which friction levels
form the experiment.  An abort ends the run: the running joint gets an ``aborted`` event and a
one-point trajectory back to the posture (the controller's cubic spline from the joint's state,
timed within the acceleration and speed limits), so that the next run starts where the plan
expects the joint: every plan starts and ends at rest at the posture.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Optional

import numpy as np
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.planning import (ExperimentPlan, plan_experiment, PlanConfig,
                                                    PlanError, trajectory_points, TrajectoryPoints)
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring.diagnostics import DiagnosticReport
from robot_wear_monitor.monitoring.runner_config import (RunnerConfig,  # noqa: F401 (re-export)
                                                         trajectory_topic)
from robot_wear_monitor.recordings.messages import (DIAGNOSTIC_OK, DIAGNOSTIC_WARN,
                                                    ExperimentEvent)

START_SERVICE = '~/start'
ABORT_SERVICE = '~/abort'
#: DiagnosticStatus name of the runner on /diagnostics.
RUNNER_STATUS_NAME = 'friction_experiment_runner'
#: Timers may fire this much early without an action being left for later [s].
_DUE_TOLERANCE_S = 1e-3


def _fail(source: str, name: str, problem: str) -> ParameterError:
    return ParameterError(f'{source}: {name}: {problem}')


def runner_config(values: Mapping[str, Any], *, source: str = '<parameters>') -> RunnerConfig:
    """
    Build the :class:`RunnerConfig` of validated ``friction_experiment_runner`` parameters.

    Checks what one parameter cannot check alone: the lengths of the per-joint arrays, the
    tested joints among ``joint_names``, the speeds within ``max_speed_rad_s`` and each window
    inside the joint limits.

    :raises ParameterError: one line naming the source and the parameter.

    """
    names = tuple(values['joint_names'])
    posture = tuple(float(v) for v in values['posture_rad'])
    joints = tuple(values['joints'])
    if len(posture) != len(names):
        raise _fail(source, 'posture_rad', f'needs one position per joint_names ({len(names)}), '
                                           f'got {len(posture)}')
    unknown = [j for j in joints if j not in names]
    if unknown:
        raise _fail(source, 'joints', f'{unknown[0]!r} is not in joint_names '
                                      f'({", ".join(names)})')
    per_joint = {name: tuple(values[name]) for name in (
        'gear_ratios', 'half_ranges_rad', 'position_lower_limits_rad',
        'position_upper_limits_rad')}
    for name, array in per_joint.items():
        optional = name.startswith('position_')
        if len(array) != len(joints) and not (optional and not array):
            also = ' or none' if optional else ''
            raise _fail(source, name, f'needs one value per tested joint ({len(joints)}{also}), '
                                      f'got {len(array)}')
    lower, upper = per_joint['position_lower_limits_rad'], per_joint['position_upper_limits_rad']
    if bool(lower) != bool(upper):
        raise _fail(source, 'position_upper_limits_rad' if lower else
                    'position_lower_limits_rad', 'give both limit arrays or neither')
    speeds = tuple(values['speeds_rad_s'])
    if not speeds:
        raise _fail(source, 'speeds_rad_s', 'needs at least one speed')
    max_speed = float(values['max_speed_rad_s']) or None
    plans = []
    for k, joint in enumerate(joints):
        ratio = per_joint['gear_ratios'][k]
        half = per_joint['half_ranges_rad'][k]
        centre = posture[names.index(joint)]
        if max_speed is not None and max(speeds) / ratio > max_speed * (1 + 1e-12):
            raise _fail(source, 'speeds_rad_s', (
                f'{max(speeds):g} rad/s (motor) is {max(speeds) / ratio:.4g} rad/s at '
                f'{joint} (gear ratio {ratio:g}), above max_speed_rad_s {max_speed:g} rad/s'))
        limits = None
        if lower:
            limits = (lower[k], upper[k])
            if not lower[k] < upper[k]:
                raise _fail(source, 'position_upper_limits_rad',
                            f'{joint}: must be above the lower limit {lower[k]:g} rad, '
                            f'got {upper[k]:g}')
            if not lower[k] <= centre - half or not centre + half <= upper[k]:
                raise _fail(source, 'half_ranges_rad', (
                    f'{joint}: the window {centre:g} +- {half:g} rad (posture_rad +- '
                    f'half_ranges_rad) is outside the joint range [{lower[k]:g}, '
                    f'{upper[k]:g}] rad'))
        target = float(values['target_std_error'])
        jerk = float(values['max_jerk_rad_s3'])
        try:
            plans.append(PlanConfig(
                joint=joint, speeds_rad_s=speeds, center_rad=centre, half_range_rad=half,
                gear_ratio=ratio, max_acceleration_rad_s2=float(values['max_acceleration_rad_s2']),
                max_jerk_rad_s3=jerk or None, max_speed_rad_s=max_speed,
                position_limits_rad=limits, rate_hz=float(values['rate_hz']),
                noise_std=float(values['noise_std']), target_std_error=target or None,
                min_duration_s=float(values['min_duration_s']), trim_s=float(values['trim_s']),
                min_samples=int(values['min_samples']), dwell_s=float(values['dwell_s']),
                joint_names=names,
                hold_positions_rad=tuple(p for n, p in zip(names, posture) if n != joint)))
        except InputError as error:
            raise _plan_error(error, joint, source) from None
    return RunnerConfig(plans=tuple(plans), joint_names=names, posture_rad=posture,
                        point_rate_hz=float(values['point_rate_hz']),
                        controller=str(values['controller']),
                        end_margin_s=float(values['end_margin_s']),
                        pause_between_joints_s=float(values['pause_between_joints_s']))


#: PlanConfig field at fault -> (the node parameter to change, what to do).
_PLAN_ERRORS = {
    'half_range_rad': ('half_ranges_rad',
                       'raise half_ranges_rad, or raise target_std_error or lower min_duration_s'),
    'position_limits_rad': ('position_lower_limits_rad',
                            'raise max_acceleration_rad_s2 or move posture_rad away from the '
                            'limit'),
    'max_speed_rad_s': ('speeds_rad_s', 'lower speeds_rad_s or raise max_speed_rad_s'),
}


def _plan_error(error: InputError, joint: str, source: str) -> ParameterError:
    """Return a planning error as a one-line parameter error (the node's words, not the CLI's)."""
    if isinstance(error, PlanError) and error.field in _PLAN_ERRORS:
        name, hint = _PLAN_ERRORS[error.field]
        return _fail(source, name, f'{joint}: {error.detail} ({hint})')
    text = str(error).splitlines()[0]
    return _fail(source, 'joints', f'{joint}: {text.removeprefix("plan: ")}')


@dataclass(frozen=True)
class PlannedJoint:
    """
    One tested joint of a run: its plan, trajectory points and times from the request.

    :ivar index: position in the run (0-based).
    :ivar joint: the tested joint.
    :ivar plan: its planned motion.
    :ivar points: the JointTrajectory points of the plan (all joints of the controller).
    :ivar start_offset_s: when its ``start`` event and trajectory are published [s].
    :ivar end_offset_s: the planned end of its motion [s].
    :ivar end_event_offset_s: when its ``end`` event is published [s].

    """

    index: int
    joint: str
    plan: ExperimentPlan
    points: TrajectoryPoints
    start_offset_s: float
    end_offset_s: float
    end_event_offset_s: float

    @property
    def duration_s(self) -> float:
        """Return the planned duration of the motion [s]."""
        return self.plan.total_s


def plan_run(config: RunnerConfig, *, source: str = '<parameters>'
             ) -> tuple[PlannedJoint, ...]:
    """
    Plan every tested joint and its offsets from a start request (see the module doc).

    :raises ParameterError: a motion that cannot be planned, naming the parameter to change.

    """
    steps = []
    offset = 0.0
    for k, plan_config in enumerate(config.plans):
        try:
            plan = plan_experiment(config=plan_config)
            points = trajectory_points(plan, point_rate_hz=config.point_rate_hz)
        except InputError as error:
            raise _plan_error(error, plan_config.joint, source) from None
        end = offset + plan.total_s
        steps.append(PlannedJoint(index=k, joint=plan_config.joint, plan=plan, points=points,
                                  start_offset_s=offset, end_offset_s=end,
                                  end_event_offset_s=end + config.end_margin_s))
        offset = end + config.end_margin_s + config.pause_between_joints_s
    return tuple(steps)


@dataclass(frozen=True)
class RunnerAction:
    """What the node publishes now: ``start`` (event, then trajectory) or ``end`` (event)."""

    kind: str
    step: PlannedJoint
    event: ExperimentEvent


class ExperimentRunner:
    """
    The runner's state: idle or running a schedule of :class:`PlannedJoint`.

    Times are the node clock's, in seconds; the node calls :meth:`due` from a timer set to
    :meth:`next_due_s` (never blocking in a callback).
    """

    def __init__(self, config: RunnerConfig, *, source: str = '<parameters>') -> None:
        """Plan every tested joint now (errors are the node's parameter errors)."""
        self.config = config
        self.schedule = plan_run(config, source=source)
        self._actions = sorted(
            [(s.start_offset_s, 0, 'start', s) for s in self.schedule]
            + [(s.end_event_offset_s, 1, 'end', s) for s in self.schedule],
            key=lambda a: (a[0], a[1]))
        self.run_start_s: Optional[float] = None
        self._next = 0
        self._ids: dict[int, int] = {}
        self._started: set[int] = set()
        self.next_experiment_id = 1
        self.runs_started = 0
        self.experiments_started = 0
        self.experiments_ended = 0
        self.experiments_aborted = 0
        self.last_outcome = 'none'

    @property
    def total_s(self) -> float:
        """Return the time from a start request to its last ``end`` event [s]."""
        return self.schedule[-1].end_event_offset_s

    @property
    def running(self) -> bool:
        """Return True while a run is in progress."""
        return self.run_start_s is not None

    def _started_s(self) -> float:
        """Return the start of the run in progress [s] (only called while running)."""
        if self.run_start_s is None:
            raise RuntimeError('no friction experiment run in progress')
        return self.run_start_s

    def start(self, now_s: float, *, trajectory_subscribers: int = 1) -> tuple[bool, str]:
        """
        Start a run at ``now_s`` if idle; return (success, one-line message).

        Refused while running and when nothing subscribes to the trajectory topic (the
        controller is not loaded: the events would announce a motion that never happens).
        """
        if self.running:
            return False, (f'already running ({self._progress(now_s)}); call '
                           f'{ABORT_SERVICE[2:]} to stop it')
        if trajectory_subscribers < 1:
            return False, (f'no subscriber on {self.config.trajectory_topic}: is the '
                           f'{self.config.controller} loaded and active?')
        self.run_start_s = float(now_s)
        self._next = 0
        self._started.clear()
        self._ids = {}
        for step in self.schedule:
            self._ids[step.index] = self.next_experiment_id
            self.next_experiment_id += 1
        self.runs_started += 1
        self.last_outcome = 'running'
        joints = ', '.join(f'{s.joint} (#{self._ids[s.index]}, {s.duration_s:.1f} s)'
                           for s in self.schedule)
        return True, (f'started the friction experiment of {joints} on '
                      f'{self.config.trajectory_topic}: {self.total_s:.1f} s planned '
                      f'to the last end event')

    def next_due_s(self) -> Optional[float]:
        """Return the node-clock time of the next action, or None when idle."""
        if not self.running:
            return None
        return self._started_s() + self._actions[self._next][0]

    def due(self, now_s: float) -> list[RunnerAction]:
        """Return the actions due at ``now_s``, in order; the run ends after the last one."""
        actions = []
        while self.running and self._next < len(self._actions):
            offset, _, kind, step = self._actions[self._next]
            if self._started_s() + offset > now_s + _DUE_TOLERANCE_S:
                break
            self._next += 1
            if kind == 'start':
                self._started.add(step.index)
                self.experiments_started += 1
            else:
                self._started.discard(step.index)
                self.experiments_ended += 1
            actions.append(RunnerAction(kind=kind, step=step,
                                        event=self.event(kind, step, stamp_s=now_s)))
        if self.running and self._next >= len(self._actions):
            self.run_start_s = None
            self.last_outcome = 'completed'
        return actions

    def event(self, kind: str, step: PlannedJoint, *, stamp_s: float) -> ExperimentEvent:
        """Return the ``kind`` event of ``step`` in the current run."""
        return ExperimentEvent(event=kind, joint=step.joint,
                               experiment_id=self._ids.get(step.index, 0),
                               speeds_rad_s=step.plan.config.speeds_rad_s,
                               planned_duration_s=step.plan.total_s,
                               controller_topic=self.config.trajectory_topic,
                               stamp_s=float(stamp_s))

    def current(self) -> Optional[PlannedJoint]:
        """Return the joint whose ``start`` was published and ``end`` not yet, if any."""
        for step in self.schedule:
            if step.index in self._started:
                return step
        return None

    def abort(self, now_s: float) -> tuple[bool, str, Optional[RunnerAction],
                                           Optional[TrajectoryPoints]]:
        """
        Stop the run; return (success, message, ``aborted`` action, hold point).

        The hold point (:meth:`hold_points`) takes the running joint back to the posture.  The
        ``aborted`` action and the hold point are None when no joint is moving (idle, or
        between two joints: the joints are at the posture).
        """
        if not self.running:
            return False, 'not running', None, None
        step = self.current()
        action = hold = None
        if step is not None:
            action = RunnerAction(kind='aborted', step=step,
                                  event=self.event('aborted', step, stamp_s=now_s))
            hold = self.hold_points(step, now_s - self._started_s() - step.start_offset_s)
            self.experiments_aborted += 1
            message = (f'aborted the friction experiment of {step.joint} '
                       f'(#{self._ids[step.index]}) after {now_s - self._started_s():.1f} s')
        else:
            message = f'aborted the run after {now_s - self._started_s():.1f} s (between joints)'
        remaining = [s.joint for s in self._not_begun()]
        if remaining:
            message += f'; not run: {", ".join(remaining)}'
        self.run_start_s = None
        self._started.clear()
        self.last_outcome = 'aborted'
        return True, message, action, hold

    def hold_points(self, step: PlannedJoint, elapsed_s: float) -> TrajectoryPoints:
        """
        Return one point at the posture for ``step``'s joint, from its state at ``elapsed_s``.

        A trajectory controller reaches a point given by position and velocity (no
        acceleration) along a cubic spline from its current state; the point's time is the
        shortest at which that spline, from the planned state at ``elapsed_s``, keeps within
        the acceleration limit and the speed limit (the repositioning speed).
        """
        plan = step.plan
        q, v, _, _ = plan.sample(np.array([max(elapsed_s, 0.0)]))
        names = self.config.joint_names
        j = names.index(step.joint)
        cfg = plan.config
        speed_limit = cfg.max_speed_rad_s or max(cfg.speeds_rad_s) / cfg.gear_ratio
        duration = cubic_stop_time(distance=self.config.posture_rad[j] - float(q[0]),
                                   velocity=float(v[0]),
                                   max_acceleration=cfg.max_acceleration_rad_s2,
                                   max_speed=max(speed_limit, abs(float(v[0]))),
                                   minimum_s=1.0 / self.config.point_rate_hz)
        return TrajectoryPoints(joint_names=names, time_from_start_s=np.array([duration]),
                                positions_rad=np.array([self.config.posture_rad], dtype=float),
                                velocities_rad_s=np.zeros((1, len(names))),
                                accelerations_rad_s2=np.zeros((1, 0)))

    def _not_begun(self) -> list[PlannedJoint]:
        begun = {a[3].index for a in self._actions[:self._next] if a[2] == 'start'}
        return [s for s in self.schedule if s.index not in begun]

    def _progress(self, now_s: float) -> str:
        step = self.current()
        n = len(self.schedule)
        elapsed = now_s - self._started_s()
        if step is not None:
            return (f'{step.joint}, joint {step.index + 1} of {n}, '
                    f'{elapsed - step.start_offset_s:.1f} s of {step.duration_s:.1f} s')
        upcoming = self._not_begun()
        if upcoming:
            return f'pause before {upcoming[0].joint}, joint {upcoming[0].index + 1} of {n}'
        return 'finishing'

    def status(self, now_s: float, *, trajectory_subscribers: int) -> DiagnosticReport:
        """
        Return the runner's diagnostics: idle or running joint k of n, and the counts.

        WARN when nothing subscribes to the trajectory topic (no controller listening).
        """
        step = self.current() if self.running else None
        values = [('state', 'running' if self.running else 'idle'),
                  ('joints', ','.join(self.config.joints)),
                  ('controller_topic', self.config.trajectory_topic),
                  ('trajectory_subscribers', str(int(trajectory_subscribers))),
                  ('planned_duration_s', f'{self.total_s:.6g}'),
                  ('runs_started', str(self.runs_started)),
                  ('experiments_started', str(self.experiments_started)),
                  ('experiments_ended', str(self.experiments_ended)),
                  ('experiments_aborted', str(self.experiments_aborted)),
                  ('last_run', self.last_outcome)]
        if self.running:
            values += [('elapsed_s', f'{now_s - self._started_s():.3f}')]
            message = f'running: {self._progress(now_s)}'
        else:
            message = 'idle' if self.runs_started == 0 else f'idle; last run {self.last_outcome}'
        if step is not None:
            values += [('current_joint', step.joint),
                       ('experiment_id', str(self._ids[step.index]))]
        if trajectory_subscribers < 1:
            return DiagnosticReport(DIAGNOSTIC_WARN, f'{message}; no subscriber on '
                                    f'{self.config.trajectory_topic}', tuple(values))
        return DiagnosticReport(DIAGNOSTIC_OK, message, tuple(values))


def cubic_stop_time(*, distance: float, velocity: float, max_acceleration: float,
                    max_speed: float, minimum_s: float) -> float:
    """
    Return the shortest time T >= ``minimum_s`` of a cubic from (0, velocity) to (distance, 0).

    The cubic Hermite spline p(t) with p(0) = 0, p'(0) = ``velocity``, p(T) = ``distance``,
    p'(T) = 0 has a linear acceleration, (6 d - 4 v T) / T^2 at 0 and (2 v T - 6 d) / T^2 at T;
    T is the first of a geometric grid (steps of 2 %) at which both are within
    ``max_acceleration`` and the speed within ``max_speed``.
    """
    d, v = float(distance), float(velocity)
    duration = float(minimum_s)
    for _ in range(2000):
        a0 = (6.0 * d - 4.0 * v * duration) / duration ** 2
        a1 = (2.0 * v * duration - 6.0 * d) / duration ** 2
        jerk = (a1 - a0) / duration
        peak = abs(v)
        if jerk != 0.0 and 0.0 < -a0 / jerk < duration:
            vertex = -a0 / jerk
            peak = max(peak, abs(v + a0 * vertex + 0.5 * jerk * vertex ** 2))
        if max(abs(a0), abs(a1)) <= max_acceleration and peak <= max_speed * (1 + 1e-9):
            return duration
        duration *= 1.02
    return duration
