"""friction_experiment_node: /joint_states -> friction_levels, one message per experiment.

Segments the configured joint into constant-speed friction levels (eq. (3)) and experiments
with :class:`robot_wear_monitor.monitoring.service.FrictionExperimentService`, and publishes
each completed experiment on ``friction_levels`` (sensor_msgs/JointState: ``velocity`` =
speed levels [rad/s],
``effort`` = friction levels, ``header.frame_id`` = joint).  Every second it publishes its
counts and the rejected inputs by reason on ``/diagnostics`` (``friction_experiment: <joint>``);
rejected inputs are also logged, at most once per 10 s.  The friction_experiment_runner's events
(``experiment_events_topic``, default ``friction_experiment/events``; empty: not subscribed)
give the experiments' exact boundaries: an ``end`` event publishes the experiment at once.
"""

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState

from robot_wear_monitor.recordings.messages import stamp_to_seconds
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                       FRICTION_EXPERIMENT_PARAMETERS,
                                                       validate_parameters)
from robot_wear_monitor.nodes import (declare_parameters, log_rejection_report, message_kit,
                                      node_time_s, spin_node)
from robot_wear_monitor.nodes.qos import (DIAGNOSTICS_QOS, EXPERIMENT_EVENTS_QOS,
                                          FRICTION_LEVELS_QOS, JOINT_STATES_QOS)
from robot_wear_monitor.monitoring.service import (DIAGNOSTICS_TOPIC, FRICTION_LEVELS_TOPIC,
                                                   FrictionExperimentService, RejectionLog)

DIAGNOSTICS_PERIOD_S = 1.0
REJECTION_LOG_PERIOD_S = 10.0


def _rounded(values, digits: int) -> list:
    """Return plain Python floats rounded for a log line (no ``np.float64(...)`` reprs)."""
    return [round(float(v), digits) for v in values]


class FrictionExperimentNode(Node):
    """Segment /joint_states of one joint and publish each completed experiment."""

    def __init__(self, **kwargs):
        """Declare and validate the parameters, then subscribe and advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(FRICTION_EXPERIMENT_NODE, **kwargs)
        raw = declare_parameters(self, FRICTION_EXPERIMENT_PARAMETERS)
        self.parameters = validate_parameters(FRICTION_EXPERIMENT_NODE, raw,
                                              source=f'{self.get_name()} parameters')
        self.service = FrictionExperimentService.from_node_parameters(self.parameters)
        self.kit = message_kit()
        self.rejection_log = RejectionLog(what='joint_states inputs',
                                          period_s=REJECTION_LOG_PERIOD_S)
        self.publisher = self.create_publisher(JointState, FRICTION_LEVELS_TOPIC,
                                               FRICTION_LEVELS_QOS)
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                                           DIAGNOSTICS_QOS)
        self.subscription = self.create_subscription(JointState, 'joint_states',
                                                     self.on_joint_state, JOINT_STATES_QOS)
        self.events_subscription = None
        if self.parameters['experiment_events_topic']:
            self.events_subscription = self.create_subscription(
                DiagnosticArray, self.parameters['experiment_events_topic'],
                self.on_experiment_event, EXPERIMENT_EVENTS_QOS)
        self.timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)
        self._rejected = 0
        speeds = _rounded(self.parameters['experiment_speeds_rad_s'], 3)
        self.get_logger().info(
            f'segmenting joint {self.service.joint!r} of '
            f'{self.subscription.topic_name} (gear ratio {self.parameters["gear_ratio"]}, '
            f'torque scale {self.parameters["torque_scale"]}), experiment speeds '
            f'{speeds or "any"} rad/s; publishing on {self.publisher.topic_name}; '
            + (f'experiment boundaries from {self.events_subscription.topic_name}'
               if self.events_subscription is not None else 'no experiment events'))

    def on_joint_state(self, msg):
        """Feed one JointState to the segmentation; publish the experiments it completes."""
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if stamp_s == 0.0:  # unstamped publisher: use the reception time
            stamp_s = node_time_s(self)
        self._publish_all(self._guarded(
            self.service.add_joint_state, stamp_s=stamp_s, name=msg.name,
            position=msg.position, velocity=msg.velocity, effort=msg.effort))
        self._log_new_rejections()

    def _guarded(self, call, *args, **kwargs):
        """Return call(...)'s experiments; an internal error is counted, never raised."""
        try:
            return call(*args, **kwargs)
        except Exception as error:  # noqa: BLE001 - the node must outlive any one input
            self.service.rejections['internal_error'] += 1
            self.service.last_error = f'{type(error).__name__}: {error}'
            return []

    def _publish_all(self, experiments):
        for experiment in experiments:
            self.publish_experiment(experiment)

    def _log_new_rejections(self):
        if self.service.rejected_total > self._rejected:
            self._rejected = self.service.rejected_total
            self.log_rejections()

    def on_experiment_event(self, msg):
        """Apply one friction_experiment_runner event; publish the experiment it ends."""
        open_before = self.service.open_experiment_id
        aborted_before = self.service.rejections['aborted_experiment']
        self._publish_all(self._guarded(self.service.handle_experiment_event_msg, msg))
        open_after = self.service.open_experiment_id
        if open_after is not None and open_after != open_before:
            self.get_logger().info(f'runner started friction experiment #{open_after} of '
                                   f'{self.service.joint!r}')
        elif self.service.rejections['aborted_experiment'] > aborted_before:
            self.get_logger().info(f'runner aborted friction experiment #{open_before} of '
                                   f'{self.service.joint!r}: its friction levels are dropped')
        self._log_new_rejections()

    def publish_experiment(self, experiment):
        """Publish one completed experiment on ``friction_levels`` and log it."""
        self.publisher.publish(self.service.friction_levels_message(self.kit, experiment))
        self.get_logger().info(
            f'experiment {self.service.experiments}: speeds '
            f'{_rounded(experiment.speeds_rad_s, 2)} rad/s, friction '
            f'{_rounded(experiment.frictions, 5)}')

    def log_rejections(self):
        """Log the inputs rejected since the last report (at most once per 10 s)."""
        log_rejection_report(self.get_logger(), self.rejection_log.report(
            self.service.all_rejections(), now_s=node_time_s(self),
            detail=self.service.last_error))

    def publish_diagnostics(self):
        """Publish the counts and rejections on /diagnostics (periodic)."""
        self.diagnostics_publisher.publish(
            self.service.diagnostics_message(self.kit, stamp_s=node_time_s(self)))
        self.log_rejections()


def main(args=None):
    """Run the node until shutdown (exit code 2 on invalid parameters)."""
    return spin_node(FrictionExperimentNode, logger_name=FRICTION_EXPERIMENT_NODE, args=args)


if __name__ == '__main__':
    sys.exit(main())
