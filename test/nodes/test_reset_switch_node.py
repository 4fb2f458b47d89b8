"""
``reset_service_enabled`` on a real ROS 2 graph: false offers no ``~/reset_alarm`` at all.

A probe node looks at the graph as any other node would: with the switch off, the estimator's
own services (its parameter services) are discovered but no reset service; with the default,
the reset service is there and answers.  A reset through the history (the dashboard's way)
reaches the running node (its alarm is published clear within its diagnostics period) and is
what its next start restores.
"""


import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from robot_wear_monitor.history import open_history
from robot_wear_monitor.nodes.qos import ALARM_QOS
from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
from std_msgs.msg import Bool
from std_srvs.srv import Trigger
from wear_testing.process_graph import write_latched_history

RESET = '/wear_estimator_node/reset_alarm'
PARAMETER_SERVICE = '/wear_estimator_node/get_parameters'


def _services(executor, probe, *, until, timeout_s=15.0):
    """Return the service names the probe sees once ``until(names)`` holds (or at timeout)."""
    names: set[str] = set()
    for _ in range(int(timeout_s / 0.05)):
        names = {name for name, _ in probe.get_service_names_and_types()}
        if until(names):
            break
        executor.spin_once(timeout_sec=0.05)
    return names


def test_the_reset_service_is_offered_only_when_enabled(ros_context, tmp_path):
    history = tmp_path / 'h.sqlite3'
    write_latched_history(history)
    executor = SingleThreadedExecutor()
    probe = rclpy.create_node('reset_switch_probe')
    executor.add_node(probe)
    alarm = []
    probe.create_subscription(Bool, 'wear_alarm', lambda m: alarm.append(m.data), ALARM_QOS)

    node = WearEstimatorNode(parameter_overrides=[
        Parameter('history_file', value=str(history)),
        Parameter('reset_service_enabled', value=False)])
    executor.add_node(node)
    assert node.get_parameter('reset_service_enabled').value is False
    assert node.service.latch.active and node.reset_services == {}
    names = _services(executor, probe, until=lambda n: PARAMETER_SERVICE in n)
    assert PARAMETER_SERVICE in names  # the node is on the graph, its services discovered
    assert not any(name.endswith('reset_alarm') for name in names), sorted(names)
    _services(executor, probe, until=lambda n: alarm == [True], timeout_s=5.0)
    assert alarm == [True]  # latched, restored from the history
    # resets go through the history (the dashboard): the running node takes them over
    with open_history(history, init=False) as store:
        store.reset_alarm(joint='joint_2', user='ana', reason='gear replaced')
    _services(executor, probe, until=lambda n: alarm[-1] is False, timeout_s=5.0)
    assert alarm == [True, False] and not node.service.latch.active
    executor.remove_node(node)
    node.destroy_node()
    _services(executor, probe, until=lambda n: PARAMETER_SERVICE not in n)

    node = WearEstimatorNode(parameter_overrides=[Parameter('history_file', value=str(history))])
    executor.add_node(node)
    assert node.get_parameter('reset_service_enabled').value is True  # the default
    assert not node.service.latch.active and node.service.latch.evidence == 0.0  # restored
    assert node.service.wear_trend.segment == 1
    names = _services(executor, probe, until=lambda n: RESET in n)
    assert RESET in names
    client = probe.create_client(Trigger, RESET)
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().success and 'no wear alarm was active' in future.result().message
    executor.remove_node(node)
    node.destroy_node()
    probe.destroy_node()
