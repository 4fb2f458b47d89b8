"""
A node stopped by SIGINT or SIGTERM exits 0 with its history whole, every time.

rclpy's own signal handler shuts the context down before the nodes are destroyed; destroying a
Fast DDS publisher of a shut-down context crashed the estimator now and then (SIGSEGV, exit
-11) right after a late transient-local subscriber had matched its alarm publisher.  The
nodes now stop their spin on the signal and are destroyed before the context shuts down.
"""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys

import pytest
from robot_wear_monitor.nodes.qos import ALARM_QOS
from std_msgs.msg import Bool
from wear_testing.process_graph import ProcessGraph, write_latched_history

ROUNDS = 3


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_the_estimator_exits_0_on_a_signal_after_a_late_subscriber_matched(tmp_path, stop):
    history = tmp_path / 'history.sqlite3'
    write_latched_history(history)
    graph = ProcessGraph(tmp_path)
    try:
        graph.spin()
        for round_ in range(ROUNDS):
            seen = []
            process = graph.start(f'estimator_{round_}', 'wear_estimator_node', '--ros-args',
                                  '-p', f'history_file:={history}')
            # a late subscriber to the latched alarm: it gets the restored alarm, then the signal
            subscription = graph.node.create_subscription(
                Bool, 'wear_alarm', lambda m: graph._add(seen, m.data), ALARM_QOS)
            assert graph.wait(lambda: seen == [True], 60.0), graph.logs()
            process.send_signal(stop)
            code = process.wait(timeout=10.0)
            log = graph.log(f'estimator_{round_}')
            assert code == 0, log
            assert 'Traceback' not in log and 'Fatal Python error' not in log, log
            graph.node.destroy_subscription(subscription)
        with sqlite3.connect(history) as conn:  # the history is whole and the alarm still on
            assert conn.execute('PRAGMA integrity_check').fetchone() == ('ok',)
            assert conn.execute('SELECT event FROM alarm_events').fetchall() == [('raised',)]
    finally:
        graph.close()


_IN_A_THREAD = """
import sys, threading, time
import rclpy
from robot_wear_monitor.nodes import spin_node
from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
result = {}
def run():
    result['code'] = spin_node(WearEstimatorNode, logger_name='wear_estimator_node',
                               args=['node', '--ros-args', '-p', 'history_file:=' + sys.argv[1]])
thread = threading.Thread(target=run)
thread.start()
deadline = time.monotonic() + 60.0
while not rclpy.ok() and time.monotonic() < deadline:
    time.sleep(0.05)
time.sleep(1.0)
rclpy.try_shutdown()  # what the owner of a thread-run node does to stop it
thread.join(10.0)
print('alive' if thread.is_alive() else result['code'])
"""


def test_a_node_spun_outside_the_main_thread_stops_when_its_context_shuts_down(tmp_path):
    # signal handlers can only be set in the main thread: there rclpy's are kept
    graph = ProcessGraph(tmp_path)  # a fresh ROS domain for the child
    try:
        done = subprocess.run([sys.executable, '-c', _IN_A_THREAD, str(tmp_path / 'h.sqlite3')],
                              env=graph.env, capture_output=True, text=True, timeout=120)
    finally:
        graph.close()
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == '0', done.stdout + done.stderr
