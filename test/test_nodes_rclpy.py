"""The rclpy nodes on a ROS 2 host: parameters, friction_levels -> outputs, latched alarm, reset.

Skipped where rclpy is missing (the logic they wrap is tested in test_service.py).
"""

import pytest

rclpy = pytest.importorskip('rclpy', reason='rclpy is not installed (no ROS 2 on this host); '
                                            'the node logic is tested in test_service.py')


@pytest.fixture
def ros_context():
    rclpy.init()
    yield
    rclpy.try_shutdown()


def test_nodes_declare_every_parameter_with_a_description(ros_context, tmp_path):
    from rclpy.parameter import Parameter

    from robot_wear_monitor.node_config import (FRICTION_EXPERIMENT_PARAMETERS,
                                                WEAR_ESTIMATOR_PARAMETERS)
    from robot_wear_monitor.nodes.friction_experiment_node import FrictionExperimentNode
    from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
    node = FrictionExperimentNode()
    try:
        for spec in FRICTION_EXPERIMENT_PARAMETERS:
            [descriptor] = node.describe_parameters([spec.name])
            assert descriptor.description == spec.description
    finally:
        node.destroy_node()
    estimator = WearEstimatorNode(parameter_overrides=[
        Parameter('history_file', value=str(tmp_path / 'h.sqlite3'))])
    try:
        names = {spec.name for spec in WEAR_ESTIMATOR_PARAMETERS}
        assert names <= set(estimator._parameters)
    finally:
        estimator.destroy_node()


def test_estimator_publishes_outputs_and_reset_clears_alarm(ros_context, tmp_path):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool, Float64
    from std_srvs.srv import Trigger

    from robot_wear_monitor.messages import friction_levels_to_msg
    from robot_wear_monitor.model import friction
    from robot_wear_monitor.nodes import message_kit
    from robot_wear_monitor.nodes.wear_estimator_node import ALARM_QOS, WearEstimatorNode
    from robot_wear_monitor.params import load_parameter_set

    estimator = WearEstimatorNode(parameter_overrides=[
        Parameter('history_file', value=str(tmp_path / 'h.sqlite3'))])
    probe = rclpy.create_node('probe')
    wear, alarm = [], []
    probe.create_subscription(Float64, 'wear', lambda m: wear.append(m.data), 10)
    probe.create_subscription(Bool, 'wear_alarm', lambda m: alarm.append(m.data), ALARM_QOS)
    publisher = probe.create_publisher(JointState, 'friction_levels', 10)
    client = probe.create_client(Trigger, '/wear_estimator_node/reset_alarm')
    executor = SingleThreadedExecutor()
    executor.add_node(estimator)
    executor.add_node(probe)
    params = load_parameter_set()
    speeds = [2.1, 28.5, 35.1, 41.7]
    levels = [float(f) for f in friction(speeds, 0.5, 40.0, 50.0, params.model)]
    for _ in range(50):
        executor.spin_once(timeout_sec=0.05)
    publisher.publish(friction_levels_to_msg(message_kit(), stamp_s=10.0, joint='joint_2',
                                             speeds_rad_s=speeds, frictions=levels))
    for _ in range(100):
        executor.spin_once(timeout_sec=0.05)
        if wear and alarm and alarm[-1]:
            break
    assert wear and abs(wear[-1] - 50.0) < 1.0
    assert alarm[-1] is True
    future = client.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().success
    for _ in range(20):
        executor.spin_once(timeout_sec=0.05)
    assert alarm[-1] is False
    estimator.destroy_node()
    probe.destroy_node()
