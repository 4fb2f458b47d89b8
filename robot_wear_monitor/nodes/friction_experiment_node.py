"""friction_experiment_node: /joint_states -> friction_levels, one message per experiment.

Segments the configured joint into constant-speed friction levels (eq. (3)) and experiments
with :class:`robot_wear_monitor.service.FrictionExperimentService`, and publishes each completed
experiment on ``friction_levels`` (sensor_msgs/JointState: ``velocity`` = speed levels [rad/s],
``effort`` = friction levels, ``header.frame_id`` = joint).
"""

import sys

from rclpy.node import Node
from sensor_msgs.msg import JointState

from robot_wear_monitor.messages import stamp_to_seconds
from robot_wear_monitor.node_config import (FRICTION_EXPERIMENT_NODE,
                                            FRICTION_EXPERIMENT_PARAMETERS, validate_parameters)
from robot_wear_monitor.nodes import declare_parameters, message_kit, spin_node
from robot_wear_monitor.nodes.qos import FRICTION_LEVELS_QOS, JOINT_STATES_QOS
from robot_wear_monitor.service import FRICTION_LEVELS_TOPIC, FrictionExperimentService


class FrictionExperimentNode(Node):
    """Segment /joint_states of one joint and publish each completed experiment."""

    def __init__(self, **kwargs):
        """Declare and validate the parameters, then subscribe and advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(FRICTION_EXPERIMENT_NODE, **kwargs)
        raw = declare_parameters(self, FRICTION_EXPERIMENT_PARAMETERS)
        self.parameters = validate_parameters(FRICTION_EXPERIMENT_NODE, raw,
                                              source='ROS parameters')
        self.service = FrictionExperimentService.from_node_parameters(self.parameters)
        self.kit = message_kit()
        self.publisher = self.create_publisher(JointState, FRICTION_LEVELS_TOPIC,
                                               FRICTION_LEVELS_QOS)
        self.subscription = self.create_subscription(JointState, 'joint_states',
                                                     self.on_joint_state, JOINT_STATES_QOS)
        self._reported = 0
        self.get_logger().info(
            f'segmenting joint {self.service.joint!r} (gear ratio '
            f'{self.parameters["gear_ratio"]}, torque scale {self.parameters["torque_scale"]}), '
            f'experiment speeds {list(self.parameters["experiment_speeds_rad_s"])} rad/s')

    def on_joint_state(self, msg):
        """Feed one JointState to the segmentation; publish the experiments it completes."""
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if stamp_s == 0.0:  # unstamped publisher: use the reception time
            stamp_s = self.get_clock().now().nanoseconds * 1e-9
        experiments = self.service.add_joint_state(
            stamp_s=stamp_s, name=list(msg.name), position=list(msg.position),
            velocity=list(msg.velocity), effort=list(msg.effort))
        for experiment in experiments:
            self.publisher.publish(self.service.friction_levels_message(self.kit, experiment))
            self.get_logger().info(
                f'experiment: speeds {[round(v, 2) for v in experiment.speeds_rad_s]} rad/s, '
                f'friction {[round(f, 5) for f in experiment.frictions]}')
        total = self.service.rejected_total
        if total > self._reported:
            self._reported = total
            self.get_logger().warn(f'rejected so far: {dict(self.service.all_rejections())}',
                                   throttle_duration_sec=10.0)


def main(args=None):
    """Run the node until shutdown (exit code 2 on invalid parameters)."""
    return spin_node(FrictionExperimentNode, logger_name=FRICTION_EXPERIMENT_NODE, args=args)


if __name__ == '__main__':
    sys.exit(main())
