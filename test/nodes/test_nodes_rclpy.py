"""
The rclpy nodes in-process on a real ROS 2 graph (Fast DDS, this session's own domain).

Each test builds the node(s) and a probe node in one executor, publishes as any other node
would and asserts on what a subscriber sees: parameters and their validation, the estimator's
outputs over a sequence that crosses the alarm threshold and goes on past it (the estimator
used to die at its first alarm), ``~/reset_alarm``, the restart from the history file, and bad
messages on both inputs (counted on /diagnostics, the node keeps running).
"""

import math
import sqlite3

from diagnostic_msgs.msg import DiagnosticArray
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from robot_wear_monitor.nodes.friction_experiment_node import (
    FrictionExperimentNode, main as friction_main)
from robot_wear_monitor.nodes.qos import ALARM_QOS, DIAGNOSTICS_QOS
from robot_wear_monitor.nodes.wear_estimator_node import (
    main as estimator_main, WearEstimatorNode)
from robot_wear_monitor.recordings.messages import (
    diagnostics_from_msg, trend_from_msg)
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger
from wear_testing import independent_robot as robot

SPEEDS = [2.1, 28.5, 35.1, 41.7]


class Probe:
    """A probe node that records what any subscriber of the monitor's topics would see."""

    def __init__(self, executor):
        """Create the probe node in ``executor``."""
        self.node = rclpy.create_node('probe')
        executor.add_node(self.node)
        self.executor = executor
        self.wear, self.alarm, self.temperature, self.levels = [], [], [], []
        self.trend = []
        self.node.create_subscription(Float64MultiArray, 'wear_trend',
                                      lambda m: self.trend.append(trend_from_msg(m)), 10)
        self.diagnostics = {}
        self.node.create_subscription(Float64, 'wear', lambda m: self.wear.append(m.data), 10)
        self.node.create_subscription(Bool, 'wear_alarm',
                                      lambda m: self.alarm.append(m.data), ALARM_QOS)
        self.node.create_subscription(Temperature, 'temperature',
                                      lambda m: self.temperature.append(m), 10)
        self.node.create_subscription(JointState, 'friction_levels',
                                      lambda m: self.levels.append(m), 10)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      DIAGNOSTICS_QOS)
        self.levels_publisher = self.node.create_publisher(JointState, 'friction_levels', 10)
        self.joint_states_publisher = self.node.create_publisher(JointState, 'joint_states',
                                                                 200)

    def _on_diagnostics(self, msg):
        for level, name, message, values in diagnostics_from_msg(msg):
            self.diagnostics.setdefault(name, []).append((level, message, values))

    def spin_until(self, predicate, timeout_s=10.0):
        for _ in range(int(timeout_s / 0.02)):
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return predicate()

    def last_diagnostics(self, prefix):
        for name, entries in self.diagnostics.items():
            if name.startswith(prefix):
                return entries[-1]
        return None


def _levels_msg(*, stamp_s, wear, temperature_degc=40.0, load=0.5, joint='joint_2',
                speeds=SPEEDS):
    frictions = [float(robot.friction_model(v, load, temperature_degc, wear)) for v in speeds]
    msg = JointState()
    msg.header.stamp.sec = int(stamp_s)
    msg.header.frame_id = joint
    msg.name = [f'{joint}/level_{i}' for i in range(len(speeds))]
    msg.velocity = [float(v) for v in speeds]
    msg.effort = [float(f) for f in frictions]
    return msg


def _estimator(tmp_path, **overrides):
    values = {'history_file': str(tmp_path / 'history.sqlite3'), **overrides}
    return WearEstimatorNode(parameter_overrides=[Parameter(k, value=v)
                                                  for k, v in values.items()])


# --------------------------------------------------------------------------- parameters

def test_nodes_declare_every_parameter_with_a_description(ros_context, tmp_path):
    from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_PARAMETERS,
                                                           WEAR_ESTIMATOR_PARAMETERS)
    for node, specs in ((FrictionExperimentNode(), FRICTION_EXPERIMENT_PARAMETERS),
                        (_estimator(tmp_path), WEAR_ESTIMATOR_PARAMETERS)):
        try:
            for spec in specs:
                [descriptor] = node.describe_parameters([spec.name])
                assert descriptor.description == spec.description
                assert descriptor.read_only
        finally:
            node.destroy_node()


@pytest.mark.parametrize('main, argument, named', [
    (friction_main, 'gear_ratio:=-1.0', 'gear_ratio: must be > 0'),
    (friction_main, 'gear_ratio:=150', 'gear_ratio: expected a double, got integer 150'),
    (friction_main, 'experiment_speeds_rad_s:=[2.1,2.1]', 'speeds must be distinct'),
    (estimator_main, 'wear_threshold:=20.0', 'wear_healthy: must be < wear_threshold'),
    (estimator_main, 'min_fit_p_value:=1.5', 'min_fit_p_value: must be in [0, 1)'),
])
def test_a_bad_parameter_refuses_the_node_with_one_line_and_exit_code_2(
        main, argument, named, capfd, tmp_path):
    code = main(args=['node', '--ros-args', '-p', argument,
                      '-p', f'history_file:={tmp_path / "h.sqlite3"}'])
    err = capfd.readouterr().err
    assert code == 2
    assert named in err
    assert 'Traceback' not in err
    assert not rclpy.ok()


def test_an_unwritable_history_refuses_the_estimator(capfd, tmp_path):
    blocker = tmp_path / 'file'
    blocker.write_text('not a folder')
    code = estimator_main(args=['node', '--ros-args', '-p',
                                f'history_file:={blocker / "h.sqlite3"}'])
    err = capfd.readouterr().err
    assert code == 2 and 'Traceback' not in err and 'h.sqlite3' in err


# --------------------------------------------------------------------------- estimator

def test_estimator_keeps_estimating_past_the_alarm_then_resets_and_restores(
        ros_context, tmp_path):
    executor = SingleThreadedExecutor()
    estimator = _estimator(tmp_path)
    executor.add_node(estimator)
    probe = Probe(executor)
    assert probe.spin_until(lambda: probe.alarm == [False]
                            and probe.levels_publisher.get_subscription_count() >= 2)
    wear_truth = [5.0, 20.0, 30.0, 40.0, 50.0, 60.0]
    temperatures = [32.0, 45.0, 38.0, 41.0, 48.0, 35.0]
    for k, (wear, temperature) in enumerate(zip(wear_truth, temperatures)):
        probe.levels_publisher.publish(_levels_msg(stamp_s=1000.0 + k, wear=wear,
                                                   temperature_degc=temperature))
        assert probe.spin_until(lambda: len(probe.wear) == k + 1), f'no /wear for {k}'
    assert probe.spin_until(lambda: len(probe.temperature) == len(wear_truth))
    assert probe.spin_until(lambda: len(probe.trend) == len(wear_truth))
    for trend in probe.trend:
        assert 0.0 <= trend['wear_low'] <= trend['wear'] <= trend['wear_high']
        assert 0.0 <= trend['probability_above_threshold'] <= 1.0
    assert probe.trend[-1]['probability_above_threshold'] > 0.9
    # One estimate per experiment, on the truth where the model is sensitive to w.
    for estimate, truth in zip(probe.wear[2:], wear_truth[2:]):
        assert abs(estimate - truth) < 2.0
    assert probe.wear[3] >= 35.0
    assert probe.alarm[-1] is True
    raised_at = next(i for i, w in enumerate(probe.wear) if w >= 35.0)
    assert raised_at == 3
    assert probe.spin_until(
        lambda: (probe.last_diagnostics('wear_monitor') or (0, '', {}))[2].get(
            'experiments') == '6', 3.0)
    level, message, values = probe.last_diagnostics('wear_monitor')
    assert level == 2 and 'WEAR ALARM' in message
    assert values['alarm'] == 'true'
    assert math.isclose(float(values['wear']), probe.wear[-1], rel_tol=1e-5)
    for msg in probe.temperature:
        assert 30.0 <= msg.temperature <= 50.0 and msg.header.frame_id == 'joint_2'

    client = probe.node.create_client(Trigger, '/wear_estimator_node/reset_alarm')
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().success and 'cleared' in future.result().message
    assert probe.spin_until(lambda: probe.alarm[-1] is False)
    assert probe.spin_until(lambda: probe.last_diagnostics('wear_monitor')[0] != 2, 3.0)

    # A reset is maintenance: the trend starts again from the new-joint prior, so one reading
    # of 55 does not raise the alarm (the reset's wall-clock stamp is later than these
    # experiments' stamps: the trend must not take that for time going backwards); a worn
    # joint keeps reading 55 and raises it again within three experiments.
    for k in range(3):
        probe.levels_publisher.publish(_levels_msg(stamp_s=2000.0 + k, wear=55.0))
        assert probe.spin_until(lambda: len(probe.wear) == 7 + k and len(probe.trend) == 7 + k)
        if k == 0:
            probe.spin_until(lambda: probe.alarm[-1] is True, 0.5)
            assert probe.alarm[-1] is False
            assert probe.trend[-1]['wear'] < 20.0
        if probe.alarm[-1]:
            break
    assert probe.spin_until(lambda: probe.alarm[-1] is True), 'alarm not raised again'
    assert probe.trend[-1]['probability_above_threshold'] >= 0.15
    stored = len(probe.wear)
    assert estimator.service.rejections.get('trend_failed', 0) == 0
    # Then a restart restores the latched state.
    executor.remove_node(estimator)
    estimator.destroy_node()

    restarted = _estimator(tmp_path)
    executor.add_node(restarted)
    late = Probe(executor)
    assert late.spin_until(lambda: late.alarm == [True]), 'latched alarm not restored'
    assert late.spin_until(lambda: late.last_diagnostics('wear_monitor') is not None, 3.0)
    level, message, values = late.last_diagnostics('wear_monitor')
    assert level == 2 and 'restored' in message and values['experiments'] == str(stored)
    assert restarted.service.restored_estimates == stored
    restarted.destroy_node()
    with sqlite3.connect(tmp_path / 'history.sqlite3') as conn:
        events = [row[0] for row in conn.execute('SELECT event FROM alarm_events ORDER BY id')]
    assert events == ['raised', 'reset', 'raised']


def test_the_node_threshold_wins_is_stored_and_warned_about_once(ros_context, tmp_path,
                                                                 capfd):
    executor = SingleThreadedExecutor()
    estimator = _estimator(tmp_path, wear_threshold=30.0)
    executor.add_node(estimator)
    probe = Probe(executor)
    assert probe.spin_until(lambda: probe.levels_publisher.get_subscription_count() >= 2)
    for k, wear in enumerate((10.0, 20.0)):
        probe.levels_publisher.publish(_levels_msg(stamp_s=1000.0 + k, wear=wear))
        assert probe.spin_until(lambda: len(probe.wear) == k + 1), f'no /wear for {k}'
    assert estimator.service.config.alarm.threshold == 30.0
    executor.remove_node(estimator)
    estimator.destroy_node()
    warnings = [line for line in capfd.readouterr().err.splitlines()
                if 'the node parameters differ from parameter set' in line]
    assert len(warnings) == 1 and 'wear_threshold 30 (the set says 35)' in warnings[0]
    with sqlite3.connect(tmp_path / 'history.sqlite3') as conn:
        assert conn.execute('SELECT threshold, warning_level FROM estimates').fetchall() == [
            (30.0, 28.0), (30.0, 28.0)]
    # the packaged values (the set's): no warning
    again = _estimator(tmp_path)
    again.destroy_node()
    assert 'differ from parameter set' not in capfd.readouterr().err


def test_estimator_counts_bad_friction_levels_and_keeps_running(ros_context, tmp_path):
    executor = SingleThreadedExecutor()
    estimator = _estimator(tmp_path)
    executor.add_node(estimator)
    probe = Probe(executor)
    assert probe.spin_until(lambda: probe.levels_publisher.get_subscription_count() >= 2)
    unequal = _levels_msg(stamp_s=10.0, wear=40.0)
    unequal.effort = unequal.effort[:2]
    not_finite = _levels_msg(stamp_s=11.0, wear=40.0)
    not_finite.effort = [float('nan')] + list(not_finite.effort[1:])
    other_joint = _levels_msg(stamp_s=12.0, wear=40.0, joint='joint_5')
    empty = JointState()
    for msg in (unequal, not_finite, other_joint, empty):
        probe.levels_publisher.publish(msg)
    probe.levels_publisher.publish(_levels_msg(stamp_s=13.0, wear=45.0))
    assert probe.spin_until(lambda: len(probe.wear) == 1)
    assert abs(probe.wear[0] - 45.0) < 2.0
    assert probe.spin_until(
        lambda: (probe.last_diagnostics('wear_monitor') or (0, '', {}))[2].get(
            'rejected_total') == '4', 3.0)
    values = probe.last_diagnostics('wear_monitor')[2]
    assert values['rejected_length_mismatch'] == '1'
    assert values['rejected_not_finite'] == '1'
    assert values['rejected_other_joint'] == '1'
    assert values['rejected_empty'] == '1'
    estimator.destroy_node()


# --------------------------------------------------------------------------- friction experiment

def _joint_state(stamp_s, names, position, velocity, effort):
    msg = JointState()
    msg.header.stamp.sec, nanosec = divmod(int(round(stamp_s * 1e9)), 1_000_000_000)
    msg.header.stamp.nanosec = nanosec
    msg.name = list(names)
    msg.position = [float(v) for v in position]
    msg.velocity = [float(v) for v in velocity]
    msg.effort = [float(v) for v in effort]
    return msg


def test_friction_experiment_node_rejects_bad_joint_states_and_keeps_segmenting(ros_context):
    recording = robot.generate_wear_test(n_experiments=2, wear_start=30.0, wear_end=40.0,
                                         seed=7, rate_hz=250.0)
    executor = SingleThreadedExecutor()
    node = FrictionExperimentNode()
    executor.add_node(node)
    probe = Probe(executor)
    assert probe.spin_until(lambda: probe.joint_states_publisher.get_subscription_count() == 1)
    publish = probe.joint_states_publisher.publish
    names = recording.names
    t0 = recording.stamps_s[0] - 100.0
    zeros = [0.0] * len(names)
    publish(_joint_state(t0, names, zeros, zeros[:3], zeros))                  # unequal
    publish(_joint_state(t0 + 0.01, names, zeros, [float('nan')] * 6, zeros))  # NaN
    publish(_joint_state(t0 + 0.02, names[2:], zeros[2:], zeros[2:], zeros[2:]))  # no joint
    publish(_joint_state(t0 + 0.03, names, zeros, zeros, zeros))
    publish(_joint_state(t0 + 0.025, names, zeros, zeros, zeros))              # backwards
    publish(_joint_state(t0 + 5.0, names, zeros, zeros, zeros))                # after a gap
    sent = 6
    for i, (stamp, _, position, velocity, effort) in enumerate(robot.messages(recording)):
        publish(_joint_state(stamp, names, position, velocity, effort))
        sent += 1
        if sent % 50 == 0:  # one executor for all: let the node take each burst
            assert probe.spin_until(lambda: node.service.messages == sent, 5.0)
    assert probe.spin_until(lambda: node.service.messages == sent, 5.0)
    assert probe.spin_until(lambda: len(probe.levels) == 2, 5.0)
    for msg, truth in zip(probe.levels, recording.truth):
        assert list(msg.velocity) == pytest.approx(SPEEDS, abs=0.5)
        assert list(msg.effort) == pytest.approx(list(truth.friction_true), abs=0.005)
    assert probe.spin_until(lambda: (probe.last_diagnostics('friction_experiment') or (
        0, '', {}))[2].get('experiments') == '2', 3.0)
    values = probe.last_diagnostics('friction_experiment')[2]
    assert values['rejected_length_mismatch'] == '1'
    assert values['rejected_non_finite'] == '1'
    assert values['rejected_joint_missing'] == '1'
    assert values['rejected_time_not_increasing'] == '1'
    assert int(values['rejected_time_gap']) >= 1
    assert values['joint_states'] == str(sent)
    node.destroy_node()


def test_the_drain_goes_on_under_sim_time_without_a_clock(ros_context):
    """The drain timer runs on the steady clock: a paused /clock must not stop the intake."""
    executor = SingleThreadedExecutor()
    node = FrictionExperimentNode(parameter_overrides=[Parameter('use_sim_time', value=True)])
    executor.add_node(node)
    probe = Probe(executor)
    assert probe.spin_until(lambda: probe.joint_states_publisher.get_subscription_count() == 1)
    names = ['joint_1', 'joint_2']
    for k in range(1, 101):  # no /clock at all: the node's ROS time stays 0
        probe.joint_states_publisher.publish(_joint_state(100.0 + k * 1e-3, names, [0.0, 0.1],
                                                          [0.0, 0.0], [0.0, 0.0]))
    assert probe.spin_until(lambda: node.service.messages == 100, 5.0), node.service.messages
    assert node.drain_period_s == 0.05 and node.drained is not None
    node.destroy_node()
