"""wear_estimator_node: friction_levels -> temperature, wear, wear_alarm and /diagnostics.

A thin shell over :class:`robot_wear_monitor.monitoring.service.WearEstimatorService`: every
completed experiment gives an estimate of (T, w); the alarm is latched (reliable +
transient-local, so a
late subscriber sees the current state) until ``~/reset_alarm`` (std_srvs/Trigger); the SQLite
history restores the trend and the alarm after a restart.
"""

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger

from robot_wear_monitor.monitoring.history import WearHistory
from robot_wear_monitor.recordings.messages import alarm_to_msg
from robot_wear_monitor.monitoring.node_config import (expand_history_path, validate_parameters,
                                                       WEAR_ESTIMATOR_NODE,
                                                       WEAR_ESTIMATOR_PARAMETERS)
from robot_wear_monitor.nodes import (declare_parameters, log_rejection_report, message_kit,
                                      node_time_s, spin_node)
from robot_wear_monitor.nodes.qos import (ALARM_QOS, DIAGNOSTICS_QOS, ESTIMATE_QOS,
                                          FRICTION_LEVELS_QOS)
from robot_wear_monitor.monitoring.service import (ALARM_TOPIC, DIAGNOSTICS_TOPIC, EstimatorConfig,
                                                   FRICTION_LEVELS_TOPIC, RejectionLog,
                                                   RESET_SERVICE, TEMPERATURE_TOPIC, TREND_TOPIC,
                                                   WEAR_TOPIC, WearEstimatorService)

DIAGNOSTICS_PERIOD_S = 1.0
REJECTION_LOG_PERIOD_S = 10.0

_TYPES = {TEMPERATURE_TOPIC: Temperature, WEAR_TOPIC: Float64, ALARM_TOPIC: Bool,
          DIAGNOSTICS_TOPIC: DiagnosticArray, TREND_TOPIC: Float64MultiArray}
_QOS = {TEMPERATURE_TOPIC: ESTIMATE_QOS, WEAR_TOPIC: ESTIMATE_QOS, ALARM_TOPIC: ALARM_QOS,
        DIAGNOSTICS_TOPIC: DIAGNOSTICS_QOS, TREND_TOPIC: ESTIMATE_QOS}


class WearEstimatorNode(Node):
    """Estimate (T, w) per experiment, publish them, latch the alarm and keep the history."""

    def __init__(self, **kwargs):
        """Declare and validate the parameters, restore the history, advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(WEAR_ESTIMATOR_NODE, **kwargs)
        raw = declare_parameters(self, WEAR_ESTIMATOR_PARAMETERS)
        self.parameters = validate_parameters(WEAR_ESTIMATOR_NODE, raw,
                                              source=f'{self.get_name()} parameters')
        config = EstimatorConfig.from_node_parameters(self.parameters)
        self.history = WearHistory(expand_history_path(self.parameters['history_file']))
        self.service = WearEstimatorService(config, history=self.history)
        self.service.warm_up()
        self.kit = message_kit()
        self.rejection_log = RejectionLog(what='friction_levels inputs',
                                          period_s=REJECTION_LOG_PERIOD_S)
        self.publishers_by_topic = {topic: self.create_publisher(_TYPES[topic], topic,
                                                                 _QOS[topic])
                                    for topic in _TYPES}
        self.subscription = self.create_subscription(JointState, FRICTION_LEVELS_TOPIC,
                                                     self.on_friction_levels,
                                                     FRICTION_LEVELS_QOS)
        self.reset_service = self.create_service(Trigger, RESET_SERVICE, self.on_reset_alarm)
        self.timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)
        self.publish_alarm()
        self.get_logger().info(
            f'joint {config.joint!r}, parameter set {config.params.name!r}, alarm at '
            f'w >= {config.alarm.threshold}; history {self.history.path}: '
            f'{self.service.restored_estimates} estimates restored, alarm '
            f'{"LATCHED" if self.service.latch.active else "clear"}')

    def publish_alarm(self):
        """Publish the latched alarm state."""
        self.publishers_by_topic[ALARM_TOPIC].publish(
            alarm_to_msg(self.kit, active=self.service.latch.active))

    def publish_diagnostics(self):
        """Publish the current diagnostics (periodic, like diagnostic_updater)."""
        self.publishers_by_topic[DIAGNOSTICS_TOPIC].publish(
            self.service.diagnostics_message(self.kit, stamp_s=node_time_s(self)))
        self.log_rejections()

    def log_rejections(self):
        """Log the inputs rejected since the last report (at most once per 10 s)."""
        log_rejection_report(self.get_logger(), self.rejection_log.report(
            self.service.rejections, now_s=node_time_s(self), detail=self.service.last_rejection))

    def on_friction_levels(self, msg):
        """Estimate from one experiment and publish every output."""
        try:
            update = self.service.handle_friction_levels(msg)
        except Exception as error:  # noqa: BLE001 - the node must outlive any one input
            self.service.reject('internal_error', f'{type(error).__name__}: {error}')
            self.get_logger().error(f'friction_levels not processed: {type(error).__name__}: '
                                    f'{error}')
            return
        if update is None:
            self.log_rejections()
            return
        for topic, out in self.service.output_messages(self.kit, update):
            self.publishers_by_topic[topic].publish(out)
        # One call site per severity: rclpy refuses a call site that changes its severity.
        if update.alarm_raised:
            self.get_logger().error(f'WEAR ALARM raised by experiment {update.index}: '
                                    f'{update.status.message}')
        else:
            self.get_logger().info(f'experiment {update.index}: {update.status.message}')

    def on_reset_alarm(self, request, response):
        """Clear the latched alarm after maintenance (std_srvs/Trigger)."""
        response.success, response.message = self.service.reset_alarm(stamp_s=node_time_s(self))
        self.get_logger().warning(f'reset_alarm: {response.message}')
        self.publish_alarm()
        self.publish_diagnostics()
        return response

    def destroy_node(self):
        """Close the history database, then destroy the node."""
        self.history.close()
        return super().destroy_node()


def main(args=None):
    """Run the node until shutdown (exit code 2 on invalid parameters or history)."""
    return spin_node(WearEstimatorNode, logger_name=WEAR_ESTIMATOR_NODE, args=args)


if __name__ == '__main__':
    sys.exit(main())
