"""robot_id on the live graph: the estimator node keys its history rows and names the robot."""

from diagnostic_msgs.msg import DiagnosticArray
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from robot_wear_monitor.history import open_history
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.nodes.qos import DIAGNOSTICS_QOS
from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

SPEEDS = [2.1, 28.5, 35.1, 41.7]


def _levels(stamp_s: float, wear: float) -> JointState:
    model = load_parameter_set().model
    msg = JointState()
    msg.header.stamp.sec = int(stamp_s)
    msg.header.frame_id = 'joint_2'
    msg.name = [f'joint_2/level_{i}' for i in range(len(SPEEDS))]
    msg.velocity = SPEEDS
    msg.effort = [float(friction(v, 0.5, 40.0, wear, model)) for v in SPEEDS]
    return msg


def test_robot_id_keys_the_history_and_names_the_robot_in_diagnostics(ros_context, tmp_path):
    history = tmp_path / 'fleet.sqlite3'
    executor = SingleThreadedExecutor()
    node = WearEstimatorNode(parameter_overrides=[
        Parameter('history_file', value=str(history)), Parameter('robot_id', value='cell_7')])
    executor.add_node(node)
    probe = rclpy.create_node('robot_id_probe')
    executor.add_node(probe)
    seen, wear = [], []
    probe.create_subscription(DiagnosticArray, '/diagnostics',
                              lambda m: seen.extend(m.status), DIAGNOSTICS_QOS)
    probe.create_subscription(Float64, 'wear', lambda m: wear.append(m.data), 10)
    publisher = probe.create_publisher(JointState, 'friction_levels', 10)

    def spin_until(predicate, timeout_s=15.0):
        for _ in range(int(timeout_s / 0.02)):
            if predicate():
                return True
            executor.spin_once(timeout_sec=0.02)
        return predicate()

    assert spin_until(lambda: publisher.get_subscription_count() >= 1)
    for k in range(2):
        publisher.publish(_levels(1000.0 + k, 20.0))
        assert spin_until(lambda: len(wear) == k + 1)
    assert spin_until(lambda: any(s.hardware_id == 'cell_7/joint_2' for s in seen))
    assert all(s.hardware_id == 'cell_7/joint_2' for s in seen if s.name.startswith('wear'))
    assert any(kv.key == 'robot' and kv.value == 'cell_7' for s in seen for kv in s.values)
    node.destroy_node()
    with open_history(history, init=False) as store:
        assert store.robots() == ('cell_7',)
        assert len(store.records(joint='joint_2', robot='cell_7')) == 2
