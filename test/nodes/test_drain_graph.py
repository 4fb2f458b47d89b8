"""
The friction node's drained intake on a live graph, as a process: 1 kHz and 4 kHz.

``friction_experiment_node`` starts from its console script with its default intake (it drains
/joint_states every ``drain_period_s``, 0.05 s) and the experiment's four speeds configured, so
that each experiment is complete at its last level.  The test publishes a recording of the
test's own generator (``independent_robot``, three experiments recorded at 1 kHz) on
``/joint_states`` with the node's QoS, paced at 1 kHz, and the same messages at 4 kHz (the
recorded stamps, so the same levels).  It checks that no message is lost (the node's
``joint_states`` count on /diagnostics is every message sent), that every ``friction_levels``
equals, float for float, what ``replay`` makes of the same messages, and the latency: each
experiment arrives within ``drain_period_s`` plus a loose allowance for the processing and a
busy machine after the publication of the sample that completes it (found by feeding the
samples one by one to the per-message path).

In-process, a wake held back: the node's executor is not spun while 0.95 s of a 4 kHz stream
(3,800 messages) is published; its default queue (``joint_states_depth``, 4000) keeps them
all, the former depth of 1000 keeps 1000 and loses the rest.
"""

import time

from diagnostic_msgs.msg import DiagnosticArray
import pytest
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from robot_wear_monitor.monitoring.drain_config import DrainConfig
from robot_wear_monitor.monitoring.joints import JointExperiments
from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
from robot_wear_monitor.monitoring.replay import replay_bag
from robot_wear_monitor.nodes.friction_experiment_node import FrictionExperimentNode
from robot_wear_monitor.nodes.qos import (DIAGNOSTICS_QOS, FRICTION_LEVELS_QOS,
                                          JOINT_STATES_QOS, joint_states_qos)
from robot_wear_monitor.recordings.messages import diagnostics_from_msg
from sensor_msgs.msg import JointState
from wear_testing import independent_robot as robot
from wear_testing.process_graph import ProcessGraph

SPEEDS = (2.1, 28.5, 35.1, 41.7)
N_EXPERIMENTS = 3
DRAIN_PERIOD_S = DrainConfig().drain_period_s
#: What the latency may exceed the drain period by [s]: the batch's processing takes a few ms
#: (docs/benchmarks.md), the rest is for a machine shared by many processes.
LATENCY_ALLOWANCE_S = 1.0
PARAMS_YAML = f"""\
friction_experiment_node:
  ros__parameters:
    experiment_speeds_rad_s: {list(SPEEDS)}
"""


class Graph(ProcessGraph):
    """The node as a process, a publisher of /joint_states and a subscriber of its outputs."""

    def __init__(self, tmp_path):
        """Subscribe to friction_levels and /diagnostics; advertise /joint_states."""
        super().__init__(tmp_path, probe='drain_probe')
        self.levels, self.counts = [], []
        self.node.create_subscription(JointState, 'friction_levels', self._on_levels,
                                      FRICTION_LEVELS_QOS)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      DIAGNOSTICS_QOS)
        self.publisher = self.node.create_publisher(JointState, 'joint_states',
                                                    JOINT_STATES_QOS)
        self.spin()

    def _on_levels(self, msg):
        stamp_s = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self._add(self.levels, (time.perf_counter(), msg.header.frame_id, stamp_s,
                                tuple(msg.velocity), tuple(msg.effort)))

    def _on_diagnostics(self, msg):
        for _, name, _, values in diagnostics_from_msg(msg):
            if name.startswith('friction_experiment'):
                self._add(self.counts, int(values['joint_states']))


@pytest.fixture(scope='module')
def recording():
    return robot.generate_wear_test(n_experiments=N_EXPERIMENTS, wear_start=10.0,
                                    wear_end=50.0, seed=21, rate_hz=1000.0)


@pytest.fixture(scope='module')
def expected(recording, tmp_path_factory):
    """Return the replay's friction levels and the index of the sample completing each."""
    folder = tmp_path_factory.mktemp('drain')
    params = folder / 'params.yaml'
    params.write_text(PARAMS_YAML)
    configuration = MonitorConfig.load(config_file=params)
    result = replay_bag(robot.write_bag(folder / 'bag', recording), out_bag=None,
                        configuration=configuration)
    levels = [(u.joint, u.stamp_s, tuple(u.speeds_rad_s), tuple(u.frictions))
              for u in result.updates]
    one_by_one = JointExperiments(configuration.experiment, source='test')
    completing = [i for i, (stamp, names, position, velocity, effort)
                  in enumerate(robot.messages(recording))
                  for _ in one_by_one.add_joint_state(stamp_s=stamp, name=names,
                                                      position=position, velocity=velocity,
                                                      effort=effort)]
    assert len(levels) == len(completing) == N_EXPERIMENTS
    return params, levels, completing


def _payloads(recording):
    payloads = []
    for stamp, names, position, velocity, effort in robot.messages(recording):
        msg = JointState()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(round(stamp * 1e9)),
                                                                1_000_000_000)
        msg.name, msg.position, msg.velocity, msg.effort = names, position, velocity, effort
        payloads.append(serialize_message(msg))
    return payloads


def _publish_paced(publisher, payloads, rate_hz):
    """Publish at ``rate_hz`` (a late message goes at once); return each one's time."""
    sent = []
    start = time.perf_counter()
    for i, payload in enumerate(payloads):
        delay = start + i / rate_hz - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        sent.append(time.perf_counter())
        publisher.publish(payload)
    return sent


@pytest.mark.parametrize('rate_hz', [1000.0, 4000.0])
def test_the_drained_node_loses_nothing_and_publishes_the_replays_levels_in_time(
        tmp_path, recording, expected, rate_hz):
    params, levels, completing = expected
    payloads = _payloads(recording)
    graph = Graph(tmp_path)
    try:
        graph.start('friction_experiment_node', 'friction_experiment_node', '--ros-args',
                    '--params-file', str(params))
        assert graph.wait(lambda: graph.counts and graph.publisher.get_subscription_count(),
                          30.0), graph.logs()
        assert graph.wait(lambda: graph.node.count_subscribers('friction_levels') >= 0, 1.0)
        time.sleep(0.5)  # discovery settles both ways (the node's friction_levels publisher)
        sent = _publish_paced(graph.publisher, payloads, rate_hz)
        achieved_hz = (len(sent) - 1) / (sent[-1] - sent[0])
        assert graph.wait(lambda: graph.counts and graph.counts[-1] == len(payloads), 20.0), (
            f'joint_states counted {graph.counts[-3:]} of {len(payloads)} sent at '
            f'{achieved_hz:.0f} Hz\n' + graph.logs())
        assert graph.wait(lambda: len(graph.levels) >= N_EXPERIMENTS, 10.0), graph.logs()
        assert graph.settle(lambda: len(graph.levels), quiet_s=0.5)
        assert [row[1:] for row in graph.levels] == levels  # float for float
        latencies = [received - sent[index]
                     for (received, *_), index in zip(graph.levels, completing)]
        assert max(latencies) <= DRAIN_PERIOD_S + LATENCY_ALLOWANCE_S, latencies
        assert min(latencies) > 0.0
        assert graph.stop('friction_experiment_node') == 0
        assert 'Traceback' not in graph.log('friction_experiment_node')
        assert 'drained every 0.05 s' in graph.log('friction_experiment_node')
        if rate_hz > 1000.0:  # the publisher did go faster than 1 kHz (a busy machine slows it)
            assert achieved_hz > 1500.0, achieved_hz
    finally:
        graph.close()


#: A wake held back by 0.95 s at 4 kHz: the longest the default queue bridges (0.05 s spare).
HELD_MESSAGES = 3800


@pytest.mark.parametrize('depth', [None, 1000])
def test_the_default_queue_bridges_a_wake_held_back_for_095_s_of_4_khz(ros_context, depth):
    overrides = [] if depth is None else [Parameter('joint_states_depth', value=depth)]
    node = FrictionExperimentNode(parameter_overrides=overrides)
    assert node.joint_states_qos.depth == (depth or DrainConfig().joint_states_depth)
    probe = ros_context.create_node('held_wake_probe')
    # the publisher keeps everything it sends until acknowledged: only the node's queue counts
    publisher = probe.create_publisher(JointState, 'joint_states',
                                       joint_states_qos(2 * HELD_MESSAGES))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(probe)
    try:
        deadline = time.monotonic() + 10.0
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        assert publisher.get_subscription_count() == 1
        names = [f'joint_{i}' for i in range(1, 7)]
        for k in range(HELD_MESSAGES):  # the node's executor is not spun meanwhile
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = 100, k * 250_000
            msg.name = names
            msg.position, msg.velocity, msg.effort = [0.1] * 6, [0.0] * 6, [0.0] * 6
            publisher.publish(msg)
        assert publisher.wait_for_all_acked(Duration(seconds=5))
        time.sleep(0.2)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:  # every wake takes what is queued
            executor.spin_once(timeout_sec=0.05)
        if depth is None:
            assert node.batches.messages == HELD_MESSAGES
        else:  # the queue keeps the newest ``depth`` messages
            assert node.batches.messages == depth
    finally:
        executor.shutdown()
        node.destroy_node()
        probe.destroy_node()
