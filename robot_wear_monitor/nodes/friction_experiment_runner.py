"""
friction_experiment_runner: runs the planned friction experiment via a trajectory controller.

A thin shell over :class:`robot_wear_monitor.monitoring.runner.ExperimentRunner`.  Every tested
joint's motion is planned at start-up (a motion the parameters do not allow refuses the node with
one line, exit code 2).  ``~/start`` (std_srvs/Trigger) runs them one after the other: per joint
the ``start`` event on ``friction_experiment/events``, its trajectory_msgs/JointTrajectory on
``/<controller>/joint_trajectory`` (ros2_control's joint_trajectory_controller; header stamp 0 =
start on receipt) and, ``end_margin_s`` after the planned end, the ``end`` event, all from
one-shot timers (no callback waits).  ``~/abort`` publishes ``aborted`` for the running joint
and a one-point trajectory that brakes it.  ``/diagnostics`` carries
``friction_experiment_runner`` (idle, or running joint k of n) every second.
"""

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from robot_wear_monitor.monitoring.node_config import (DEPRECATED_PARAMETERS,
                                                       FRICTION_EXPERIMENT_RUNNER_NODE,
                                                       FRICTION_EXPERIMENT_RUNNER_PARAMETERS)
from robot_wear_monitor.monitoring.runner import (ABORT_SERVICE, ExperimentRunner, runner_config,
                                                  RUNNER_STATUS_NAME, START_SERVICE)
from robot_wear_monitor.monitoring.topics import DIAGNOSTICS_TOPIC
from robot_wear_monitor.nodes.messages import message_kit
from robot_wear_monitor.nodes.node_helpers import node_time_s
from robot_wear_monitor.nodes.parameters import (declare_deprecated_parameters,
                                                 declare_parameters, validated_with_warnings)
from robot_wear_monitor.nodes.qos import DIAGNOSTICS_QOS, EXPERIMENT_EVENTS_QOS, TRAJECTORY_QOS
from robot_wear_monitor.nodes.spinning import spin_node
from robot_wear_monitor.recordings.messages import (diagnostics_to_msg, experiment_event_to_msg,
                                                    EXPERIMENT_EVENTS_TOPIC, trajectory_to_msg)
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

DIAGNOSTICS_PERIOD_S = 1.0


class FrictionExperimentRunner(Node):
    """Run the planned friction experiment of the tested joints on request."""

    def __init__(self, **kwargs):
        """
        Declare and validate the parameters, plan every joint, advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(FRICTION_EXPERIMENT_RUNNER_NODE, **kwargs)
        raw = declare_parameters(self, FRICTION_EXPERIMENT_RUNNER_PARAMETERS)
        source = f'{self.get_name()} parameters'
        deprecated = declare_deprecated_parameters(self, FRICTION_EXPERIMENT_RUNNER_NODE)
        defaults = {spec.name: spec.default for spec in FRICTION_EXPERIMENT_RUNNER_PARAMETERS}
        for old in deprecated:  # the old name wins over the new one's default (not over a value)
            new = DEPRECATED_PARAMETERS[FRICTION_EXPERIMENT_RUNNER_NODE][old]
            if raw.get(new) == defaults[new]:
                raw.pop(new)
        self.parameters = validated_with_warnings(self, FRICTION_EXPERIMENT_RUNNER_NODE,
                                                  {**raw, **deprecated}, source=source)
        self.runner = ExperimentRunner(runner_config(self.parameters, source=source),
                                       source=source)
        self.kit = message_kit()
        # Built once: a start request only publishes them.
        self.trajectories = {step.index: trajectory_to_msg(self.kit, points=step.points)
                             for step in self.runner.schedule}
        self.trajectory_publisher = self.create_publisher(
            JointTrajectory, self.runner.config.trajectory_topic, TRAJECTORY_QOS)
        self.events_publisher = self.create_publisher(DiagnosticArray, EXPERIMENT_EVENTS_TOPIC,
                                                      EXPERIMENT_EVENTS_QOS)
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                                           DIAGNOSTICS_QOS)
        self.start_service = self.create_service(Trigger, START_SERVICE, self.on_start)
        self.abort_service = self.create_service(Trigger, ABORT_SERVICE, self.on_abort)
        self.diagnostics_timer = self.create_timer(DIAGNOSTICS_PERIOD_S,
                                                   self.publish_diagnostics)
        self.step_timer = None
        plans = ', '.join(f'{step.joint} {step.duration_s:.1f} s' for step in
                          self.runner.schedule)
        self.get_logger().info(
            f'friction experiment of {plans} (speeds '
            f'{list(self.runner.config.plans[0].speeds_rad_s)} rad/s, motor side), '
            f'{self.runner.total_s:.1f} s per run; trajectories on '
            f'{self.trajectory_publisher.topic_name}, events on '
            f'{self.events_publisher.topic_name}; call {self.resolve_service_name(START_SERVICE)} '
            '(std_srvs/Trigger) to run it: robot-wear-monitor call start, or ros2 service call')

    def subscribers(self):
        """Return how many subscriptions the trajectory topic has (the controller's)."""
        return self.trajectory_publisher.get_subscription_count()

    def on_start(self, request, response):
        """Start a run if idle (std_srvs/Trigger); the first joint starts at once."""
        response.success, response.message = self.runner.start(
            node_time_s(self), trajectory_subscribers=self.subscribers())
        if response.success:
            self.get_logger().info(response.message)
            self.run_due_actions()
        else:
            self.get_logger().warning(f'start refused: {response.message}')
        return response

    def on_abort(self, request, response):
        """Abort the run (std_srvs/Trigger): ``aborted`` event and a braking hold point."""
        now_s = node_time_s(self)
        response.success, response.message, action, hold = self.runner.abort(now_s)
        self.cancel_step_timer()
        if action is not None:
            self.events_publisher.publish(
                experiment_event_to_msg(self.kit, stamp_s=now_s, event=action.event))
        if hold is not None:
            self.trajectory_publisher.publish(trajectory_to_msg(self.kit, points=hold))
        if response.success:
            self.get_logger().warning(response.message)
        self.publish_diagnostics()
        return response

    def run_due_actions(self):
        """Publish what is due now (events, trajectories), then set the timer of the next."""
        self.cancel_step_timer()
        now_s = node_time_s(self)
        for action in self.runner.due(now_s):
            self.events_publisher.publish(
                experiment_event_to_msg(self.kit, stamp_s=now_s, event=action.event))
            if action.kind == 'start':
                self.trajectory_publisher.publish(self.trajectories[action.step.index])
            self.get_logger().info(
                f'{action.kind} of the friction experiment of {action.step.joint} '
                f'(#{action.event.experiment_id}, joint {action.step.index + 1} of '
                f'{len(self.runner.schedule)})')
        due_s = self.runner.next_due_s()
        if due_s is not None:
            self.step_timer = self.create_timer(max(due_s - node_time_s(self), 1e-3),
                                                self.run_due_actions)
        else:
            self.publish_diagnostics()

    def cancel_step_timer(self):
        """Destroy the one-shot timer of the next action, if any."""
        if self.step_timer is not None:
            self.step_timer.cancel()
            self.destroy_timer(self.step_timer)
            self.step_timer = None

    def publish_diagnostics(self):
        """Publish the runner's status on /diagnostics (periodic and on every change)."""
        status = self.runner.status(node_time_s(self), trajectory_subscribers=self.subscribers())
        self.diagnostics_publisher.publish(diagnostics_to_msg(
            self.kit, stamp_s=node_time_s(self), name=RUNNER_STATUS_NAME,
            hardware_id=','.join(self.runner.config.joints), level=status.level,
            message=status.message, values=status.values))


def main(args=None):
    """Run the node until shutdown (exit code 2 on invalid parameters)."""
    return spin_node(FrictionExperimentRunner, logger_name=FRICTION_EXPERIMENT_RUNNER_NODE,
                     args=args)


if __name__ == '__main__':
    sys.exit(main())
