"""
Closed loop on a live ROS 2 graph: runner -> simulated arm -> segmentation -> estimate.

Four processes, started the way a user starts them, with their parameters on the command line:
``friction_experiment_runner``, ``friction_experiment_node``, ``wear_estimator_node`` and
``wear_testing/simulated_arm_node.py`` (the tests' own stand-in for a robot with a
joint_trajectory_controller:
it follows the JointTrajectory and publishes /joint_states at 250 Hz in real time with
``independent_robot``'s friction at a known wear, temperature and load).  The test calls
``~/start`` twice (joint_2 then joint_3 each time) and then starts a third run and aborts it
during joint_2.  The friction node monitors joint_2: exactly two experiments must come out,
each within its run's start/end events, at the designed speeds, with friction levels near the
truth, published right after the end event; ``/wear`` follows each of them; the aborted run and
joint_3's events are counted and produce nothing.  Own ROS_DOMAIN_ID, localhost discovery.
"""

import json
from pathlib import Path
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
from robot_wear_monitor.nodes.qos import DIAGNOSTICS_QOS, EXPERIMENT_EVENTS_QOS
from robot_wear_monitor.recordings.messages import (diagnostics_from_msg,
                                                    experiment_event_from_msg,
                                                    stamp_to_seconds)
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger
from wear_testing.paths import console_script
from wear_testing.process_graph import ProcessGraph
from wear_testing.trajectory_follower import JointTruth

BIN = Path(sys.executable).parent
NAMES = [f'joint_{i}' for i in range(1, 7)]
POSTURE = [0.1, 0.6, -0.4, 0.05, 0.5, -0.2]
SPEEDS = [2.1, 28.5, 35.1, 41.7]
TRUTH = {'joint_2': {'gear_ratio': 150.0, 'load': 0.45, 'temperature_degc': 38.0,
                     'wear': 42.0},
         'joint_3': {'gear_ratio': 120.0, 'load': 0.6, 'temperature_degc': 45.0, 'wear': 10.0,
                     'gravity': 0.3}}
NODES = ('simulated_arm', 'friction_experiment_runner', 'friction_experiment_node',
         'wear_estimator_node')


def _array(values):
    return '[' + ','.join(str(v) for v in values) + ']'


class Graph(ProcessGraph):
    """The processes and a probe node on one ROS domain; everything is stopped at the end."""

    def __init__(self, tmp_path):
        """Start a context on a fresh domain and subscribe like a user."""
        super().__init__(tmp_path, probe='closed_loop_probe')
        self.lock = threading.Lock()
        self.levels, self.wear, self.events, self.status = [], [], [], {}
        self.node.create_subscription(JointState, 'friction_levels', self._on_levels, 10)
        self.node.create_subscription(Float64, 'wear', lambda m: self._add(self.wear, m.data),
                                      10)
        self.node.create_subscription(DiagnosticArray, 'friction_experiment/events',
                                      self._on_event, EXPERIMENT_EVENTS_QOS)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      DIAGNOSTICS_QOS)
        self.clients = {name: self.node.create_client(
            Trigger, f'/friction_experiment_runner/{name}') for name in ('start', 'abort')}
        self.spin()

    def _on_levels(self, msg):
        self._add(self.levels, (time.monotonic(), stamp_to_seconds(msg.header.stamp),
                                list(msg.velocity), list(msg.effort)))

    def _on_event(self, msg):
        self._add(self.events, (time.monotonic(), experiment_event_from_msg(msg)))

    def _on_diagnostics(self, msg):
        for _, name, message, values in diagnostics_from_msg(msg):
            with self.lock:
                self.status[name] = (message, values)

    def call(self, name):
        client = self.clients[name]
        assert client.wait_for_service(timeout_sec=10.0), self.logs()
        future = client.call_async(Trigger.Request())
        deadline = time.monotonic() + 5.0
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert future.done(), f'no answer from ~/{name}'
        return future.result()

    def kinds(self, joint):
        return [(e.event, e.experiment_id) for _, e in self.events if e.joint == joint]

    def close(self):
        """Stop every process with SIGINT first (a node's clean exit), then as the base does."""
        for name in self.processes:
            self.stop(name)
        super().close()


@pytest.fixture
def graph(tmp_path):
    g = Graph(tmp_path)
    yield g
    g.close()


def test_runner_drives_the_arm_and_the_monitor_finds_exactly_the_planned_experiments(
        graph, tmp_path):
    arm = {'names': NAMES, 'posture': POSTURE, 'tested': TRUTH, 'rate_hz': 250.0, 'seed': 5}
    graph.start('simulated_arm', *[sys.executable, '-m', 'wear_testing.simulated_arm_node',
                                   json.dumps(arm)])
    graph.start('friction_experiment_node', *[
        console_script('friction_experiment_node'), '--ros-args', '-p', 'joint:=joint_2',
        '-p', 'gear_ratio:=150.0', '-p', 'torque_scale:=10.0',
        '-p', f'experiment_speeds_rad_s:={_array(SPEEDS)}', '-p', 'idle_gap_s:=300.0'])
    graph.start('wear_estimator_node', *[
        console_script('wear_estimator_node'), '--ros-args', '-p', 'joint:=joint_2',
        '-p', f'history_file:={tmp_path / "history.sqlite3"}'])
    graph.start('friction_experiment_runner', *[
        console_script('friction_experiment_runner'), '--ros-args',
        '-p', f'joint_names:={_array(NAMES)}', '-p', f'posture_rad:={_array(POSTURE)}',
        '-p', 'joints:=[joint_2,joint_3]', '-p', 'gear_ratios:=[150.0,120.0]',
        '-p', 'half_ranges_rad:=[0.1,0.1]', '-p', f'speeds_rad_s:={_array(SPEEDS)}',
        '-p', 'pause_between_joints_s:=0.5', '-p', 'end_margin_s:=0.5'])

    def ready():
        runner = graph.status.get('friction_experiment_runner', ('', {}))[1]
        segmentation = graph.status.get('friction_experiment: joint_2', ('', {}))[1]
        return (runner.get('trajectory_subscribers') == '1'
                and int(segmentation.get('joint_states', '0')) > 250
                and 'wear_monitor: joint_2' in graph.status)
    assert graph.wait(ready, 25.0), 'the graph did not come up\n' + graph.logs()

    for run in range(2):
        response = graph.call('start')
        assert response.success, response.message
        assert 'joint_2' in response.message and 'joint_3' in response.message
        if run == 0:
            assert not graph.call('start').success  # busy
        assert graph.wait(lambda: ('end', 2 * run + 2) in graph.kinds('joint_3'), 20.0), (
            f'run {run} did not end\n' + graph.logs())
    response = graph.call('start')
    assert response.success
    assert graph.wait(lambda: ('start', 5) in graph.kinds('joint_2'), 3.0)
    time.sleep(2.0)  # into the experiment of joint_2
    aborted = graph.call('abort')
    assert aborted.success and 'joint_2' in aborted.message, aborted.message
    assert graph.wait(lambda: len(graph.wear) >= 2, 15.0), graph.logs()
    # nothing more may come: events, levels and estimates stay the same for 1.5 s
    assert graph.settle(lambda: (len(graph.events), len(graph.levels), len(graph.wear)),
                        quiet_s=1.5)

    assert graph.kinds('joint_2') == [('start', 1), ('end', 1), ('start', 3), ('end', 3),
                                      ('start', 5), ('aborted', 5)]
    assert graph.kinds('joint_3') == [('start', 2), ('end', 2), ('start', 4), ('end', 4)]
    assert len(graph.levels) == 2, graph.logs()
    assert len(graph.wear) == 2
    truth = JointTruth(**TRUTH['joint_2'])
    by_id = {(e.event, e.experiment_id): (received, e) for received, e in graph.events}
    for (received, stamp, speeds, frictions), run_id in zip(graph.levels, (1, 3)):
        start = by_id[('start', run_id)][1]
        end_received, end = by_id[('end', run_id)]
        assert start.stamp_s < stamp < end.stamp_s  # the levels of this run only
        # published at the end event (not at an idle gap, seconds later); the probe gets the
        # event and the levels on two topics, in either order
        assert abs(received - end_received) < 1.0
        assert speeds == pytest.approx(SPEEDS, abs=0.5)
        assert frictions == pytest.approx(truth.friction(speeds).tolist(), abs=3e-3)
    for estimate in graph.wear:
        assert estimate == pytest.approx(TRUTH['joint_2']['wear'], abs=12.0)
    assert np.ptp([e.planned_duration_s for _, e in graph.events]) < 1.0

    assert graph.wait(lambda: graph.status['friction_experiment: joint_2'][1].get(
        'rejected_aborted_experiment') == '1', 3.0)
    _, segmentation = graph.status['friction_experiment: joint_2']
    assert segmentation['experiments'] == '2'
    assert segmentation['experiments_from_events'] == '2'
    assert segmentation['experiment_events'] == '6'
    assert segmentation['experiment_events_other_joints'] == '4'
    assert segmentation['experiments_incomplete'] == '0'
    message, runner = graph.status['friction_experiment_runner']
    assert message == 'idle; last run aborted'
    assert (runner['runs_started'], runner['experiments_aborted']) == ('3', '1')
    _, estimator = graph.status['wear_monitor: joint_2']
    assert estimator['experiments'] == '2'

    for name in NODES:
        assert graph.processes[name].poll() is None, f'{name} died\n' + graph.log(name)
    for name in NODES:
        assert graph.stop(name) == 0, graph.log(name)
        assert 'Traceback' not in graph.log(name), graph.log(name)
