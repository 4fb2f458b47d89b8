"""
The friction experiment runner without ROS, its events, and the event-driven experiments.

The runner's schedule, start/busy/abort and status are checked against plans built here from
``planning`` directly; its parameters are refused with one line naming the parameter.  The
event message round-trips through the rosbags kit.  The experiments that the
FrictionExperimentService forms from the runner's events are checked on a recording made here:
``trajectory_follower`` (the tests' own spline follower and joint model, with
``independent_robot``'s friction model) executes the runner's trajectories; the package's
simulator is not used.
"""

import dataclasses
import math

import numpy as np
import pytest
from robot_wear_monitor.experiment.planning import plan_experiment, PlanConfig, trajectory_points
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.monitoring.runner import ExperimentRunner, runner_config
from robot_wear_monitor.recordings import messages
from rosbags.typesys import get_typestore, Stores
from wear_testing.trajectory_follower import JointTruth, SimulatedArm

KIT = messages.rosbags_kit(get_typestore(Stores.ROS2_JAZZY))
RUNNER = node_config.FRICTION_EXPERIMENT_RUNNER_NODE
NAMES = [f'joint_{i}' for i in range(1, 7)]
POSTURE = [0.1, 0.6, -0.4, 0.05, 0.5, -0.2]
SPEEDS = (2.1, 28.5, 35.1, 41.7)
RATE_HZ = 250.0


def runner_values(**overrides):
    values = {'joint_names': NAMES, 'posture_rad': POSTURE, 'joints': ['joint_2', 'joint_3'],
              'gear_ratios': [150.0, 120.0], 'half_ranges_rad': [0.1, 0.1],
              'pause_between_joints_s': 1.0, 'end_margin_s': 0.5}
    values.update(overrides)
    return node_config.validate_parameters(RUNNER, values, source='test')


def make_runner(**overrides):
    return ExperimentRunner(runner_config(runner_values(**overrides), source='test'),
                            source='test')


def reference_plan(joint, ratio, **settings):
    """Return the plan of one joint as a user would build it with planning directly."""
    hold = tuple(p for n, p in zip(NAMES, POSTURE) if n != joint)
    config = PlanConfig(joint=joint, speeds_rad_s=SPEEDS, center_rad=POSTURE[NAMES.index(joint)],
                        half_range_rad=0.1, gear_ratio=ratio, max_acceleration_rad_s2=5.0,
                        rate_hz=250.0, noise_std=0.01, target_std_error=0.001,
                        min_duration_s=0.2, trim_s=0.02, min_samples=20, dwell_s=0.1,
                        joint_names=tuple(NAMES), hold_positions_rad=hold, **settings)
    return plan_experiment(config=config)


# --------------------------------------------------------------------------- runner logic

def test_runner_plans_each_tested_joint_one_after_the_other():
    runner = make_runner()
    first, second = runner.schedule
    for step, (joint, ratio) in zip(runner.schedule, (('joint_2', 150.0), ('joint_3', 120.0))):
        plan = reference_plan(joint, ratio)
        expected = trajectory_points(plan, point_rate_hz=50.0)
        assert step.joint == joint
        assert step.plan.total_s == pytest.approx(plan.total_s, abs=1e-12)
        assert step.points.joint_names == tuple(NAMES)
        np.testing.assert_allclose(step.points.time_from_start_s, expected.time_from_start_s)
        np.testing.assert_allclose(step.points.positions_rad, expected.positions_rad)
        np.testing.assert_allclose(step.points.velocities_rad_s, expected.velocities_rad_s)
        # the tested joint moves about its posture value, the others hold theirs
        j = NAMES.index(joint)
        column = step.points.positions_rad[:, j]
        assert column.min() < POSTURE[j] < column.max()
        others = np.delete(step.points.positions_rad, j, axis=1)
        np.testing.assert_array_equal(others, np.tile(np.delete(POSTURE, j), (len(column), 1)))
    assert first.start_offset_s == 0.0
    assert first.end_offset_s == pytest.approx(first.duration_s)
    assert first.end_event_offset_s == pytest.approx(first.end_offset_s + 0.5)
    assert second.start_offset_s == pytest.approx(first.end_event_offset_s + 1.0)
    assert second.end_event_offset_s == pytest.approx(second.start_offset_s
                                                      + second.duration_s + 0.5)
    assert runner.total_s == pytest.approx(second.end_event_offset_s)


def test_runner_start_events_busy_and_next_run():
    runner = make_runner()
    assert runner.start(100.0, trajectory_subscribers=0)[0] is False  # no controller
    ok, message = runner.start(100.0)
    assert ok and 'joint_2' in message and 'joint_3' in message
    assert f'{runner.total_s:.1f} s' in message and '\n' not in message
    assert runner.next_due_s() == 100.0
    [action] = runner.due(100.0)
    assert (action.kind, action.step.joint) == ('start', 'joint_2')
    event = action.event
    assert (event.event, event.joint, event.experiment_id) == ('start', 'joint_2', 1)
    assert event.speeds_rad_s == SPEEDS
    assert event.controller_topic == '/joint_trajectory_controller/joint_trajectory'
    assert event.planned_duration_s == pytest.approx(runner.schedule[0].duration_s)
    busy, message = runner.start(101.0)
    assert not busy and message.startswith('already running (joint_2, joint 1 of 2')
    first, second = runner.schedule
    assert runner.due(100.0 + first.end_event_offset_s - 0.01) == []
    assert runner.next_due_s() == pytest.approx(100.0 + first.end_event_offset_s)
    [end] = runner.due(100.0 + first.end_event_offset_s)
    assert (end.kind, end.event.experiment_id, end.event.stamp_s) == (
        'end', 1, 100.0 + first.end_event_offset_s)
    status = runner.status(100.0 + first.end_event_offset_s + 0.1, trajectory_subscribers=1)
    assert status.message.startswith('running: pause before joint_3, joint 2 of 2')
    later = runner.due(100.0 + runner.total_s + 5.0)  # a late timer: both actions, in order
    assert [(a.kind, a.step.joint, a.event.experiment_id) for a in later] == [
        ('start', 'joint_3', 2), ('end', 'joint_3', 2)]
    assert not runner.running and runner.next_due_s() is None
    assert runner.status(200.0, trajectory_subscribers=1).message == 'idle; last run completed'
    assert runner.start(300.0)[0]
    assert runner.due(300.0)[0].event.experiment_id == 3


def test_runner_abort_brakes_the_running_joint_and_skips_the_rest():
    runner = make_runner()
    assert runner.abort(0.0)[:2] == (False, 'not running')
    runner.start(10.0)
    runner.due(10.0)
    step = runner.schedule[0]
    elapsed = 2.3
    ok, message, action, hold = runner.abort(10.0 + elapsed)
    assert ok and 'joint_2' in message and 'not run: joint_3' in message
    assert (action.kind, action.event.event, action.event.experiment_id) == (
        'aborted', 'aborted', 1)
    # one point back at the posture, reached by the controller's cubic from the joint's state
    # within the acceleration limit (5 rad/s^2) and the speed limit (41.7 / 150 rad/s)
    np.testing.assert_array_equal(hold.positions_rad, [POSTURE])
    assert not hold.velocities_rad_s.any() and hold.accelerations_rad_s2.size == 0
    [duration] = hold.time_from_start_s
    q, v, _, _ = step.plan.sample(np.array([elapsed]))
    distance, v = POSTURE[1] - q[0], v[0]
    assert abs(v) > 0.1 and abs(distance) > 0.01  # aborted in a fast pass, off the centre

    def peaks(time_s):  # largest |acceleration| and |speed| of the cubic Hermite spline
        s = np.linspace(0.0, 1.0, 2001)
        speed = ((3 * s**2 - 4 * s + 1) * v * time_s + (-6 * s**2 + 6 * s) * distance) / time_s
        acceleration = ((6 * s - 4) * v * time_s + (-12 * s + 6) * distance) / time_s**2
        return np.abs(acceleration).max(), np.abs(speed).max()

    acceleration, speed = peaks(duration)
    assert acceleration <= 5.0 + 1e-9 and speed <= 41.7 / 150 + 1e-9
    faster = peaks(duration / 1.03)  # and as short as that allows
    assert faster[0] > 5.0 or faster[1] > 41.7 / 150
    assert not runner.running
    status = runner.status(12.0, trajectory_subscribers=0)
    assert status.level == messages.DIAGNOSTIC_WARN and 'last run aborted' in status.message
    assert dict(status.values)['experiments_aborted'] == '1'
    assert runner.start(20.0)[0]  # idle again
    # between two joints nothing moves: no aborted event, no hold trajectory
    runner.due(20.0 + runner.schedule[0].end_event_offset_s)
    ok, message, action, hold = runner.abort(20.0 + runner.schedule[0].end_event_offset_s + 0.5)
    assert ok and action is None and hold is None and 'between joints' in message


@pytest.mark.parametrize('overrides, named', [
    ({'half_ranges_rad': [0.02, 0.1]}, 'half_ranges_rad: joint_2: speed'),
    ({'max_acceleration_rad_s2': 0.0}, 'max_acceleration_rad_s2: must be > 0'),
    ({'max_acceleration_rad_s2': -1.0}, 'max_acceleration_rad_s2: must be > 0'),
    ({'max_speed_rad_s': 0.2}, 'speeds_rad_s: 41.7 rad/s (motor) is 0.278 rad/s at joint_2'),
    ({'position_lower_limits_rad': [0.55, -1.0], 'position_upper_limits_rad': [1.0, 1.0]},
     'half_ranges_rad: joint_2: the window 0.6 +- 0.1 rad'),
    ({'half_ranges_rad': [0.04, 0.1], 'position_lower_limits_rad': [0.559, -1.0],
      'position_upper_limits_rad': [1.0, 1.0]}, 'position_lower_limits_rad: joint_2: speed'),
    ({'position_lower_limits_rad': [0.0, 0.0], 'position_upper_limits_rad': []},
     'position_upper_limits_rad: give both limit arrays or neither'),
    ({'joints': ['joint_2', 'joint_9']}, "joints: 'joint_9' is not in joint_names"),
    ({'joints': ['joint_2', 'joint_2']}, 'joints: names must be distinct'),
    ({'gear_ratios': [150.0]}, 'gear_ratios: needs one value per tested joint (2)'),
    ({'posture_rad': [0.0]}, 'posture_rad: needs one position per joint_names (6)'),
    ({'speeds_rad_s': [2.1, -1.0]}, 'speeds_rad_s: speeds must be > 0'),
    ({'joints': 'joint_2'}, 'joints: expected a list of strings'),
    ({'controller': ''}, 'controller: must not be empty'),
])
def test_bad_runner_parameters_are_refused_with_one_line_naming_the_parameter(overrides,
                                                                              named):
    with pytest.raises(ParameterError) as caught:
        make_runner(**overrides)
    text = str(caught.value)
    assert named in text
    assert '\n' not in text and '--' not in text  # the node's words, not the CLI's


def test_packaged_runner_parameters_plan_and_the_events_topic_is_checked():
    values = node_config.load_node_parameters(RUNNER)
    runner = ExperimentRunner(runner_config(values))
    assert [s.joint for s in runner.schedule] == ['joint_2']
    assert runner.config.trajectory_topic == '/joint_trajectory_controller/joint_trajectory'
    experiment = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE)
    assert experiment['experiment_events_topic'] == messages.EXPERIMENT_EVENTS_TOPIC
    node_config.validate_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                    {'experiment_events_topic': ''})
    with pytest.raises(ParameterError, match='experiment_events_topic: must be a topic'):
        node_config.validate_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                        {'experiment_events_topic': 'a b'})


# --------------------------------------------------------------------------- event messages

def test_experiment_event_round_trips_through_the_rosbags_kit():
    event = messages.ExperimentEvent(event='aborted', joint='joint_2', experiment_id=7,
                                     speeds_rad_s=SPEEDS, planned_duration_s=4.5766,
                                     controller_topic='/jtc/joint_trajectory')
    msg = messages.experiment_event_to_msg(KIT, stamp_s=1700000000.25, event=event)
    [(level, name, text, values)] = messages.diagnostics_from_msg(msg)
    assert (level, name, text) == (messages.DIAGNOSTIC_WARN,
                                   'friction_experiment_runner: joint_2', 'aborted')
    assert msg.status[0].hardware_id == 'joint_2'
    assert values['speeds_rad_s'] == '2.1,28.5,35.1,41.7' and values['experiment_id'] == '7'
    back = messages.experiment_event_from_msg(msg)
    assert back.stamp_s == pytest.approx(1700000000.25, abs=1e-6)
    assert dataclasses.replace(back, stamp_s=0.0) == event
    start = messages.experiment_event_to_msg(KIT, stamp_s=1.0, event=messages.ExperimentEvent(
        'start', 'joint_2', 1, SPEEDS, 4.0))
    assert messages.level_to_int(start.status[0].level) == messages.DIAGNOSTIC_OK
    # and through the serialised bytes of a bag
    typestore = get_typestore(Stores.ROS2_JAZZY)
    raw = typestore.serialize_cdr(msg, messages.EXPERIMENT_EVENTS_TYPE)
    assert messages.experiment_event_from_msg(
        typestore.deserialize_cdr(raw, messages.EXPERIMENT_EVENTS_TYPE)) == back


@pytest.mark.parametrize('change, reason', [
    (lambda m: m.status.clear(), 'malformed'),
    (lambda m: setattr(m.status[0], 'name', 'wear_monitor: joint_2'), 'malformed'),
    (lambda m: m.status[0].values.pop(2), 'missing_key'),
    (lambda m: setattr(m.status[0].values[0], 'value', 'paused'), 'unknown_event'),
    (lambda m: setattr(m.status[0].values[2], 'value', 'one'), 'bad_value'),
    (lambda m: setattr(m.status[0].values[3], 'value', '2.1,-3'), 'bad_value'),
    (lambda m: setattr(m.status[0].values[4], 'value', 'nan'), 'bad_value'),
])
def test_malformed_events_are_refused_with_a_reason(change, reason):
    msg = messages.experiment_event_to_msg(KIT, stamp_s=1.0, event=messages.ExperimentEvent(
        'end', 'joint_2', 1, SPEEDS, 4.0))
    msg.status = list(msg.status)
    msg.status[0].values = list(msg.status[0].values)
    change(msg)
    with pytest.raises(messages.MessageError) as caught:
        messages.experiment_event_from_msg(msg)
    assert caught.value.reason == reason


# --------------------------------------------------------------------------- event-driven assembly

TRUTH = {'joint_2': JointTruth(gear_ratio=150.0, load=0.45, temperature_degc=38.0, wear=42.0),
         'joint_3': JointTruth(gear_ratio=120.0, load=0.6, temperature_degc=45.0, wear=10.0,
                               gravity=0.3)}


def run_session(commands, *, events=True, event_lag_s=0.0, seed=4, idle_gap_s=3.0, batch=0):
    """
    Simulate the runner driving the arm; feed a FrictionExperimentService of joint_2.

    ``commands``: (time from the session start [s], 'start' | 'abort').  Events are applied
    ``event_lag_s`` later than their stamps (negative: before the samples reach them), or not
    at all without ``events``.  ``batch``: the samples go in batches of this many to
    ``add_recording``, as the node drains its queue (an event first takes the batch so far,
    as the node drains before it applies one); 0: one by one to ``add_joint_state``.
    Returns (service, [(sample time when emitted, experiment)], runner, every event).
    """
    runner = make_runner()
    arm = SimulatedArm(NAMES, POSTURE, tested=TRUTH, seed=seed)
    # the configured speeds: the assembler without events completes (or abandons) on them
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                              overrides={'experiment_speeds_rad_s': SPEEDS,
                                                         'idle_gap_s': idle_gap_s})
    service = FrictionExperimentService.from_node_parameters(values)
    t0 = 1_700_000_000.0
    commands = sorted(commands)
    end_s = commands[-1][0] + runner.total_s + 3.0
    pending = []  # (apply at, event)
    emitted, log, queued = [], [], []
    column = NAMES.index('joint_2')

    def drain(now):
        if queued:
            t, q, v, e = (np.array(values) for values in zip(*queued))
            emitted.extend((now, e) for e in service.add_recording(
                time_s=t, position_rad=q, velocity_rad_s=v, effort=e))
            queued.clear()

    for k in range(int(end_s * RATE_HZ)):
        now = t0 + k / RATE_HZ
        if batch and len(queued) >= batch:
            drain(now)
        while commands and t0 + commands[0][0] <= now:
            _, command = commands.pop(0)
            if command == 'start':
                assert runner.start(now)[0]
            else:
                _, _, action, hold = runner.abort(now)
                pending.append((now + event_lag_s, action.event))
                log.append(action.event)
                arm.command_points(now + 0.004, hold)
        for action in runner.due(now):
            pending.append((now + event_lag_s, action.event))
            log.append(action.event)
            if action.kind == 'start':
                arm.command_points(now + 0.004, action.step.points)  # transport delay
        for at, event in sorted(pending, key=lambda p: p[0]):
            if at <= now and events:
                drain(now)
                emitted += [(now, e) for e in service.add_experiment_event(event)]
        pending = [(at, event) for at, event in pending if at > now]
        position, velocity, effort = arm.sample(now)
        if batch:
            queued.append((now, position[column], velocity[column], effort[column]))
            continue
        emitted += [(now, e) for e in service.add_joint_state(
            stamp_s=now, name=NAMES, position=position, velocity=velocity, effort=effort)]
    drain(math.inf)
    emitted += [(math.inf, e) for e in service.finish()]
    return service, emitted, runner, log


def joint_2_events(log, kind):
    return [e for e in log if e.joint == 'joint_2' and e.event == kind]


SESSION = [(0.5, 'start'), (14.0, 'start'), (16.5, 'abort'), (21.0, 'start')]


@pytest.fixture(scope='module')
def session():
    return run_session(SESSION)


def test_events_give_exactly_the_planned_experiments_near_the_truth(session):
    service, emitted, runner, log = session
    starts, ends = joint_2_events(log, 'start'), joint_2_events(log, 'end')
    assert [e.experiment_id for e in starts] == [1, 3, 5]  # ids are per joint and run
    assert [e.experiment_id for e in joint_2_events(log, 'aborted')] == [3]
    assert [e.experiment_id for e in ends] == [1, 5]
    assert len(emitted) == 2
    truth = TRUTH['joint_2']
    for (when, experiment), start, end in zip(emitted, (starts[0], starts[2]), ends):
        # emitted at the end event (the first sample at its stamp), not after an idle gap
        end_stamp = end.stamp_s
        assert end_stamp - start.stamp_s == pytest.approx(runner.schedule[0].end_event_offset_s,
                                                          abs=1.01 / RATE_HZ)
        assert end_stamp <= when <= end_stamp + 1.5 / RATE_HZ
        assert experiment.speeds_rad_s == pytest.approx(SPEEDS, abs=0.3)
        assert experiment.frictions == pytest.approx(truth.friction(experiment.speeds_rad_s),
                                                     abs=2e-3)
        assert start.stamp_s <= experiment.start_time_s < experiment.end_time_s <= end_stamp
    status = service.current_status()
    values = dict(status.values)
    assert status.level == messages.DIAGNOSTIC_OK  # an abort is routine, not a defect
    assert values['experiments'] == '2' and values['experiments_from_events'] == '2'
    assert values['rejected_aborted_experiment'] == '1'
    assert values['experiment_events'] == '6'  # start+end, start+aborted, start+end
    assert values['experiment_events_other_joints'] == '4'  # joint_3 in runs 1 and 3
    assert values['experiments_incomplete'] == '0' and values['experiment_open'] == 'none'
    assert values['experiment_events_unmatched'] == '0'


def test_without_events_the_aborted_levels_spoil_the_next_experiment(session):
    service, emitted, _, _ = run_session(SESSION, events=False, idle_gap_s=30.0)
    # With a long idle gap the assembler still finds two complete experiments, but the second
    # one merges the aborted run's first levels with the next run's: the events keep them
    # apart, and so does the default idle gap (3 s of standstill drop the aborted run).
    assert len(emitted) == 2
    spoiled = emitted[1][1]
    with_events = session[1][1][1]
    assert spoiled.levels[0].n_forward > 1.5 * with_events.levels[0].n_forward
    assert spoiled.start_time_s < with_events.start_time_s - 4.0
    _, clean, _, _ = run_session(SESSION, events=False)
    assert len(clean) == 2
    assert clean[1][1].levels[0].n_forward == pytest.approx(with_events.levels[0].n_forward,
                                                            abs=2)
    assert clean[1][1].start_time_s == pytest.approx(with_events.start_time_s, abs=0.01)


@pytest.mark.parametrize('batch, event_lag_s', [(13, 0.0), (50, 0.0), (50, -2.0), (50, 0.3)])
def test_drained_batches_give_the_experiments_of_one_sample_at_a_time(session, batch,
                                                                      event_lag_s):
    """The node's drain (batches to add_recording, events between them) changes nothing."""
    reference = session if event_lag_s == 0.0 else run_session(SESSION, event_lag_s=event_lag_s)
    service, emitted, _, _ = run_session(SESSION, batch=batch, event_lag_s=event_lag_s)
    assert [e for _, e in emitted] == [e for _, e in reference[1]]  # bit for bit
    for (when, _), (then, _) in zip(emitted, reference[1]):
        assert then <= when <= then + (batch + 1) / RATE_HZ  # at most one batch later
    got, expected = dict(service.current_status().values), dict(
        reference[0].current_status().values)
    for key in ('experiments', 'experiments_from_events', 'experiment_events',
                'rejected_aborted_experiment', 'levels_outside_experiment', 'friction_levels'):
        assert got[key] == expected[key], key


def test_events_ahead_of_the_samples_close_at_the_first_sample_at_the_end_stamp():
    service, emitted, runner, log = run_session([(0.5, 'start')], event_lag_s=-2.0)
    assert len(emitted) == 1
    when, experiment = emitted[0]
    end_stamp = joint_2_events(log, 'end')[0].stamp_s
    assert end_stamp <= when <= end_stamp + 1.5 / RATE_HZ
    assert len(experiment.levels) == 4


def test_a_start_without_end_is_closed_by_the_next_start_and_unmatched_events_are_counted():
    # the configured speeds: the assembler without events completes (or abandons) on them
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                              overrides={'experiment_speeds_rad_s': SPEEDS})
    service = FrictionExperimentService.from_node_parameters(values)
    event = messages.ExperimentEvent
    assert service.add_experiment_event(event('end', 'joint_2', 5, SPEEDS, 4.0, '', 1.0)) == []
    assert service.add_experiment_event(event('start', 'joint_2', 6, SPEEDS, 4.0, '', 2.0)) == []
    assert service.open_experiment_id == 6
    assert service.add_experiment_event(event('end', 'joint_2', 5, SPEEDS, 4.0, '', 3.0)) == []
    assert service.open_experiment_id == 6  # another experiment's end does not close it
    assert service.add_experiment_event(event('start', 'joint_2', 7, SPEEDS, 4.0, '', 4.0)) == []
    assert service.open_experiment_id == 7  # no levels: nothing emitted
    service.handle_experiment_event_msg(KIT.make(messages.DIAGNOSTICS_TYPE,
                                                 header=messages.make_header(KIT, stamp_s=1.0),
                                                 status=[]))
    values = dict(service.current_status().values)
    assert values['experiment_events_unmatched'] == '2'
    assert values['rejected_experiment_event_malformed'] == '1'
    assert values['experiment_open'] == '7'
    assert service.finish() == []


def test_an_unfinished_experiment_is_emitted_with_the_levels_it_has():
    service, emitted, runner, _ = run_session([(0.5, 'start'), (3.0, 'abort')], events=False)
    assert emitted == []  # 2 of 4 speeds: the assembler abandons it
    # the configured speeds: the assembler without events completes (or abandons) on them
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                              overrides={'experiment_speeds_rad_s': SPEEDS})
    service = FrictionExperimentService.from_node_parameters(values)
    start = messages.ExperimentEvent('start', 'joint_2', 1, SPEEDS, 4.0, '', 0.0)
    service.add_experiment_event(start)
    arm = SimulatedArm(NAMES, POSTURE, tested=TRUTH, seed=1)
    arm.command_points(0.004, runner.schedule[0].points)
    for k in range(int(2.5 * RATE_HZ)):
        position, velocity, effort = arm.sample(k / RATE_HZ)
        service.add_joint_state(stamp_s=k / RATE_HZ, name=NAMES, position=position,
                                velocity=velocity, effort=effort)
    [experiment] = service.finish()  # the stream ends with the experiment open
    assert 1 <= len(experiment.levels) < 4
    assert dict(service.current_status().values)['experiments_incomplete'] == '1'
