"""``robot-wear-monitor call`` and node ``--help``: act on the live graph without ros2cli."""

from __future__ import annotations

import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from robot_wear_monitor.cli.call import service_candidates
from robot_wear_monitor.history import open_history
from robot_wear_monitor.nodes.qos import DIAGNOSTICS_QOS, TRAJECTORY_QOS
from robot_wear_monitor.recordings.messages import diagnostics_from_msg
from trajectory_msgs.msg import JointTrajectory
from wear_testing.paths import console_script
from wear_testing.process_graph import ProcessGraph, write_latched_history

TRAJECTORY_TOPIC = '/joint_trajectory_controller/joint_trajectory'
#: The runner's parameters beside its defaults (joint_2): a long standstill at every turn, so
#: the run lasts well beyond the calls of this test (each one a process starting rclpy).
RUNNER = ('-p', 'dwell_s:=10.0')


def _call(graph, *options, timeout=60):
    return subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'call', *options],
                          env=graph.env, capture_output=True, text=True, timeout=timeout)


def test_the_service_names_follow_the_robot_namespace_and_the_joint():
    assert service_candidates(action='start') == ['/friction_experiment_runner/start']
    assert service_candidates(action='reset-alarm', robot='cell_7', joint='joint 2') == [
        '/cell_7/wear_estimator_node/joint_2/reset_alarm',
        '/cell_7/wear_estimator_node/reset_alarm']


def test_reset_alarm_clears_the_latched_alarm_of_a_running_node(tmp_path):
    history = tmp_path / 'fleet.sqlite3'
    write_latched_history(history, robot='cell_7')
    graph = ProcessGraph(tmp_path)
    try:
        graph.start('estimator', 'wear_estimator_node', '--ros-args', '-r', '__ns:=/cell_7',
                    '-p', f'history_file:={history}', '-p', 'robot_id:=cell_7')
        missing = _call(graph, 'start', '--timeout', '2')
        assert missing.returncode == 2
        assert 'no service /friction_experiment_runner/start within 2 s' in missing.stderr
        done = _call(graph, 'reset-alarm', '--robot', 'cell_7')
        assert done.returncode == 0, done.stderr + graph.logs()
        assert done.stdout.strip() == ('/cell_7/wear_estimator_node/reset_alarm: success: '
                                       'wear alarm cleared; evidence and trend reset')
        again = _call(graph, 'reset-alarm', '--robot', 'cell_7')
        assert 'no wear alarm was active' in again.stdout
    finally:
        graph.close()
    with open_history(history, robot='cell_7', init=False) as stored:
        events = [e.event for e in stored.events(joint='joint_2')]
    assert events == ['raised', 'reset', 'reset']


def test_start_and_abort_get_the_answers_of_a_running_runner(tmp_path):
    graph = ProcessGraph(tmp_path)
    trajectories, status = [], []
    try:
        graph.start('runner', 'friction_experiment_runner', '--ros-args', *RUNNER)
        # no trajectory controller yet: the runner refuses to start, and has nothing to abort
        refused = _call(graph, 'start')
        assert refused.returncode == 1, refused.stderr + graph.logs()
        assert refused.stdout.strip() == (
            f'/friction_experiment_runner/start: refused: no subscriber on {TRAJECTORY_TOPIC}: '
            'is the joint_trajectory_controller loaded and active?')
        idle = _call(graph, 'abort')
        assert idle.returncode == 1, idle.stderr + graph.logs()
        assert idle.stdout.strip() == '/friction_experiment_runner/abort: refused: not running'
        # the probe stands in for the controller: a subscriber of the trajectory topic
        graph.node.create_subscription(JointTrajectory, TRAJECTORY_TOPIC,
                                       lambda m: graph._add(trajectories, m), TRAJECTORY_QOS)

        def on_diagnostics(msg):
            for _, name, _, values in diagnostics_from_msg(msg):
                if name == 'friction_experiment_runner':
                    graph._add(status, values)
        graph.node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics,
                                       DIAGNOSTICS_QOS)
        graph.spin()
        assert graph.wait(lambda: any(v.get('trajectory_subscribers') == '1' for v in status),
                          15.0), 'the runner did not see the controller\n' + graph.logs()
        started = _call(graph, 'start')
        assert started.returncode == 0, started.stderr + graph.logs()
        assert started.stdout.startswith(
            '/friction_experiment_runner/start: success: started the friction experiment of '
            'joint_2 (#1, '), started.stdout
        assert f' s) on {TRAJECTORY_TOPIC}: ' in started.stdout
        assert graph.wait(lambda: len(trajectories) == 1, 5.0), graph.logs()
        busy = _call(graph, 'start')
        assert busy.returncode == 1
        assert busy.stdout.startswith('/friction_experiment_runner/start: refused: already '
                                      'running ('), busy.stdout
        assert busy.stdout.rstrip().endswith('call abort to stop it')
        aborted = _call(graph, 'abort')
        assert aborted.returncode == 0, aborted.stderr + graph.logs()
        assert aborted.stdout.startswith('/friction_experiment_runner/abort: success: aborted '
                                         'the friction experiment of joint_2 (#1) after '), (
            aborted.stdout)
        # the braking point back at the posture follows the planned trajectory
        assert graph.wait(lambda: len(trajectories) == 2, 5.0), graph.logs()
        assert len(trajectories[1].points) == 1
        assert graph.stop('runner') == 0, graph.log('runner')
        assert 'Traceback' not in graph.log('runner')
    finally:
        graph.close()


def test_node_executables_answer_help_without_starting(tmp_path):
    for node in ('friction_experiment_node', 'wear_estimator_node',
                 'friction_experiment_runner'):
        start = time.monotonic()
        done = subprocess.run([console_script(node), '--help'], capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 0, done.stderr
        assert done.stdout.startswith(f'usage: {node} [--ros-args')
        assert time.monotonic() - start < 30
    assert 'gear_ratio (double, default 150.0)' in subprocess.run(
        [console_script('friction_experiment_node'), '-h'], capture_output=True, text=True,
        timeout=60).stdout
