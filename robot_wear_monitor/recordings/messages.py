"""
Pure mapping between the monitoring service's results and ROS 2 message fields.

The same functions build messages for the live nodes (rclpy message classes) and for the bag
replay (rosbags typestore classes): the message classes come from a :class:`MessageKit`, which also
says how the two worlds spell a float array (list for rclpy, numpy array for rosbags) and a
``byte`` field (``bytes`` of length 1 for rclpy, ``int`` for rosbags).  Nothing here imports rclpy.

Topic and type contract (documented in ``docs/service.md`` and the README):

``friction_levels`` (sensor_msgs/msg/JointState), one message per completed experiment:
    ``header.stamp`` end time of the experiment's last sample; ``header.frame_id`` the joint;
    ``name[i]`` = ``<joint>/level_<i>``; ``velocity[i]`` the motor-side speed level [rad/s];
    ``effort[i]`` the friction level tau_f (normalised torque) of eq. (3); ``position`` empty.
``temperature`` (sensor_msgs/msg/Temperature): T-hat [degC] and its variance [degC^2].
``wear`` (std_msgs/msg/Float64): w-hat.
``wear_alarm`` (std_msgs/msg/Bool): the latched alarm state.
``/diagnostics`` (diagnostic_msgs/msg/DiagnosticArray): one DiagnosticStatus with key-values.
``wear_trend`` (std_msgs/msg/Float64MultiArray): the filtered trend and forecast after each
    experiment; one dimension labelled ``<joint>:`` followed by :data:`TREND_FIELDS` joined by
    commas, ``data`` in that order (w, its 95 % interval, P(w >= threshold), rate [w per
    experiment], remaining experiments to the threshold with 95 % interval, crossing time [s]
    with 95 % interval, time of the experiment [s]; inf = beyond the forecast horizon, NaN =
    unknown).
``<controller>/joint_trajectory`` (trajectory_msgs/msg/JointTrajectory): the planned friction
    experiment (``experiment.planning.trajectory_points``), positions [rad], velocities
    [rad/s] and accelerations [rad/s^2] of every joint at each point, ``effort`` empty.
``friction_experiment/events`` (diagnostic_msgs/msg/DiagnosticArray): the friction experiment
    runner's boundaries of each experiment, one message per event: ``header.stamp`` the time of
    the event (runner clock); one DiagnosticStatus named ``friction_experiment_runner:
    <joint>``, ``hardware_id`` the joint, ``message`` the event (``start``, ``end`` or
    ``aborted``), level OK (WARN for ``aborted``), key-values ``event``, ``joint``,
    ``experiment_id`` (integer), ``speeds_rad_s`` (motor side, comma-separated),
    ``planned_duration_s`` and ``controller_topic``.  ``end`` comes ``end_margin_s`` after the
    planned end of the motion (:class:`ExperimentEvent`).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Callable, Iterable, Sequence

import numpy as np
from robot_wear_monitor.errors import InputError

FRICTION_LEVELS_TYPE = 'sensor_msgs/msg/JointState'
TEMPERATURE_TYPE = 'sensor_msgs/msg/Temperature'
WEAR_TYPE = 'std_msgs/msg/Float64'
ALARM_TYPE = 'std_msgs/msg/Bool'
DIAGNOSTICS_TYPE = 'diagnostic_msgs/msg/DiagnosticArray'
TREND_TYPE = 'std_msgs/msg/Float64MultiArray'
TRAJECTORY_TYPE = 'trajectory_msgs/msg/JointTrajectory'

#: ``wear_trend`` fields, in the order of ``data`` (also the label of its one dimension).
TREND_FIELDS = ('wear', 'wear_low', 'wear_high', 'probability_above_threshold', 'rate',
                'remaining_experiments', 'remaining_experiments_low',
                'remaining_experiments_high', 'crossing_time_s', 'crossing_time_low_s',
                'crossing_time_high_s', 'time_s')

# Status levels of diagnostic_msgs/msg/DiagnosticStatus.
DIAGNOSTIC_OK = 0
DIAGNOSTIC_WARN = 1
DIAGNOSTIC_ERROR = 2
DIAGNOSTIC_STALE = 3
LEVEL_NAMES = {DIAGNOSTIC_OK: 'OK', DIAGNOSTIC_WARN: 'WARN', DIAGNOSTIC_ERROR: 'ERROR',
               DIAGNOSTIC_STALE: 'STALE'}


class MessageError(InputError):
    """A received message cannot be used; ``reason`` is a short counter key for diagnostics."""

    def __init__(self, reason: str, detail: str) -> None:
        """Keep the counter key ``reason`` and the one-line ``detail``."""
        super().__init__(f'{reason}: {detail}')
        self.reason = reason
        self.detail = detail


@dataclass(frozen=True)
class MessageKit:
    """
    Message classes plus the two field conventions that differ between rclpy and rosbags.

    :ivar get_type: returns the message class of a ROS type name such as
        ``'sensor_msgs/msg/JointState'``.
    :ivar float_array: converts a sequence of floats to what a ``float64[]`` field takes.
    :ivar byte: converts an int in 0..255 to what a ``byte`` field takes.

    """

    get_type: Callable[[str], Any]
    float_array: Callable[[Iterable[float]], Any]
    byte: Callable[[int], Any]

    def make(self, type_name: str, **fields: Any) -> Any:
        """Build a message of ``type_name`` from keyword fields (all fields must be given)."""
        return self.get_type(type_name)(**fields)


def rosbags_kit(typestore: Any) -> MessageKit:
    """Return the kit for a rosbags typestore (``float64[]`` as numpy, ``byte`` as int)."""
    return MessageKit(get_type=typestore.types.__getitem__,
                      float_array=lambda values: np.asarray(list(values), dtype=np.float64),
                      byte=int)


def rclpy_kit(get_message: Callable[[str], Any]) -> MessageKit:
    """Return the kit for rclpy message classes (``get_message`` from rosidl_runtime_py)."""
    return MessageKit(get_type=get_message,
                      float_array=lambda values: [float(v) for v in values],
                      byte=lambda value: bytes([int(value)]))


def level_to_int(value: Any) -> int:
    """Return a DiagnosticStatus ``level`` as int, whether it is bytes (rclpy) or int (rosbags)."""
    if isinstance(value, (bytes, bytearray)):
        return int(value[0])
    return int(value)


# --------------------------------------------------------------------------- time

def split_stamp(stamp_s: float) -> tuple[int, int]:
    """Return (sec, nanosec) of a time in seconds, nanosec in [0, 1e9)."""
    total_ns = int(round(float(stamp_s) * 1e9))
    sec, nanosec = divmod(total_ns, 1_000_000_000)
    return int(sec), int(nanosec)


def stamp_to_seconds(stamp: Any) -> float:
    """Return a builtin_interfaces/Time as float seconds."""
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def stamp_to_nanoseconds(stamp_s: float) -> int:
    """Return a time in seconds as integer nanoseconds (bag timestamps)."""
    return int(round(float(stamp_s) * 1e9))


def make_header(kit: MessageKit, *, stamp_s: float, frame_id: str = '') -> Any:
    """Build a std_msgs/Header."""
    sec, nanosec = split_stamp(stamp_s)
    stamp = kit.make('builtin_interfaces/msg/Time', sec=sec, nanosec=nanosec)
    return kit.make('std_msgs/msg/Header', stamp=stamp, frame_id=frame_id)


# --------------------------------------------------------------------------- friction_levels

@dataclass(frozen=True)
class FrictionLevelsMessage:
    """The content of one ``friction_levels`` message: one completed experiment."""

    stamp_s: float
    joint: str
    speeds_rad_s: tuple[float, ...]
    frictions: tuple[float, ...]


def level_names(joint: str, count: int) -> list[str]:
    """Return the ``name`` entries of a friction_levels message: ``<joint>/level_<i>``."""
    return [f'{joint}/level_{i}' for i in range(count)]


def friction_levels_to_msg(kit: MessageKit, *, stamp_s: float, joint: str,
                           speeds_rad_s: Iterable[float], frictions: Iterable[float]) -> Any:
    """Build the friction_levels JointState: velocity = speeds [rad/s], effort = friction."""
    speeds = [float(v) for v in speeds_rad_s]
    values = [float(f) for f in frictions]
    if len(speeds) != len(values) or not speeds:
        raise ValueError(f'need as many speeds as frictions (>= 1), got {len(speeds)} and '
                         f'{len(values)}')
    return kit.make(FRICTION_LEVELS_TYPE,
                    header=make_header(kit, stamp_s=stamp_s, frame_id=joint),
                    name=level_names(joint, len(speeds)),
                    position=kit.float_array([]),
                    velocity=kit.float_array(speeds),
                    effort=kit.float_array(values))


def friction_levels_from_msg(msg: Any) -> FrictionLevelsMessage:
    """
    Read a friction_levels JointState; raise :class:`MessageError` when it is unusable.

    Reasons (diagnostic counter keys): ``empty``, ``length_mismatch``, ``not_finite``,
    ``non_positive_speed``.
    """
    try:
        speeds = tuple(float(v) for v in msg.velocity)
        frictions = tuple(float(f) for f in msg.effort)
        names = list(msg.name)
        stamp_s = stamp_to_seconds(msg.header.stamp)
        joint = str(msg.header.frame_id)
    except (AttributeError, TypeError, ValueError) as error:
        raise MessageError('malformed', f'not a JointState with numbers: {error}') from None
    if not speeds and not frictions:
        raise MessageError('empty', 'no friction levels (velocity and effort are empty)')
    if len(speeds) != len(frictions) or (names and len(names) != len(speeds)):
        raise MessageError('length_mismatch',
                           f'velocity has {len(speeds)}, effort {len(frictions)}, '
                           f'name {len(names)} entries')
    if not all(math.isfinite(v) for v in speeds + frictions):
        raise MessageError('not_finite', 'a speed or friction level is NaN or infinite')
    if min(speeds) <= 0:
        raise MessageError('non_positive_speed',
                           f'speed levels must be > 0 rad/s (motor side), got {min(speeds)}')
    return FrictionLevelsMessage(stamp_s=stamp_s, joint=joint, speeds_rad_s=speeds,
                                 frictions=frictions)


# --------------------------------------------------------------------------- estimator outputs

def temperature_to_msg(kit: MessageKit, *, stamp_s: float, frame_id: str,
                       temperature_degc: float, variance_degc2: float) -> Any:
    """Build sensor_msgs/Temperature (variance 0 means unknown in the message definition)."""
    variance = float(variance_degc2) if math.isfinite(variance_degc2) else 0.0
    return kit.make(TEMPERATURE_TYPE, header=make_header(kit, stamp_s=stamp_s, frame_id=frame_id),
                    temperature=float(temperature_degc), variance=variance)


def wear_to_msg(kit: MessageKit, *, wear: float) -> Any:
    """Build std_msgs/Float64 holding w-hat."""
    return kit.make(WEAR_TYPE, data=float(wear))


def alarm_to_msg(kit: MessageKit, *, active: bool) -> Any:
    """Build std_msgs/Bool holding the latched alarm state."""
    return kit.make(ALARM_TYPE, data=bool(active))


def trend_to_msg(kit: MessageKit, *, stamp_s: float, joint: str, trend: Any) -> Any:
    """Build the ``wear_trend`` Float64MultiArray of a trend estimate (see the module doc)."""
    del stamp_s  # Float64MultiArray has no header; the time is the last element of data
    values = [float(getattr(trend, name)) for name in TREND_FIELDS]
    dimension = kit.make('std_msgs/msg/MultiArrayDimension',
                         label=f'{joint}:' + ','.join(TREND_FIELDS), size=len(values),
                         stride=len(values))
    layout = kit.make('std_msgs/msg/MultiArrayLayout', dim=[dimension], data_offset=0)
    return kit.make(TREND_TYPE, layout=layout, data=kit.float_array(values))


def trend_from_msg(msg: Any) -> dict[str, float]:
    """Return the ``wear_trend`` fields by name (the inverse of :func:`trend_to_msg`)."""
    label = str(msg.layout.dim[0].label)
    names = label.split(':', 1)[-1].split(',')
    return {name: float(value) for name, value in zip(names, msg.data)}


def diagnostics_to_msg(kit: MessageKit, *, stamp_s: float, name: str, hardware_id: str,
                       level: int, message: str,
                       values: Sequence[tuple[str, str]]) -> Any:
    """Build a DiagnosticArray with one DiagnosticStatus and its key-values."""
    key_value = kit.get_type('diagnostic_msgs/msg/KeyValue')  # looked up once, not per pair
    key_values = [key_value(key=str(k), value=str(v)) for k, v in values]
    status = kit.make('diagnostic_msgs/msg/DiagnosticStatus', level=kit.byte(level),
                      name=name, message=message, hardware_id=hardware_id, values=key_values)
    return kit.make(DIAGNOSTICS_TYPE, header=make_header(kit, stamp_s=stamp_s),
                    status=[status])


def diagnostics_from_msg(msg: Any) -> list[tuple[int, str, str, dict[str, str]]]:
    """Return (level, name, message, key-values) of every status of a DiagnosticArray."""
    return [(level_to_int(s.level), str(s.name), str(s.message),
             {str(kv.key): str(kv.value) for kv in s.values}) for s in msg.status]


# --------------------------------------------------------------------------- joint trajectory

def _duration(kit: MessageKit, seconds: float) -> Any:
    sec, nanosec = split_stamp(seconds)
    return kit.make('builtin_interfaces/msg/Duration', sec=sec, nanosec=nanosec)


def trajectory_to_msg(kit: MessageKit, *, points: Any, stamp_s: float = 0.0,
                      frame_id: str = '') -> Any:
    """
    Build a trajectory_msgs/JointTrajectory from ``TrajectoryPoints``.

    ``stamp_s`` = 0 means "start on receipt" for ros2_control's joint_trajectory_controller.
    """
    empty = kit.float_array([])
    rows = [kit.make('trajectory_msgs/msg/JointTrajectoryPoint',
                     positions=kit.float_array(q), velocities=kit.float_array(v),
                     accelerations=kit.float_array(a), effort=empty,
                     time_from_start=_duration(kit, t))
            for t, q, v, a in zip(points.time_from_start_s, points.positions_rad,
                                  points.velocities_rad_s, points.accelerations_rad_s2)]
    header = make_header(kit, stamp_s=stamp_s, frame_id=frame_id)
    return kit.make(TRAJECTORY_TYPE, header=header, joint_names=list(points.joint_names),
                    points=rows)


def trajectory_to_dict(points: Any) -> dict[str, Any]:
    """Return a JointTrajectory as plain data (the YAML that ``ros2 topic pub`` accepts)."""
    def duration(seconds: float) -> dict[str, int]:
        sec, nanosec = split_stamp(seconds)
        return {'sec': sec, 'nanosec': nanosec}
    return {
        'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''},
        'joint_names': list(points.joint_names),
        'points': [{'positions': [float(x) for x in q], 'velocities': [float(x) for x in v],
                    'accelerations': [float(x) for x in a], 'effort': [],
                    'time_from_start': duration(t)}
                   for t, q, v, a in zip(points.time_from_start_s, points.positions_rad,
                                         points.velocities_rad_s,
                                         points.accelerations_rad_s2)],
    }


def trajectory_from_msg(msg: Any) -> dict[str, Any]:
    """
    Return the content of a JointTrajectory as a dict; raise MessageError when malformed.

    Keys: ``joint_names``, ``time_from_start_s`` (P,) [s], ``positions`` [rad],
    ``velocities`` [rad/s] and ``accelerations`` [rad/s^2] of shape (P, J) (or (P, 0) where the
    points leave them empty).
    """
    names = list(msg.joint_names)
    times: list[float] = []
    columns: dict[str, list] = {'positions': [], 'velocities': [], 'accelerations': []}
    for k, point in enumerate(msg.points):
        times.append(float(point.time_from_start.sec)
                     + 1e-9 * float(point.time_from_start.nanosec))
        for key, values in columns.items():
            row = [float(x) for x in getattr(point, key)]
            if row and len(row) != len(names):
                raise MessageError('length_mismatch', f'point {k}: {len(row)} {key} for '
                                                      f'{len(names)} joints')
            values.append(row)
    return {'joint_names': names, 'time_from_start_s': np.asarray(times),
            **{key: np.asarray(values, dtype=float) for key, values in columns.items()}}


# --------------------------------------------------------------------------- experiment events

#: Topic of the friction experiment runner's events (relative: ``/friction_experiment/events``).
EXPERIMENT_EVENTS_TOPIC = 'friction_experiment/events'
EXPERIMENT_EVENTS_TYPE = DIAGNOSTICS_TYPE
#: The events, in the order they can happen to one experiment (``end`` or ``aborted``).
EXPERIMENT_EVENT_KINDS = ('start', 'end', 'aborted')
#: DiagnosticStatus name of an event: ``friction_experiment_runner: <joint>``.
EXPERIMENT_EVENT_NAME = 'friction_experiment_runner'
#: Key-values of an event's DiagnosticStatus, in order.
EXPERIMENT_EVENT_KEYS = ('event', 'joint', 'experiment_id', 'speeds_rad_s',
                         'planned_duration_s', 'controller_topic')


@dataclass(frozen=True)
class ExperimentEvent:
    """
    One event of the friction experiment runner (see the module docstring).

    :ivar event: ``start``, ``end`` or ``aborted``.
    :ivar joint: the tested joint.
    :ivar experiment_id: the runner's number of this joint's experiment (start, end and aborted
        of one experiment share it).
    :ivar speeds_rad_s: the planned speeds, motor side [rad/s], in the order they are run.
    :ivar planned_duration_s: duration of the planned motion [s].
    :ivar controller_topic: the JointTrajectory topic the motion was sent to.
    :ivar stamp_s: ``header.stamp`` [s] as read by :func:`experiment_event_from_msg` (the
        runner's clock); :func:`experiment_event_to_msg` stamps with its own argument.

    """

    event: str
    joint: str
    experiment_id: int
    speeds_rad_s: tuple[float, ...]
    planned_duration_s: float
    controller_topic: str = ''
    stamp_s: float = 0.0


def experiment_event_to_msg(kit: MessageKit, *, stamp_s: float, event: ExperimentEvent) -> Any:
    """
    Build the DiagnosticArray of one experiment event, stamped ``stamp_s`` [s].

    Level OK for ``start`` and ``end``, WARN for ``aborted``.
    """
    if event.event not in EXPERIMENT_EVENT_KINDS:
        raise ValueError(f'event must be one of {", ".join(EXPERIMENT_EVENT_KINDS)}, got '
                         f'{event.event!r}')
    values = (('event', event.event), ('joint', event.joint),
              ('experiment_id', str(int(event.experiment_id))),
              ('speeds_rad_s', ','.join(repr(float(v)) for v in event.speeds_rad_s)),
              ('planned_duration_s', repr(float(event.planned_duration_s))),
              ('controller_topic', event.controller_topic))
    level = DIAGNOSTIC_WARN if event.event == 'aborted' else DIAGNOSTIC_OK
    return diagnostics_to_msg(kit, stamp_s=stamp_s,
                              name=f'{EXPERIMENT_EVENT_NAME}: {event.joint}',
                              hardware_id=event.joint, level=level, message=event.event,
                              values=values)


def experiment_event_from_msg(msg: Any) -> ExperimentEvent:
    """
    Read an experiment event; raise :class:`MessageError` when it is unusable.

    Reasons (diagnostic counter keys): ``malformed`` (not a DiagnosticArray with exactly one
    status of the runner), ``missing_key``, ``unknown_event``, ``bad_value``.
    """
    try:
        statuses = list(msg.status)
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if len(statuses) != 1:
            raise MessageError('malformed', f'expected one DiagnosticStatus, got '
                                            f'{len(statuses)}')
        status = statuses[0]
        name = str(status.name)
        values = {str(kv.key): str(kv.value) for kv in status.values}
    except (AttributeError, TypeError, ValueError) as error:
        if isinstance(error, MessageError):
            raise
        raise MessageError('malformed', f'not a DiagnosticArray: {error}') from None
    if not name.startswith(EXPERIMENT_EVENT_NAME):
        raise MessageError('malformed', f'status {name!r} is not a '
                                        f'{EXPERIMENT_EVENT_NAME} event')
    missing = [key for key in EXPERIMENT_EVENT_KEYS if key not in values]
    if missing:
        raise MessageError('missing_key', f'no key-value {missing[0]!r}')
    if values['event'] not in EXPERIMENT_EVENT_KINDS:
        raise MessageError('unknown_event', f'event {values["event"]!r} is not one of '
                                            f'{", ".join(EXPERIMENT_EVENT_KINDS)}')
    if not values['joint']:
        raise MessageError('bad_value', 'joint is empty')
    try:
        experiment_id = int(values['experiment_id'])
        text = values['speeds_rad_s'].strip()
        speeds = tuple(float(v) for v in text.split(',')) if text else ()
        duration = float(values['planned_duration_s'])
    except ValueError as error:
        raise MessageError('bad_value', f'not a number: {error}') from None
    if not all(math.isfinite(v) and v > 0 for v in speeds):
        raise MessageError('bad_value', f'speeds must be > 0 rad/s (motor side), got {speeds}')
    if not (math.isfinite(duration) and duration >= 0):
        raise MessageError('bad_value', f'planned_duration_s must be >= 0, got {duration}')
    return ExperimentEvent(event=values['event'], joint=values['joint'],
                           experiment_id=experiment_id, speeds_rad_s=speeds,
                           planned_duration_s=duration,
                           controller_topic=values['controller_topic'], stamp_s=stamp_s)
