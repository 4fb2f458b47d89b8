"""``robot-wear-monitor call`` and node ``--help``: act on the live graph without ros2cli."""

from __future__ import annotations

import subprocess
import sys
import time

from conftest import require_rclpy

require_rclpy()

from process_graph import console_script, ProcessGraph  # noqa: E402, I100

from robot_wear_monitor.cli.call import service_candidates  # noqa: E402
from robot_wear_monitor.monitoring.history import (AlarmEvent, HistoryRecord,  # noqa: E402
                                                   open_history)


def _latched_history(path, robot):
    with open_history(path, robot=robot) as history:
        record = HistoryRecord(joint='joint_2', stamp_s=100.0, speeds_rad_s=(2.1, 28.5),
                               frictions=(0.2, 0.1), temperature_degc=40.0,
                               temperature_std_degc=2.0, wear=48.0, wear_std=4.0, chi2=1.0,
                               dof=0, p_value=float('nan'), temperature_at_bound=False,
                               wear_at_bound=False, alarm_active=True, alarm_evidence=3.0,
                               status_level=2, parameter_set='abb_irb6620_joint2')
        history.append(record, events=[AlarmEvent(joint='joint_2', stamp_s=100.0,
                                                  event='raised', wear=48.0)])


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
    _latched_history(history, 'cell_7')
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
