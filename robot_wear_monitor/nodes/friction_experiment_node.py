"""
friction_experiment_node: /joint_states -> friction_levels, one message per experiment.

Segments the monitored joint(s) into constant-speed friction levels (eq. (3)) and experiments
with one :class:`robot_wear_monitor.monitoring.experiment_service.FrictionExperimentService` per
joint (:class:`~robot_wear_monitor.monitoring.joints.JointExperiments`: ``joint``, or
``joints``, or ``joints: [all]`` for every joint that appears; per-joint values as
``<joint>.<name>`` parameters), and publishes each completed experiment on ``friction_levels``
(sensor_msgs/JointState: ``velocity`` = speed levels [rad/s], ``effort`` = friction levels,
``header.frame_id`` = joint).  Every second it publishes its counts and the rejected inputs by
reason on ``/diagnostics``, one status per joint (``friction_experiment: <joint>``); rejected
inputs are also logged, at most once per 10 s.  The friction_experiment_runner's events
(``experiment_events_topic``, default ``friction_experiment/events``; empty: not subscribed)
give the experiments' exact boundaries: an ``end`` event publishes the experiment at once.

/joint_states is drained, not called back per message (``drain_period_s``, default 0.05 s):
the subscription stays out of the executor's wait set (:mod:`robot_wear_monitor.nodes.drain`)
and a timer takes every message queued since its last wake, as CDR bytes, decoded and
segmented in one batch by the replay's decoder and chunk segmenter
(:class:`~robot_wear_monitor.monitoring.joint_state_batches.JointStateBatches`): the replay's
friction levels, bit for bit, for a fraction of the executor's per-message cost.  An
experiment is published at most ``drain_period_s`` plus the batch's processing after the
sample that completes it; an event first drains the queue, so it comes after the samples
received before it.  ``drain_period_s: 0.0``: one callback per message (``on_joint_state``).
"""

import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from robot_wear_monitor.monitoring.diagnostics import RejectionLog
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.monitoring.joint_state_batches import JointStateBatches
from robot_wear_monitor.monitoring.joints import JointExperiments, rejections_by_joint
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                       FRICTION_EXPERIMENT_PARAMETERS,
                                                       validate_parameters)
from robot_wear_monitor.monitoring.topics import DIAGNOSTICS_TOPIC, FRICTION_LEVELS_TOPIC
from robot_wear_monitor.nodes.drain import DrainedSubscription
from robot_wear_monitor.nodes.messages import message_kit
from robot_wear_monitor.nodes.node_helpers import log_rejection_report, node_time_s
from robot_wear_monitor.nodes.parameters import declare_joint_parameters, declare_parameters
from robot_wear_monitor.nodes.qos import (DIAGNOSTICS_QOS, EXPERIMENT_EVENTS_QOS,
                                          FRICTION_LEVELS_QOS, joint_states_qos)
from robot_wear_monitor.nodes.spinning import spin_node
from robot_wear_monitor.recordings.messages import stamp_to_seconds
from robot_wear_monitor.text import escaped
from sensor_msgs.msg import JointState

DIAGNOSTICS_PERIOD_S = 1.0
REJECTION_LOG_PERIOD_S = 10.0


def _rounded(values, digits: int) -> list:
    """Return plain Python floats rounded for a log line (no ``np.float64(...)`` reprs)."""
    return [round(float(v), digits) for v in values]


class FrictionExperimentNode(Node):
    """Segment /joint_states of the monitored joints and publish each completed experiment."""

    def __init__(self, **kwargs):
        """
        Declare and validate the parameters, then subscribe and advertise.

        ``kwargs`` go to rclpy Node (e.g. ``parameter_overrides`` in tests).
        """
        super().__init__(FRICTION_EXPERIMENT_NODE, **kwargs)
        raw = declare_parameters(self, FRICTION_EXPERIMENT_PARAMETERS)
        self.parameters = validate_parameters(FRICTION_EXPERIMENT_NODE, raw,
                                              source=f'{self.get_name()} parameters')
        self.joints = JointExperiments(
            self.parameters, parameters_for=lambda joint: declare_joint_parameters(
                self, FRICTION_EXPERIMENT_NODE, FRICTION_EXPERIMENT_PARAMETERS, self.parameters,
                joint))
        self.kit = message_kit()
        self.rejection_log = RejectionLog(what='joint_states inputs',
                                          period_s=REJECTION_LOG_PERIOD_S)
        self.publisher = self.create_publisher(JointState, FRICTION_LEVELS_TOPIC,
                                               FRICTION_LEVELS_QOS)
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                                           DIAGNOSTICS_QOS)
        self.drain_period_s = float(self.parameters['drain_period_s'])
        self.joint_states_qos = joint_states_qos(int(self.parameters['joint_states_depth']))
        self.drained = self.batches = self.drain_timer = None
        if self.drain_period_s > 0:
            self.drained = DrainedSubscription(self, JointState, 'joint_states',
                                               self.joint_states_qos)
            self.subscription = self.drained.subscription
            self.batches = JointStateBatches(self.joints)
            # on the steady clock: a paused /clock (use_sim_time) must not stop the drain
            self.drain_timer = self.create_timer(self.drain_period_s, self.drain_joint_states,
                                                 clock=Clock(clock_type=ClockType.STEADY_TIME))
        else:
            self.subscription = self.create_subscription(JointState, 'joint_states',
                                                         self.on_joint_state,
                                                         self.joint_states_qos)
        self.events_subscription = None
        if self.parameters['experiment_events_topic']:
            self.events_subscription = self.create_subscription(
                DiagnosticArray, self.parameters['experiment_events_topic'],
                self.on_experiment_event, EXPERIMENT_EVENTS_QOS)
        self.timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)
        self._rejected = 0
        self._internal_errors = 0
        self._last_error = ''
        self._last_message_monotonic = None
        self._last_tick_monotonic = None
        joints = ('every joint of /joint_states' if self.joints.selection is None else
                  ', '.join(f'{s.joint!r} (gear ratio {s.segmenter_config.gear_ratio:g}, '
                            f'torque scale {s.segmenter_config.torque_scale:g}, speeds '
                            f'{_rounded(s.experiment_speeds_rad_s, 3) or "found in the data"})'
                            for s in self.joints.services.values()))
        self.get_logger().info(
            f'segmenting {joints} of {self.subscription.topic_name} ('
            + (f'drained every {self.drain_period_s:g} s' if self.drained is not None
               else 'a callback per message')
            + f', queue depth {self.joint_states_qos.depth}); publishing on '
            f'{self.publisher.topic_name}; '
            + (f'experiment boundaries from {self.events_subscription.topic_name}'
               if self.events_subscription is not None else 'no experiment events'))

    @property
    def service(self) -> FrictionExperimentService:
        """Return the service of the first monitored joint (the only one without joints)."""
        return next(iter(self.joints.services.values()))

    def _all_rejections(self):
        """Return the rejections of every joint by reason (prefixed by the joint if several)."""
        total = rejections_by_joint({joint: service.all_rejections()
                                     for joint, service in self.joints.services.items()})
        if self._internal_errors:
            total['internal_error'] = self._internal_errors
        return total

    def on_joint_state(self, msg):
        """Feed one JointState to the segmentation; publish the experiments it completes."""
        self._last_message_monotonic = time.monotonic()
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if stamp_s == 0.0:  # unstamped publisher: use the reception time
            stamp_s = node_time_s(self)
        refused = len(self.joints.refused)
        self._publish_all(self._guarded(
            self.joints.add_joint_state, stamp_s=stamp_s, name=msg.name,
            position=msg.position, velocity=msg.velocity, effort=msg.effort))
        self._after_input(refused)

    def drain_joint_states(self):
        """Take every queued /joint_states message and segment them as batches (the timer)."""
        if self.drained is None:
            return
        limit = self.joint_states_qos.depth
        while True:
            raws, receive_ns = self.drained.take_all(limit)
            if raws:
                self.on_joint_states(raws, receive_ns)
            if len(raws) < limit:
                return

    def on_joint_states(self, raws, receive_ns):
        """Decode and segment one drained batch (CDR bytes, reception times [ns]); publish."""
        self._last_message_monotonic = time.monotonic()
        refused = len(self.joints.refused)
        self._publish_all(self._guarded(self.batches.add, raws, receive_ns))
        self._after_input(refused)

    def _after_input(self, refused):
        """Log the joints refused since ``refused`` were (once each) and new rejections."""
        if len(self.joints.refused) > refused:  # said once per joint; the others go on
            for joint, error in list(self.joints.refused.items())[refused:]:
                self.get_logger().error(f'joint {joint!r} not monitored: {escaped(error)}')
        self._log_new_rejections()

    def _guarded(self, call, *args, **kwargs):
        """Return call(...)'s experiments; an internal error is counted, never raised."""
        try:
            return call(*args, **kwargs)
        except Exception as error:  # noqa: BLE001 - the node must outlive any one input
            text = f'{type(error).__name__}: {error}'
            if self.joints.services:  # shown in the first joint's diagnostics
                self.service.rejections['internal_error'] += 1
                self.service.last_error = text
            else:
                self._internal_errors += 1
                self._last_error = text
            return []

    def _publish_all(self, experiments):
        for service, experiment in experiments:
            self.publish_experiment(experiment, service=service)

    def _rejected_total(self):
        return self._internal_errors + sum(s.rejected_total
                                           for s in self.joints.services.values())

    def _log_new_rejections(self):
        total = self._rejected_total()
        if total > self._rejected:
            self._rejected = total
            self.log_rejections()

    def on_experiment_event(self, msg):
        """Apply one friction_experiment_runner event; publish the experiment it ends."""
        self.drain_joint_states()  # the samples received before the event come first
        services = list(self.joints.services.values())
        open_before = [s.open_experiment_id for s in services]
        aborted_before = [s.rejections['aborted_experiment'] for s in services]
        self._publish_all(self._guarded(self.joints.handle_experiment_event_msg, msg))
        for service, was_open, aborted in zip(services, open_before, aborted_before):
            open_after = service.open_experiment_id
            if open_after is not None and open_after != was_open:
                self.get_logger().info(f'runner started friction experiment #{open_after} of '
                                       f'{service.joint!r}')
            elif service.rejections['aborted_experiment'] > aborted:
                self.get_logger().info(f'runner aborted friction experiment #{was_open} of '
                                       f'{service.joint!r}: its friction levels are dropped')
        self._log_new_rejections()

    def publish_experiment(self, experiment, *, service=None):
        """Publish one completed experiment on ``friction_levels`` and log it."""
        service = service or self.service
        self.publisher.publish(service.friction_levels_message(self.kit, experiment))
        self.get_logger().info(
            f'experiment {service.experiments} of {service.joint!r}: speeds '
            f'{_rounded(experiment.speeds_rad_s, 2)} rad/s, friction '
            f'{_rounded(experiment.frictions, 5)}')

    def log_rejections(self):
        """Log the inputs rejected since the last report (at most once per 10 s)."""
        detail = self._last_error or next(
            (s.last_error for s in self.joints.services.values() if s.last_error), '')
        log_rejection_report(self.get_logger(), self.rejection_log.report(
            self._all_rejections(), now_s=node_time_s(self), detail=detail))

    def close_if_stream_stopped(self):
        """
        Publish the experiments in progress when /joint_states has stopped for idle_gap_s.

        Measured on the monotonic clock since the last message (not on the message stamps,
        which stop too): the experiment of a robot that stops publishing after it is not held
        back until the next one.
        """
        self.drain_joint_states()  # what is queued counts as received
        now = time.monotonic()
        blocked = (self._last_tick_monotonic is not None
                   and now - self._last_tick_monotonic > 2.5 * DIAGNOSTICS_PERIOD_S)
        self._last_tick_monotonic = now
        if self._last_message_monotonic is None or blocked:
            return  # after a blocked executor the queued messages come first
        silent_s = now - self._last_message_monotonic
        for service in self.joints.services.values():
            if silent_s > service.idle_gap_s:
                self._publish_all(self._guarded(
                    lambda s=service: [(s, e) for e in s.close_idle()]))

    def publish_diagnostics(self):
        """Publish the counts and rejections on /diagnostics, one status per joint."""
        self.close_if_stream_stopped()
        msg = self.joints.diagnostics_message(self.kit, stamp_s=node_time_s(self))
        if msg is not None:
            self.diagnostics_publisher.publish(msg)
        self.log_rejections()


def main(args=None):
    """Run the node until shutdown (exit code 2 on invalid parameters)."""
    return spin_node(FrictionExperimentNode, logger_name=FRICTION_EXPERIMENT_NODE, args=args)


if __name__ == '__main__':
    sys.exit(main())
