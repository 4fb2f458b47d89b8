"""
wear_estimator_node: friction_levels -> temperature, wear, wear_alarm and /diagnostics.

A thin shell over
:class:`robot_wear_monitor.monitoring.estimator_service.WearEstimatorService`, one per monitored
joint (:class:`~robot_wear_monitor.monitoring.joints.WearEstimatorFleet`; the
``friction_levels`` of a joint go to its estimator by ``header.frame_id``): every completed
experiment gives an estimate of (T, w); the alarm is latched (reliable + transient-local, so a
late subscriber sees the current state) until ``~/reset_alarm`` (std_srvs/Trigger; with
``joints``: ``~/<joint>/reset_alarm``; not offered with ``reset_service_enabled`` false, when
resets must go through the dashboard); the history restores the trend and the alarm after a
restart.  With ``joints`` the outputs of a joint are under ``<joint>/``.
"""

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from robot_wear_monitor.errors import escaped, InputError
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.monitoring.diagnostics import RejectionLog
from robot_wear_monitor.monitoring.estimator_service import WearEstimatorService
from robot_wear_monitor.monitoring.joints import (output_topic, rejections_by_joint,
                                                  reset_service_name, WearEstimatorFleet)
from robot_wear_monitor.monitoring.node_config import (expand_history_path, per_joint_outputs,
                                                       validate_parameters, WEAR_ESTIMATOR_NODE,
                                                       WEAR_ESTIMATOR_PARAMETERS)
from robot_wear_monitor.monitoring.topics import (ALARM_TOPIC, DIAGNOSTICS_TOPIC,
                                                  FRICTION_LEVELS_TOPIC, TEMPERATURE_TOPIC,
                                                  TREND_TOPIC, WEAR_TOPIC)
from robot_wear_monitor.nodes.messages import message_kit
from robot_wear_monitor.nodes.node_helpers import log_rejection_report, node_time_s
from robot_wear_monitor.nodes.parameters import declare_joint_parameters, declare_parameters
from robot_wear_monitor.nodes.qos import (ALARM_QOS, DIAGNOSTICS_QOS, ESTIMATE_QOS,
                                          FRICTION_LEVELS_QOS)
from robot_wear_monitor.nodes.spinning import spin_node
from robot_wear_monitor.recordings.messages import alarm_to_msg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger

DIAGNOSTICS_PERIOD_S = 1.0
REJECTION_LOG_PERIOD_S = 10.0

_TYPES = {TEMPERATURE_TOPIC: Temperature, WEAR_TOPIC: Float64, ALARM_TOPIC: Bool,
          DIAGNOSTICS_TOPIC: DiagnosticArray, TREND_TOPIC: Float64MultiArray}
_QOS = {TEMPERATURE_TOPIC: ESTIMATE_QOS, WEAR_TOPIC: ESTIMATE_QOS, ALARM_TOPIC: ALARM_QOS,
        DIAGNOSTICS_TOPIC: DIAGNOSTICS_QOS, TREND_TOPIC: ESTIMATE_QOS}


class WearEstimatorNode(Node):
    """Estimate (T, w) per experiment, publish them, latch the alarm and keep the history."""

    def __init__(self, **kwargs):
        """
        Declare and validate the parameters, restore the history, advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(WEAR_ESTIMATOR_NODE, **kwargs)
        raw = declare_parameters(self, WEAR_ESTIMATOR_PARAMETERS)
        self.parameters = validate_parameters(WEAR_ESTIMATOR_NODE, raw,
                                              source=f'{self.get_name()} parameters')
        self.history = WearHistory(expand_history_path(self.parameters['history_file']),
                                   robot=self.parameters['robot_id'] or None)
        self.kit = message_kit()
        self.rejection_log = RejectionLog(what='friction_levels inputs',
                                          period_s=REJECTION_LOG_PERIOD_S)
        self.publishers_by_joint = {}
        self.reset_services = {}
        # the shared diagnostics topic first: a joint's advertisement may publish on it
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                                           _QOS[DIAGNOSTICS_TOPIC])
        self.fleet = WearEstimatorFleet(
            self.parameters, history=self.history, warm_up=True,
            parameters_for=lambda joint: declare_joint_parameters(
                self, WEAR_ESTIMATOR_NODE, WEAR_ESTIMATOR_PARAMETERS, self.parameters, joint),
            on_new_service=self._advertise)
        self.subscription = self.create_subscription(JointState, FRICTION_LEVELS_TOPIC,
                                                     self.on_friction_levels,
                                                     FRICTION_LEVELS_QOS)
        self.timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)
        if self.fleet.selection is None:
            self.get_logger().info(f'estimating every joint that comes on '
                                   f'{self.subscription.topic_name}; history '
                                   f'{self.history.path}')

    @property
    def service(self) -> WearEstimatorService:
        """Return the estimator of the first monitored joint (the only one without joints)."""
        return next(iter(self.fleet.services.values()))

    @property
    def publishers_by_topic(self):
        """Return base topic -> publisher of the first joint (the only one without joints)."""
        return self.publishers_by_joint[self.service.config.joint]

    def _advertise(self, service):
        """Create the publishers and the reset service of a new joint; publish its alarm."""
        joint = service.config.joint
        per_joint = per_joint_outputs(self.parameters)
        publishers = {DIAGNOSTICS_TOPIC: self.diagnostics_publisher}
        for topic in (TEMPERATURE_TOPIC, WEAR_TOPIC, ALARM_TOPIC, TREND_TOPIC):
            publishers[topic] = self.create_publisher(
                _TYPES[topic], output_topic(topic, joint, per_joint=per_joint), _QOS[topic])
        self.publishers_by_joint[joint] = publishers
        if self.parameters['reset_service_enabled']:
            self.reset_services[joint] = self.create_service(
                Trigger, reset_service_name(joint, per_joint=per_joint),
                lambda request, response: self.on_reset_alarm(request, response, joint=joint))
        publishers[ALARM_TOPIC].publish(alarm_to_msg(self.kit, active=service.latch.active))
        config = service.config
        self.get_logger().info(
            f'joint {joint!r}, parameter set {config.params.name!r}, alarm at '
            f'w >= {config.alarm.threshold}; history {escaped(self.history.path)}: '
            f'{service.restored_estimates} estimates restored, alarm '
            f'{"LATCHED" if service.latch.active else "clear"}'
            + ('' if self.parameters['reset_service_enabled'] else
               '; no reset service (reset_service_enabled false)'))
        warning = config.levels_warning()
        if warning:  # once per joint: its estimator is built once
            self.get_logger().warning(escaped(warning))

    def publish_alarm(self, joint=None):
        """Publish the latched alarm state of a joint (default: every joint)."""
        for name in ([joint] if joint is not None else list(self.fleet.services)):
            self.publishers_by_joint[name][ALARM_TOPIC].publish(
                alarm_to_msg(self.kit, active=self.fleet.services[name].latch.active))

    def publish_diagnostics(self):
        """
        Publish every joint's current diagnostics (periodic, like diagnostic_updater).

        First take over the resets stored in the history meanwhile (the dashboard's): the
        joint's alarm is published clear at once.
        """
        for joint, service in self.fleet.services.items():
            try:
                event = service.follow_history_reset()
            except InputError as error:  # a lost history server: said once per period
                self.get_logger().error(f'{joint!r}: {escaped(error)}')
                break
            if event is not None:
                self.get_logger().warning(
                    f'reset_alarm of {joint!r} stored in the history by '
                    f'{event.user or "the ROS service"!r}: {event.note[:200]!r}')
                self.publish_alarm(joint)
        msg = self.fleet.diagnostics_message(self.kit, stamp_s=node_time_s(self))
        if msg is not None:
            self.diagnostics_publisher.publish(msg)
        self.log_rejections()

    def log_rejections(self):
        """Log the inputs rejected since the last report (at most once per 10 s)."""
        counts = rejections_by_joint({joint: service.rejections
                                      for joint, service in self.fleet.services.items()})
        for reason, count in self.fleet.rejections.items():
            counts[reason] = counts.get(reason, 0) + count
        detail = next((s.last_rejection for s in reversed(self.fleet.services.values())
                       if s.last_rejection), self.fleet.last_rejection)
        log_rejection_report(self.get_logger(), self.rejection_log.report(
            counts, now_s=node_time_s(self), detail=detail))

    def on_friction_levels(self, msg):
        """Estimate from one experiment and publish every output."""
        try:
            service, update = self.fleet.handle_friction_levels(msg)
        except Exception as error:  # noqa: BLE001 - the node must outlive any one input
            target = self.service if self.fleet.services else None
            if target is not None:
                target.reject('internal_error', f'{type(error).__name__}: {error}')
            self.get_logger().error(f'friction_levels not processed: {type(error).__name__}: '
                                    f'{escaped(error)}')
            return
        if update is None:
            self.log_rejections()
            return
        publishers = self.publishers_by_joint[service.config.joint]
        for topic, out in service.output_messages(self.kit, update):
            publishers[topic].publish(out)
        # One call site per severity: rclpy refuses a call site that changes its severity.
        if update.alarm_raised:
            self.get_logger().error(f'WEAR ALARM raised by experiment {update.index} of '
                                    f'{update.joint!r}: {escaped(update.status.message)}')
        else:
            self.get_logger().info(f'experiment {update.index} of {update.joint!r}: '
                                   f'{escaped(update.status.message)}')

    def on_reset_alarm(self, request, response, *, joint=None):
        """Clear the latched alarm of a joint after maintenance (std_srvs/Trigger)."""
        joint = joint if joint is not None else self.service.config.joint
        service = self.fleet.services[joint]
        response.success, response.message = service.reset_alarm(stamp_s=node_time_s(self))
        self.get_logger().warning(f'reset_alarm of {joint!r}: {escaped(response.message)}')
        self.publish_alarm(joint)
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
