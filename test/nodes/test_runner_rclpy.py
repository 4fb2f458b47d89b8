"""
friction_experiment_runner in-process on a real ROS 2 graph (Fast DDS, this session's domain).

The runner and a probe node share one SingleThreadedExecutor; the probe subscribes as a
trajectory controller and a friction_experiment_node would, and calls the services: the
trajectory on ``/joint_trajectory_controller/joint_trajectory`` equals the planning module's
points of the same configuration, ``start`` and ``end`` events arrive in order with ``end``
about the planned duration + ``end_margin_s`` later, a busy runner refuses a second start, an
abort sends ``aborted`` and a point back at the posture, and bad parameters refuse the node.
"""

import time

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from robot_wear_monitor.experiment.planning import (plan_experiment, PlanConfig,
                                                    trajectory_points)
from robot_wear_monitor.monitoring.node_config import (
    FRICTION_EXPERIMENT_RUNNER_PARAMETERS)
from robot_wear_monitor.nodes.friction_experiment_runner import (
    FrictionExperimentRunner, main as runner_main)
from robot_wear_monitor.nodes.qos import (DIAGNOSTICS_QOS, EXPERIMENT_EVENTS_QOS,
                                          TRAJECTORY_QOS)
from robot_wear_monitor.recordings.messages import (diagnostics_from_msg,
                                                    experiment_event_from_msg,
                                                    trajectory_from_msg)
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

NAMES = [f'joint_{i}' for i in range(1, 7)]
POSTURE = [0.1, 0.6, -0.4, 0.05, 0.5, -0.2]
SPEEDS = [28.5, 41.7]
TOPIC = '/joint_trajectory_controller/joint_trajectory'
SETTINGS = {'joint_names': NAMES, 'posture_rad': POSTURE, 'joints': ['joint_2'],
            'gear_ratios': [150.0], 'half_ranges_rad': [0.1], 'speeds_rad_s': SPEEDS,
            'end_margin_s': 0.5}


def _runner(**overrides):
    values = {**SETTINGS, **overrides}
    return FrictionExperimentRunner(parameter_overrides=[Parameter(k, value=v)
                                                         for k, v in values.items()])


class Probe:
    """A controller-like subscriber of the trajectory, an events listener and a caller."""

    def __init__(self, executor, topic=TOPIC):
        """Create the probe node in ``executor``."""
        self.node = rclpy.create_node('runner_probe')
        executor.add_node(self.node)
        self.executor = executor
        self.trajectories, self.events, self.status = [], [], []
        self.node.create_subscription(JointTrajectory, topic, self._on_trajectory,
                                      TRAJECTORY_QOS)
        self.node.create_subscription(DiagnosticArray, 'friction_experiment/events',
                                      self._on_event, EXPERIMENT_EVENTS_QOS)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      DIAGNOSTICS_QOS)
        self.clients = {name: self.node.create_client(
            Trigger, f'/friction_experiment_runner/{name}') for name in ('start', 'abort')}

    def _on_trajectory(self, msg):
        self.trajectories.append((time.monotonic(), msg))

    def _on_event(self, msg):
        self.events.append((time.monotonic(), experiment_event_from_msg(msg)))

    def _on_diagnostics(self, msg):
        for level, name, message, values in diagnostics_from_msg(msg):
            if name == 'friction_experiment_runner':
                self.status.append((level, message, values))

    def spin_until(self, predicate, timeout_s=10.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return predicate()

    def call(self, name):
        client = self.clients[name]
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(Trigger.Request())
        self.executor.spin_until_future_complete(future, timeout_sec=5.0)
        return future.result()

    def kinds(self):
        return [event.event for _, event in self.events]


def _expected_points():
    hold = tuple(p for n, p in zip(NAMES, POSTURE) if n != 'joint_2')
    plan = plan_experiment(config=PlanConfig(
        joint='joint_2', speeds_rad_s=tuple(SPEEDS), center_rad=0.6, half_range_rad=0.1,
        gear_ratio=150.0, max_acceleration_rad_s2=5.0, rate_hz=250.0, noise_std=0.01,
        target_std_error=0.001, min_duration_s=0.2, trim_s=0.02, min_samples=20, dwell_s=0.1,
        joint_names=tuple(NAMES), hold_positions_rad=hold))
    return plan, trajectory_points(plan, point_rate_hz=50.0)


def test_start_publishes_the_planned_trajectory_and_the_start_and_end_events(ros_context):
    executor = SingleThreadedExecutor()
    runner = _runner()
    executor.add_node(runner)
    probe = Probe(executor)
    assert probe.spin_until(lambda: runner.subscribers() >= 1 and probe.status)
    assert probe.status[-1][1] == 'idle'
    plan, expected = _expected_points()

    response = probe.call('start')
    assert response.success, response.message
    assert 'joint_2' in response.message and f'{plan.total_s + 0.5:.1f} s' in response.message
    assert probe.spin_until(lambda: probe.trajectories and probe.kinds() == ['start'], 5.0)
    received, msg = probe.trajectories[0]
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (0, 0)  # start on receipt
    content = trajectory_from_msg(msg)
    assert content['joint_names'] == NAMES
    np.testing.assert_allclose(content['time_from_start_s'], expected.time_from_start_s,
                               atol=1e-9)
    np.testing.assert_allclose(content['positions'], expected.positions_rad, atol=1e-12)
    np.testing.assert_allclose(content['velocities'], expected.velocities_rad_s, atol=1e-12)
    np.testing.assert_allclose(content['accelerations'], expected.accelerations_rad_s2,
                               atol=1e-12)
    start = probe.events[0][1]
    assert (start.joint, start.experiment_id, tuple(start.speeds_rad_s)) == (
        'joint_2', 1, tuple(SPEEDS))
    assert start.planned_duration_s == pytest.approx(plan.total_s)
    assert start.controller_topic == TOPIC

    busy = probe.call('start')
    assert not busy.success and busy.message.startswith('already running')
    assert probe.spin_until(lambda: probe.status and probe.status[-1][2]['state'] == 'running'
                            and probe.status[-1][2].get('current_joint') == 'joint_2', 3.0)

    assert probe.spin_until(lambda: probe.kinds() == ['start', 'end'], plan.total_s + 3.0)
    end = probe.events[1][1]
    assert end.experiment_id == 1
    assert end.stamp_s - start.stamp_s == pytest.approx(plan.total_s + 0.5, abs=0.1)
    assert probe.events[1][0] - probe.events[0][0] == pytest.approx(plan.total_s + 0.5,
                                                                    abs=0.25)
    assert probe.spin_until(lambda: probe.status[-1][1] == 'idle; last run completed', 3.0)
    values = probe.status[-1][2]
    assert (values['experiments_started'], values['experiments_ended']) == ('1', '1')
    assert len(probe.trajectories) == 1

    again = probe.call('start')  # idle again: a new experiment id
    assert again.success
    assert probe.spin_until(lambda: len(probe.events) == 3, 3.0)
    assert probe.events[2][1].experiment_id == 2
    assert probe.call('abort').success
    runner.destroy_node()


def test_abort_sends_aborted_and_a_point_back_at_the_posture(ros_context):
    executor = SingleThreadedExecutor()
    runner = _runner(speeds_rad_s=[2.1, 28.5, 35.1, 41.7])
    executor.add_node(runner)
    probe = Probe(executor)
    assert probe.spin_until(lambda: runner.subscribers() >= 1)
    assert not probe.call('abort').success  # nothing to abort
    assert probe.call('start').success
    probe.spin_until(lambda: False, 1.2)
    response = probe.call('abort')
    assert response.success and 'aborted the friction experiment of joint_2' in response.message
    assert probe.spin_until(lambda: probe.kinds() == ['start', 'aborted']
                            and len(probe.trajectories) == 2, 3.0)
    aborted = probe.events[1][1]
    assert aborted.experiment_id == probe.events[0][1].experiment_id
    hold = trajectory_from_msg(probe.trajectories[1][1])
    assert hold['positions'].tolist() == [POSTURE]
    assert hold['velocities'].tolist() == [[0.0] * 6] and hold['accelerations'].size == 0
    assert 0.0 < hold['time_from_start_s'][0] < 1.0
    assert probe.spin_until(lambda: probe.status
                            and probe.status[-1][1] == 'idle; last run aborted', 3.0)
    probe.spin_until(lambda: False, 0.3)
    assert probe.kinds() == ['start', 'aborted']  # no end event after an abort
    assert probe.call('start').success  # and a new run can start
    assert probe.call('abort').success
    runner.destroy_node()


def test_start_is_refused_without_a_controller(ros_context):
    executor = SingleThreadedExecutor()
    runner = _runner(controller='no_controller')
    executor.add_node(runner)
    probe = Probe(executor)  # listens on the default controller's topic only
    response = probe.call('start')
    assert not response.success
    assert 'no subscriber on /no_controller/joint_trajectory' in response.message
    assert probe.spin_until(lambda: probe.status and probe.status[-1][0] == 1, 3.0)
    assert probe.kinds() == []
    runner.destroy_node()


def test_runner_declares_every_parameter_with_a_description(ros_context):
    runner = _runner()
    try:
        for spec in FRICTION_EXPERIMENT_RUNNER_PARAMETERS:
            [descriptor] = runner.describe_parameters([spec.name])
            assert descriptor.description == spec.description
            assert descriptor.read_only
    finally:
        runner.destroy_node()


@pytest.mark.parametrize('arguments, named', [
    (['half_ranges_rad:=[0.01]'], 'half_ranges_rad: joint_2: speed'),
    (['max_acceleration_rad_s2:=0.0'], 'max_acceleration_rad_s2: must be > 0'),
    (['max_acceleration_rad_s2:=5'], 'max_acceleration_rad_s2: expected a double'),
    (['max_speed_rad_s:=0.1'], 'speeds_rad_s: 41.7 rad/s (motor) is 0.278 rad/s at joint_2'),
    (['position_lower_limits_rad:=[0.05]', 'position_upper_limits_rad:=[1.0]'],
     'half_ranges_rad: joint_2: the window 0 +- 0.1 rad'),
    (['joints:=[joint_2,joint_7]', 'gear_ratios:=[150.0,100.0]',
      'half_ranges_rad:=[0.1,0.1]'], "joints: 'joint_7' is not in joint_names"),
    (['gear_ratios:=[]'], 'gear_ratios: needs one value per tested joint (1), got 0'),
])
def test_bad_parameters_refuse_the_runner_with_one_line_and_exit_code_2(
        arguments, named, capfd):
    args = ['friction_experiment_runner', '--ros-args']
    for argument in arguments:
        args += ['-p', argument]
    code = runner_main(args=args)
    err = capfd.readouterr().err
    assert code == 2
    assert named in err
    assert len([line for line in err.splitlines() if line.strip()]) == 1
    assert 'Traceback' not in err
    assert not rclpy.ok()


def test_the_packaged_params_file_starts_the_runner(ros_context):
    from robot_wear_monitor.monitoring.node_config import default_node_config_file
    rclpy.try_shutdown()
    rclpy.init(args=['runner', '--ros-args', '--params-file', str(default_node_config_file())])
    runner = FrictionExperimentRunner()
    try:
        assert [s.joint for s in runner.runner.schedule] == ['joint_2']
        assert runner.parameters['position_lower_limits_rad'] == ()
    finally:
        runner.destroy_node()


def test_the_old_name_min_plateau_s_still_sets_min_duration_s(ros_context):
    """One setting, one name: the runner's min_plateau_s is read as min_duration_s, warned."""
    runner = _runner(min_plateau_s=0.5)
    try:
        assert runner.parameters['min_duration_s'] == 0.5
        assert 'min_plateau_s' not in runner.parameters
        assert all(plan.min_duration_s == 0.5 for plan in runner.runner.config.plans)
        # the longer minimum plateau is planned: 0.5 s at 250 Hz is 125 samples per pass
        assert runner.runner.config.plans[0].samples_per_pass == 125
    finally:
        runner.destroy_node()
